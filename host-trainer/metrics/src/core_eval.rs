//! Evaluation of exported blobs **through `gpecnet-core`** (what the device
//! runs) and through the trainer's reference path, with the same seeds.
//!
//! Seeds: window `i` of a dataset (in loading order) uses latent seed
//! `base_seed + i`. Predictions are computed in parallel but accumulated in
//! window order, so the metrics are identical for any thread count.
//!
//! Whole data sets go through the core's batched path
//! ([`gpecnet_core::batch`]: [`BLOCK`] windows per task, their samples
//! [`gpecnet_core::batch::HOST_LANES`] side by side), which gives the same
//! bits as [`gpecnet_core::Predictor`] window by window (`tests/tests/batch_vs_scalar.rs`)
//! in a fraction of the time.
//!
//! For a model without a trajectory predictor, the 11 intermediate points
//! are placed on the straight line from the last observation to each
//! endpoint (documented in the model card when used).

use anyhow::{anyhow, Result};
use gpecnet_core::batch::{HostBatchPredictor, Query};
use gpecnet_core::blob::MAX_TTS_SAMPLES;
use gpecnet_core::{FastSine, LibmSine, Model, Sine, Trajectory};

use crate::data::{Dataset, Window, FUTURE, PAST};
use crate::eval::{Metrics, MetricsAccumulator, Prediction};
use crate::reference::{RefModel, SineKind};

/// Scratch width of the host predictor: enough for the paper-size model.
pub const HOST_WIDTH: usize = 1024;
/// Most samples per window on the host.
pub const HOST_MAX_K: usize = 64;

/// The most endpoints per window the host evaluation gets from `model`: the
/// core's own bound ([`gpecnet_core::sampling::max_endpoints_of`]: K for a
/// proposal model, `min(tts_samples, 64)` with test-time sampling) with the
/// host's buffers, and at most [`HOST_MAX_K`].
pub fn host_max_endpoints(model: &Model<'_>) -> usize {
    let capacity = if model.extensions().tts_samples > 0 {
        MAX_TTS_SAMPLES
    } else {
        HOST_MAX_K
    };
    gpecnet_core::sampling::max_endpoints_of(model, capacity).min(HOST_MAX_K)
}

/// Refuses an endpoint count `k` (given as option `name`, e.g. `--k`) that
/// `model` cannot give, before any work, naming the limit.
pub fn check_k(name: &str, model: &Model<'_>, k: usize) -> Result<()> {
    let most = host_max_endpoints(model);
    if k == 0 || k > most {
        let tts = model.extensions().tts_samples;
        let why = if model.has_proposal() {
            " (its proposal has K latents)".to_string()
        } else if tts > 0 && k > most {
            // Test-time sampling reduces its N samples to the endpoints: never more than N.
            format!(
                " (it was exported with --tts {tts}: test-time sampling reduces --tts samples \
                 to {name} endpoints by k-means, so {name} must be at most --tts, and at most \
                 {HOST_MAX_K})"
            )
        } else {
            String::new()
        };
        return Err(anyhow!(
            "{name} {k}: this model gives 1..={most} endpoints per prediction{why}"
        ));
    }
    Ok(())
}

pub fn to_fixed(t: &[[f32; 2]]) -> [[f32; 2]; FUTURE] {
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

/// Windows per task of the batched evaluation: enough to fill the lanes
/// many times over, few enough that two threads share the work evenly.
pub const BLOCK: usize = 64;

/// One batched-path [`Query`] per past, track `i` with latent seed `seed(i)` (the
/// evaluation's convention is `base_seed + i`).
pub fn queries<P: AsRef<[[f32; 2]]>>(pasts: &[P], seed: impl Fn(usize) -> u64) -> Vec<Query<'_>> {
    pasts
        .iter()
        .enumerate()
        .map(|(i, p)| Query {
            past: p.as_ref(),
            seed: seed(i),
        })
        .collect()
}

/// `windows` through `gpecnet-core`'s batched predictor (window `i` with
/// seed `seeds(i)`): per window the blob's endpoint set (test-time
/// sampling), or `k` trajectories, or `k` straight-line-filled endpoints of
/// an endpoint-only model. The same bits as [`gpecnet_core::Predictor`] window by window.
fn predict_block_with<S: Sine>(
    model: &Model<'_>,
    windows: &[Window],
    seeds: impl Fn(usize) -> u64,
    k: usize,
) -> Result<Vec<Prediction>> {
    let mut p =
        Box::new(HostBatchPredictor::<S, HOST_WIDTH>::new(*model).map_err(|e| anyhow!("{e}"))?);
    let pasts: Vec<[[f32; 2]; PAST]> = windows.iter().map(Window::obs).collect();
    let queries = queries(&pasts, seeds);
    let at = |e: gpecnet_core::batch::QueryError| {
        let w = &windows[e.index.min(windows.len().saturating_sub(1))];
        anyhow!("{}#{}: {}", w.scene, w.ped_id, e.error)
    };
    let fill = |ends: &[[f32; 2]], past: &[[f32; 2]; PAST]| Prediction {
        trajectories: ends
            .iter()
            .map(|e| linear_fill(past[PAST - 1], *e))
            .collect(),
    };
    let n = queries.len();
    if model.extensions().tts_samples == 0 && model.has_predictor() {
        let mut t = vec![Trajectory::new(); n * k];
        p.predict_trajectories_many(&queries, k, &mut t)
            .map_err(at)?;
        return Ok(t
            .chunks(k)
            .map(|t| Prediction {
                trajectories: t.iter().map(|t| to_fixed(t)).collect(),
            })
            .collect());
    }
    let mut ends = vec![[0.0f32; 2]; n * k];
    if model.extensions().tts_samples > 0 {
        p.predict_endpoint_sets::<MAX_TTS_SAMPLES>(&queries, k, &mut ends)
            .map_err(at)?;
    } else {
        p.predict_samples_many(&queries, k, &mut ends).map_err(at)?;
    }
    Ok(ends
        .chunks(k)
        .zip(&pasts)
        .map(|(e, past)| fill(e, past))
        .collect())
}

/// [`predict_block_with`] with the sine of `sine` (ignored by fixed-point blobs).
fn predict_block(
    model: &Model<'_>,
    sine: SineKind,
    windows: &[Window],
    seeds: impl Fn(usize) -> u64,
    k: usize,
) -> Result<Vec<Prediction>> {
    check_k("k", model, k)?;
    match sine {
        SineKind::Libm => predict_block_with::<LibmSine>(model, windows, seeds, k),
        SineKind::Fast => predict_block_with::<FastSine>(model, windows, seeds, k),
    }
}

/// K samples for one window through `gpecnet-core` (its batched path; the
/// same bits as [`gpecnet_core::Predictor`]).
pub fn predict_core(
    model: &Model<'_>,
    sine: SineKind,
    w: &Window,
    seed: u64,
    k: usize,
) -> Result<Prediction> {
    let mut p = predict_block(model, sine, std::slice::from_ref(w), |_| seed, k)?;
    p.pop().ok_or_else(|| anyhow!("no prediction"))
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

/// `f` over `windows` in blocks of [`BLOCK`] on all cores ([`parallel_map`]), the results
/// in window order: `f(block, seeds)`, where `seeds(i)` is `base_seed +` the window's index
/// in `windows` (wrapping) for window `i` of the block.
fn in_blocks<T: Send>(
    windows: &[Window],
    base_seed: u64,
    f: impl Fn(&[Window], &dyn Fn(usize) -> u64) -> Result<Vec<T>> + Sync,
) -> Result<Vec<T>> {
    let blocks = parallel_map(windows.len().div_ceil(BLOCK), |b| {
        let lo = b * BLOCK;
        let hi = (lo + BLOCK).min(windows.len());
        f(&windows[lo..hi], &|i| {
            base_seed.wrapping_add((lo + i) as u64)
        })
    })?;
    Ok(blocks.into_iter().flatten().collect())
}

/// Evaluates a blob through `gpecnet-core` on every window of `ds` (the
/// batched path, [`BLOCK`] windows per task on all cores).
pub fn evaluate_core(
    blob: &[u8],
    sine: SineKind,
    ds: &Dataset,
    k: usize,
    base_seed: u64,
) -> Result<(Metrics, Vec<Prediction>)> {
    let model = Model::from_blob(blob).map_err(|e| anyhow!("{e}"))?;
    let preds = in_blocks(&ds.windows, base_seed, |ws, seeds| {
        predict_block(&model, sine, ws, seeds, k)
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

pub fn accumulate(ds: &Dataset, preds: &[Prediction]) -> Result<Metrics> {
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

/// The point forecasts of `windows` through `gpecnet-core`'s batched path
/// (f32 blobs with `sine`; fixed-point blobs always with their integer sine).
fn points_core(
    model: &Model<'_>,
    sine: SineKind,
    windows: &[Window],
) -> Result<Vec<[[f32; 2]; FUTURE]>> {
    fn points<S: Sine>(model: &Model<'_>, windows: &[Window]) -> Result<Vec<Trajectory>> {
        let mut p =
            Box::new(HostBatchPredictor::<S, HOST_WIDTH>::new(*model).map_err(|e| anyhow!("{e}"))?);
        let pasts: Vec<[[f32; 2]; PAST]> = windows.iter().map(Window::obs).collect();
        let queries = queries(&pasts, |_| 0);
        let mut out = vec![Trajectory::new(); queries.len()];
        p.predict_points(&queries, &mut out).map_err(|e| {
            let w = &windows[e.index.min(windows.len().saturating_sub(1))];
            anyhow!("{}#{}: {}", w.scene, w.ped_id, e.error)
        })?;
        Ok(out)
    }
    let t = match sine {
        SineKind::Libm => points::<LibmSine>(model, windows),
        SineKind::Fast => points::<FastSine>(model, windows),
    }?;
    Ok(t.iter().map(|t| to_fixed(t)).collect())
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
    let points = in_blocks(&ds.windows, 0, |ws, _| points_core(&model, sine, ws))?;
    let preds: Vec<Prediction> = points.into_iter().map(Prediction::single).collect();
    Ok(Some((accumulate(ds, &preds)?, preds)))
}

/// One window's planner outputs through `gpecnet_core::Predictor::predict_forecast`.
#[derive(Clone, Debug, PartialEq)]
pub struct PlannerOut {
    /// The endpoints.
    pub endpoints: Vec<[f32; 2]>,
    /// Their probabilities.
    pub probs: Vec<f32>,
    /// The point forecast's endpoint.
    pub point: Option<[f32; 2]>,
    /// `[r50, r90]`.
    pub radii: Option<[f32; 2]>,
}

/// The planner outputs of every window of `ds` through `gpecnet-core` (window `i` with
/// seed `base_seed + i`, [`HOST_MAX_K`] endpoints at most), `None` for a model without
/// endpoint probabilities.
pub fn planner_core(
    blob: &[u8],
    sine: SineKind,
    ds: &Dataset,
    base_seed: u64,
) -> Result<Option<Vec<PlannerOut>>> {
    let model = Model::from_blob(blob).map_err(|e| anyhow!("{e}"))?;
    if !model.has_probabilities() {
        return Ok(None);
    }
    fn block<S: Sine>(
        model: Model<'_>,
        ws: &[Window],
        seed: impl Fn(usize) -> u64,
    ) -> Result<Vec<PlannerOut>> {
        let mut p =
            gpecnet_core::Predictor::<S, HOST_WIDTH>::new(model).map_err(|e| anyhow!("{e}"))?;
        ws.iter()
            .enumerate()
            .map(|(i, w)| {
                let f = p
                    .predict_forecast::<HOST_MAX_K>(&w.obs(), seed(i))
                    .map_err(|e| anyhow!("{e}"))?;
                Ok(PlannerOut {
                    endpoints: f.endpoints.to_vec(),
                    probs: f.probabilities.to_vec(),
                    point: f.point,
                    radii: f.radii.map(|r| [r.r50, r.r90]),
                })
            })
            .collect()
    }
    let out = in_blocks(&ds.windows, base_seed, |ws, seed| match sine {
        SineKind::Libm => block::<LibmSine>(model, ws, seed),
        SineKind::Fast => block::<FastSine>(model, ws, seed),
    })?;
    Ok(Some(out))
}

/// Whether every window's probabilities through `gpecnet-core` (`outs`) equal, bit for bit,
/// those a reference computes for its observed past (`reference`; `None` = it has none).
pub fn probabilities_match(
    windows: &[Window],
    outs: &[PlannerOut],
    reference: impl Fn(&[[f32; 2]]) -> Option<Vec<f32>>,
) -> bool {
    windows.len() == outs.len()
        && outs.iter().zip(windows).all(|(o, w)| {
            reference(&w.obs()).is_some_and(|p| {
                p.iter()
                    .map(|v| v.to_bits())
                    .eq(o.probs.iter().map(|v| v.to_bits()))
            })
        })
}

/// The [`crate::planner_metrics::PlannerAccumulator`] of `outs` on `windows`, window `w`'s
/// distances times `unit(w)`.
pub fn planner_accumulator(
    windows: &[Window],
    outs: &[PlannerOut],
    unit: impl Fn(&Window) -> Result<f64>,
) -> Result<crate::planner_metrics::PlannerAccumulator> {
    let mut acc = crate::planner_metrics::PlannerAccumulator::new();
    for (w, o) in windows.iter().zip(outs) {
        acc.add(&crate::planner_metrics::PlannerWindow {
            endpoints: &o.endpoints,
            probs: &o.probs,
            truth: w.pos[PAST + FUTURE - 1],
            point: o.point,
            radii: o.radii,
            unit: unit(w)?,
        });
    }
    Ok(acc)
}

/// [`crate::planner_metrics::PlannerMetrics`] of `outs` on `windows`, window `w`'s
/// distances times `unit(w)`.
pub fn planner_metrics(
    windows: &[Window],
    outs: &[PlannerOut],
    unit: impl Fn(&Window) -> Result<f64>,
) -> Result<crate::planner_metrics::PlannerMetrics> {
    Ok(planner_accumulator(windows, outs, unit)?.finish())
}

/// What an evaluation reads from a model with endpoint probabilities, every window computed
/// once ([`forecasts_core`]).
#[derive(Clone, Debug, PartialEq)]
pub struct Forecasts {
    /// The `k` samples of every window: what [`evaluate_core`] gives.
    pub samples: Vec<Prediction>,
    /// The point forecast of every window, for a model with a point head: what
    /// [`evaluate_point_core`] gives.
    pub points: Option<Vec<Prediction>>,
    /// The planner outputs of every window: what [`planner_core`] gives.
    pub planner: Vec<PlannerOut>,
}

/// One pass through `gpecnet-core` for a model with endpoint probabilities (window `i` with
/// seed `base_seed + i`): per window the endpoints and trajectories, their probabilities,
/// the point forecast and its radii, each computed once. The same bits as
/// [`evaluate_core`] (`k` samples), [`evaluate_point_core`] and [`planner_core`] give one
/// by one: a proposal model's sample stream is one sequence whose first `k` elements are
/// the `k` samples and whose first [`HOST_MAX_K`]-bounded elements are the planner's
/// endpoints ([`gpecnet_core::sampling::max_endpoints_of`]), and the probabilities, the
/// point forecast and the radii follow in the planner's order
/// ([`gpecnet_core::Predictor::predict_planner`]). `None` for a model without
/// probabilities or with test-time sampling, whose outputs these functions give separately.
/// `sine` is ignored for fixed-point blobs.
pub fn forecasts_core(
    blob: &[u8],
    sine: SineKind,
    ds: &Dataset,
    k: usize,
    base_seed: u64,
) -> Result<Option<Forecasts>> {
    let model = Model::from_blob(blob).map_err(|e| anyhow!("{e}"))?;
    if !model.has_probabilities() || model.extensions().tts_samples > 0 {
        return Ok(None);
    }
    check_k("k", &model, k)?;
    type One = (Prediction, Option<Prediction>, PlannerOut);
    fn block<S: Sine>(
        model: Model<'_>,
        ws: &[Window],
        seed: impl Fn(usize) -> u64,
        k: usize,
    ) -> Result<Vec<One>> {
        let mut p =
            gpecnet_core::Predictor::<S, HOST_WIDTH>::new(model).map_err(|e| anyhow!("{e}"))?;
        // The planner's endpoints: as many as `predict_forecast::<HOST_MAX_K>` gives.
        let n = gpecnet_core::sampling::max_endpoints_of(&model, HOST_MAX_K);
        let drawn = n.max(k);
        let (trajectories, head) = (model.has_predictor(), model.has_point_head());
        let scales = model.radius_scales();
        let mut t = vec![Trajectory::new(); drawn];
        let mut ends = vec![[0.0f32; 2]; drawn];
        let mut probs = vec![0.0f32; n];
        ws.iter()
            .enumerate()
            .map(|(i, w)| {
                let at = |e: gpecnet_core::PredictError| anyhow!("{}#{}: {e}", w.scene, w.ped_id);
                let past = w.obs();
                let samples = if trajectories {
                    p.predict_trajectories(&past, seed(i), &mut t).map_err(at)?;
                    for (e, t) in ends.iter_mut().zip(&t) {
                        *e = *t.last().ok_or_else(|| {
                            anyhow!(
                                "{}#{}: the model gave an empty trajectory",
                                w.scene,
                                w.ped_id
                            )
                        })?;
                    }
                    t[..k].iter().map(|t| to_fixed(t)).collect()
                } else {
                    p.predict_samples(&past, seed(i), &mut ends).map_err(at)?;
                    ends[..k]
                        .iter()
                        .map(|e| linear_fill(past[PAST - 1], *e))
                        .collect()
                };
                let learned = p.probabilities(&mut probs).map_err(at)?;
                let point = if head {
                    Some(p.predict_point(&past).map_err(at)?)
                } else {
                    None
                };
                let point_end = point.as_ref().and_then(|t| t.last().copied());
                let radii = match point_end {
                    Some(pt) if learned => Some(
                        gpecnet_core::planner::radii(pt, &ends[..n], &probs, scales).map_err(at)?,
                    ),
                    _ => None,
                };
                Ok((
                    Prediction {
                        trajectories: samples,
                    },
                    point.as_ref().map(|t| Prediction::single(to_fixed(t))),
                    PlannerOut {
                        endpoints: ends[..n].to_vec(),
                        probs: probs.clone(),
                        point: point_end,
                        radii: radii.map(|r| [r.r50, r.r90]),
                    },
                ))
            })
            .collect()
    }
    let blocks = in_blocks(&ds.windows, base_seed, |ws, seed| match sine {
        SineKind::Libm => block::<LibmSine>(model, ws, seed, k),
        SineKind::Fast => block::<FastSine>(model, ws, seed, k),
    })?;
    let n = ds.windows.len();
    let mut out = Forecasts {
        samples: Vec::with_capacity(n),
        points: model.has_point_head().then(|| Vec::with_capacity(n)),
        planner: Vec::with_capacity(n),
    };
    for (s, point, planner) in blocks {
        out.samples.push(s);
        if let (Some(all), Some(pt)) = (out.points.as_mut(), point) {
            all.push(pt);
        }
        out.planner.push(planner);
    }
    Ok(Some(out))
}
