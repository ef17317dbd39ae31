//! What a planner gets, measured: how good the endpoint probabilities and the point
//! forecast's radii are on a set of windows (`docs/planner.md` explains each number).
//!
//! Per window the inputs are the K endpoints, their probabilities, the true endpoint, the
//! point forecast's endpoint and its radii `r50`/`r90`, all in one unit; a per-window
//! factor turns distances into the reported unit (1, or pixels per metre for SDD in metres
//! reported in pixels). The closest endpoint `j*` is the one with the smallest distance to
//! the truth, as minFDE uses; among endpoints at exactly that distance (slots whose latents
//! both hit the clamp give the same endpoint, bit for bit) the most probable one, so a set
//! of duplicates counts as the one point it is.

use serde::{Deserialize, Serialize};

use crate::dist::kde_nll_weighted;

/// Equal-width probability bins of the calibration errors.
pub const ECE_BINS: usize = 15;

/// One window's planner outputs and its truth.
#[derive(Clone, Copy, Debug)]
pub struct PlannerWindow<'a> {
    /// The K endpoints.
    pub endpoints: &'a [[f32; 2]],
    /// Their probabilities (summing to 1).
    pub probs: &'a [f32],
    /// The true endpoint.
    pub truth: [f32; 2],
    /// The point forecast's endpoint, if the model has one.
    pub point: Option<[f32; 2]>,
    /// `[r50, r90]` around `point`, if the model has them.
    pub radii: Option<[f32; 2]>,
    /// Multiplier from the endpoints' unit to the reported one.
    pub unit: f64,
}

/// The planner metrics of a set of windows (distances in the reported unit).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct PlannerMetrics {
    /// Windows.
    pub n: usize,
    /// Argoverse 2's brier-minFDE: mean over windows of `minFDE + (1 − p_j*)²`, `p_j*` the
    /// probability of the closest endpoint (the second term has no unit; the sum is in the
    /// reported unit as Argoverse defines it).
    pub brier_min_fde: f64,
    /// Share of windows whose most probable endpoint is the closest one (or at its distance).
    pub top_is_closest: f64,
    /// Mean distance of the most probable endpoint to the truth.
    pub top_fde: f64,
    /// Mean distance of the probability-weighted mean endpoint to the truth.
    pub weighted_fde: f64,
    /// Expected calibration error over every (window, endpoint) probability: [`ECE_BINS`]
    /// equal-width bins, `Σ_b (n_b/N)·|mean p − share closest|`.
    pub ece: f64,
    /// The same over the most probable endpoint of each window only (top-label ECE).
    pub top_ece: f64,
    /// Mean KDE NLL of the truth under the probability-weighted mixture (nats; Scott's
    /// bandwidth on the K endpoints, `crate::dist::kde_nll_weighted`, in the endpoints' own
    /// unit).
    pub mixture_nll: f64,
    /// The same with equal weights (`crate::dist::kde_nll`), for comparison.
    pub uniform_nll: f64,
    /// Mean distance of the point forecast to the truth (0 when there is none).
    pub point_fde: f64,
    /// Share of windows with the truth within `r50` of the point forecast.
    pub r50_coverage: f64,
    /// Share of windows with the truth within `r90` of the point forecast.
    pub r90_coverage: f64,
    /// 10th, 50th and 90th percentile of `r90` over the windows (its spread).
    pub r90_percentiles: [f64; 3],
    /// Windows that had radii.
    pub with_radii: usize,
}

/// Collects [`PlannerWindow`]s.
#[derive(Clone, Debug, Default)]
pub struct PlannerAccumulator {
    n: usize,
    brier: f64,
    top_hit: f64,
    top_fde: f64,
    weighted_fde: f64,
    mixture_nll: f64,
    uniform_nll: f64,
    point_fde: f64,
    points: usize,
    r50_in: usize,
    r90_in: usize,
    r90: Vec<f64>,
    /// Per bin: count, sum of p, sum of outcomes (every probability).
    bins: [(usize, f64, f64); ECE_BINS],
    /// The same for the most probable endpoint.
    top_bins: [(usize, f64, f64); ECE_BINS],
}

fn dist(a: [f32; 2], b: [f32; 2]) -> f64 {
    let (dx, dy) = (
        f64::from(a[0]) - f64::from(b[0]),
        f64::from(a[1]) - f64::from(b[1]),
    );
    (dx * dx + dy * dy).sqrt()
}

fn bin_of(p: f64) -> usize {
    ((p * ECE_BINS as f64) as usize).min(ECE_BINS - 1)
}

fn ece_of(bins: &[(usize, f64, f64); ECE_BINS]) -> f64 {
    let total: usize = bins.iter().map(|b| b.0).sum();
    if total == 0 {
        return 0.0;
    }
    bins.iter()
        .filter(|b| b.0 > 0)
        .map(|&(c, p, o)| (c as f64 / total as f64) * ((p - o) / c as f64).abs())
        .sum()
}

/// The index of the largest value (the first of equals); 0 when empty.
pub fn argmax(v: &[f32]) -> usize {
    let mut best = 0;
    for (i, &p) in v.iter().enumerate() {
        if p > v[best] {
            best = i;
        }
    }
    best
}

/// The index of the endpoint closest to `truth` (the first of equals); 0 when empty.
pub fn closest(endpoints: &[[f32; 2]], truth: [f32; 2]) -> usize {
    let mut best = (0, f64::INFINITY);
    for (i, e) in endpoints.iter().enumerate() {
        let d = dist(*e, truth);
        if d < best.1 {
            best = (i, d);
        }
    }
    best.0
}

/// [`closest`], ties (equal distances) broken by the larger probability, then the first.
pub fn closest_by(endpoints: &[[f32; 2]], probs: &[f32], truth: [f32; 2]) -> usize {
    let mut best = (0, f64::INFINITY, f32::NEG_INFINITY);
    for (i, (e, &p)) in endpoints.iter().zip(probs).enumerate() {
        let d = dist(*e, truth);
        if d < best.1 || (d == best.1 && p > best.2) {
            best = (i, d, p);
        }
    }
    best.0
}

impl PlannerAccumulator {
    /// An empty accumulator.
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds one window (ignored when it has no endpoints or the lengths differ).
    pub fn add(&mut self, w: &PlannerWindow<'_>) {
        let k = w.endpoints.len();
        if k == 0 || w.probs.len() != k {
            return;
        }
        let j = closest_by(w.endpoints, w.probs, w.truth);
        let top = argmax(w.probs);
        let pj = f64::from(w.probs[j]);
        let top_closest = dist(w.endpoints[top], w.truth) == dist(w.endpoints[j], w.truth);
        self.n += 1;
        self.brier += dist(w.endpoints[j], w.truth) * w.unit + (1.0 - pj) * (1.0 - pj);
        self.top_hit += f64::from(u8::from(top_closest));
        self.top_fde += dist(w.endpoints[top], w.truth) * w.unit;
        let mut mean = [0.0f64; 2];
        for (e, &p) in w.endpoints.iter().zip(w.probs) {
            mean[0] += f64::from(p) * f64::from(e[0]);
            mean[1] += f64::from(p) * f64::from(e[1]);
        }
        self.weighted_fde += dist([mean[0] as f32, mean[1] as f32], w.truth) * w.unit;
        self.mixture_nll += kde_nll_weighted(w.endpoints, Some(w.probs), w.truth);
        self.uniform_nll += kde_nll_weighted(w.endpoints, None, w.truth);
        for (i, &p) in w.probs.iter().enumerate() {
            let b = &mut self.bins[bin_of(f64::from(p))];
            b.0 += 1;
            b.1 += f64::from(p);
            b.2 += f64::from(u8::from(i == j));
        }
        let tb = &mut self.top_bins[bin_of(f64::from(w.probs[top]))];
        tb.0 += 1;
        tb.1 += f64::from(w.probs[top]);
        tb.2 += f64::from(u8::from(top_closest));
        if let Some(pt) = w.point {
            let d = dist(pt, w.truth) * w.unit;
            self.point_fde += d;
            self.points += 1;
            if let Some([r50, r90]) = w.radii {
                self.r50_in += usize::from(d <= f64::from(r50) * w.unit);
                self.r90_in += usize::from(d <= f64::from(r90) * w.unit);
                self.r90.push(f64::from(r90) * w.unit);
            }
        }
    }

    /// The calibration bins over every probability: `(count, sum of p, count closest)` per
    /// equal-width bin (the reliability diagram, `crate::draw::reliability_svg`).
    pub fn bins(&self) -> &[(usize, f64, f64); ECE_BINS] {
        &self.bins
    }

    /// The metrics so far.
    pub fn finish(&self) -> PlannerMetrics {
        let n = self.n.max(1) as f64;
        let with_radii = self.r90.len();
        let mut r = self.r90.clone();
        r.sort_by(f64::total_cmp);
        let pct = |q: f64| -> f64 {
            if r.is_empty() {
                return 0.0;
            }
            r[((q * (r.len() - 1) as f64).round() as usize).min(r.len() - 1)]
        };
        let radii_n = with_radii.max(1) as f64;
        PlannerMetrics {
            n: self.n,
            brier_min_fde: self.brier / n,
            top_is_closest: self.top_hit / n,
            top_fde: self.top_fde / n,
            weighted_fde: self.weighted_fde / n,
            ece: ece_of(&self.bins),
            top_ece: ece_of(&self.top_bins),
            mixture_nll: self.mixture_nll / n,
            uniform_nll: self.uniform_nll / n,
            point_fde: self.point_fde / self.points.max(1) as f64,
            r50_coverage: self.r50_in as f64 / radii_n,
            r90_coverage: self.r90_in as f64 / radii_n,
            r90_percentiles: [pct(0.1), pct(0.5), pct(0.9)],
            with_radii,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_sure_right_model_scores_perfectly() {
        let ends = [[0.0, 0.0], [10.0, 0.0]];
        let mut acc = PlannerAccumulator::new();
        acc.add(&PlannerWindow {
            endpoints: &ends,
            probs: &[1.0, 0.0],
            truth: [0.0, 0.0],
            point: Some([1.0, 0.0]),
            radii: Some([0.5, 2.0]),
            unit: 1.0,
        });
        let m = acc.finish();
        assert_eq!(
            (m.brier_min_fde, m.top_is_closest, m.top_fde),
            (0.0, 1.0, 0.0)
        );
        assert_eq!((m.ece, m.r50_coverage, m.r90_coverage), (0.0, 0.0, 1.0));
        assert_eq!(m.point_fde, 1.0);
    }

    #[test]
    fn a_sure_wrong_model_is_penalised_and_miscalibrated() {
        let ends = [[0.0, 0.0], [10.0, 0.0]];
        let mut acc = PlannerAccumulator::new();
        acc.add(&PlannerWindow {
            endpoints: &ends,
            probs: &[0.0, 1.0],
            truth: [0.0, 0.0],
            point: None,
            radii: None,
            unit: 2.0,
        });
        let m = acc.finish();
        assert_eq!(
            (m.brier_min_fde, m.top_is_closest, m.top_fde),
            (1.0, 0.0, 20.0)
        );
        // Both probabilities are wrong by 1: bin 0 holds p = 0 with outcome 1, bin 14 p = 1
        // with outcome 0.
        assert_eq!(m.ece, 1.0);
        assert_eq!(m.with_radii, 0);
    }
}
