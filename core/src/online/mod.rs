//! The forecast checks itself: an online loop that calibrates the radii and
//! the point forecast on the device, from the truth it sees 0.4 s … 4.8 s
//! after each forecast.
//!
//! A blob's radii `r50`/`r90` ([`crate::planner`]) are multipliers fitted once
//! on the training data's validation split; on a scene the model never saw
//! they cover more or less than they claim. A drone tracks every pedestrian
//! it forecasts, so 0.4 s after a forecast it knows the first step's truth,
//! and 4.8 s after it the endpoint's. This module feeds that truth back:
//!
//! * **per-horizon radii** `r50(h)`, `r90(h)` for `h = 1 … 12` steps (a tube a
//!   planner checks a time-indexed path against), each `c(h) · scale(h)` with
//!   its own multiplier `c(h)` learned by quantile tracking (adaptive
//!   conformal inference, Gibbs & Candès 2021), optionally per motion state;
//! * the **point forecast** as an online aggregate of the model's point head
//!   and three constant-velocity experts (over the last 1, 2 and 4 steps),
//!   weighted per horizon (and motion state) by exponentially discounted
//!   losses, so a scene where constant velocity wins is followed.
//!
//! [`Forecaster`] is the one call per camera frame: detections in (the
//! [`crate::tracks::TimedTrackTable`] resamples them onto the model's
//! period), a [`TrackForecast`] per track with a new grid point out, the loop
//! fed automatically. [`forecast`] is the sequence it runs for one track, for
//! callers with their own track handling; [`Calibration`] is what is learned,
//! with [`Calibration::state`] and [`Calibration::restore`] to keep it across
//! flights.
//!
//! ```
//! # let bytes = include_bytes!("../../../weights/sdd-m-lp-qe.gpec");
//! use gpecnet_core::online::{Config, Forecaster, TrackForecast};
//! use gpecnet_core::tracks::Observation;
//! use gpecnet_core::{units::CallerUnit, LibmSine, Model, Predictor};
//!
//! let model = Model::from_blob(bytes)?;
//! let mut p = Predictor::<LibmSine, 64>::with_units(model, CallerUnit::Metres)?;
//! // 16 tracks, 2 forecasts per track awaiting their truth, 1 s gap bridged.
//! let mut f: Forecaster<16, 2> = Forecaster::new(&model, Config::metres(), 1_000)?;
//! let mut seen = 0;
//! for frame in 0..300u32 {
//!     let t_ms = frame * 100; // a 10 Hz tracker
//!     let walker = Observation { id: 7, pos: [1.3 * t_ms as f32 / 1000.0, 2.0] };
//!     f.frame::<_, 64, 20>(&mut p, t_ms, &[walker], |fc: &TrackForecast<20>| {
//!         let r = fc.radii[11]; // the endpoint's radii, 4.8 s after fc.end_ms
//!         assert!(0.0 < r.r50 && r.r50 <= r.r90);
//!         seen += 1;
//!     });
//! }
//! assert!(seen > 50);
//! assert!(f.calibration().feedback_count(gpecnet_core::online::MotionState::Walking) > 0);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! # What the numbers guarantee
//!
//! Quantile tracking gives a **long-run** guarantee: for every horizon and
//! motion state, over any sequence of feedback (no assumption on the scene),
//! the fraction of misses converges to `α` as long as the multiplier stays
//! inside its bounds (`|miss rate − α| ≤ (log c_max − log c_min + γ)/(γ·T)`
//! after `T` updates of the cell). A miss is judged with the multiplier
//! current when the truth arrives (at most 4.8 s after the one issued with
//! the forecast), so the issued radii's coverage is this up to the drift of
//! the multiplier in that time: measured, not guaranteed. It says nothing
//! about one window or one pedestrian. The aggregate point forecast is, by the exponential-weights
//! bound, within `O(log(experts)/η)` of the best expert's discounted loss at
//! each horizon. `docs/online.md` has the measured coverage, per scene and per
//! horizon, with the loop off and on.
//!
//! # The update rules (all f32, in this order; the same bits on every target)
//!
//! A forecast issued at grid step `s` (the newest history point) is scored
//! at step `s + h` for each horizon `h = 1 … 12` against the track's grid
//! position there (the truth, as the track table delivers it). With `y` that
//! position, `p_h` the issued point, `scale` the forecast's scale (below) and
//! `e_i` each expert's prediction at `h`:
//!
//! 1. **Multipliers** (per level `l`: `α = Config::alpha[l]`): `d =
//!    sqrtf(dx·dx + dy·dy)` of `y − p_h`; `radius = c·(scale·h/12)` with the
//!    cell's current `c`; `c ← clamp(c·u, c_min, c_max)` with `u = up_l =
//!    expf(γ·(1 − α))` when `d > radius` (a miss), else `u = down_l =
//!    expf(−γ·α)` (both computed once, libm 0.2.16); then `c50 ← min(c50,
//!    c90)`. In logs this is `θ ← θ + γ·(1[miss] − α)`.
//! 2. **Losses** (per expert `i`, when available): `L_i ← min(λ·L_i +
//!    min(|y − e_i|, loss_cap), loss_cap/(1 − λ))`, `|·|` as in rule 1.
//! 3. **Weights** at forecast time (per horizon): `m = min_i L_i`, `η_h = η
//!    / (h/12)`, `w_i = expf(−(η_h·(L_i − m)))`, `S = w_0 + w_1 + …` left to
//!    right, `w_i ← w_i / S`. The point is `p_h = Σ_i w_i·e_i` per
//!    coordinate, left to right from 0 in expert order (head, CV1, CV2,
//!    CV4). With [`Config::adapt`] off, the point is the head's exactly
//!    (constant velocity with weights by rule 3 for a model without head).
//! 4. **Scale**: `s = sqrtf(Σ_i p_i·|e_i − q|²)` over the endpoints and their
//!    probabilities around the head's endpoint `q` (the planner's step 3
//!    without multipliers; uniform probabilities for a model without learned
//!    ones; the point's endpoint for a model without head), `scale =
//!    max(s, min_scale)`; the radii of horizon `h` are `c(h)·(scale·h/12)`.
//!    With the blob's multipliers, `r(12)` is the planner's static radius.
//! 5. **Experts**: `CVn_h = q₀ + v_n·h` per coordinate with `q₀` the newest
//!    observed point and `v_n = (q₀ − q₋ₙ)/n` (`n = 1, 2, 4`).
//! 6. **Motion state**: observed speed `v = |q₀ − q₋₇| / (7·period)` (the
//!    displacement over the history, caller units per second), binned by
//!    [`Config::speed_thresholds`] into [`MotionState`].
//!
//! Bounds: a multiplier never leaves `[c_min, c_max]`, a loss never leaves
//! `[0, loss_cap/(1 − λ)]`, a scale is at least `min_scale`, so no feedback
//! (an id switch, a teleporting detection, NaN, a long pause, the `u32` wrap)
//! makes a radius NaN, zero, negative or unbounded, or a weight NaN; feedback
//! that is not finite is ignored.
//!
//! # Memory
//!
//! [`Calibration`] is about 1.3 KiB (4 motion states × 12 horizons × (2
//! multipliers + 4 losses)). Per track, a [`Forecaster`] keeps `P` forecasts
//! waiting for their truth (240 B each on a 32-bit target: issued point and
//! head, 12 steps each, the experts' anchor and velocities, scale, state) and
//! 16 B of bookkeeping: 496 B for `P = 2`, the table's 104 B besides. With
//! `P < 12` not every forecast is scored: one every `⌈12/P⌉` grid steps per
//! track, which still gives every cell feedback at `2.5·P/12` Hz per track.

mod calibration;
mod forecast;
mod forecaster;
mod pending;

pub use calibration::{Calibration, STATE_LEN};
pub use forecast::{calibrate, forecast, model_outputs, TrackForecast};
pub use forecaster::{Forecaster, FrameReport};

use crate::output::PredictError;

/// Horizons the loop scores: the shipped models' 12 steps of 0.4 s.
pub const HORIZONS: usize = 12;
/// Radius levels: `r50` (index 0) and `r90` (index 1).
pub const LEVELS: usize = 2;
/// Experts of the point forecast: the model's point head, then constant
/// velocity over the last 1, 2 and 4 steps.
pub const EXPERTS: usize = 4;
/// The steps of the constant-velocity experts 1, 2 and 3.
pub const CV_STEPS: [usize; 3] = [1, 2, 4];
/// Motion states with calibrations of their own.
pub const BINS: usize = 4;
/// Multipliers `[c50, c90]` for a model without learned radii (a
/// two-dimensional Gaussian's 50 % and 90 % radii in units of its RMS
/// distance: `sqrt(ln 4)/sqrt(2)` and `sqrt(ln 100)/sqrt(2)`, rounded).
pub const DEFAULT_MULTIPLIERS: [f32; LEVELS] = [0.83, 1.52];

/// A pedestrian's motion when forecast, by observed speed (rule 6).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u8)]
pub enum MotionState {
    /// Below the first threshold (0.3 m/s by default).
    Standing = 0,
    /// Below the second (0.9 m/s).
    Slow = 1,
    /// Below the third (1.8 m/s).
    Walking = 2,
    /// At or above the third.
    Fast = 3,
}

impl MotionState {
    /// Every state, in order.
    pub const ALL: [MotionState; BINS] = [
        MotionState::Standing,
        MotionState::Slow,
        MotionState::Walking,
        MotionState::Fast,
    ];

    /// The state of `speed` under `thresholds` (ascending); a speed that is
    /// not a number counts as [`MotionState::Fast`] (the widest radii).
    pub fn of_speed(speed: f32, thresholds: [f32; 3]) -> Self {
        if speed < thresholds[0] {
            MotionState::Standing
        } else if speed < thresholds[1] {
            MotionState::Slow
        } else if speed < thresholds[2] {
            MotionState::Walking
        } else {
            MotionState::Fast
        }
    }

    /// Its lower-case name (`standing`, `slow`, `walking`, `fast`).
    pub const fn name(self) -> &'static str {
        match self {
            MotionState::Standing => "standing",
            MotionState::Slow => "slow",
            MotionState::Walking => "walking",
            MotionState::Fast => "fast",
        }
    }
}

/// The loop's settings. Distances are in the caller's unit (the
/// [`crate::Predictor`]'s): [`Config::metres`] is for metres, and
/// [`Config::scaled`] converts it for another unit.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Config {
    /// Learn from feedback (`false`: the blob's static multipliers and the
    /// head's point forecast, as without the loop).
    pub adapt: bool,
    /// Target miss rates of `r50` and `r90`: `[0.5, 0.1]`.
    pub alpha: [f32; LEVELS],
    /// Step of the multipliers' logarithm per update, `γ`: 0.2.
    pub gamma: f32,
    /// Learning rate of the expert weights per caller unit of discounted
    /// error at the endpoint horizon, `η`: 2 per metre.
    pub eta: f32,
    /// Forgetting factor of the expert losses per update, `λ`: 0.999.
    pub forgetting: f32,
    /// The constant-velocity experts' initial loss at the endpoint horizon
    /// (caller unit; `h/12` of it at horizon `h`): 0.5 m, so the point head
    /// starts with about 57 % of the weight (each constant-velocity expert
    /// with `e^{-1}` of the head's).
    pub expert_prior: f32,
    /// Observed speeds (caller units per second) separating standing, slow,
    /// walking and fast: `[0.3, 0.9, 1.8]` m/s.
    pub speed_thresholds: [f32; 3],
    /// One calibration per motion state (`false`, the default: one for
    /// all; per-state calibrations did worse on validation, `docs/online.md`).
    pub motion_bins: bool,
    /// The smallest scale (caller unit): 0.05 m.
    pub min_scale: f32,
    /// The largest error one update counts (caller unit): 10 m.
    pub loss_cap: f32,
    /// `[c_min, c_max]`, the range of every multiplier: `[0.02, 50]`.
    pub multiplier_bounds: [f32; 2],
}

impl Config {
    /// The defaults, for callers in metres (each field's doc gives its value).
    pub const fn metres() -> Self {
        Config {
            adapt: true,
            alpha: [0.5, 0.1],
            gamma: 0.2,
            eta: 2.0,
            forgetting: 0.999,
            expert_prior: 0.5,
            speed_thresholds: [0.3, 0.9, 1.8],
            motion_bins: false,
            min_scale: 0.05,
            loss_cap: 10.0,
            multiplier_bounds: [0.02, 50.0],
        }
    }

    /// This config for a caller whose unit is `units_per_metre` of its unit
    /// per metre (pixels per metre for a camera): every distance and speed
    /// multiplied by it, `η` divided by it.
    pub fn scaled(self, units_per_metre: f32) -> Self {
        let f = units_per_metre;
        Config {
            eta: self.eta / f,
            expert_prior: self.expert_prior * f,
            speed_thresholds: [
                self.speed_thresholds[0] * f,
                self.speed_thresholds[1] * f,
                self.speed_thresholds[2] * f,
            ],
            min_scale: self.min_scale * f,
            loss_cap: self.loss_cap * f,
            ..self
        }
    }

    /// Checks every field: `0 < α90 < α50 < 1`, `0 < γ ≤ 1`, `η > 0`, `0 < λ
    /// < 1`, `0 ≤ expert_prior ≤ loss_cap/(1 − λ)`, thresholds finite,
    /// non-negative and ascending, `min_scale > 0`, `loss_cap > 0`, `0 <
    /// c_min < c_max`, all finite. [`OnlineError::BadConfig`] otherwise.
    pub fn validate(&self) -> Result<(), OnlineError> {
        let pos = |v: f32| v.is_finite() && v > 0.0;
        let [a50, a90] = self.alpha;
        let [lo, hi] = self.multiplier_bounds;
        let [t0, t1, t2] = self.speed_thresholds;
        let ok = a90 > 0.0
            && a90 < a50
            && a50 < 1.0
            && pos(self.gamma)
            && self.gamma <= 1.0
            && pos(self.eta)
            && self.forgetting > 0.0
            && self.forgetting < 1.0
            && pos(self.min_scale)
            && pos(self.loss_cap)
            && self.expert_prior.is_finite()
            && self.expert_prior >= 0.0
            && self.expert_prior <= self.loss_cap / (1.0 - self.forgetting)
            && t0.is_finite()
            && t2.is_finite()
            && 0.0 <= t0
            && t0 <= t1
            && t1 <= t2
            && pos(lo)
            && hi.is_finite()
            && lo < hi;
        if ok {
            Ok(())
        } else {
            Err(OnlineError::BadConfig)
        }
    }
}

impl Default for Config {
    fn default() -> Self {
        Self::metres()
    }
}

/// Why the loop refused something.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum OnlineError {
    /// A [`Config`] field (or the initial multipliers) is out of range
    /// ([`Config::validate`]).
    BadConfig,
    /// The model does not forecast 12 steps from 8 on a period of whole
    /// milliseconds (the loop's shape).
    ModelShape,
    /// A calibration state of the wrong length.
    StateLength,
    /// A calibration state without the magic `GPOL`.
    StateMagic,
    /// A calibration state of another layout version.
    StateVersion,
    /// A calibration state of another shape (bins, horizons, levels, experts).
    StateShape,
    /// A calibration state whose CRC does not match (damaged).
    StateCrc,
    /// A calibration state with a value outside this config's bounds.
    StateValue,
    /// An output buffer is too small.
    BufferTooSmall,
    /// A prediction was refused.
    Predict(PredictError),
}

impl From<PredictError> for OnlineError {
    fn from(e: PredictError) -> Self {
        OnlineError::Predict(e)
    }
}

impl core::fmt::Display for OnlineError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            OnlineError::BadConfig => f.write_str("online loop config out of range"),
            OnlineError::ModelShape => f.write_str(
                "the online loop needs a model forecasting 12 steps from 8 on a whole-millisecond period",
            ),
            OnlineError::StateLength => f.write_str("calibration state has the wrong length"),
            OnlineError::StateMagic => f.write_str("not a calibration state (magic)"),
            OnlineError::StateVersion => f.write_str("calibration state of another version"),
            OnlineError::StateShape => f.write_str("calibration state of another shape"),
            OnlineError::StateCrc => f.write_str("calibration state damaged (CRC)"),
            OnlineError::StateValue => f.write_str("calibration state value out of bounds"),
            OnlineError::BufferTooSmall => f.write_str("output buffer too small"),
            OnlineError::Predict(e) => write!(f, "{e}"),
        }
    }
}

impl core::error::Error for OnlineError {}
