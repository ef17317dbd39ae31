//! The Abruptness Score (paper appendix "Non-linearity analysis: Abruptness-Score").
//!
//! For every consecutive triple `A, B, C` of a trajectory, with `a = AB`, `b = BC`:
//!
//! ```text
//! θ      = | asin( (a × b) / (|a| |b|) ) |          (+ π/2 when the turn is obtuse: a · b < 0)
//! score += ceil( 180 θ / (10 π) ) · | a × b |
//! ```
//!
//! `ceil(180θ/(10π))` is the turn in degrees rounded up to the next multiple of 10°, divided by 10
//! (a tolerance of 1e-9 is subtracted before the `ceil`, so an exact 90° turn counts as 9, not as
//! 10 through floating-point noise).
//!
//! **Degenerate segments.** A triple in which `a` or `b` has zero length (a zero-length step: the
//! pedestrian did not move between two annotations) contributes **0**: the turn angle is
//! undefined there, and `|a × b| = 0` anyway. Consequently a stop followed by a turn (`A, B, B, C`)
//! is not scored, and an exact U-turn (`a` anti-parallel to `b`) also scores 0 because
//! `|a × b| = 0` (the paper's formula weights by the cross product).
//!
//! **Areal-scaled form** ([`abscore_scaled`]): the score divided by the area of the tightest
//! axis-aligned bounding box `(max x − min x)(max y − min y)`. When that area is 0 (all points on
//! one axis-parallel line: "perfectly linear") it is divided by the path length instead; when the
//! path length is also 0 (a stationary trajectory) the scaled score is 0. Scores are computed in
//! f64 from the f32 positions.

use crate::data::Dataset;

use super::Stats;

/// Contribution of one triple `A, B, C` (0 for zero-length steps, see the module docs).
pub fn triple_score(a_pt: [f32; 2], b_pt: [f32; 2], c_pt: [f32; 2]) -> f64 {
    let a = [
        b_pt[0] as f64 - a_pt[0] as f64,
        b_pt[1] as f64 - a_pt[1] as f64,
    ];
    let b = [
        c_pt[0] as f64 - b_pt[0] as f64,
        c_pt[1] as f64 - b_pt[1] as f64,
    ];
    let (na, nb) = (a[0].hypot(a[1]), b[0].hypot(b[1]));
    if na == 0.0 || nb == 0.0 {
        return 0.0;
    }
    let cross = a[0] * b[1] - a[1] * b[0];
    let dot = a[0] * b[0] + a[1] * b[1];
    let mut theta = (cross / (na * nb)).clamp(-1.0, 1.0).asin().abs();
    if dot < 0.0 {
        theta += std::f64::consts::FRAC_PI_2;
    }
    let bucket = (180.0 * theta / (10.0 * std::f64::consts::PI) - 1e-9)
        .ceil()
        .max(0.0);
    bucket * cross.abs()
}

/// Unscaled AbScore of a trajectory (sum over consecutive triples; 0 for fewer than 3 points).
pub fn abscore(pts: &[[f32; 2]]) -> f64 {
    pts.windows(3).map(|w| triple_score(w[0], w[1], w[2])).sum()
}

/// Path length (sum of step lengths), f64.
pub fn path_length(pts: &[[f32; 2]]) -> f64 {
    pts.windows(2)
        .map(|w| (w[1][0] as f64 - w[0][0] as f64).hypot(w[1][1] as f64 - w[0][1] as f64))
        .sum()
}

/// Area of the tightest axis-aligned bounding box, f64.
pub fn bbox_area(pts: &[[f32; 2]]) -> f64 {
    let (w, h) = bbox_extent(pts);
    w * h
}

/// Width and height of the tightest axis-aligned bounding box, f64 (0, 0 when empty).
pub fn bbox_extent(pts: &[[f32; 2]]) -> (f64, f64) {
    if pts.is_empty() {
        return (0.0, 0.0);
    }
    let (mut x0, mut y0, mut x1, mut y1) = (f64::MAX, f64::MAX, f64::MIN, f64::MIN);
    for p in pts {
        x0 = x0.min(p[0] as f64);
        x1 = x1.max(p[0] as f64);
        y0 = y0.min(p[1] as f64);
        y1 = y1.max(p[1] as f64);
    }
    (x1 - x0, y1 - y0)
}

/// Areal-scaled AbScore: [`abscore`] / bbox area; / path length when the area is 0; 0 when the
/// path length is 0 too.
pub fn abscore_scaled(pts: &[[f32; 2]]) -> f64 {
    let s = abscore(pts);
    let area = bbox_area(pts);
    if area > 0.0 {
        return s / area;
    }
    let len = path_length(pts);
    if len > 0.0 {
        s / len
    } else {
        0.0
    }
}

/// Per-window scores of a dataset: `(unscaled, scaled)` in window order.
pub fn scores(ds: &Dataset) -> (Vec<f64>, Vec<f64>) {
    ds.windows
        .iter()
        .map(|w| (abscore(&w.pos), abscore_scaled(&w.pos)))
        .unzip()
}

/// Which score an outlier filter thresholds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Which {
    /// [`abscore`].
    Unscaled,
    /// [`abscore_scaled`].
    Scaled,
}

/// Outlier filtering: keep the windows whose score (`which`) is `<= max`. Returns the filtered
/// dataset (order preserved, name suffixed) and the number removed.
pub fn filter_by_abscore(ds: &Dataset, which: Which, max: f64) -> (Dataset, usize) {
    let windows: Vec<_> = ds
        .windows
        .iter()
        .filter(|w| {
            let s = match which {
                Which::Unscaled => abscore(&w.pos),
                Which::Scaled => abscore_scaled(&w.pos),
            };
            s <= max
        })
        .cloned()
        .collect();
    let removed = ds.len() - windows.len();
    (
        Dataset {
            name: format!("{}[abscore<={max}]", ds.name),
            unit: ds.unit,
            windows,
        },
        removed,
    )
}

/// Statistics of both score forms for one dataset: `(unscaled, scaled)`.
pub fn stats(ds: &Dataset) -> (Stats, Stats) {
    let (u, s) = scores(ds);
    (Stats::of(&u), Stats::of(&s))
}
