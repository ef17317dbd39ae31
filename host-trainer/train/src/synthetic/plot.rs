//! Hand-written SVG pictures for the synthetic-data tools (no font or system library needed;
//! same style as [`crate::draw`]).

use std::fmt::Write as _;

use crate::draw::svg::{escape, header, Panel as Frame};

const COLORS: [&str; 6] = [
    "#1d3557", "#e76f51", "#2a9d8f", "#e9c46a", "#6a4c93", "#888888",
];

/// A `size` (width, height) chart titled `title`: the document header and the axes frame of
/// the plot area (70 px left, 40 px top, 20 px right, 50 px bottom) for the data ranges `xr`,
/// `yr` with `labels` (x, y). Returns the SVG so far and the plot area `(x0, y0, x1, y1)`.
fn chart(
    size: (f32, f32),
    title: &str,
    xr: (f64, f64),
    yr: (f64, f64),
    labels: (&str, &str),
) -> (String, (f32, f32, f32, f32)) {
    let (w, h) = size;
    let area = (70.0, 40.0, w - 20.0, h - 50.0);
    let mut s = String::new();
    header(&mut s, w, h, title);
    axes(&mut s, area, xr, yr, labels.0, labels.1);
    (s, area)
}

/// Axes frame with tick labels: plot area `(x0, y0, x1, y1)` in pixels for data ranges.
#[allow(clippy::too_many_arguments)]
fn axes(
    s: &mut String,
    area: (f32, f32, f32, f32),
    xr: (f64, f64),
    yr: (f64, f64),
    xlabel: &str,
    ylabel: &str,
) {
    let (x0, y0, x1, y1) = area;
    let _ = writeln!(
        s,
        r#"<rect x="{x0}" y="{y0}" width="{}" height="{}" fill="none" stroke="black"/>"#,
        x1 - x0,
        y1 - y0
    );
    for i in 0..=4 {
        let f = i as f32 / 4.0;
        let xv = xr.0 + (xr.1 - xr.0) * f as f64;
        let yv = yr.0 + (yr.1 - yr.0) * f as f64;
        let px = x0 + (x1 - x0) * f;
        let py = y1 - (y1 - y0) * f;
        let _ = writeln!(
            s,
            r#"<text x="{px:.1}" y="{}" font-size="10" text-anchor="middle">{}</text>"#,
            y1 + 14.0,
            fmt_num(xv)
        );
        let _ = writeln!(
            s,
            r#"<text x="{}" y="{:.1}" font-size="10" text-anchor="end">{}</text>"#,
            x0 - 4.0,
            py + 3.0,
            fmt_num(yv)
        );
    }
    let _ = writeln!(
        s,
        r#"<text x="{}" y="{}" font-size="11" text-anchor="middle">{}</text>"#,
        (x0 + x1) / 2.0,
        y1 + 30.0,
        escape(xlabel)
    );
    let _ = writeln!(
        s,
        r#"<text x="12" y="{}" font-size="11" transform="rotate(-90 12 {})" text-anchor="middle">{}</text>"#,
        (y0 + y1) / 2.0,
        (y0 + y1) / 2.0,
        escape(ylabel)
    );
}

fn fmt_num(v: f64) -> String {
    if v == 0.0 {
        "0".into()
    } else if v.abs() >= 1e4 || v.abs() < 1e-2 {
        format!("{v:.1e}")
    } else if v.abs() >= 100.0 {
        format!("{v:.0}")
    } else {
        format!("{v:.2}")
    }
}

fn legend(s: &mut String, x: f32, y: f32, names: &[&str]) {
    for (i, n) in names.iter().enumerate() {
        let yy = y + 14.0 * i as f32;
        let _ = writeln!(
            s,
            r#"<rect x="{x}" y="{}" width="10" height="10" fill="{}"/><text x="{}" y="{}" font-size="11">{}</text>"#,
            yy - 9.0,
            COLORS[i % COLORS.len()],
            x + 14.0,
            yy,
            escape(n)
        );
    }
}

/// Overlaid histograms (as fractions of each series) of values in `[0, max]`; values above
/// `max` are left out (the tail threshold) and counted in the legend.
pub fn histogram_svg(
    title: &str,
    xlabel: &str,
    series: &[(&str, &[f64])],
    max: f64,
    bins: usize,
) -> String {
    let bins = bins.max(1);
    let max = if max > 0.0 { max } else { 1.0 };
    let mut hists = Vec::new();
    let mut ymax = 0.0f64;
    for (_, vals) in series {
        let mut c = vec![0usize; bins];
        let mut over = 0;
        for &v in vals.iter() {
            if v > max {
                over += 1;
                continue;
            }
            let b = ((v / max) * bins as f64).floor() as usize;
            c[b.min(bins - 1)] += 1;
        }
        let n = vals.len().max(1) as f64;
        let f: Vec<f64> = c.iter().map(|&k| k as f64 / n).collect();
        ymax = f.iter().copied().fold(ymax, f64::max);
        hists.push((f, over));
    }
    let ymax = if ymax > 0.0 { ymax * 1.05 } else { 1.0 };
    let (mut s, area) = chart(
        (720.0, 420.0),
        title,
        (0.0, max),
        (0.0, ymax),
        (xlabel, "fraction of trajectories"),
    );
    let bw = (area.2 - area.0) / bins as f32;
    for (k, (f, _)) in hists.iter().enumerate() {
        let sub = bw / hists.len() as f32;
        for (i, &v) in f.iter().enumerate() {
            let hh = ((v / ymax) as f32) * (area.3 - area.1);
            let x = area.0 + bw * i as f32 + sub * k as f32;
            let _ = writeln!(
                s,
                r#"<rect x="{x:.2}" y="{:.2}" width="{:.2}" height="{hh:.2}" fill="{}" opacity="0.8"/>"#,
                area.3 - hh,
                sub.max(0.5),
                COLORS[k % COLORS.len()]
            );
        }
    }
    let names: Vec<String> = series
        .iter()
        .zip(&hists)
        .map(|((n, v), (_, over))| {
            format!(
                "{n} (n={}, {over} above {} not shown)",
                v.len(),
                fmt_num(max)
            )
        })
        .collect();
    let refs: Vec<&str> = names.iter().map(|s| s.as_str()).collect();
    legend(&mut s, area.2 - 330.0, area.1 + 16.0, &refs);
    s.push_str("</svg>\n");
    s
}

/// Grouped bar chart: one group per label, one bar per series (values as given).
pub fn bars_svg(
    title: &str,
    ylabel: &str,
    labels: &[String],
    series: &[(&str, Vec<f64>)],
) -> String {
    let ymax = series
        .iter()
        .flat_map(|(_, v)| v.iter().copied())
        .fold(0.0f64, f64::max)
        .max(1e-9)
        * 1.05;
    let (mut s, area) = chart((760.0, 420.0), title, (0.0, 0.0), (0.0, ymax), ("", ylabel));
    let n = labels.len().max(1);
    let gw = (area.2 - area.0) / n as f32;
    let sub = gw * 0.8 / series.len().max(1) as f32;
    for (i, l) in labels.iter().enumerate() {
        let gx = area.0 + gw * i as f32 + gw * 0.1;
        for (k, (_, v)) in series.iter().enumerate() {
            let val = v.get(i).copied().unwrap_or(0.0);
            let hh = ((val / ymax) as f32) * (area.3 - area.1);
            let _ = writeln!(
                s,
                r#"<rect x="{:.2}" y="{:.2}" width="{sub:.2}" height="{hh:.2}" fill="{}"/>"#,
                gx + sub * k as f32,
                area.3 - hh,
                COLORS[k % COLORS.len()]
            );
        }
        let _ = writeln!(
            s,
            r#"<text x="{:.1}" y="{}" font-size="10" text-anchor="middle">{}</text>"#,
            gx + gw * 0.4,
            area.3 + 28.0,
            escape(l)
        );
    }
    let names: Vec<&str> = series.iter().map(|(n, _)| *n).collect();
    legend(&mut s, area.2 - 200.0, area.1 + 16.0, &names);
    s.push_str("</svg>\n");
    s
}

/// Line chart of several series over a shared x axis (`x[i]` for each `y[i]`).
pub fn lines_svg(
    title: &str,
    xlabel: &str,
    ylabel: &str,
    x: &[f64],
    series: &[(&str, Vec<f64>)],
) -> String {
    let xr = (
        x.first().copied().unwrap_or(0.0),
        x.last()
            .copied()
            .unwrap_or(1.0)
            .max(x.first().copied().unwrap_or(0.0) + 1e-9),
    );
    let all = series.iter().flat_map(|(_, v)| v.iter().copied());
    let (mut lo, mut hi) = (f64::MAX, f64::MIN);
    for v in all {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if lo > hi {
        (lo, hi) = (0.0, 1.0);
    }
    if hi - lo < 1e-12 {
        hi = lo + 1.0;
    }
    let (mut s, area) = chart((720.0, 420.0), title, xr, (lo, hi), (xlabel, ylabel));
    for (k, (_, v)) in series.iter().enumerate() {
        let pts: Vec<String> = x
            .iter()
            .zip(v)
            .map(|(&a, &b)| {
                let px = area.0 + ((a - xr.0) / (xr.1 - xr.0)) as f32 * (area.2 - area.0);
                let py = area.3 - ((b - lo) / (hi - lo)) as f32 * (area.3 - area.1);
                format!("{px:.1},{py:.1}")
            })
            .collect();
        let _ = writeln!(
            s,
            r#"<polyline fill="none" stroke="{}" stroke-width="1.5" points="{}"/>"#,
            COLORS[k % COLORS.len()],
            pts.join(" ")
        );
    }
    let names: Vec<&str> = series.iter().map(|(n, _)| *n).collect();
    legend(&mut s, area.2 - 260.0, area.1 + 16.0, &names);
    s.push_str("</svg>\n");
    s
}

/// One panel of a trajectory picture.
pub struct Panel {
    /// Caption under the panel.
    pub caption: String,
    /// Highlighted trajectory (drawn thick turquoise, e.g. the RL agent), if any.
    pub main: Option<Vec<[f32; 2]>>,
    /// Goal of the highlighted trajectory (red cross), if any.
    pub goal: Option<[f32; 2]>,
    /// Other trajectories (thin grey, e.g. HMM agents).
    pub others: Vec<Vec<[f32; 2]>>,
    /// Points to mark with a circle (e.g. impending collision states).
    pub marks: Vec<[f32; 2]>,
}

/// Trajectory panels, `cols` per row, each scaled to its own content (equal axes); the start
/// of every trajectory is a dot.
pub fn panels_svg(title: &str, panels: &[Panel], cols: usize) -> String {
    const P: f32 = 300.0;
    let cols = cols.max(1);
    let rows = panels.len().div_ceil(cols).max(1);
    let (w, h) = (cols as f32 * P, rows as f32 * P + 30.0);
    let mut s = String::new();
    header(&mut s, w, h, title);
    for (n, p) in panels.iter().enumerate() {
        let (ox, oy) = ((n % cols) as f32 * P, (n / cols) as f32 * P + 30.0);
        let mut all: Vec<[f32; 2]> = p.others.iter().flatten().copied().collect();
        if let Some(m) = &p.main {
            all.extend(m.iter().copied());
        }
        all.extend(p.goal);
        let frame = Frame::fit((ox, oy), P, &all, (25.0, 20.0, 50.0), 1.0);
        frame.border(&mut s);
        let poly = |s: &mut String, t: &[[f32; 2]], style: &str, dot: &str| {
            frame.polyline(s, t, style);
            if let Some(&q) = t.first() {
                let (a, b) = frame.map(q);
                let _ = writeln!(s, r#"<circle cx="{a:.1}" cy="{b:.1}" r="3" fill="{dot}"/>"#);
            }
        };
        for o in &p.others {
            poly(&mut s, o, r##"stroke="#999" stroke-width="1.2""##, "#999");
        }
        if let Some(m) = &p.main {
            poly(
                &mut s,
                m,
                r##"stroke="#2ec4b6" stroke-width="3""##,
                "#1d3557",
            );
        }
        for &q in &p.marks {
            let (a, b) = frame.map(q);
            let _ = writeln!(
                s,
                r##"<circle cx="{a:.1}" cy="{b:.1}" r="5" fill="none" stroke="#e76f51"/>"##
            );
        }
        if let Some(g) = p.goal {
            let (a, b) = frame.map(g);
            let _ = writeln!(
                s,
                r##"<path d="M{} {} L{} {} M{} {} L{} {}" stroke="#d62828" stroke-width="2.5"/>"##,
                a - 6.0,
                b - 6.0,
                a + 6.0,
                b + 6.0,
                a - 6.0,
                b + 6.0,
                a + 6.0,
                b - 6.0
            );
        }
        frame.scale_bar(&mut s, "px");
        frame.caption(&mut s, &escape(&p.caption));
    }
    s.push_str("</svg>\n");
    s
}
