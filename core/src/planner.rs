//! What a path planner gets besides the endpoints: a probability for each
//! endpoint and two radii around the point forecast.
//!
//! A model with endpoint probabilities (format version 6,
//! [`crate::Model::has_probabilities`]) is a learned-proposal model whose
//! proposal network also gives `K` logits, one per latent slot, trained to
//! put mass on the endpoint closest to the truth and calibrated on validation.
//! Its blob also records two radius multipliers `[c50, c90]` fitted on
//! validation so that the true endpoint lies within `r50` of the point
//! forecast in half of the windows and within `r90` in nine of ten.
//!
//! # The computation, in order (all f32; `weights/FORMAT.md`, "Format version 6")
//!
//! 1. Logits: the proposal's hidden layers on the features (as for a
//!    latent), then rows `K·zdim .. K·zdim + k` of its last layer, each
//!    converted to f32 with that layer's output exponent. Only the first `k`
//!    logits are used when the caller asks for `k < K` endpoints.
//! 2. [`softmax`]: `m` the largest logit, `e_i = expf(l_i − m)` (libm 0.2.16,
//!    pure software: the same bits on every target), `s = e_0 + e_1 + …` left
//!    to right, `p_i = e_i / s`.
//! 3. [`radii`]: `s² = Σ_i p_i·(dx_i·dx_i + dy_i·dy_i)` left to right from 0
//!    (`dx_i = e_i[0] − point[0]` on the endpoints and the point forecast's
//!    endpoint as returned to the caller), `s = sqrtf(s²)` (libm), `r50 =
//!    c50·s`, `r90 = c90·s`: a radius that grows with the spread of the
//!    likely endpoints around the point forecast, in the caller's unit.
//!
//! A model without probabilities gets `1/k` for each endpoint and no radii:
//! [`Forecast::learned`] says which.
//!
//! ```
//! # let bytes = include_bytes!("../../weights/sdd-m-lp-qe.gpec");
//! use gpecnet_core::{planner::Forecast, sine::LibmSine, Model, Predictor};
//! let model = Model::from_blob(bytes)?;
//! let mut p = Predictor::<LibmSine, 64>::new(model)?;
//! let past = [[0.0, 0.0], [0.4, 0.0], [0.8, 0.1], [1.2, 0.1],
//!             [1.6, 0.2], [2.0, 0.2], [2.4, 0.3], [2.8, 0.3]];
//! let f: Forecast<20> = p.predict_forecast(&past, 0)?;
//! assert!(f.learned);
//! let total: f32 = f.probabilities.iter().sum();
//! assert!((total - 1.0).abs() < 1e-5);
//! let r = f.radii.expect("a model with probabilities has radii");
//! assert!(0.0 < r.r50 && r.r50 <= r.r90);
//! # Ok::<(), gpecnet_core::Error>(())
//! ```

use heapless::Vec;

use crate::output::{PredictError, Trajectory};

/// The two radii of a point forecast (caller's unit): the true endpoint lies
/// within `r50` of the point forecast's endpoint in about half of the windows
/// and within `r90` in about nine of ten (calibrated on validation).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Radii {
    /// Median radius.
    pub r50: f32,
    /// 90 % radius.
    pub r90: f32,
}

/// One forecast for a planner: `K` endpoints with their probabilities, the
/// point forecast's endpoint and, for a model with probabilities, its radii.
#[derive(Clone, Debug, PartialEq)]
pub struct Forecast<const K: usize> {
    /// The model's endpoint set (its protocol, [`crate::sampling`]).
    pub endpoints: Vec<[f32; 2], K>,
    /// One probability per endpoint, summing to 1 (up to rounding).
    pub probabilities: Vec<f32, K>,
    /// Whether the probabilities are the model's learned ones (`false`:
    /// `1/K` each, the model has none).
    pub learned: bool,
    /// The point forecast's endpoint, when the model has a point head.
    pub point: Option<[f32; 2]>,
    /// The radii around [`Forecast::point`], for a model with probabilities.
    pub radii: Option<Radii>,
}

impl<const K: usize> Forecast<K> {
    /// The index of the most probable endpoint (the first of equals), `None`
    /// without endpoints ([`most_probable`]).
    pub fn most_probable(&self) -> Option<usize> {
        most_probable(&self.probabilities)
    }
}

/// What [`Predictor::predict_planner`](crate::predictor::Predictor::predict_planner)
/// gives besides the endpoints and probabilities it writes into the caller's
/// buffers: the slice form of a [`Forecast`], for callers whose buffer sizes
/// are only known at run time (the C ABI, the golden replay).
#[derive(Clone, Debug, PartialEq)]
pub struct PlannerOutput {
    /// Whether the probabilities are the model's learned ones (`false`:
    /// `1/k` each, the model has none).
    pub learned: bool,
    /// The point forecast, when the model has a point head.
    pub point: Option<Trajectory>,
    /// The radii around the point forecast's endpoint, for a model with
    /// probabilities.
    pub radii: Option<Radii>,
}

/// The steps the planner sequence ([`sequence`]) runs, as the engine gives them
/// in the model's unit and the predictor in the caller's.
pub(crate) trait Steps {
    /// The model's endpoint set into `out` (`predict_endpoint_set::<N>`).
    fn endpoint_set<const N: usize>(
        &mut self,
        past: &[[f32; 2]],
        seed: u64,
        out: &mut [[f32; 2]],
    ) -> Result<(), PredictError>;
    /// The probabilities of the endpoints just drawn; `true` when learned.
    fn probabilities(&mut self, out: &mut [f32]) -> Result<bool, PredictError>;
    /// The point forecast.
    fn point(&mut self, past: &[[f32; 2]]) -> Result<Trajectory, PredictError>;
    /// The model's point head and radius multipliers.
    fn point_head_and_scales(&self) -> (bool, [f32; 2]);
}

/// Implements [`Steps`] for `$ty` (generics `[$gen]`) by its inherent calls:
/// `predict_endpoint_set`, `probabilities`, `predict_point` and the
/// model's point head and radius multipliers ([`crate::Engine`] in the
/// model's unit, [`crate::Predictor`] in the caller's).
macro_rules! steps_by_calls {
    ([$($gen:tt)*] $ty:ty) => {
        impl<$($gen)*> $crate::planner::Steps for $ty {
            fn endpoint_set<const N: usize>(
                &mut self,
                past: &[[f32; 2]],
                seed: u64,
                out: &mut [[f32; 2]],
            ) -> Result<(), $crate::output::PredictError> {
                self.predict_endpoint_set::<N>(past, seed, out)
            }
            fn probabilities(&mut self, out: &mut [f32]) -> Result<bool, $crate::output::PredictError> {
                Self::probabilities(self, out)
            }
            fn point(
                &mut self,
                past: &[[f32; 2]],
            ) -> Result<$crate::output::Trajectory, $crate::output::PredictError> {
                self.predict_point(past)
            }
            fn point_head_and_scales(&self) -> (bool, [f32; 2]) {
                (self.model().has_point_head(), self.model().radius_scales())
            }
        }
    };
}
pub(crate) use steps_by_calls;

/// The public entry point of the planner sequence on a type with [`Steps`]
/// ([`sequence`] on `Self`): written as its documented signature (which
/// `tests/public_api.rs` reads from the invocation), the body generated.
macro_rules! planner_call {
    (
        $(#[$doc:meta])*
        pub fn $name:ident<const $n:ident: usize>(
            &mut self,
            $past:ident: $pt:ty,
            $seed:ident: $st:ty,
            $ends:ident: $et:ty,
            $probs:ident: $prt:ty $(,)?
        ) -> $ret:ty;
    ) => {
        $(#[$doc])*
        pub fn $name<const $n: usize>(
            &mut self,
            $past: $pt,
            $seed: $st,
            $ends: $et,
            $probs: $prt,
        ) -> $ret {
            $crate::planner::sequence::<$n, Self>(self, $past, $seed, $ends, $probs)
        }
    };
}
pub(crate) use planner_call;

/// The planner sequence, one order for every caller: the endpoint set into
/// `endpoints`, their probabilities into `probabilities`, then the point
/// forecast (with a point head) and, for a model with probabilities, the
/// [`radii`]. [`PredictError::BadSampleCount`] when the two buffers differ in
/// length.
pub(crate) fn sequence<const N: usize, S: Steps>(
    steps: &mut S,
    past: &[[f32; 2]],
    seed: u64,
    endpoints: &mut [[f32; 2]],
    probabilities: &mut [f32],
) -> Result<PlannerOutput, PredictError> {
    if probabilities.len() != endpoints.len() {
        return Err(PredictError::BadSampleCount);
    }
    steps.endpoint_set::<N>(past, seed, endpoints)?;
    let learned = steps.probabilities(probabilities)?;
    let (point_head, scales) = steps.point_head_and_scales();
    let point = if point_head {
        Some(steps.point(past)?)
    } else {
        None
    };
    let radii = match point.as_ref().and_then(|t| t.last()) {
        Some(&pt) if learned => Some(radii(pt, endpoints, probabilities, scales)?),
        _ => None,
    };
    Ok(PlannerOutput {
        learned,
        point,
        radii,
    })
}

/// The index of the most probable of `probabilities` (the first of equals),
/// `None` when empty.
pub fn most_probable(probabilities: &[f32]) -> Option<usize> {
    let mut best: Option<(usize, f32)> = None;
    for (i, &p) in probabilities.iter().enumerate() {
        if best.is_none_or(|(_, b)| p > b) {
            best = Some((i, p));
        }
    }
    best.map(|(i, _)| i)
}

/// Step 2: the softmax of `logits` into `out` in place (the logits are read
/// from `out`). [`PredictError::NonFiniteOutput`] when a logit is not finite
/// or the sum is not positive; [`PredictError::BadSampleCount`] when empty.
#[inline(never)]
pub fn softmax(out: &mut [f32]) -> Result<(), PredictError> {
    if out.is_empty() {
        return Err(PredictError::BadSampleCount);
    }
    // Indexed loops whose counter passes through `black_box`: the compiler cannot
    // count the iterations, so it does not unroll them (at opt-level 3 it would
    // copy each body several times: a kilobyte of flash for 20 numbers).
    let mut m = f32::NEG_INFINITY;
    let mut i = 0;
    while let Some(&l) = out.get(i) {
        if !l.is_finite() {
            return Err(PredictError::NonFiniteOutput);
        }
        if l > m {
            m = l;
        }
        i = core::hint::black_box(i) + 1;
    }
    let mut s = 0.0f32;
    let mut i = 0;
    while let Some(v) = out.get_mut(i) {
        *v = exp(*v - m);
        s += *v;
        i = core::hint::black_box(i) + 1;
    }
    if !(s.is_finite() && s > 0.0) {
        return Err(PredictError::NonFiniteOutput);
    }
    let mut i = 0;
    while let Some(v) = out.get_mut(i) {
        *v /= s;
        i = core::hint::black_box(i) + 1;
    }
    Ok(())
}

/// Step 3: the radii of `point` for `endpoints` weighted by `probs` (pairs up
/// to the shorter length), with the model's multipliers `scales` (`[c50,
/// c90]`, [`crate::Model::radius_scales`]).
/// [`PredictError::NonFiniteOutput`] when a radius is not finite.
#[inline(never)]
pub fn radii(
    point: [f32; 2],
    endpoints: &[[f32; 2]],
    probs: &[f32],
    scales: [f32; 2],
) -> Result<Radii, PredictError> {
    let mut s2 = 0.0f32;
    for (e, &p) in endpoints.iter().zip(probs) {
        let (dx, dy) = (e[0] - point[0], e[1] - point[1]);
        s2 += p * (dx * dx + dy * dy);
    }
    let s = libm::sqrtf(s2);
    let r = Radii {
        r50: scales[0] * s,
        r90: scales[1] * s,
    };
    if r.r50.is_finite() && r.r90.is_finite() {
        Ok(r)
    } else {
        Err(PredictError::NonFiniteOutput)
    }
}

/// libm's `expf`, out of line: one copy in flash, called from the softmax's loop.
#[inline(never)]
fn exp(x: f32) -> f32 {
    libm::expf(x)
}

/// `1/k` in each of `out`'s `k` elements (a model without probabilities; out of
/// line, so a model with them does not carry it in its executed code).
#[inline(never)]
pub(crate) fn uniform(out: &mut [f32]) {
    let k = out.len().max(1) as f32;
    for v in out.iter_mut() {
        *v = 1.0 / k;
    }
}
