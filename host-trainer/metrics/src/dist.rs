//! Distribution metrics of K predicted endpoints: the KDE negative log-likelihood of the truth
//! (Trajectron++'s), optionally weighted by endpoint probabilities, and the hit rates within
//! fixed radii.

use std::fmt;

use crate::data::{Dataset, Window, FUTURE};
use crate::eval::Prediction;

/// Trajectron++'s floor on the log-density of the truth (`log_pdf_lower_bound = -20` in its
/// `compute_kde_nll`): [`kde_nll`] never exceeds `-KDE_LOG_PDF_FLOOR` = 20 nats.
pub const KDE_LOG_PDF_FLOOR: f64 = -20.0;

/// Relative ridge added to the diagonal of the samples' covariance in [`kde_nll`]:
/// `Σ + (KDE_RIDGE_REL · tr(Σ)/2 + KDE_RIDGE_ABS) · I`.
pub const KDE_RIDGE_REL: f64 = 1e-9;

/// Absolute part of the ridge in [`kde_nll`], in squared dataset units (px² for SDD).
pub const KDE_RIDGE_ABS: f64 = 1e-9;

/// KDE negative log-likelihood (Trajectron++'s `compute_kde_nll`, at the endpoint only) of the
/// true endpoint `gt` under a 2-D Gaussian kernel density estimate fitted to the K predicted
/// `endpoints`. In **nats, in the dataset's units** (SDD: the density is per px², so the value
/// depends on the unit: converting pixels to metres subtracts `2 ln(px per m)`). Lower is
/// better.
///
/// Semantics of `scipy.stats.gaussian_kde(endpoints.T).logpdf(gt)`, computed in f64:
///
/// * bandwidth: **Scott's rule**, kernel covariance `H = f² Σ` with `f = K^(-1/(d+4))`,
///   `d = 2`, i.e. `f² = K^(-1/3)`, and `Σ` the *unbiased* sample covariance of the K
///   endpoints (divided by `K - 1`; by 1 when K = 1);
/// * density `p(gt) = (1/K) Σ_k N(gt; e_k, H)`, evaluated with log-sum-exp;
/// * result `-max(ln p(gt), KDE_LOG_PDF_FLOOR)`: the log-density is floored at
///   [`KDE_LOG_PDF_FLOOR`] = −20 like Trajectron++, so a truth far from every sample costs
///   20 nats, not infinity;
/// * where scipy raises `LinAlgError` (singular `Σ`: all endpoints equal, collinear, or
///   K = 1) Trajectron++ gives NaN; here a ridge `(KDE_RIDGE_REL · tr(Σ)/2 + KDE_RIDGE_ABS) · I`
///   (1e-9 relative plus 1e-9 unit²) is **always** added to `Σ` before scaling, so such sets
///   give a finite value (a very narrow kernel: the floor unless the truth is on the samples).
///   For a well-conditioned set the ridge moves the result by about 1e-9 relative.
///
/// Non-finite inputs and an empty `endpoints` give the floor value (20).
pub fn kde_nll(endpoints: &[[f32; 2]], gt: [f32; 2]) -> f64 {
    kde_nll_weighted(endpoints, None, gt)
}

/// [`kde_nll`] of the mixture that weights kernel `k` by `weights[k]` (the endpoint
/// probabilities; the same bandwidth, Scott's rule on the unweighted endpoints): `p(gt) =
/// Σ_k w_k N(gt; e_k, H)`. `None` is [`kde_nll`]'s `1/K` each, bit for bit. Weights of
/// another length than the endpoints, or not finite, give the floor value.
pub fn kde_nll_weighted(endpoints: &[[f32; 2]], weights: Option<&[f32]>, gt: [f32; 2]) -> f64 {
    let ceiling = -KDE_LOG_PDF_FLOOR;
    if weights.is_some_and(|w| w.len() != endpoints.len() || w.iter().any(|v| !v.is_finite())) {
        return ceiling;
    }
    let k = endpoints.len();
    if k == 0
        || !gt.iter().all(|v| v.is_finite())
        || endpoints.iter().flatten().any(|v| !v.is_finite())
    {
        return ceiling;
    }
    let kf = k as f64;
    let (mut mx, mut my) = (0.0f64, 0.0f64);
    for e in endpoints {
        mx += f64::from(e[0]);
        my += f64::from(e[1]);
    }
    mx /= kf;
    my /= kf;
    let (mut sxx, mut syy, mut sxy) = (0.0f64, 0.0f64, 0.0f64);
    for e in endpoints {
        let (dx, dy) = (f64::from(e[0]) - mx, f64::from(e[1]) - my);
        sxx += dx * dx;
        syy += dy * dy;
        sxy += dx * dy;
    }
    let dof = if k > 1 { kf - 1.0 } else { 1.0 };
    let (sxx, syy, sxy) = (sxx / dof, syy / dof, sxy / dof);
    let ridge = KDE_RIDGE_REL * 0.5 * (sxx + syy) + KDE_RIDGE_ABS;
    // Scott's factor squared: (K^(-1/6))^2.
    let f2 = kf.powf(-1.0 / 3.0);
    let (hxx, hyy, hxy) = ((sxx + ridge) * f2, (syy + ridge) * f2, sxy * f2);
    let det = hxx * hyy - hxy * hxy;
    if !(det.is_finite() && det > 0.0) {
        return ceiling;
    }
    // Inverse of H.
    let (ixx, iyy, ixy) = (hyy / det, hxx / det, -hxy / det);
    let (gx, gy) = (f64::from(gt[0]), f64::from(gt[1]));
    let mut expo = Vec::with_capacity(k);
    for e in endpoints {
        let (dx, dy) = (gx - f64::from(e[0]), gy - f64::from(e[1]));
        let m2 = ixx * dx * dx + 2.0 * ixy * dx * dy + iyy * dy * dy;
        expo.push(-0.5 * m2);
    }
    let top = expo.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let log_norm = -(2.0 * std::f64::consts::PI).ln() - 0.5 * det.ln();
    let log_pdf = match weights {
        None => {
            let sum: f64 = expo.iter().map(|x| (x - top).exp()).sum();
            top + sum.ln() - kf.ln() + log_norm
        }
        Some(w) => {
            let sum: f64 = expo
                .iter()
                .zip(w)
                .map(|(x, &wk)| f64::from(wk) * (x - top).exp())
                .sum();
            top + sum.ln() + log_norm
        }
    };
    if log_pdf.is_nan() {
        return ceiling;
    }
    -log_pdf.max(KDE_LOG_PDF_FLOOR)
}

/// Distance from `gt` to the closest of `endpoints` (f64; infinity when empty).
pub fn min_endpoint_distance(endpoints: &[[f32; 2]], gt: [f32; 2]) -> f64 {
    endpoints
        .iter()
        .map(|e| {
            let dx = f64::from(e[0]) - f64::from(gt[0]);
            let dy = f64::from(e[1]) - f64::from(gt[1]);
            (dx * dx + dy * dy).sqrt()
        })
        .fold(f64::INFINITY, f64::min)
}

/// Distribution-quality metrics of K sampled endpoints, next to [`Metrics`](crate::eval::Metrics) (which stays
/// unchanged: its JSON is part of the model cards). Endpoints are the last points of the
/// predicted trajectories, the same points minFDE uses.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct DistMetrics {
    /// Mean over windows of [`kde_nll`] of the true endpoint (nats, dataset units; lower is
    /// better; at most 20 per window).
    pub kde_nll: f64,
    /// Fraction of windows whose true endpoint is within 20 units (px for SDD) of at least one
    /// predicted endpoint (`minFDE ≤ 20`): [`DistAccumulator::within`]`(20.0)`.
    pub hit20: f64,
    /// The same within 40 units.
    pub hit40: f64,
}

impl fmt::Display for DistMetrics {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "KDE-NLL={:.3} hit@20={:.4} hit@40={:.4}",
            self.kde_nll, self.hit20, self.hit40
        )
    }
}

/// Running sums for [`DistMetrics`]: the sum of [`kde_nll`] and every window's distance from
/// the truth to its closest sample, so [`DistAccumulator::within`] answers any radius.
/// Mergeable like [`MetricsAccumulator`](crate::eval::MetricsAccumulator) (merge shards in window order for bit-identical sums).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct DistAccumulator {
    sum_nll: f64,
    min_dist: Vec<f64>,
}

impl DistAccumulator {
    /// An empty accumulator.
    pub fn new() -> Self {
        Self::default()
    }

    /// Add one window: its K predicted endpoints and its true endpoint.
    pub fn add_endpoints(&mut self, endpoints: &[[f32; 2]], gt: [f32; 2]) {
        self.sum_nll += kde_nll(endpoints, gt);
        self.min_dist.push(min_endpoint_distance(endpoints, gt));
    }

    /// Add one window's prediction (its trajectories' last points against
    /// [`Window::endpoint`]).
    pub fn add(&mut self, w: &Window, pred: &Prediction) {
        let ends: Vec<[f32; 2]> = pred.trajectories.iter().map(|t| t[FUTURE - 1]).collect();
        self.add_endpoints(&ends, w.endpoint());
    }

    /// Append another accumulator's windows after this one's.
    pub fn merge(&mut self, other: &DistAccumulator) {
        self.sum_nll += other.sum_nll;
        self.min_dist.extend_from_slice(&other.min_dist);
    }

    /// Number of windows added.
    pub fn len(&self) -> usize {
        self.min_dist.len()
    }

    /// `true` when nothing has been added.
    pub fn is_empty(&self) -> bool {
        self.min_dist.is_empty()
    }

    /// Fraction of windows whose true endpoint is within `r` (`≤ r`, dataset units) of at
    /// least one predicted endpoint. NaN when empty.
    pub fn within(&self, r: f64) -> f64 {
        let hits = self.min_dist.iter().filter(|&&d| d <= r).count();
        hits as f64 / self.min_dist.len() as f64
    }

    /// The averaged metrics; `None` when no window was added.
    pub fn finish(&self) -> Option<DistMetrics> {
        if self.is_empty() {
            return None;
        }
        Some(DistMetrics {
            kde_nll: self.sum_nll / self.len() as f64,
            hit20: self.within(20.0),
            hit40: self.within(40.0),
        })
    }
}

/// [`DistMetrics`] of predictions for every window of `ds` (in order); `None` when `ds` is
/// empty or the lengths differ.
pub fn dist_metrics(ds: &Dataset, preds: &[Prediction]) -> Option<DistMetrics> {
    dist_accumulator(ds, preds)?.finish()
}

/// The radii of the two hit rates reported beside every endpoint set: 0.5 / 1 m, or
/// 20 / 40 px.
pub fn hit_radii(unit: crate::data::Unit) -> [f64; 2] {
    match unit {
        crate::data::Unit::Pixels => [20.0, 40.0],
        crate::data::Unit::Metres => [0.5, 1.0],
    }
}

/// The [`DistAccumulator`] of predictions for every window of `ds` (in order), for callers
/// that want [`DistAccumulator::within`] at other radii too; `None` when the lengths differ.
pub fn dist_accumulator(ds: &Dataset, preds: &[Prediction]) -> Option<DistAccumulator> {
    if ds.windows.len() != preds.len() {
        return None;
    }
    let mut acc = DistAccumulator::new();
    for (w, p) in ds.windows.iter().zip(preds) {
        acc.add(w, p);
    }
    Some(acc)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: f64, b: f64, tol: f64) -> bool {
        (a - b).abs() <= tol * b.abs().max(1.0)
    }

    /// Five spread-out samples, the healthy set of the KDE tests.
    const SPREAD: [[f32; 2]; 5] = [
        [0.0, 0.0],
        [10.0, 2.0],
        [3.0, -7.0],
        [-4.0, 5.0],
        [8.0, 8.0],
    ];

    // Reference values: scipy 1.17 `-gaussian_kde(pts.T).logpdf(gt)[0]`.
    #[test]
    fn kde_nll_matches_scipy() {
        let a = SPREAD;
        assert!(close(kde_nll(&a, [2.0, 1.0]), 5.921155544059406, 1e-7));
        let b = [
            [100.5, 200.25],
            [130.0, 190.0],
            [90.0, 260.0],
            [115.0, 215.0],
            [140.0, 230.0],
            [60.0, 180.0],
            [125.0, 205.0],
            [99.0, 199.0],
        ];
        assert!(close(kde_nll(&b, [170.0, 260.0]), 11.983679791168822, 1e-7));
        let c = [[1.0, 1.0], [1.0, -1.0], [-1.0, 1.0], [-1.0, -1.0]];
        assert!(close(kde_nll(&c, [0.0, 0.0]), 2.854011807463979, 1e-7));
        // Closed form for c: Σ = 4/3 I, H = 4/3 · 4^(-1/3) I, every sample at squared
        // Mahalanobis distance 2 / h².
        let h2 = 4.0 / 3.0 * 4f64.powf(-1.0 / 3.0);
        let want = -((-1.0 / h2).exp() / (2.0 * std::f64::consts::PI * h2)).ln();
        assert!(close(kde_nll(&c, [0.0, 0.0]), want, 1e-7));
    }

    #[test]
    fn kde_nll_is_finite_on_degenerate_sets() {
        // All equal (Σ = 0): point mass; far truth hits the floor, exact truth is very likely.
        let same = [[5.0, 5.0]; 20];
        assert_eq!(kde_nll(&same, [50.0, 5.0]), 20.0);
        let at = kde_nll(&same, [5.0, 5.0]);
        assert!(at.is_finite() && at < 0.0, "{at}");
        // Collinear (singular Σ): finite; off the line it is the floor.
        let line: Vec<[f32; 2]> = (0..20).map(|i| [i as f32, 2.0 * i as f32]).collect();
        assert_eq!(kde_nll(&line, [3.0, 40.0]), 20.0);
        assert!(kde_nll(&line, [3.0, 6.0]).is_finite());
        // K = 1, empty, non-finite.
        assert_eq!(kde_nll(&[[0.0, 0.0]], [1.0, 0.0]), 20.0);
        assert_eq!(kde_nll(&[], [1.0, 0.0]), 20.0);
        assert_eq!(kde_nll(&[[f32::NAN, 0.0], [1.0, 1.0]], [1.0, 0.0]), 20.0);
        // A far-away truth under a healthy set is floored too.
        let a = SPREAD;
        assert_eq!(kde_nll(&a, [1e4, 1e4]), 20.0);
    }

    #[test]
    fn kde_nll_is_translation_invariant_and_unit_dependent() {
        let a = SPREAD;
        let shifted: Vec<[f32; 2]> = a.iter().map(|p| [p[0] + 64.0, p[1] - 32.0]).collect();
        assert!(close(
            kde_nll(&a, [2.0, 1.0]),
            kde_nll(&shifted, [66.0, -31.0]),
            1e-9
        ));
        // Scaling coordinates by 2 divides the density by 4: NLL + ln 4.
        let scaled: Vec<[f32; 2]> = a.iter().map(|p| [2.0 * p[0], 2.0 * p[1]]).collect();
        assert!(close(
            kde_nll(&scaled, [4.0, 2.0]),
            kde_nll(&a, [2.0, 1.0]) + 4f64.ln(),
            1e-7
        ));
    }

    #[test]
    fn dist_accumulator_within_and_merge() {
        let mut acc = DistAccumulator::new();
        assert!(acc.finish().is_none());
        // Closest sample at 10, 20, 30 and 50.
        for d in [10.0f32, 20.0, 30.0, 50.0] {
            acc.add_endpoints(&[[d, 0.0], [0.0, 100.0]], [0.0, 0.0]);
        }
        assert_eq!(acc.len(), 4);
        assert_eq!(acc.within(20.0), 0.5);
        assert_eq!(acc.within(40.0), 0.75);
        assert_eq!(acc.within(0.0), 0.0);
        assert_eq!(acc.within(f64::INFINITY), 1.0);
        let m = acc.finish().unwrap();
        assert_eq!((m.hit20, m.hit40), (0.5, 0.75));
        let mut a = DistAccumulator::new();
        let mut b = DistAccumulator::new();
        a.add_endpoints(&[[10.0, 0.0], [0.0, 100.0]], [0.0, 0.0]);
        a.add_endpoints(&[[20.0, 0.0], [0.0, 100.0]], [0.0, 0.0]);
        b.add_endpoints(&[[30.0, 0.0], [0.0, 100.0]], [0.0, 0.0]);
        b.add_endpoints(&[[50.0, 0.0], [0.0, 100.0]], [0.0, 0.0]);
        a.merge(&b);
        assert_eq!(a, acc);
    }
}
