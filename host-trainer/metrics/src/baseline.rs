//! Deterministic baselines (K = 1) and their evaluation: constant velocity over the last `n`
//! steps, with `n` chosen on validation ([`select_cv_n`]), the strongest simple baseline every
//! card reports.

use crate::data::{Dataset, Window, FUTURE, PAST};
use crate::eval::{Metrics, MetricsAccumulator, Prediction};

/// Evaluate a deterministic single-trajectory baseline (K = 1) over a dataset (raw units).
///
/// A window whose baseline output is not finite (only possible if coordinates overflow f32)
/// is skipped, so `n` can be smaller than `ds.len()`; on the benchmark data it never is.
pub fn evaluate_baseline(ds: &Dataset, baseline: fn(&Window) -> [[f32; 2]; FUTURE]) -> Metrics {
    evaluate_baseline_with(ds, baseline)
}

/// [`evaluate_baseline`] for any closure (e.g. `|w| constant_velocity_n(w, 3)`).
pub fn evaluate_baseline_with<F>(ds: &Dataset, baseline: F) -> Metrics
where
    F: Fn(&Window) -> [[f32; 2]; FUTURE],
{
    let mut acc = MetricsAccumulator::new();
    for w in &ds.windows {
        let traj = baseline(w);
        // A baseline built from finite data is finite unless the coordinates overflow f32;
        // skip such a window instead of failing the whole evaluation.
        let _ = acc.add(w, &Prediction::single(traj));
    }
    acc.finish()
}

fn extrapolate(last: [f32; 2], v: [f64; 2]) -> [[f32; 2]; FUTURE] {
    let mut out = [[0.0f32; 2]; FUTURE];
    for (j, o) in out.iter_mut().enumerate() {
        let t = (j + 1) as f64;
        *o = [
            (f64::from(last[0]) + v[0] * t) as f32,
            (f64::from(last[1]) + v[1] * t) as f32,
        ];
    }
    out
}

/// Most observed steps a constant-velocity baseline can average over (`PAST - 1` = 7).
pub const CV_MAX_STEPS: usize = PAST - 1;

/// Constant-velocity baseline with the velocity **averaged over the last `n` observed steps**:
/// `v = (pos[7] - pos[7 - n]) / n`, future step `j` (1-based) is `pos[7] + j * v`. Computed in
/// f64, returned in raw units. `n` is clamped to `1..=7` ([`CV_MAX_STEPS`]).
///
/// `n = 1` is [`constant_velocity`] (last step) and `n = 7` is [`constant_velocity_avg`]
/// (whole observation), bit for bit. Larger `n` smooths annotation jitter but reacts later to
/// turns and speed changes; `gpecnet eval` picks `n` on the validation scenes
/// ([`select_cv_n`]).
pub fn constant_velocity_n(w: &Window, n: usize) -> [[f32; 2]; FUTURE] {
    let n = n.clamp(1, CV_MAX_STEPS);
    let a = w.pos[PAST - 1 - n];
    let b = w.pos[PAST - 1];
    let steps = n as f64;
    let v = [
        (f64::from(b[0]) - f64::from(a[0])) / steps,
        (f64::from(b[1]) - f64::from(a[1])) / steps,
    ];
    extrapolate(b, v)
}

/// Constant-velocity baseline: velocity = the **last observed step** `pos[7] - pos[6]`;
/// future step `j` (1-based) is `pos[7] + j * v`. Computed in f64, returned in raw units.
/// Same as [`constant_velocity_n`] with `n = 1`.
pub fn constant_velocity(w: &Window) -> [[f32; 2]; FUTURE] {
    constant_velocity_n(w, 1)
}

/// Constant-velocity baseline with the velocity **averaged over the 7 observed steps**,
/// `(pos[7] - pos[0]) / 7`, extrapolated from `pos[7]`. Less sensitive to annotation jitter on
/// the last step than [`constant_velocity`]. Same as [`constant_velocity_n`] with `n = 7`.
pub fn constant_velocity_avg(w: &Window) -> [[f32; 2]; FUTURE] {
    constant_velocity_n(w, CV_MAX_STEPS)
}

/// [`constant_velocity_n`] for every `n = 1..=7` on `ds`: element `n - 1` holds the metrics
/// of `n` (K = 1, raw units).
pub fn cv_sweep(ds: &Dataset) -> Vec<Metrics> {
    (1..=CV_MAX_STEPS)
        .map(|n| evaluate_baseline_with(ds, |w| constant_velocity_n(w, n)))
        .collect()
}

/// The constant-velocity window `n` with the lowest FDE on `val` (ties: the smaller `n`), and
/// the whole [`cv_sweep`] of `val`. `None` when `val` has no window. Pass the **validation**
/// set (SDD: [`crate::data::default_sdd_val_scenes`] held out of `sdd/train`), never the test
/// set: the choice is a model-selection step.
pub fn select_cv_n(val: &Dataset) -> Option<(usize, Vec<Metrics>)> {
    if val.windows.is_empty() {
        return None;
    }
    let sweep = cv_sweep(val);
    let mut best = 0;
    for (i, m) in sweep.iter().enumerate() {
        if m.fde_k1 < sweep[best].fde_k1 {
            best = i;
        }
    }
    Some((best + 1, sweep))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::data::WINDOW;

    fn wiggly() -> Window {
        let mut w = Window {
            scene: "s".into(),
            ped_id: 1.0,
            frames: [0; WINDOW],
            pos: [[0.0; 2]; WINDOW],
        };
        for (t, p) in w.pos.iter_mut().enumerate() {
            let t = t as f32;
            *p = [3.0 * t + (t * 1.7).sin(), 0.5 * t * t - (t * 0.9).cos()];
        }
        w
    }

    #[test]
    fn constant_velocity_n_ends_match_the_named_baselines() {
        let w = wiggly();
        assert_eq!(constant_velocity_n(&w, 1), constant_velocity(&w));
        assert_eq!(constant_velocity_n(&w, 7), constant_velocity_avg(&w));
        // Clamped.
        assert_eq!(constant_velocity_n(&w, 0), constant_velocity_n(&w, 1));
        assert_eq!(constant_velocity_n(&w, 99), constant_velocity_n(&w, 7));
        // n = 3: v = (p7 - p4) / 3.
        let c = constant_velocity_n(&w, 3);
        let v = [
            (f64::from(w.pos[7][0]) - f64::from(w.pos[4][0])) / 3.0,
            (f64::from(w.pos[7][1]) - f64::from(w.pos[4][1])) / 3.0,
        ];
        for (j, p) in c.iter().enumerate() {
            let t = (j + 1) as f64;
            assert_eq!(p[0], (f64::from(w.pos[7][0]) + v[0] * t) as f32);
            assert_eq!(p[1], (f64::from(w.pos[7][1]) + v[1] * t) as f32);
        }
    }

    #[test]
    fn select_cv_n_picks_lowest_fde() {
        // A pedestrian accelerating along x: the last step is the best velocity estimate.
        let mut w = wiggly();
        for (t, p) in w.pos.iter_mut().enumerate() {
            let t = t as f32;
            *p = [t * t, 0.0];
        }
        let ds = Dataset {
            name: "acc".into(),
            unit: crate::data::Unit::Pixels,
            windows: vec![w],
        };
        let (n, sweep) = select_cv_n(&ds).unwrap();
        assert_eq!(sweep.len(), 7);
        assert_eq!(n, 1);
        assert!(sweep.windows(2).all(|p| p[0].fde_k1 < p[1].fde_k1));
        let empty = Dataset {
            windows: vec![],
            ..ds
        };
        assert!(select_cv_n(&empty).is_none());
    }
}
