//! Evaluation of exported blobs **through `gpecnet-core`** (what the device
//! runs) and through the trainer's reference path, with the same seeds.
//!
//! Seeds: window `i` of a dataset (in loading order) uses latent seed
//! `base_seed + i`. Predictions are computed in parallel but accumulated in
//! window order, so the metrics are identical for any thread count.
//!
//! For a model without a trajectory predictor, the 11 intermediate points
//! are placed on the straight line from the last observation to each
//! endpoint (documented in the model card when used).

use anyhow::{anyhow, Result};
use gpecnet_core::{FastSine, LibmSine, Model, Predictor, Sine};

use crate::data::{Dataset, Window, FUTURE, PAST};
use crate::eval::{Metrics, MetricsAccumulator, Prediction};
use crate::reference::{RefModel, SineKind};

/// Scratch width of the host predictor: enough for the paper-size model.
pub const HOST_WIDTH: usize = 1024;
/// Most samples per window on the host.
pub const HOST_MAX_K: usize = 64;

pub(crate) fn to_fixed(t: &[[f32; 2]]) -> [[f32; 2]; FUTURE] {
    let mut out = [[0.0; 2]; FUTURE];
    for (o, p) in out.iter_mut().zip(t) {
        *o = *p;
    }
    out
}

/// Straight-line fill from `last` to `end` (for endpoint-only models).
pub fn linear_fill(last: [f32; 2], end: [f32; 2]) -> [[f32; 2]; FUTURE] {
    let mut out = [[0.0; 2]; FUTURE];
    for (t, o) in out.iter_mut().enumerate() {
        let a = (t + 1) as f32 / FUTURE as f32;
        *o = [
            last[0] + (end[0] - last[0]) * a,
            last[1] + (end[1] - last[1]) * a,
        ];
    }
    out
}

/// One window through `gpecnet-core`'s run-time dispatching predictor: the
/// blob's endpoint set (test-time sampling), or `k` trajectories, or `k`
/// straight-line-filled endpoints of an endpoint-only model.
fn predict_core_with<S: Sine>(
    model: &Model<'_>,
    w: &Window,
    seed: u64,
    k: usize,
) -> Result<Prediction> {
    let mut p = Box::new(Predictor::<S, HOST_WIDTH>::new(*model).map_err(|e| anyhow!("{e}"))?);
    let past = w.obs();
    let at = |e| anyhow!("{}#{}: {e}", w.scene, w.ped_id);
    let fill = |ends: Vec<[f32; 2]>| -> Vec<[[f32; 2]; FUTURE]> {
        ends.iter()
            .map(|e| linear_fill(past[PAST - 1], *e))
            .collect()
    };
    let mut ends = vec![[0.0f32; 2]; k];
    let trajectories = if model.extensions().tts_samples > 0 {
        p.predict_endpoint_set::<{ gpecnet_core::blob::MAX_TTS_SAMPLES }>(&past, seed, &mut ends)
            .map_err(at)?;
        fill(ends)
    } else if model.has_predictor() {
        let mut t = vec![gpecnet_core::Trajectory::new(); k];
        p.predict_trajectories(&past, seed, &mut t).map_err(at)?;
        t.iter().map(|t| to_fixed(t)).collect()
    } else {
        p.predict_samples(&past, seed, &mut ends).map_err(at)?;
        fill(ends)
    };
    Ok(Prediction { trajectories })
}

/// K samples for one window through `gpecnet-core`.
pub fn predict_core(
    model: &Model<'_>,
    sine: SineKind,
    w: &Window,
    seed: u64,
    k: usize,
) -> Result<Prediction> {
    if k == 0 || k > HOST_MAX_K {
        return Err(anyhow!("k must be 1..={HOST_MAX_K}"));
    }
    match sine {
        SineKind::Libm => predict_core_with::<LibmSine>(model, w, seed, k),
        SineKind::Fast => predict_core_with::<FastSine>(model, w, seed, k),
    }
}

/// K samples for one window through the reference path.
pub fn predict_reference(
    model: &RefModel,
    sine: SineKind,
    w: &Window,
    seed: u64,
    k: usize,
) -> Prediction {
    let past = w.obs();
    if model.config.tts_samples > 0 {
        let ends = model.predict_set(&past, seed, k, sine).unwrap_or_default();
        return Prediction {
            trajectories: ends
                .iter()
                .map(|e| linear_fill(past[PAST - 1], *e))
                .collect(),
        };
    }
    let p = model.predict(&past, seed, k, sine, !model.nets.predictor.is_empty());
    let trajectories = if model.nets.predictor.is_empty() {
        p.endpoints
            .iter()
            .map(|e| linear_fill(past[PAST - 1], *e))
            .collect()
    } else {
        p.trajectories.iter().map(|t| to_fixed(t)).collect()
    };
    Prediction { trajectories }
}

/// Maps `f` over `0..n` on all cores (scoped threads, contiguous chunks); results in index
/// order, so anything accumulated from them is independent of the thread count.
pub fn parallel_map<T: Send>(n: usize, f: impl Fn(usize) -> Result<T> + Sync) -> Result<Vec<T>> {
    let threads = std::thread::available_parallelism()
        .map_or(1, |n| n.get())
        .min(n.max(1));
    let chunk = n.div_ceil(threads);
    let parts: Vec<Result<Vec<T>>> = std::thread::scope(|s| {
        let handles: Vec<_> = (0..threads)
            .map(|t| {
                let f = &f;
                s.spawn(move || {
                    (t * chunk..((t + 1) * chunk).min(n))
                        .map(f)
                        .collect::<Result<Vec<T>>>()
                })
            })
            .collect();
        handles
            .into_iter()
            .map(|h| h.join().unwrap_or_else(|_| Err(anyhow!("worker panicked"))))
            .collect()
    });
    let mut out = Vec::with_capacity(n);
    for p in parts {
        out.extend(p?);
    }
    Ok(out)
}

/// Evaluates a blob through `gpecnet-core` on every window of `ds`.
pub fn evaluate_core(
    blob: &[u8],
    sine: SineKind,
    ds: &Dataset,
    k: usize,
    base_seed: u64,
) -> Result<(Metrics, Vec<Prediction>)> {
    let model = Model::from_blob(blob).map_err(|e| anyhow!("{e}"))?;
    let preds = parallel_map(ds.windows.len(), |i| {
        predict_core(
            &model,
            sine,
            &ds.windows[i],
            base_seed.wrapping_add(i as u64),
            k,
        )
    })?;
    Ok((accumulate(ds, &preds)?, preds))
}

/// Evaluates the reference path on every window of `ds`.
pub fn evaluate_reference(
    model: &RefModel,
    sine: SineKind,
    ds: &Dataset,
    k: usize,
    base_seed: u64,
) -> Result<(Metrics, Vec<Prediction>)> {
    let preds = parallel_map(ds.windows.len(), |i| {
        Ok(predict_reference(
            model,
            sine,
            &ds.windows[i],
            base_seed.wrapping_add(i as u64),
            k,
        ))
    })?;
    Ok((accumulate(ds, &preds)?, preds))
}

pub(crate) fn accumulate(ds: &Dataset, preds: &[Prediction]) -> Result<Metrics> {
    if ds.windows.is_empty() {
        return Err(anyhow!(
            "{}: {}",
            ds.name,
            crate::eval::EvalError::NoWindows
        ));
    }
    let mut acc = MetricsAccumulator::new();
    for (w, p) in ds.windows.iter().zip(preds) {
        acc.add(w, p)
            .map_err(|e| anyhow!("{}#{}: {e:?}", w.scene, w.ped_id))?;
    }
    Ok(acc.finish())
}

/// The point forecast of one window through `gpecnet-core` (f32 blobs with
/// `sine`; fixed-point blobs always with their integer sine).
fn point_core(model: &Model<'_>, sine: SineKind, w: &Window) -> Result<[[f32; 2]; FUTURE]> {
    fn point<S: Sine>(model: &Model<'_>, past: &[[f32; 2]]) -> Result<gpecnet_core::Trajectory> {
        let mut p = Box::new(Predictor::<S, HOST_WIDTH>::new(*model).map_err(|e| anyhow!("{e}"))?);
        p.predict_point(past).map_err(|e| anyhow!("{e}"))
    }
    let past = w.obs();
    let t = match sine {
        SineKind::Libm => point::<LibmSine>(model, &past),
        SineKind::Fast => point::<FastSine>(model, &past),
    }
    .map_err(|e| anyhow!("{}#{}: {e}", w.scene, w.ped_id))?;
    Ok(to_fixed(&t))
}

/// The point forecast (K = 1: `ade_k1`/`fde_k1` are its ADE/FDE) of a blob through
/// `gpecnet-core` on every window of `ds`, and the forecasts; `None` for a blob without a
/// point-forecast head. `sine` is ignored for fixed-point blobs.
pub fn evaluate_point_core(
    blob: &[u8],
    sine: SineKind,
    ds: &Dataset,
) -> Result<Option<(Metrics, Vec<Prediction>)>> {
    let model = Model::from_blob(blob).map_err(|e| anyhow!("{e}"))?;
    if !model.has_point_head() {
        return Ok(None);
    }
    let preds = parallel_map(ds.windows.len(), |i| {
        Ok(Prediction::single(point_core(
            &model,
            sine,
            &ds.windows[i],
        )?))
    })?;
    Ok(Some((accumulate(ds, &preds)?, preds)))
}
