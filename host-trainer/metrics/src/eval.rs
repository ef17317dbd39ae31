//! Trajectory-prediction metrics: best-of-K ADE/FDE. The baselines are [`crate::baseline`],
//! the distribution metrics (KDE NLL, hit rates) [`crate::dist`].
//!
//! # Units
//!
//! PECNet computes its errors in *scaled* model coordinates (`(p - p0) * data_scale`) and
//! divides by `data_scale` at the end. We compute them directly in **raw dataset units**, from
//! [`Window::future`] and predictions already mapped back to raw coordinates, so the numbers
//! are **pixels for SDD and metres for ETH/UCY** (the two agree up to f32 rounding). SDD can be
//! reported in metres with per-scene factors from [`crate::data::sdd_metres_per_pixel`] via
//! [`MetricsAccumulator::add_scaled`].
//!
//! # Definitions (Y-Net's)
//!
//! For one window with K predicted 12-step trajectories `ŷ_k` and ground truth `y`:
//! `ADE_k = mean_t ||ŷ_k[t] - y[t]||₂` over the 12 future steps, `FDE_k = ||ŷ_k[11] - y[11]||₂`.
//! minADE = `min_k ADE_k`, minFDE = `min_k FDE_k` (taken independently), each then averaged
//! over windows. Note PECNet's own script picks the best *endpoint* and computes ADE on that
//! one trajectory; this module uses the standard independent minima.

use std::fmt;

use crate::data::{Dataset, Window, FUTURE};

/// K predicted future trajectories for one window, in raw dataset units. The last point of
/// each trajectory is its endpoint.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Prediction {
    /// The K trajectories (K ≥ 1).
    pub trajectories: Vec<[[f32; 2]; FUTURE]>,
}

impl Prediction {
    /// A single-sample (K = 1) prediction.
    pub fn single(traj: [[f32; 2]; FUTURE]) -> Prediction {
        Prediction {
            trajectories: vec![traj],
        }
    }
}

/// Aggregated metrics over `n` windows with `k` samples each (raw units unless produced by
/// [`MetricsAccumulator::add_scaled`]).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Metrics {
    /// Number of windows.
    pub n: usize,
    /// Samples per window (K).
    pub k: usize,
    /// Mean over windows of min over K of ADE (best-of-K, oracle).
    pub min_ade: f64,
    /// Mean over windows of min over K of FDE (best-of-K, oracle).
    pub min_fde: f64,
    /// Mean ADE of the first sample only.
    pub ade_k1: f64,
    /// Mean FDE of the first sample only.
    pub fde_k1: f64,
    /// Mean FDE over all K samples and windows (what a user with no oracle gets on average).
    pub mean_fde: f64,
    /// Mean ADE over all K samples and windows.
    pub mean_ade: f64,
}

impl fmt::Display for Metrics {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "n={} K={} minADE={:.3} minFDE={:.3} ADE@1={:.3} FDE@1={:.3} meanADE={:.3} meanFDE={:.3}",
            self.n,
            self.k,
            self.min_ade,
            self.min_fde,
            self.ade_k1,
            self.fde_k1,
            self.mean_ade,
            self.mean_fde
        )
    }
}

/// Errors from adding predictions to a [`MetricsAccumulator`].
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum EvalError {
    /// A prediction with no trajectory.
    #[error("empty prediction (K = 0) for scene {scene} ped {ped_id}")]
    EmptyPrediction {
        /// Scene of the window.
        scene: String,
        /// Ped id of the window.
        ped_id: f64,
    },
    /// Predictions with different K were mixed in one accumulator.
    #[error("prediction has K = {found} samples but the accumulator holds K = {expected}")]
    KMismatch {
        /// K of the accumulator.
        expected: usize,
        /// K of the new prediction (or merged accumulator).
        found: usize,
    },
    /// Nothing to evaluate: ADE/FDE of zero windows would be NaN.
    #[error("no window to evaluate (an empty data set): ADE/FDE are undefined")]
    NoWindows,
    /// A predicted point is NaN or infinite.
    #[error("non-finite predicted point for scene {scene} ped {ped_id} (sample {sample})")]
    NonFinite {
        /// Scene of the window.
        scene: String,
        /// Ped id of the window.
        ped_id: f64,
        /// Index of the offending sample.
        sample: usize,
    },
}

/// Running sums for [`Metrics`], in f64. Mergeable, so shards can be evaluated in parallel
/// and combined with [`MetricsAccumulator::merge`].
#[derive(Debug, Clone, Default, PartialEq)]
pub struct MetricsAccumulator {
    n: usize,
    k: Option<usize>,
    sum_min_ade: f64,
    sum_min_fde: f64,
    sum_ade_k1: f64,
    sum_fde_k1: f64,
    sum_mean_ade: f64,
    sum_mean_fde: f64,
}

/// ADE and FDE of one predicted trajectory against ground truth, in f64.
pub fn ade_fde(pred: &[[f32; 2]; FUTURE], gt: &[[f32; 2]; FUTURE]) -> (f64, f64) {
    let mut sum = 0.0f64;
    let mut last = 0.0f64;
    for (p, g) in pred.iter().zip(gt) {
        let dx = f64::from(p[0]) - f64::from(g[0]);
        let dy = f64::from(p[1]) - f64::from(g[1]);
        last = (dx * dx + dy * dy).sqrt();
        sum += last;
    }
    (sum / FUTURE as f64, last)
}

impl MetricsAccumulator {
    /// An empty accumulator.
    pub fn new() -> Self {
        Self::default()
    }

    /// Add one window's prediction (errors in raw units).
    pub fn add(&mut self, w: &Window, pred: &Prediction) -> Result<(), EvalError> {
        self.add_scaled(w, pred, 1.0)
    }

    /// Add one window's prediction with every error multiplied by `scale` (e.g. the scene's
    /// metres per pixel to report SDD in metres).
    pub fn add_scaled(
        &mut self,
        w: &Window,
        pred: &Prediction,
        scale: f64,
    ) -> Result<(), EvalError> {
        let k = pred.trajectories.len();
        if k == 0 {
            return Err(EvalError::EmptyPrediction {
                scene: w.scene.clone(),
                ped_id: w.ped_id,
            });
        }
        if let Some(expected) = self.k {
            if expected != k {
                return Err(EvalError::KMismatch { expected, found: k });
            }
        }
        if let Some(sample) = pred
            .trajectories
            .iter()
            .position(|t| t.iter().flatten().any(|v| !v.is_finite()))
        {
            return Err(EvalError::NonFinite {
                scene: w.scene.clone(),
                ped_id: w.ped_id,
                sample,
            });
        }
        let gt = w.future();
        let (mut min_ade, mut min_fde) = (f64::INFINITY, f64::INFINITY);
        let (mut sum_ade, mut sum_fde) = (0.0, 0.0);
        let (mut ade1, mut fde1) = (0.0, 0.0);
        for (i, t) in pred.trajectories.iter().enumerate() {
            let (ade, fde) = ade_fde(t, &gt);
            let (ade, fde) = (ade * scale, fde * scale);
            if i == 0 {
                (ade1, fde1) = (ade, fde);
            }
            min_ade = min_ade.min(ade);
            min_fde = min_fde.min(fde);
            sum_ade += ade;
            sum_fde += fde;
        }
        self.k = Some(k);
        self.n += 1;
        self.sum_min_ade += min_ade;
        self.sum_min_fde += min_fde;
        self.sum_ade_k1 += ade1;
        self.sum_fde_k1 += fde1;
        self.sum_mean_ade += sum_ade / k as f64;
        self.sum_mean_fde += sum_fde / k as f64;
        Ok(())
    }

    /// Combine another accumulator (e.g. from another thread) into this one.
    pub fn merge(&mut self, other: &MetricsAccumulator) -> Result<(), EvalError> {
        match (self.k, other.k) {
            (Some(a), Some(b)) if a != b => {
                return Err(EvalError::KMismatch {
                    expected: a,
                    found: b,
                })
            }
            (None, b) => self.k = b,
            _ => {}
        }
        self.n += other.n;
        self.sum_min_ade += other.sum_min_ade;
        self.sum_min_fde += other.sum_min_fde;
        self.sum_ade_k1 += other.sum_ade_k1;
        self.sum_fde_k1 += other.sum_fde_k1;
        self.sum_mean_ade += other.sum_mean_ade;
        self.sum_mean_fde += other.sum_mean_fde;
        Ok(())
    }

    /// Number of windows added so far.
    pub fn len(&self) -> usize {
        self.n
    }

    /// `true` when nothing has been added.
    pub fn is_empty(&self) -> bool {
        self.n == 0
    }

    /// The averaged metrics. With no window added, `n = 0`, `k = 0` and every metric is NaN.
    pub fn finish(&self) -> Metrics {
        let n = self.n as f64;
        Metrics {
            n: self.n,
            k: self.k.unwrap_or(0),
            min_ade: self.sum_min_ade / n,
            min_fde: self.sum_min_fde / n,
            ade_k1: self.sum_ade_k1 / n,
            fde_k1: self.sum_fde_k1 / n,
            mean_fde: self.sum_mean_fde / n,
            mean_ade: self.sum_mean_ade / n,
        }
    }
}

/// Evaluate a predictor over every window of a dataset (raw units); an empty dataset is
/// [`EvalError::NoWindows`], never NaN metrics.
pub fn evaluate<F>(ds: &Dataset, mut predict: F) -> Result<Metrics, EvalError>
where
    F: FnMut(&Window) -> Prediction,
{
    if ds.windows.is_empty() {
        return Err(EvalError::NoWindows);
    }
    let mut acc = MetricsAccumulator::new();
    for w in &ds.windows {
        acc.add(w, &predict(w))?;
    }
    Ok(acc.finish())
}
