//! `metrics.csv`, `metrics.jsonl` and `curves.svg` of a run.

use std::io::Write;
use std::path::Path;

use anyhow::Result;

use crate::checkpoint::EpochMetrics;
use crate::data::Unit;
use crate::eval::Metrics;

/// Write `metrics.csv` and `metrics.jsonl` (whole history, atomically).
pub fn write_metrics(run_dir: &Path, history: &[EpochMetrics]) -> Result<()> {
    let mut jsonl = String::new();
    let mut rows = Vec::with_capacity(history.len());
    for m in history {
        let v =
            |f: fn(&Metrics) -> f64| m.val.as_ref().map(|x| f(x).to_string()).unwrap_or_default();
        rows.push([
            m.epoch.to_string(),
            m.train_loss.to_string(),
            m.train_rcl.to_string(),
            m.train_kld.to_string(),
            m.train_adl.to_string(),
            v(|x| x.min_ade),
            v(|x| x.min_fde),
            v(|x| x.ade_k1),
            v(|x| x.fde_k1),
            v(|x| x.mean_ade),
            v(|x| x.mean_fde),
            format!("{:.3}", m.seconds),
        ]);
        jsonl += &serde_json::to_string(m)?;
        jsonl.push('\n');
    }
    let csv = crate::csvfile::to_csv(
        &[
            "epoch",
            "train_loss",
            "train_rcl",
            "train_kld",
            "train_adl",
            "val_min_ade",
            "val_min_fde",
            "val_ade_k1",
            "val_fde_k1",
            "val_mean_ade",
            "val_mean_fde",
            "seconds",
        ],
        rows,
    )?;
    crate::rundir::write_atomic(&run_dir.join("metrics.csv"), csv.as_bytes())?;
    crate::rundir::write_atomic(&run_dir.join("metrics.jsonl"), jsonl.as_bytes())?;
    Ok(())
}

/// Plot training loss parts (log scale) and validation min ADE/FDE to an SVG file.
/// Uses plotters' SVG backend without any font feature (no fontconfig needed).
pub fn plot_curves(path: &Path, history: &[EpochMetrics], unit: Unit) -> Result<()> {
    use plotters::prelude::*;
    if history.is_empty() {
        return Ok(());
    }
    let err = |e: &dyn std::fmt::Display| anyhow::anyhow!("{e}");
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (1100, 420)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| err(&e))?;
        let (left, right) = root.split_horizontally(550);
        let xmax = history.last().map_or(1, |m| m.epoch).max(2) as f64;
        let xmin = history.first().map_or(1, |m| m.epoch) as f64;

        type Series = (&'static str, fn(&EpochMetrics) -> f64, RGBColor);
        let series: [Series; 3] = [
            ("total", |m| m.train_loss, BLACK),
            ("rcl (endpoint MSE)", |m| m.train_rcl, BLUE),
            ("adl (path MSE)", |m| m.train_adl, RED),
        ];
        let vals: Vec<f64> = history
            .iter()
            .flat_map(|m| series.iter().map(move |s| s.1(m)))
            .filter(|v| v.is_finite() && *v > 0.0)
            .collect();
        let lo = vals.iter().cloned().fold(f64::INFINITY, f64::min).max(1e-9);
        let hi = vals.iter().cloned().fold(0.0, f64::max).max(lo * 10.0);
        let mut c = ChartBuilder::on(&left)
            .caption("training loss", ("sans-serif", 18))
            .margin(10)
            .x_label_area_size(35)
            .y_label_area_size(60)
            .build_cartesian_2d(xmin..xmax, (lo * 0.8..hi * 1.25).log_scale())
            .map_err(|e| err(&e))?;
        c.configure_mesh()
            .x_desc("epoch")
            .draw()
            .map_err(|e| err(&e))?;
        for (name, f, color) in series {
            c.draw_series(LineSeries::new(
                history.iter().map(|m| (m.epoch as f64, f(m).max(lo))),
                color,
            ))
            .map_err(|e| err(&e))?
            .label(name)
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], color));
        }
        c.configure_series_labels()
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .draw()
            .map_err(|e| err(&e))?;

        let pts: Vec<(f64, f64, f64)> = history
            .iter()
            .filter_map(|m| m.val.map(|v| (m.epoch as f64, v.min_ade, v.min_fde)))
            .collect();
        if !pts.is_empty() {
            let ymax = pts.iter().map(|p| p.2.max(p.1)).fold(0.0, f64::max) * 1.1;
            let mut c = ChartBuilder::on(&right)
                .caption(format!("validation best-of-K ({unit})"), ("sans-serif", 18))
                .margin(10)
                .x_label_area_size(35)
                .y_label_area_size(50)
                .build_cartesian_2d(xmin..xmax, 0.0..ymax.max(1e-6))
                .map_err(|e| err(&e))?;
            c.configure_mesh()
                .x_desc("epoch")
                .draw()
                .map_err(|e| err(&e))?;
            c.draw_series(LineSeries::new(pts.iter().map(|p| (p.0, p.1)), BLUE))
                .map_err(|e| err(&e))?
                .label("minADE")
                .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLUE));
            c.draw_series(LineSeries::new(pts.iter().map(|p| (p.0, p.2)), RED))
                .map_err(|e| err(&e))?
                .label("minFDE")
                .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], RED));
            c.configure_series_labels()
                .background_style(WHITE.mix(0.8))
                .border_style(BLACK)
                .draw()
                .map_err(|e| err(&e))?;
        }
        root.present().map_err(|e| err(&e))?;
    }
    let mut bytes = Vec::new();
    bytes.write_all(svg.as_bytes())?;
    crate::rundir::write_atomic(path, &bytes)?;
    Ok(())
}
