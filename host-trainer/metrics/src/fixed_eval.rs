//! A fixed-point model on a data set, through `gpecnet-core` and through the integer reference.

use anyhow::{anyhow, Result};

use crate::core_eval::linear_fill;
use crate::data::{Dataset, Window, PAST};
use crate::eval::{Metrics, Prediction};
use crate::quantize::QModel;

/// K samples for one window of a fixed-point blob through `gpecnet_core`
/// (the run-time dispatching predictor; the sine argument is irrelevant for
/// fixed-point blobs).
pub fn predict_core_fixed(
    model: &gpecnet_core::Model<'_>,
    w: &Window,
    seed: u64,
    k: usize,
) -> Result<Prediction> {
    crate::core_eval::predict_core(model, crate::reference::SineKind::Libm, w, seed, k)
}

/// K samples for one window through the integer reference.
pub fn predict_reference_fixed(m: &QModel, w: &Window, seed: u64, k: usize) -> Prediction {
    let past = w.obs();
    let (ends, trajs) = if m.config.tts_samples > 0 {
        (
            m.predict_set(&past, seed, k).unwrap_or_default(),
            Vec::new(),
        )
    } else {
        m.predict(&past, seed, k)
    };
    let trajectories = if trajs.is_empty() {
        ends.iter()
            .map(|e| linear_fill(past[PAST - 1], *e))
            .collect()
    } else {
        trajs
            .iter()
            .map(|t| crate::core_eval::to_fixed(t))
            .collect()
    };
    Prediction { trajectories }
}

/// Evaluates a fixed-point blob through `gpecnet-core` (window `i` uses seed `base_seed + i`).
pub fn evaluate_core_fixed(
    blob: &[u8],
    ds: &Dataset,
    k: usize,
    base_seed: u64,
) -> Result<(Metrics, Vec<Prediction>)> {
    // The one evaluation through the core (batched); its sine is unused here.
    let model = gpecnet_core::Model::from_blob(blob).map_err(|e| anyhow!("{e}"))?;
    if model.numeric() != gpecnet_core::NumericKind::Int16Q15 {
        return Err(anyhow!("not a fixed-point blob"));
    }
    crate::core_eval::evaluate_core(blob, crate::reference::SineKind::Libm, ds, k, base_seed)
}

/// Evaluates the integer reference on every window of `ds`.
pub fn evaluate_reference_fixed(
    m: &QModel,
    ds: &Dataset,
    k: usize,
    base_seed: u64,
) -> Result<(Metrics, Vec<Prediction>)> {
    let preds = crate::core_eval::parallel_map(ds.windows.len(), |i| {
        Ok(predict_reference_fixed(
            m,
            &ds.windows[i],
            base_seed.wrapping_add(i as u64),
            k,
        ))
    })?;
    Ok((crate::core_eval::accumulate(ds, &preds)?, preds))
}
