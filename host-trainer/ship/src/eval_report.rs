//! What `gpecnet eval` prints: the [`EvalReport`] of a blob as the human table or as one
//! JSON object (`--json`; the field names are part of the CLI's contract, see
//! `gpecnet eval --help`).

use std::fmt::Write as _;
use std::path::Path;

use crate::blob_eval::EvalReport;

/// Appends one formatted line to the `String` `$out` (which cannot fail).
macro_rules! w {
    ($out:expr, $($arg:tt)*) => {{
        let _ = writeln!($out, $($arg)*);
    }};
}

/// The JSON key of a hit rate: the radius and its unit (`hit_0.5m`, `hit_1m`, `hit_20px`).
pub fn hit_key(radius: f64, unit: crate::data::Unit) -> String {
    format!("hit_{radius}{}", unit.suffix())
}

/// The report as one JSON object (`gpecnet eval --json`); `blob` is the path as given.
pub fn json(r: &EvalReport, blob: &Path) -> serde_json::Value {
    let (m, cv, cvn, d) = (&r.metrics, &r.constant_velocity, &r.cv, &r.dist);
    serde_json::json!({
        "name": r.name,
        "blob": blob.display().to_string(),
        "dataset": r.dataset,
        "unit": r.unit.suffix(),
        "n": m.n,
        "k": m.k,
        "min_ade": m.min_ade,
        "min_fde": m.min_fde,
        "ade_k1": m.ade_k1,
        "fde_k1": m.fde_k1,
        "mean_ade": m.mean_ade,
        "mean_fde": m.mean_fde,
        "point_ade": r.point.map(|p| p.0),
        "point_fde": r.point.map(|p| p.1),
        "cv_n": r.cv_n,
        "cv_ade": cvn.ade_k1,
        "cv_fde": cvn.fde_k1,
        "cv_last_ade": cv.ade_k1,
        "cv_last_fde": cv.fde_k1,
        "cv_val_fde": r.cv_val.iter().map(|v| v.fde_k1).collect::<Vec<_>>(),
        "n_val": r.n_val,
        "kde_nll": d.kde_nll,
        hit_key(r.hits[0].0, r.unit): r.hits[0].1,
        hit_key(r.hits[1].0, r.unit): r.hits[1].1,
        "hits": r.hits.iter().map(|(radius, fraction)| serde_json::json!({"radius": radius, "unit": r.unit.suffix(), "fraction": fraction})).collect::<Vec<_>>(),
        "cv_n_chosen_on": match &r.cv_fixed {
            Some(dir) => format!("fixed at {} (no val/ in {dir})", r.cv_n),
            None => "validation".to_string(),
        },
        "scenes": r.scenes,
        "speeds": r.speeds,
        "changes": r.changes,
        "min_ade_px": r.pixels.map(|p| p.metrics.min_ade),
        "min_fde_px": r.pixels.map(|p| p.metrics.min_fde),
        "point_ade_px": r.pixels.and_then(|p| p.point.map(|q| q.0)),
        "point_fde_px": r.pixels.and_then(|p| p.point.map(|q| q.1)),
        "cv_ade_px": r.pixels.map(|p| p.cv.ade_k1),
        "cv_fde_px": r.pixels.map(|p| p.cv.fde_k1),
        "matches_card": r.matches_card,
        "svg": r.svg.as_ref().map(|p| p.display().to_string()),
        "probabilities": if r.planner.is_some() { "learned" } else { "uniform (the model has none: 1/K each)" },
        "planner": r.planner,
        "planner_px": r.planner_px,
        "reliability_svg": r.reliability.as_ref().map(|p| p.display().to_string()),
    })
}

/// The report as the human table (`gpecnet eval`), one line per row, ending in a newline.
pub fn table(r: &EvalReport) -> String {
    let (m, cv, cvn, d) = (&r.metrics, &r.constant_velocity, &r.cv, &r.dist);
    let mut out = String::new();
    let u = r.unit.suffix();
    w!(
        out,
        "model {} on the {} test set ({} windows), through gpecnet-core, unit: {} ({u})",
        r.name,
        r.dataset,
        m.n,
        r.unit.words()
    );
    w!(out, "{:<44} {:>9} {:>9}", "", "ADE", "FDE");
    let row = |out: &mut String, label: String, ade: f64, fde: f64| {
        let _ = writeln!(out, "{label:<44} {ade:>9.3} {fde:>9.3}");
    };
    row(
        &mut out,
        format!("best of K = {}", m.k),
        m.min_ade,
        m.min_fde,
    );
    row(&mut out, "K = 1 (first sample)".into(), m.ade_k1, m.fde_k1);
    row(
        &mut out,
        format!("mean over the {} samples", m.k),
        m.mean_ade,
        m.mean_fde,
    );
    match r.point {
        Some((ade, fde)) => row(&mut out, "point forecast".into(), ade, fde),
        None => w!(out, "{:<44} {:>9} {:>9}", "point forecast", "n/a", "n/a"),
    }
    row(
        &mut out,
        "constant velocity (K = 1)".into(),
        cv.ade_k1,
        cv.fde_k1,
    );
    let cv_label = match &r.cv_fixed {
        Some(_) => format!("constant velocity, n = {} (fixed: no val/)", r.cv_n),
        None => format!("constant velocity, n = {} (chosen on val)", r.cv_n),
    };
    row(&mut out, cv_label, cvn.ade_k1, cvn.fde_k1);
    w!(out,
        "distribution of the K = {} endpoints: KDE NLL {:.3} nats ({u}), true endpoint within {} {u} of a sample {:.2} %, within {} {u} {:.2} %",
        m.k,
        d.kde_nll,
        r.hits[0].0,
        100.0 * r.hits[0].1,
        r.hits[1].0,
        100.0 * r.hits[1].1
    );
    if let Some(p) = &r.pixels {
        w!(
            out,
            "the same in pixels, scene by scene (the pixel literature's unit):"
        );
        row(
            &mut out,
            format!("best of K = {} (px)", p.metrics.k),
            p.metrics.min_ade,
            p.metrics.min_fde,
        );
        if let Some((ade, fde)) = p.point {
            row(&mut out, "point forecast (px)".into(), ade, fde);
        }
        row(
            &mut out,
            "constant velocity on sdd, chosen on val (px)".into(),
            p.cv.ade_k1,
            p.cv.fde_k1,
        );
    }
    match &r.cv_fixed {
        Some(dir) => w!(
            out,
            "constant-velocity n: fixed at {} observed steps (0.8 s): {dir} has no val/ to choose it on",
            r.cv_n
        ),
        None => w!(
            out,
            "constant-velocity n: lowest FDE on {} {} validation windows; val FDE for n = 1..7: {}",
            r.n_val,
            r.dataset,
            r.cv_val
                .iter()
                .map(|v| format!("{:.2}", v.fde_k1))
                .collect::<Vec<_>>()
                .join(", ")
        ),
    }
    if r.scenes.len() > 1 {
        let title = format!(
            "per scene ({u}; point = the point forecast's FDE, CV = constant velocity n = {}):",
            r.cv_n
        );
        group_table(&mut out, &title, "scene", &r.scenes, r.hits, u);
    }
    if !r.speeds.is_empty() {
        let title = format!(
            "per observed speed (|p7 - p0| over the 2.8 s observed; {u}; CV n = {}):",
            r.cv_n
        );
        group_table(&mut out, &title, "speed", &r.speeds, r.hits, u);
    }
    if !r.changes.is_empty() {
        let title = format!(
            "starters (standing when forecast, > 1 m away at 4.8 s) and stoppers (moving, then \
             standing over the last 1.6 s); {u}; CV n = {}:",
            r.cv_n
        );
        group_table(&mut out, &title, "change", &r.changes, r.hits, u);
    }
    match r.matches_card {
        Some(true) => w!(out, "model card: reproduced exactly"),
        Some(false) => {
            w!(
                out,
                "model card: NOT reproduced (different K, seed, sine or weights?)"
            )
        }
        None if r.card_on_other_data => {
            w!(out, "model card: about another data set (not compared)")
        }
        None => w!(out, "model card: none next to the blob"),
    }
    match (&r.planner, &r.planner_px) {
        (Some(p), px) => {
            w!(out, "what a planner gets (learned endpoint probabilities, radii around the point forecast):");
            let both = |v: f64, w: Option<f64>| match w {
                Some(w) => format!("{v:.3} {u} ({w:.2} px)"),
                None => format!("{v:.3} {u}"),
            };
            w!(out,
                "  P(most probable = closest) {:.3}; FDE of the most probable {}, of the probability-weighted mean {}, of the point forecast {}",
                p.top_is_closest,
                both(p.top_fde, px.map(|x| x.top_fde)),
                both(p.weighted_fde, px.map(|x| x.weighted_fde)),
                both(p.point_fde, px.map(|x| x.point_fde))
            );
            w!(out,
                "  brier-minFDE {}; ECE {:.4} (top-label {:.4}); mixture NLL {:.3} vs {:.3} with equal weights",
                both(p.brier_min_fde, px.map(|x| x.brier_min_fde)),
                p.ece,
                p.top_ece,
                p.mixture_nll,
                p.uniform_nll
            );
            w!(out,
                "  truth within r50 {:.1} %, within r90 {:.1} % of the point forecast; r90 10/50/90th percentile {}",
                100.0 * p.r50_coverage,
                100.0 * p.r90_coverage,
                p.r90_percentiles
                    .iter()
                    .map(|v| format!("{v:.3}"))
                    .collect::<Vec<_>>()
                    .join(" / ")
            );
        }
        (None, _) => {
            w!(
                out,
                "endpoint probabilities: none in this model (1/K each, no radii)"
            )
        }
    }
    if let Some(p) = &r.svg {
        w!(out, "drew predictions to {}", p.display());
    }
    if let Some(p) = &r.reliability {
        w!(out, "drew the reliability diagram to {}", p.display());
    }
    out
}

/// One table of [`crate::blob_eval::SceneRow`]s under `title` (`what` names the first
/// column): windows, best-of-K ADE/FDE, the point forecast's FDE, constant velocity, and the
/// hit rates at the report's two radii `hits` in the unit `u`.
fn group_table(
    out: &mut String,
    title: &str,
    what: &str,
    rows: &[crate::blob_eval::SceneRow],
    hits: [(f64, f64); 2],
    u: &str,
) {
    let width = rows
        .iter()
        .map(|s| s.scene.len())
        .max()
        .unwrap_or(5)
        .max(what.len());
    w!(out, "{title}");
    w!(
        out,
        "  {:<width$} {:>7} {:>8} {:>8} {:>8} {:>8} {:>8} {:>9} {:>9}",
        what,
        "windows",
        "minADE",
        "minFDE",
        "point",
        "CV ADE",
        "CV FDE",
        format!("<{}{u}", hits[0].0),
        format!("<{}{u}", hits[1].0)
    );
    for s in rows {
        w!(
            out,
            "  {:<width$} {:>7} {:>8.3} {:>8.3} {:>8} {:>8.3} {:>8.3} {:>8.1}% {:>8.1}%",
            s.scene,
            s.n,
            s.min_ade,
            s.min_fde,
            s.point_fde.map_or("n/a".to_string(), |v| format!("{v:.3}")),
            s.cv_ade,
            s.cv_fde,
            100.0 * s.hits[0],
            100.0 * s.hits[1]
        );
    }
}
