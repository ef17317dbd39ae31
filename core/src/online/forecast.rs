//! [`forecast`]: the one forecast sequence for one track, *endpoints →
//! probabilities → point forecast → radii*, then the loop's experts, their
//! aggregate and the per-horizon radii; and [`TrackForecast`], what it gives.
//!
//! Every caller that forecasts for a planner runs this function: the
//! [`super::Forecaster`] (one call per camera frame), the C ABI, the firmware
//! demo and the golden replay.

use heapless::Vec;

use super::calibration::horizon_fraction;
use super::{Calibration, MotionState, CV_STEPS, EXPERTS, HORIZONS};
use crate::output::{PredictError, Trajectory};
use crate::planner::{radii, Radii};
use crate::sine::Sine;
use crate::tracks::HISTORY;
use crate::Predictor;

/// One track's forecast, in the caller's unit (see the parent module).
#[derive(Clone, Debug, PartialEq)]
pub struct TrackForecast<const K: usize> {
    /// The track id (0 from [`forecast`]; the [`super::Forecaster`] sets it).
    pub id: u32,
    /// The time of the history's newest point (caller's milliseconds; 0
    /// from [`forecast`]): step `h` is at `end_ms + h·period`.
    pub end_ms: u32,
    /// The observed speed (caller units per second, rule 6).
    pub speed: f32,
    /// Its motion state.
    pub motion: MotionState,
    /// The model's endpoint set.
    pub endpoints: Vec<[f32; 2], K>,
    /// One probability per endpoint.
    pub probabilities: Vec<f32, K>,
    /// Whether the probabilities are the model's learned ones.
    pub learned: bool,
    /// The model's point head, when it has one (the first expert).
    pub head: Option<Trajectory>,
    /// The point forecast the loop issues: the experts' aggregate (the head
    /// itself with the loop off), step 1 first.
    pub point: [[f32; 2]; HORIZONS],
    /// `r50`/`r90` around [`TrackForecast::point`] at each step.
    pub radii: [Radii; HORIZONS],
    /// The planner's static radii around the head's endpoint (the blob's
    /// multipliers), for a model with probabilities.
    pub static_radii: Option<Radii>,
    /// The scale of the radii at the endpoint horizon (rule 4).
    pub scale: f32,
    /// The experts' weights at the endpoint horizon (head, CV1, CV2, CV4).
    pub weights: [f32; EXPERTS],
    /// The newest observed point (the constant-velocity experts' anchor).
    pub anchor: [f32; 2],
    /// The constant-velocity experts' velocities per step (rule 5).
    pub velocities: [[f32; 2]; 3],
}

impl<const K: usize> TrackForecast<K> {
    /// An empty forecast, to be filled by [`forecast`].
    pub const fn new() -> Self {
        const ZERO: Radii = Radii { r50: 0.0, r90: 0.0 };
        TrackForecast {
            id: 0,
            end_ms: 0,
            speed: 0.0,
            motion: MotionState::Standing,
            endpoints: Vec::new(),
            probabilities: Vec::new(),
            learned: false,
            head: None,
            point: [[0.0; 2]; HORIZONS],
            radii: [ZERO; HORIZONS],
            static_radii: None,
            scale: 0.0,
            weights: [0.0; EXPERTS],
            anchor: [0.0; 2],
            velocities: [[0.0; 2]; 3],
        }
    }

    /// Copies what [`model_outputs`] gives (endpoints, probabilities,
    /// `learned`, point head, static radii) from `from`.
    pub fn copy_model_outputs(&mut self, from: &TrackForecast<K>) {
        self.endpoints.clone_from(&from.endpoints);
        self.probabilities.clone_from(&from.probabilities);
        self.learned = from.learned;
        self.head.clone_from(&from.head);
        self.static_radii = from.static_radii;
    }

    /// The prediction of expert `e` (0: head, 1–3: constant velocity) at
    /// horizon `h` (1-based; rule 5), `None` without a head or outside
    /// `1..=12`.
    pub fn expert(&self, e: usize, h: usize) -> Option<[f32; 2]> {
        expert_at(self.head.as_ref(), self.anchor, &self.velocities, e, h)
    }
}

impl<const K: usize> Default for TrackForecast<K> {
    fn default() -> Self {
        Self::new()
    }
}

/// Runs the forecast sequence on `past` (the last [`HISTORY`] grid points,
/// oldest first, caller's unit) into `out`: the model's endpoints (as many as
/// it gives up to `K`), their probabilities, the point head, the planner's
/// static radii, then the experts, the aggregate point and the per-horizon
/// radii under `calibration` (the rules of the parent module). `period_s` is
/// the model's period in seconds. Fails as [`Predictor::predict_planner`]
/// does with `N = K` (so a test-time-sampling model whose `tts_samples`
/// exceed `K`, e.g. the `-tiny-qe` models' 80, fails with
/// [`PredictError::CapacityExceeded`]: give those a `K` of at least their
/// samples, or use a learned-proposal model), or with
/// [`PredictError::CapacityExceeded`] for a model that does not forecast
/// [`HORIZONS`] steps.
pub fn forecast<S: Sine, const W: usize, const K: usize>(
    p: &mut Predictor<'_, S, W>,
    calibration: &Calibration,
    past: &[[f32; 2]; HISTORY],
    seed: u64,
    period_s: f32,
    out: &mut TrackForecast<K>,
) -> Result<(), PredictError> {
    model_outputs(p, past, seed, out)?;
    calibrate(calibration, past, period_s, out)
}

/// The model's part of [`forecast`]: the planner's sequence
/// ([`Predictor::predict_planner`] with `N = K`) into `out`'s endpoints,
/// probabilities, `learned`, point head and static radii; nothing else of
/// `out` changes. It depends on `past` and `seed` only, so a caller running
/// two forecasters over the same detections (the loop off and on, say) may
/// compute it once and copy it ([`TrackForecast::copy_model_outputs`],
/// [`super::Forecaster::frame_with`]).
pub fn model_outputs<S: Sine, const W: usize, const K: usize>(
    p: &mut Predictor<'_, S, W>,
    past: &[[f32; 2]; HISTORY],
    seed: u64,
    out: &mut TrackForecast<K>,
) -> Result<(), PredictError> {
    // Endpoints, probabilities, point head, static radii: the planner's sequence.
    let n = crate::sampling::max_endpoints_of(p.model(), K);
    out.endpoints.clear();
    out.probabilities.clear();
    // At most K elements each (the capacity), so neither resize can fail.
    let _ = out.endpoints.resize(n, [0.0; 2]);
    let _ = out.probabilities.resize(n, 0.0);
    let planned = p.predict_planner::<K>(past, seed, &mut out.endpoints, &mut out.probabilities)?;
    if planned.point.as_ref().is_some_and(|t| t.len() != HORIZONS) {
        return Err(PredictError::CapacityExceeded);
    }
    out.learned = planned.learned;
    out.static_radii = planned.radii;
    out.head = planned.point;
    Ok(())
}

/// The loop's part of [`forecast`], after [`model_outputs`]: the experts
/// and motion state of `past`, the aggregate point and the per-horizon radii
/// under `calibration` (rules 3–6 of the parent module), into `out`.
pub fn calibrate<const K: usize>(
    calibration: &Calibration,
    past: &[[f32; 2]; HISTORY],
    period_s: f32,
    out: &mut TrackForecast<K>,
) -> Result<(), PredictError> {
    // Experts (rule 5) and motion state (rule 6).
    let [.., q0] = *past;
    let [first, ..] = *past;
    out.anchor = q0;
    for (v, &n) in out.velocities.iter_mut().zip(&CV_STEPS) {
        let q = past.get(HISTORY - 1 - n).copied().unwrap_or(q0);
        *v = [(q0[0] - q[0]) / n as f32, (q0[1] - q[1]) / n as f32];
    }
    out.speed = distance(q0, first) / (7.0 * period_s);
    let config = calibration.config();
    out.motion = MotionState::of_speed(out.speed, config.speed_thresholds);

    // The aggregate point (rule 3).
    let has_head = out.head.is_some();
    let available = [has_head, true, true, true];
    for h in 1..=HORIZONS {
        let w = if config.adapt || !has_head {
            calibration.weights(out.motion, h, available)
        } else {
            [1.0, 0.0, 0.0, 0.0]
        };
        let mut pt = [0.0f32; 2];
        for (e, &we) in w.iter().enumerate() {
            if let Some(x) = out.expert(e, h) {
                pt[0] += we * x[0];
                pt[1] += we * x[1];
            }
        }
        if let Some(o) = out.point.get_mut(h - 1) {
            *o = pt;
        }
        if h == HORIZONS {
            out.weights = w;
        }
    }

    // Scale (rule 4) and per-horizon radii.
    let [.., point_end] = out.point;
    let centre = out
        .head
        .as_ref()
        .and_then(|t| t.last().copied())
        .unwrap_or(point_end);
    let s = radii(centre, &out.endpoints, &out.probabilities, [1.0, 1.0])?.r50;
    let scale = if s > config.min_scale {
        s
    } else {
        config.min_scale
    };
    out.scale = scale;
    for (h, r) in (1..=HORIZONS).zip(out.radii.iter_mut()) {
        let [c50, c90] = calibration.multipliers(out.motion, h);
        let sh = scale * horizon_fraction(h);
        *r = Radii {
            r50: c50 * sh,
            r90: c90 * sh,
        };
        if !(r.r50.is_finite() && r.r90.is_finite()) {
            return Err(PredictError::NonFiniteOutput);
        }
    }
    if !out.point.iter().flatten().all(|v| v.is_finite()) {
        return Err(PredictError::NonFiniteOutput);
    }
    Ok(())
}

/// Expert `e` at horizon `h` (see [`TrackForecast::expert`]).
pub(super) fn expert_at(
    head: Option<&Trajectory>,
    anchor: [f32; 2],
    velocities: &[[f32; 2]; 3],
    e: usize,
    h: usize,
) -> Option<[f32; 2]> {
    if !(1..=HORIZONS).contains(&h) {
        return None;
    }
    match e {
        0 => head.and_then(|t| t.get(h - 1).copied()),
        _ => velocities.get(e - 1).map(|v| {
            let k = h as f32;
            [anchor[0] + v[0] * k, anchor[1] + v[1] * k]
        }),
    }
}

/// `sqrtf(dx·dx + dy·dy)` of `a − b` (libm's correctly rounded square root).
pub(super) fn distance(a: [f32; 2], b: [f32; 2]) -> f32 {
    let (dx, dy) = (a[0] - b[0], a[1] - b[1]);
    libm::sqrtf(dx * dx + dy * dy)
}
