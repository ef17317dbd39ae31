//! Pictures a person can check: predicted vs. true trajectories as SVG.
//!
//! Plain SVG written by hand (no font or system library needed).

use std::fmt::Write as _;

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
    items: &[(&Window, &Prediction)],
    cols: usize,
) -> String {
    let cols = cols.max(1);
    let rows = items.len().div_ceil(cols).max(1);
    let (w, h) = (cols as f32 * PANEL, rows as f32 * PANEL + 44.0);
    let mut s = String::new();
    let _ = writeln!(
        s,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" viewBox="0 0 {w} {h}" font-family="sans-serif">"#
    );
    let _ = writeln!(
        s,
        r#"<rect width="100%" height="100%" fill="white"/><text x="8" y="20" font-size="14">{}</text>"#,
        escape(title)
    );
    for (n, (win, pred)) in items.iter().enumerate() {
        let (ox, oy) = ((n % cols) as f32 * PANEL, (n / cols) as f32 * PANEL + 44.0);
        let mut pts: Vec<[f32; 2]> = win.pos.to_vec();
        pts.extend(pred.trajectories.iter().flatten());
        let (mut x0, mut y0, mut x1, mut y1) = (f32::MAX, f32::MAX, f32::MIN, f32::MIN);
        for p in &pts {
            x0 = x0.min(p[0]);
            y0 = y0.min(p[1]);
            x1 = x1.max(p[0]);
            y1 = y1.max(p[1]);
        }
        let span = (x1 - x0).max(y1 - y0).max(1e-3);
        let sc = (PANEL - 40.0) / span;
        let map = |p: [f32; 2]| (ox + 20.0 + (p[0] - x0) * sc, oy + 20.0 + (p[1] - y0) * sc);
        let poly = |s: &mut String, p: &[[f32; 2]], style: &str| {
            let d: Vec<String> = p
                .iter()
                .map(|&q| {
                    let (a, b) = map(q);
                    format!("{a:.1},{b:.1}")
                })
                .collect();
            let _ = writeln!(
                s,
                r#"<polyline fill="none" {style} points="{}"/>"#,
                d.join(" ")
            );
        };
        let _ = writeln!(
            s,
            r##"<rect x="{}" y="{}" width="{}" height="{}" fill="none" stroke="#ccc"/>"##,
            ox + 2.0,
            oy + 2.0,
            PANEL - 4.0,
            PANEL - 4.0
        );
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
        for t in &pred.trajectories {
            let mut line = vec![win.pos[7]];
            line.extend_from_slice(t);
            poly(
                &mut s,
                &line,
                r##"stroke="#f4a261" stroke-width="0.8" opacity="0.7""##,
            );
            let (a, b) = map(t[t.len() - 1]);
            let _ = writeln!(
                s,
                r##"<circle cx="{a:.1}" cy="{b:.1}" r="2.2" fill="#d62828"/>"##
            );
        }
        if let Some((i, fde)) = best {
            let mut line = vec![win.pos[7]];
            line.extend_from_slice(&pred.trajectories[i]);
            poly(&mut s, &line, r##"stroke="#d62828" stroke-width="2""##);
            let _ = writeln!(
                s,
                r#"<text x="{}" y="{}" font-size="10">{} #{} minFDE {:.1} {}</text>"#,
                ox + 8.0,
                oy + PANEL - 8.0,
                escape(&win.scene),
                win.ped_id,
                fde,
                unit
            );
        }
        poly(
            &mut s,
            &win.pos[..8],
            r##"stroke="#1d3557" stroke-width="2.5""##,
        );
        poly(
            &mut s,
            &win.pos[7..],
            r##"stroke="#2a9d8f" stroke-width="2.5" stroke-dasharray="4 2""##,
        );
        let bar = 10f32.powf((span / 4.0).log10().floor());
        let (a, b) = (ox + PANEL - 20.0 - bar * sc, oy + 14.0);
        let _ = writeln!(
            s,
            r#"<line x1="{a:.1}" y1="{b}" x2="{:.1}" y2="{b}" stroke="black"/><text x="{a:.1}" y="{}" font-size="9">{bar} {unit}</text>"#,
            ox + PANEL - 20.0,
            b - 3.0
        );
    }
    let _ = writeln!(
        s,
        r##"<text x="8" y="36" font-size="11" fill="#555">blue: observed 8 steps · dashed green: true future · orange: the K sampled trajectories, red dots their endpoints · thick red: best of K</text>"##
    );
    s.push_str("</svg>\n");
    s
}

fn escape(t: &str) -> String {
    t.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}
