//! Validation metrics of a model (best-of-K, K = 1, the point head).

use anyhow::Result;
use candle_core::{Device, Tensor};

use crate::config::TrainConfig;
use crate::data::{self, Sample, Window, FUTURE, PAST};
use crate::eval::{Metrics, MetricsAccumulator, Prediction};
use crate::model::Model;
use crate::rng::{streams, Rng};

use super::*;

/// Validation of the point head (K = 1 metrics of its deterministic forecast), or `None`
/// when the model has no head.
pub fn validate_point(
    model: &Model,
    cfg: &TrainConfig,
    windows: &[Window],
) -> Result<Option<Metrics>> {
    if model.point_head.is_none() {
        return Ok(None);
    }
    let mut acc = MetricsAccumulator::new();
    for chunk in windows.chunks(VAL_CHUNK) {
        let obs: Vec<f32> = chunk
            .iter()
            .flat_map(|w| {
                let s = data::normalize(w, cfg.data_scale);
                s.obs.into_iter().flatten()
            })
            .collect();
        let obs = Tensor::from_vec(obs, (chunk.len(), 2 * PAST), &Device::Cpu)?;
        let Some(pred) = model.point_forecast(&obs)? else {
            return Ok(None);
        };
        let fut = pred.flatten_all()?.to_vec1::<f32>()?;
        for (i, w) in chunk.iter().enumerate() {
            let t = raw_future(&fut, i, w, cfg.data_scale);
            acc.add(w, &Prediction::single(t))?;
        }
    }
    Ok(Some(acc.finish()))
}

/// Best-of-K validation of `model` on raw `windows`: K = `cfg.k` futures per window with
/// `z ~ N(0, sigma^2)` from a fresh VALIDATION-stream RNG (identical draws every call),
/// mapped back to raw units (`p / data_scale + p0`).
///
/// With social pooling the windows are grouped like the training data
/// ([`crate::social::group_windows`]), packed into chunks without splitting groups, and each
/// of the K samples is pooled over its own copy of the chunk (the same latents as without
/// pooling: row `i * K + j` is sample `j` of window `i`).
pub fn validate_model(model: &Model, cfg: &TrainConfig, windows: &[Window]) -> Result<Metrics> {
    if model.has_social() {
        return validate_social(model, cfg, windows);
    }
    let mut rng = Rng::with_stream(cfg.seed, streams::VALIDATION);
    let k = cfg.k;
    let zdim = model.zdim();
    let mut acc = MetricsAccumulator::new();
    for chunk in windows.chunks(VAL_CHUNK) {
        let samples: Vec<Sample> = chunk
            .iter()
            .map(|w| data::normalize(w, cfg.data_scale))
            .collect();
        let rows = chunk.len() * k;
        let mut obs: Vec<f32> = Vec::with_capacity(rows * 2 * PAST);
        let mut init: Vec<f32> = Vec::with_capacity(rows * 2);
        for s in &samples {
            for _ in 0..k {
                obs.extend(s.obs.iter().flatten());
                init.extend(s.initial_pos);
            }
        }
        let obs = Tensor::from_vec(obs, (rows, 2 * PAST), &Device::Cpu)?;
        let init = Tensor::from_vec(init, (rows, 2), &Device::Cpu)?;
        let z = Tensor::from_vec(
            rng.normal_vec(rows * zdim, cfg.sigma),
            (rows, zdim),
            &Device::Cpu,
        )?;
        let fut = model
            .sample_future(&obs, &init, &z, None)?
            .flatten_all()?
            .to_vec1::<f32>()?;
        for (i, w) in chunk.iter().enumerate() {
            let trajectories = (0..k)
                .map(|j| raw_future(&fut, i * k + j, w, cfg.data_scale))
                .collect();
            acc.add(w, &Prediction { trajectories })?;
        }
    }
    Ok(acc.finish())
}

fn validate_social(model: &Model, cfg: &TrainConfig, windows: &[Window]) -> Result<Metrics> {
    let mut rng = Rng::with_stream(cfg.seed, streams::VALIDATION);
    let (k, zdim) = (cfg.k, model.zdim());
    let groups: Vec<Vec<u32>> =
        crate::social::group_windows(windows, cfg.time_thresh, cfg.dist_thresh)
            .into_iter()
            .map(|g| g.into_iter().map(|i| i as u32).collect())
            .collect();
    let mut acc = MetricsAccumulator::new();
    for chunk_groups in crate::social::pack_groups(&groups, VAL_CHUNK) {
        let idx: Vec<usize> = chunk_groups
            .iter()
            .flat_map(|g| g.iter().map(|&i| i as usize))
            .collect();
        let sizes: Vec<usize> = chunk_groups.iter().map(|g| g.len()).collect();
        let mask = crate::social::block_mask(&sizes)?;
        let n = idx.len();
        let samples: Vec<Sample> = idx
            .iter()
            .map(|&i| data::normalize(&windows[i], cfg.data_scale))
            .collect();
        let obs: Vec<f32> = samples
            .iter()
            .flat_map(|s| s.obs.iter().flatten())
            .copied()
            .collect();
        let init: Vec<f32> = samples.iter().flat_map(|s| s.initial_pos).collect();
        let obs = Tensor::from_vec(obs, (n, 2 * PAST), &Device::Cpu)?;
        let init = Tensor::from_vec(init, (n, 2), &Device::Cpu)?;
        let z_all = rng.normal_vec(n * k * zdim, cfg.sigma);
        // fut[j]: [n, FUTURE, 2] flattened, for sample j of every window.
        let mut fut = Vec::with_capacity(k);
        for j in 0..k {
            let z: Vec<f32> = (0..n)
                .flat_map(|i| {
                    z_all[(i * k + j) * zdim..(i * k + j + 1) * zdim]
                        .iter()
                        .copied()
                })
                .collect();
            let z = Tensor::from_vec(z, (n, zdim), &Device::Cpu)?;
            fut.push(
                model
                    .sample_future(&obs, &init, &z, Some(&mask))?
                    .flatten_all()?
                    .to_vec1::<f32>()?,
            );
        }
        for (i, &wi) in idx.iter().enumerate() {
            let w = &windows[wi];
            let trajectories = fut
                .iter()
                .map(|f| raw_future(f, i, w, cfg.data_scale))
                .collect();
            acc.add(w, &Prediction { trajectories })?;
        }
    }
    Ok(acc.finish())
}

/// Row `row` of a flattened model-space output `[rows, FUTURE, 2]`, mapped back to raw
/// units around the first observed position of `w` (`p / data_scale + p0`).
fn raw_future(flat: &[f32], row: usize, w: &Window, data_scale: f32) -> [[f32; 2]; FUTURE] {
    let base = row * FUTURE * 2;
    let mut t = [[0.0f32; 2]; FUTURE];
    for (s, p) in t.iter_mut().enumerate() {
        let q = [flat[base + 2 * s], flat[base + 2 * s + 1]];
        *p = data::denormalize_point(q, w.pos[0], data_scale);
    }
    t
}
