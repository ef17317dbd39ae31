//! Pictures a person can check: predicted vs. true trajectories as SVG.
//!
//! Plain SVG written by hand (no font or system library needed); the `svg` module holds the pieces
//! every hand-written picture of the crate shares (this one and `synth::plot`'s).

use std::fmt::Write as _;

use self::svg::{escape, header, Panel};

use crate::core_eval::PlannerOut;
use crate::data::Window;
use crate::eval::Prediction;

const PANEL: f32 = 260.0;

/// Draws up to `cols × rows` windows, one panel each: observed steps (blue),
/// true future (green), the K predicted trajectories (thin orange) with their
/// endpoints (red dots), and the best-of-K trajectory (thick red). Each panel
/// is scaled to its own content; a scale bar shows the unit.
pub fn predictions_svg(
    title: &str,
    unit: &str,
    items: &[(&Window, &Prediction, Option<&PlannerOut>)],
    cols: usize,
) -> String {
    let cols = cols.max(1);
    let rows = items.len().div_ceil(cols).max(1);
    let (w, h) = (cols as f32 * PANEL, rows as f32 * PANEL + 44.0);
    let mut s = String::new();
    header(&mut s, w, h, title);
    for (n, (win, pred, planner)) in items.iter().enumerate() {
        let (ox, oy) = ((n % cols) as f32 * PANEL, (n / cols) as f32 * PANEL + 44.0);
        let mut pts: Vec<[f32; 2]> = win.pos.to_vec();
        pts.extend(pred.trajectories.iter().flatten());
        // The r90 circle stays inside the panel.
        if let Some((q, [_, r90])) = planner.and_then(|p| Some((p.point?, p.radii?))) {
            pts.extend([[q[0] - r90, q[1] - r90], [q[0] + r90, q[1] + r90]]);
        }
        let panel = Panel::fit((ox, oy), PANEL, &pts, (20.0, 20.0, 40.0), 1e-3);
        panel.border(&mut s);
        let best = pred
            .trajectories
            .iter()
            .enumerate()
            .map(|(i, t)| {
                let e = t[t.len() - 1];
                let g = win.pos[19];
                (i, (e[0] - g[0]).hypot(e[1] - g[1]))
            })
            .min_by(|a, b| a.1.total_cmp(&b.1));
        let k = pred.trajectories.len().max(1) as f32;
        for (i, t) in pred.trajectories.iter().enumerate() {
            let mut line = vec![win.pos[7]];
            line.extend_from_slice(t);
            panel.polyline(
                &mut s,
                &line,
                r##"stroke="#f4a261" stroke-width="0.8" opacity="0.7""##,
            );
            let (a, b) = panel.map(t[t.len() - 1]);
            // With probabilities: the dot's area grows with p (the size of 1/K is the plain
            // dot's), and its opacity too.
            let (r, op) = match planner.filter(|p| p.probs.len() == pred.trajectories.len()) {
                Some(p) => {
                    let rel = p.probs[i] * k;
                    (
                        2.2 * rel.sqrt().clamp(0.4, 3.0),
                        (0.25 + 0.75 * rel / 3.0).min(1.0),
                    )
                }
                None => (2.2, 1.0),
            };
            let _ = writeln!(
                s,
                r##"<circle cx="{a:.1}" cy="{b:.1}" r="{r:.1}" fill="#d62828" opacity="{op:.2}"/>"##
            );
        }
        if let Some(p) = planner {
            if let Some(q) = p.point {
                let (a, b) = panel.map(q);
                if let Some(radii) = p.radii {
                    for (r, dash) in radii.iter().zip(["2 2", "5 3"]) {
                        let _ = writeln!(
                            s,
                            r##"<circle cx="{a:.1}" cy="{b:.1}" r="{:.1}" fill="none" stroke="#6a4c93" stroke-dasharray="{dash}"/>"##,
                            r * panel.scale()
                        );
                    }
                }
                let _ = writeln!(
                    s,
                    r##"<path d="M{:.1},{:.1}l6,6m0,-6l-6,6" stroke="#6a4c93" stroke-width="2"/>"##,
                    a - 3.0,
                    b - 3.0
                );
            }
        }
        if let Some((i, fde)) = best {
            let mut line = vec![win.pos[7]];
            line.extend_from_slice(&pred.trajectories[i]);
            panel.polyline(&mut s, &line, r##"stroke="#d62828" stroke-width="2""##);
            let caption = format!(
                "{} #{} minFDE {fde:.1} {unit}",
                escape(&win.scene),
                win.ped_id
            );
            panel.caption(&mut s, &caption);
        }
        panel.polyline(
            &mut s,
            &win.pos[..8],
            r##"stroke="#1d3557" stroke-width="2.5""##,
        );
        panel.polyline(
            &mut s,
            &win.pos[7..],
            r##"stroke="#2a9d8f" stroke-width="2.5" stroke-dasharray="4 2""##,
        );
        panel.scale_bar(&mut s, unit);
    }
    let _ = writeln!(
        s,
        r##"<text x="8" y="36" font-size="11" fill="#555">blue: observed 8 steps · dashed green: true future · orange: the K sampled trajectories, red dots their endpoints (sized by probability when the model has them) · thick red: best of K · purple cross: point forecast, dashed circles its r50 and r90</text>"##
    );
    s.push_str("</svg>\n");
    s
}

/// A reliability diagram of endpoint probabilities: for each of the equal-width bins
/// (`(count, sum of p, sum of outcomes)`, [`crate::planner_metrics::PlannerAccumulator::bins`])
/// a bar at the share of endpoints that were the closest, against the diagonal of perfect
/// calibration; the bar's number is its count.
pub fn reliability_svg(title: &str, bins: &[(usize, f64, f64)]) -> String {
    let (w, h, m) = (420.0f32, 460.0f32, 50.0f32);
    let side = w - 2.0 * m;
    let mut s = String::new();
    header(&mut s, w, h, title);
    let (x0, y0) = (m, h - m);
    let _ = writeln!(
        s,
        r##"<rect x="{m}" y="{}" width="{side}" height="{side}" fill="none" stroke="#999"/><line x1="{x0}" y1="{y0}" x2="{}" y2="{}" stroke="#999" stroke-dasharray="4 3"/>"##,
        y0 - side,
        x0 + side,
        y0 - side
    );
    let n = bins.len().max(1) as f32;
    // The probabilities of 20 endpoints sit near 1/20: the axes show 0 .. top, the largest
    // bin edge that holds a probability, so the low bins are readable.
    let used = bins.iter().rposition(|b| b.0 > 0).map_or(1, |i| i + 1) as f32;
    let top = used / n;
    for (i, &(c, p, o)) in bins.iter().enumerate() {
        if c == 0 {
            continue;
        }
        let freq = (o / c as f64) as f32;
        let conf = (p / c as f64) as f32;
        let bw = side / used;
        let x = x0 + i as f32 * bw;
        let bh = (freq / top).min(1.0) * side;
        let _ = writeln!(
            s,
            r##"<rect x="{:.1}" y="{:.1}" width="{:.1}" height="{bh:.1}" fill="#457b9d" opacity="0.8"/><circle cx="{:.1}" cy="{:.1}" r="2.5" fill="#d62828"/><text x="{:.1}" y="{:.1}" font-size="8" text-anchor="middle">{c}</text>"##,
            x + 1.0,
            y0 - bh,
            bw - 2.0,
            x0 + conf / top * side,
            y0 - (conf / top).min(1.0) * side,
            x + bw / 2.0,
            y0 - bh - 3.0
        );
    }
    let _ = writeln!(
        s,
        r##"<text x="{x0}" y="{}" font-size="10">0</text><text x="{}" y="{}" font-size="10">{top:.2}</text><text x="{}" y="{}" font-size="11" text-anchor="middle">predicted probability (blue bar: share that was the closest endpoint; red dot: the bin's mean probability)</text><text x="14" y="{}" font-size="11" transform="rotate(-90 14 {})" text-anchor="middle">observed frequency (0 .. {top:.2})</text>"##,
        y0 + 14.0,
        x0 + side - 16.0,
        y0 + 14.0,
        w / 2.0,
        y0 + 32.0,
        y0 - side / 2.0,
        y0 - side / 2.0
    );
    s.push_str("</svg>\n");
    s
}

/// The pieces of the crate's hand-written SVG pictures: the document header, and square
/// trajectory panels scaled to their content with equal axes.
pub mod svg {
    use std::fmt::Write as _;

    /// `t` with the XML special characters of text content escaped.
    pub fn escape(t: &str) -> String {
        t.replace('&', "&amp;")
            .replace('<', "&lt;")
            .replace('>', "&gt;")
    }

    /// Opens a `w × h` SVG document on a white background with `title` at the top left.
    pub fn header(s: &mut String, w: f32, h: f32, title: &str) {
        let _ = writeln!(
            s,
            r#"<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" viewBox="0 0 {w} {h}" font-family="sans-serif">"#
        );
        let _ = writeln!(
            s,
            r#"<rect width="100%" height="100%" fill="white"/><text x="8" y="20" font-size="14">{}</text>"#,
            escape(title)
        );
    }

    /// One square panel of side `size` at `(ox, oy)`: data points map to pixels with one scale
    /// for both axes, chosen so the content's larger extent fills the panel less its inset.
    pub struct Panel {
        ox: f32,
        oy: f32,
        size: f32,
        /// Left and top inset in pixels.
        left: f32,
        top: f32,
        /// The content's smallest coordinates.
        x0: f32,
        y0: f32,
        /// The content's larger extent (at least the minimum span).
        span: f32,
        /// Pixels per data unit.
        sc: f32,
    }

    impl Panel {
        /// The panel at `origin` fitted to `points`; `inset` = (left, top, total of both
        /// margins along an axis) in pixels; the extent is at least `min_span` (an empty set
        /// of points is the unit square).
        pub fn fit(
            origin: (f32, f32),
            size: f32,
            points: &[[f32; 2]],
            inset: (f32, f32, f32),
            min_span: f32,
        ) -> Self {
            let [x0, y0, x1, y1] = if points.is_empty() {
                [0.0, 0.0, 1.0, 1.0]
            } else {
                let far = [f32::MAX, f32::MAX, f32::MIN, f32::MIN];
                points.iter().fold(far, |[a, b, c, d], q| {
                    [a.min(q[0]), b.min(q[1]), c.max(q[0]), d.max(q[1])]
                })
            };
            let span = (x1 - x0).max(y1 - y0).max(min_span);
            Self {
                ox: origin.0,
                oy: origin.1,
                size,
                left: inset.0,
                top: inset.1,
                x0,
                y0,
                span,
                sc: (size - inset.2) / span,
            }
        }

        /// Pixels per data unit.
        pub fn scale(&self) -> f32 {
            self.sc
        }

        /// The pixel position of data point `q`.
        pub fn map(&self, q: [f32; 2]) -> (f32, f32) {
            (
                self.ox + self.left + (q[0] - self.x0) * self.sc,
                self.oy + self.top + (q[1] - self.y0) * self.sc,
            )
        }

        /// The panel's light grey border.
        pub fn border(&self, s: &mut String) {
            let _ = writeln!(
                s,
                r##"<rect x="{}" y="{}" width="{}" height="{}" fill="none" stroke="#ccc"/>"##,
                self.ox + 2.0,
                self.oy + 2.0,
                self.size - 4.0,
                self.size - 4.0
            );
        }

        /// A polyline through `points` with the SVG attributes `style`.
        pub fn polyline(&self, s: &mut String, points: &[[f32; 2]], style: &str) {
            let d: Vec<String> = points
                .iter()
                .map(|&q| {
                    let (a, b) = self.map(q);
                    format!("{a:.1},{b:.1}")
                })
                .collect();
            let _ = writeln!(
                s,
                r#"<polyline fill="none" {style} points="{}"/>"#,
                d.join(" ")
            );
        }

        /// A scale bar at the top right: a power of ten of about a quarter of the extent.
        pub fn scale_bar(&self, s: &mut String, unit: &str) {
            let bar = 10f32.powf((self.span / 4.0).log10().floor());
            let (a, b) = (self.ox + self.size - 20.0 - bar * self.sc, self.oy + 14.0);
            let _ = writeln!(
                s,
                r#"<line x1="{a:.1}" y1="{b}" x2="{:.1}" y2="{b}" stroke="black"/><text x="{a:.1}" y="{}" font-size="9">{bar} {unit}</text>"#,
                self.ox + self.size - 20.0,
                b - 3.0
            );
        }

        /// A caption at the bottom left (`text` is written as is: escape what needs it).
        pub fn caption(&self, s: &mut String, text: &str) {
            let _ = writeln!(
                s,
                r#"<text x="{}" y="{}" font-size="10">{text}</text>"#,
                self.ox + 8.0,
                self.oy + self.size - 8.0
            );
        }
    }
}
