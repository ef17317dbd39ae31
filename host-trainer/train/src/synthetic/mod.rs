//! Synthetic trajectories and data analysis (the paper's sections "Augmenting with RL
//! Synthetic Trajectories", "Deep Policy Gradient Network", "SDD: Data Analysis" and
//! "Non-linearity analysis: Abruptness-Score"). See `docs/synthetic.md`.
//!
//! * [`abscore`]: the Abruptness Score, its areal-scaled form, statistics and outlier filtering.
//! * [`classify`]: the paper's 7 trajectory types and the unique-points histogram.
//! * [`newtonian`]: constant-velocity / constant-acceleration / turning generators.
//! * [`hmm`]: the HMM interaction playground (hidden motion states, proximity detection).
//! * [`agent`]: the 8→16→8→4 policy network and REINFORCE with the paper's reward.
//! * [`sample`]: the fixed-order synthetic pool matching the training set's type statistics.
//! * [`start_stop`]: synthetic starters and stoppers on real observed pasts (metres).
//! * [`plot`]: hand-written SVG pictures.
//!
//! The data side only: it sits below the training loop, which reads the pool
//! ([`sample::read_pool`]) to augment a run. The commands over these modules and the sweep
//! that trains on the pool are [`crate::synth`], above the loop.
//!
//! Everything random is driven by [`crate::rng::Rng`] (ChaCha8 with hand-written samplers), so
//! every output is reproducible from its seed.

pub mod abscore;
pub mod agent;
pub mod classify;
pub mod hmm;
pub mod newtonian;
pub mod plot;
pub mod sample;
pub mod start_stop;

use crate::data::WINDOW;

/// Time between consecutive trajectory points (SDD: 12 frames at 30 fps).
pub const DT: f32 = 0.4;

/// The SDD pixel range every synthetic trajectory stays in: `x, y ∈ [0, 2000]` (SDD train spans
/// x 2.5–1953.5 px, y 8.5–1990 px).
pub const SDD_RANGE: [f32; 2] = [2000.0, 2000.0];

/// One 20-point trajectory (pixels), like [`crate::data::Window::pos`].
pub type Traj = [[f32; 2]; WINDOW];

/// `true` when every coordinate is finite and inside `[0, SDD_RANGE]`.
pub fn in_range(t: &[[f32; 2]]) -> bool {
    t.iter().all(|p| {
        p[0].is_finite()
            && p[1].is_finite()
            && (0.0..=SDD_RANGE[0]).contains(&p[0])
            && (0.0..=SDD_RANGE[1]).contains(&p[1])
    })
}

/// Summary statistics of a sample (population std; quantiles by linear interpolation between
/// order statistics, numpy's default).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Stats {
    /// Number of values.
    pub n: usize,
    /// Mean.
    pub mean: f64,
    /// Population standard deviation.
    pub std: f64,
    /// Minimum.
    pub min: f64,
    /// 25th percentile.
    pub q1: f64,
    /// Median.
    pub median: f64,
    /// 75th percentile.
    pub q3: f64,
    /// 95th percentile.
    pub p95: f64,
    /// 99th percentile.
    pub p99: f64,
    /// Maximum.
    pub max: f64,
}

/// Quantile `q ∈ [0, 1]` of an ascending-sorted slice (linear interpolation); 0 when empty.
pub fn quantile_sorted(sorted: &[f64], q: f64) -> f64 {
    if sorted.is_empty() {
        return 0.0;
    }
    let pos = q.clamp(0.0, 1.0) * (sorted.len() - 1) as f64;
    let lo = pos.floor() as usize;
    let hi = pos.ceil() as usize;
    sorted[lo] + (sorted[hi] - sorted[lo]) * (pos - lo as f64)
}

impl Stats {
    /// Statistics of `values` (NaNs are not expected; all zeros for an empty slice).
    pub fn of(values: &[f64]) -> Stats {
        let mut v = values.to_vec();
        v.sort_by(f64::total_cmp);
        let n = v.len();
        let mean = if n == 0 {
            0.0
        } else {
            v.iter().sum::<f64>() / n as f64
        };
        let var = if n == 0 {
            0.0
        } else {
            v.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / n as f64
        };
        Stats {
            n,
            mean,
            std: var.sqrt(),
            min: v.first().copied().unwrap_or(0.0),
            q1: quantile_sorted(&v, 0.25),
            median: quantile_sorted(&v, 0.5),
            q3: quantile_sorted(&v, 0.75),
            p95: quantile_sorted(&v, 0.95),
            p99: quantile_sorted(&v, 0.99),
            max: v.last().copied().unwrap_or(0.0),
        }
    }

    /// Markdown table header matching [`Stats::md_row`].
    pub fn md_header() -> &'static str {
        "| set | n | mean | std | min | 25% | 50% | 75% | 95% | 99% | max |\n|---|---|---|---|---|---|---|---|---|---|---|"
    }

    /// One markdown table row.
    pub fn md_row(&self, name: &str) -> String {
        format!(
            "| {name} | {} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} |",
            self.n, self.mean, self.std, self.min, self.q1, self.median, self.q3, self.p95, self.p99, self.max
        )
    }
}
