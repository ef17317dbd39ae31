//! `gpecnet select`: inference settings chosen on **validation** through `gpecnet-core`.
//!
//! A trained run's best model is exported in memory once per setting — latent spread `sigma`
//! and test-time sampling `N` (0 = plain sampling; otherwise `N` samples reduced to K by
//! k-means, first-K initialisation, 3 Lloyd iterations: the best of the grid in `docs/tts.md`)
//! — and evaluated through `gpecnet-core` on the run's validation windows (seed of window `i`
//! is `i`). The point forecast does not depend on either setting and is reported once. The
//! test set is never read.

use std::path::Path;

use anyhow::{bail, Result};

use crate::core_eval::{evaluate_core, evaluate_point_core};
use crate::data::{self, Dataset};
use crate::eval::Metrics;
use crate::export::blob_bytes;
use crate::reference::SineKind;
use crate::run_export::model_from_run;

/// One evaluated setting.
#[derive(Clone, Debug, serde::Serialize)]
pub struct SelectRow {
    /// Latent standard deviation.
    pub sigma: f32,
    /// Test-time samples (0 = plain).
    pub tts: usize,
    /// Validation metrics of the K endpoints.
    pub val: Metrics,
    /// Their distribution quality: KDE NLL of the true endpoint (nats, the data's unit).
    pub kde_nll: f64,
    /// Share of windows with an endpoint within 0.5 / 1 m (20 / 40 px).
    pub hits: [f64; 2],
}

/// The validation windows of a run's config (raw coordinates).
pub fn validation_set(cfg: &crate::config::TrainConfig, data_root: &Path) -> Result<Dataset> {
    let spec = cfg.dataset_spec()?;
    Ok(data::load(
        data_root,
        &spec,
        data::Split::Val,
        &cfg.val_scenes,
    )?)
}

/// Evaluates every `(sigma, tts)` of the grid; returns the rows and the point forecast's
/// validation metrics (when the model has a head).
pub fn select(
    run: &Path,
    data_root: &Path,
    sigmas: &[f32],
    tts: &[usize],
    k: usize,
    sine: SineKind,
) -> Result<(Vec<SelectRow>, Option<Metrics>)> {
    // The training config's rule for sigma: finite and >= 0.
    if let Some(s) = sigmas.iter().find(|s| !(s.is_finite() && **s >= 0.0)) {
        bail!("--sigmas {s} is out of range: allowed finite numbers >= 0");
    }
    for &n in tts {
        if n != 0 && (n < k || n > gpecnet_core::blob::MAX_TTS_SAMPLES) {
            bail!(
                "--tts {n} with --k {k}: test-time sampling draws --tts samples and reduces \
                 them to --k endpoints by k-means, so each --tts must be 0 (plain sampling) \
                 or between --k = {k} and {}",
                gpecnet_core::blob::MAX_TTS_SAMPLES
            );
        }
    }
    let (cfg, model, _) = model_from_run(run, "select")?;
    let val = validation_set(&cfg, data_root)?;
    if val.is_empty() {
        bail!("the run's validation split is empty");
    }
    let mut rows = Vec::new();
    for &sigma in sigmas {
        for &n in tts {
            let mut m = model.clone();
            m.config.sigma = sigma;
            m.config.tts_samples = n;
            m.config.tts_iters = if n > 0 { 3 } else { 0 };
            m.config.tts_init = 0;
            let blob = blob_bytes(&m)?;
            let (val_m, preds) = evaluate_core(&blob, sine, &val, k, 0)?;
            let acc = crate::dist::dist_accumulator(&val, &preds)
                .ok_or_else(|| anyhow::anyhow!("one prediction per validation window"))?;
            let radii = crate::dist::hit_radii(val.unit);
            rows.push(SelectRow {
                sigma,
                tts: n,
                val: val_m,
                kde_nll: acc.finish().map_or(f64::NAN, |d| d.kde_nll),
                hits: radii.map(|r| acc.within(r)),
            });
        }
    }
    let point = evaluate_point_core(&blob_bytes(&model)?, sine, &val)?.map(|(m, _)| m);
    Ok((rows, point))
}

/// The setting [`select`]'s rows recommend: lowest validation minFDE, ties by minADE (`None`
/// for no rows).
pub fn best(rows: &[SelectRow]) -> Option<&SelectRow> {
    rows.iter().min_by(|x, y| {
        (x.val.min_fde.total_cmp(&y.val.min_fde)).then(x.val.min_ade.total_cmp(&y.val.min_ade))
    })
}

/// [`select`]'s result as `gpecnet select` prints it: a Markdown table of the rows (K = `k`)
/// and the point forecast's line; every line ends in a newline.
pub fn table(k: usize, rows: &[SelectRow], point: Option<&Metrics>) -> String {
    let mut s = format!("validation, through gpecnet-core, K = {k}:\n");
    s.push_str(
        "| sigma | N | minADE | minFDE | KDE NLL | hits (two radii) |\n|---|---|---|---|---|---|\n",
    );
    for r in rows {
        s.push_str(&format!(
            "| {} | {} | {:.3} | {:.3} | {:.3} | {:.1} % / {:.1} % |\n",
            r.sigma,
            r.tts,
            r.val.min_ade,
            r.val.min_fde,
            r.kde_nll,
            100.0 * r.hits[0],
            100.0 * r.hits[1]
        ));
    }
    if let Some(p) = point {
        s.push_str(&format!(
            "point forecast: ADE {:.3} FDE {:.3}\n",
            p.ade_k1, p.fde_k1
        ));
    }
    s
}
