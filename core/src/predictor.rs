//! [`Predictor`]: endpoint, trajectory and point forecasts from any valid
//! blob, its numeric kind chosen at run time from the blob.
//!
//! A `Predictor<'a, S, W>` owns a copy of the [`Model`] view (one lifetime:
//! the blob's, `'static` for a blob in flash), so it can live in a `static`
//! or be moved into a task. `S` is the sine an f32 blob runs with (ignored by
//! fixed-point blobs, which use the integer table sine); `W` is the scratch
//! width, at least [`Model::scratch_width`]. The arithmetic, step by step, is
//! in [`crate::engine`]; both numeric kinds run that one engine.
//!
//! ```
//! # fn demo(blob: &'static [u8]) -> Result<(), gpecnet_core::Error> {
//! use gpecnet_core::{LibmSine, Model, Predictor};
//! let model = Model::from_blob(blob)?;
//! let mut p: Predictor<'_, LibmSine, 128> = Predictor::new(model)?;
//! let past = [[10.0, 20.0], [11.0, 21.0], [12.0, 22.0], [13.0, 23.0],
//!             [14.0, 24.0], [15.0, 25.0], [16.0, 26.0], [17.0, 27.0]];
//! let mut ends = [[0.0f32; 2]; 20];
//! p.predict_endpoint_set::<128>(&past, /* seed */ 7, &mut ends)?;
//! # Ok(()) }
//! ```
//!
//! # Memory
//!
//! `size_of::<Predictor<S, W>>()` is `20·W` bytes plus about 1.6 KiB on a
//! 32-bit target (the f32 engine's five rows of `W` f32, the model view, the
//! sampler state): 4,128 B for `W = 128` on a Cortex-M4F. Outputs go to caller-owned buffers; [`Trajectory`] is 260 bytes.

use crate::blob::{Model, NumericKind, MAX_PAST};
use crate::engine::Engine;
use crate::fixed::Q15;
use crate::float::Float;
pub use crate::output::{PredictError, Trajectory};
use crate::planner::{Forecast, PlannerOutput};
use crate::sine::Sine;
use crate::units::{CallerUnit, Conversion};
use crate::Error;

/// One engine per numeric kind, holding the one a blob's kind calls for:
/// the run-time dispatch of [`Predictor`] (scalar engines) and of
/// `batch::BatchPredictor` (batched engines).
pub(crate) enum ByKind<F, Q> {
    /// The engine of an f32 blob.
    F32(F),
    /// The engine of an int16/Q15 blob.
    Q15(Q),
}

/// Evaluates `$body` with `$e` bound to whichever engine the [`ByKind`]
/// `$p` holds (both arms are the same code, typed per engine).
macro_rules! on_kind {
    ($p:expr, $e:ident => $body:expr) => {
        match $p {
            $crate::predictor::ByKind::F32($e) => $body,
            $crate::predictor::ByKind::Q15($e) => $body,
        }
    };
}
pub(crate) use on_kind;

/// The one-track sample calls of [`Predictor`]: the engine's call of the
/// same name with `past` in the model's unit, then `out` in the caller's
/// ([`CallerPoints`]). Each written as its documented signature (which
/// `tests/public_api.rs` reads from the invocation), the body generated.
macro_rules! sample_calls {
    ($(
        $(#[$doc:meta])*
        pub fn $name:ident $(<const $n:ident: usize>)?
            (&mut self, $past:ident: $pt:ty, $seed:ident: $st:ty, $out:ident: $ot:ty $(,)?)
            -> $ret:ty;
    )*) => {
        $(
            $(#[$doc])*
            pub fn $name $(<const $n: usize>)? (&mut self, $past: $pt, $seed: $st, $out: $ot) -> $ret {
                self.run($past, |k, $past| {
                    on_kind!(k, e => e.$name $(::<$n>)? ($past, $seed, $out))
                })?;
                CallerPoints::to_caller($out, self.units);
                Ok(())
            }
        )*
    };
}

/// The engines of a [`Predictor`], one per numeric kind.
type Engines<'a, S, const W: usize> = ByKind<Engine<'a, Float<S>, W>, Engine<'a, Q15, W>>;

/// Predicts from any valid blob (see the module docs).
pub struct Predictor<'a, S: Sine, const W: usize> {
    engine: Engines<'a, S, W>,
    units: Conversion,
}

impl<'a, S: Sine, const W: usize> Predictor<'a, S, W> {
    /// A predictor for `model`, whatever its numeric kind. Fails with
    /// [`PredictError::ScratchTooSmall`] when [`Model::scratch_width`]
    /// exceeds `W`.
    ///
    /// Positions go in and come out in the model's own unit, unchecked
    /// (pixels for the SDD pixel models, metres for the metric ones): the
    /// same as [`Predictor::with_units`] with [`CallerUnit::ModelUnit`].
    /// Prefer `with_units`, which refuses a caller unit the model cannot take.
    pub fn new(model: Model<'a>) -> Result<Self, Error> {
        Ok(Self {
            engine: match model.numeric() {
                NumericKind::F32 => ByKind::F32(Engine::new(model)?),
                NumericKind::Int16Q15 => ByKind::Q15(Engine::new(model)?),
            },
            units: Conversion::IDENTITY,
        })
    }

    /// A predictor for a caller whose positions are in `unit`: refused with
    /// [`Error::Unit`] when the model cannot take them (the rules and the
    /// exact conversion are in [`crate::units`]), else as [`Predictor::new`],
    /// converting every input and output where the units differ.
    pub fn with_units(model: Model<'a>, unit: CallerUnit) -> Result<Self, Error> {
        let units = Conversion::new(&model, unit)?;
        let mut p = Self::new(model)?;
        p.units = units;
        Ok(p)
    }

    /// The conversion between the caller's positions and the model's
    /// ([`Conversion::IDENTITY`] when they are the same).
    pub fn units(&self) -> Conversion {
        self.units
    }

    /// `f(engine, past)` with `past` in the model's unit.
    fn run<R>(
        &mut self,
        past: &[[f32; 2]],
        f: impl FnOnce(&mut Engines<'a, S, W>, &[[f32; 2]]) -> Result<R, PredictError>,
    ) -> Result<R, PredictError> {
        if self.units.is_identity() {
            f(&mut self.engine, past)
        } else {
            self.run_converted(past, f)
        }
    }

    /// [`Self::run`] through a converted copy of `past`, out of line so that
    /// predictors without a conversion do not carry the copy on their stack.
    #[inline(never)]
    fn run_converted<R>(
        &mut self,
        past: &[[f32; 2]],
        f: impl FnOnce(&mut Engines<'a, S, W>, &[[f32; 2]]) -> Result<R, PredictError>,
    ) -> Result<R, PredictError> {
        let mut buf = [[0.0; 2]; MAX_PAST];
        let expected = usize::from(self.model().config().past_len);
        let past = model_past(self.units, past, expected, &mut buf)?;
        f(&mut self.engine, past)
    }

    /// The model.
    pub fn model(&self) -> &Model<'a> {
        on_kind!(&self.engine, e => e.model())
    }

    /// Name of the sine this predictor runs the model with (`S::NAME` for
    /// f32 blobs, `q15-table` for fixed-point ones), as golden files name it.
    pub fn sine_name(&self) -> &'static str {
        match self.engine {
            ByKind::F32(_) => S::NAME,
            ByKind::Q15(_) => crate::fixed::SINE_NAME,
        }
    }

    /// The model's deterministic point forecast: `future_len` points, the
    /// last one the endpoint. Needs a point-forecast head
    /// ([`Model::has_point_head`]); the model's single best guess.
    pub fn predict_point(&mut self, past: &[[f32; 2]]) -> Result<Trajectory, PredictError> {
        let mut t = self.run(past, |k, past| on_kind!(k, e => e.predict_point(past)))?;
        caller_points(self.units, &mut t);
        Ok(t)
    }

    sample_calls! {
        /// The model's endpoint set: `out.len()` endpoints (plain latent samples
        /// or, when the blob asks for test-time sampling, the k-means reduction of
        /// its `tts_samples` samples; see [`crate::sampling`]). `N` bounds the
        /// samples drawn (8 bytes of stack each): at least
        /// [`crate::sampling::samples_needed`].
        pub fn predict_endpoint_set<const N: usize>(&mut self, past: &[[f32; 2]], seed: u64, out: &mut [[f32; 2]]) -> Result<(), PredictError>;

        /// `out.len()` plain latent samples (the first endpoints of the stream
        /// seeded with `seed`), whatever the blob's protocol.
        pub fn predict_samples(&mut self, past: &[[f32; 2]], seed: u64, out: &mut [[f32; 2]]) -> Result<(), PredictError>;

        /// `out.len()` full trajectories of plain latent samples (the last point
        /// of each is its endpoint). Needs [`Model::has_predictor`].
        pub fn predict_trajectories(&mut self, past: &[[f32; 2]], seed: u64, out: &mut [Trajectory]) -> Result<(), PredictError>;
    }

    /// Starts a sample stream (encodes `past` once); then call
    /// [`Predictor::next_endpoint`] once per sample, yielding to other tasks
    /// in between if you like. `start` + `k` × `next_endpoint` gives exactly
    /// [`Predictor::predict_samples`] with `k` outputs.
    pub fn start(&mut self, past: &[[f32; 2]], seed: u64) -> Result<(), PredictError> {
        self.run(past, |k, past| on_kind!(k, e => e.start(past, seed)))
    }

    /// The next sample's endpoint of the stream begun by [`Predictor::start`].
    pub fn next_endpoint(&mut self) -> Result<[f32; 2], PredictError> {
        let mut p = [on_kind!(&mut self.engine, e => e.next_endpoint())?];
        caller_points(self.units, &mut p);
        let [p] = p;
        Ok(p)
    }

    /// The probabilities of the first `out.len()` endpoints of the stream
    /// begun by [`Predictor::start`] (or by a `predict_*` call), any time
    /// after it: `Ok(true)` with the model's learned ones, `Ok(false)` with
    /// `1/k` each for a model without them ([`crate::planner`]).
    pub fn probabilities(&mut self, out: &mut [f32]) -> Result<bool, PredictError> {
        on_kind!(&mut self.engine, e => e.probabilities(out))
    }

    /// What a planner needs in one call ([`crate::planner`]): the model's
    /// endpoints, as many as it gives up to `K`
    /// ([`crate::sampling::max_endpoints_of`]; [`Predictor::predict_planner`] with `N = K`, so a
    /// test-time-sampling model fails with
    /// [`PredictError::CapacityExceeded`]), their probabilities, the point
    /// forecast's endpoint (with a point head) and its radii (with
    /// probabilities), all in the caller's unit.
    pub fn predict_forecast<const K: usize>(
        &mut self,
        past: &[[f32; 2]],
        seed: u64,
    ) -> Result<Forecast<K>, PredictError> {
        let mut endpoints = heapless::Vec::new();
        let mut probabilities = heapless::Vec::new();
        // At most K elements each (the capacity), so neither resize can fail.
        let n = crate::sampling::max_endpoints_of(self.model(), K);
        let _ = endpoints.resize(n, [0.0; 2]);
        let _ = probabilities.resize(n, 0.0);
        let out = self.predict_planner::<K>(past, seed, &mut endpoints, &mut probabilities)?;
        Ok(Forecast {
            endpoints,
            probabilities,
            learned: out.learned,
            point: out.point.and_then(|t| t.last().copied()),
            radii: out.radii,
        })
    }

    crate::planner::planner_call! {
        /// [`Predictor::predict_forecast`] into the caller's buffers, in one
        /// order every caller shares: the endpoint set into `endpoints`
        /// ([`Predictor::predict_endpoint_set`] with its `N`), their
        /// probabilities into `probabilities` ([`Predictor::probabilities`]),
        /// then the point forecast (with a point head) and, for a model with
        /// probabilities, the radii ([`crate::planner::radii`]).
        /// [`PredictError::BadSampleCount`] when the two buffers differ in length.
        pub fn predict_planner<const N: usize>(&mut self, past: &[[f32; 2]], seed: u64, endpoints: &mut [[f32; 2]], probabilities: &mut [f32]) -> Result<PlannerOutput, PredictError>;
    }

    /// The full trajectory of the sample [`Predictor::next_endpoint`] drew last.
    pub fn last_trajectory(&mut self) -> Result<Trajectory, PredictError> {
        let mut t = on_kind!(&mut self.engine, e => e.last_trajectory())?;
        caller_points(self.units, &mut t);
        Ok(t)
    }
}

crate::planner::steps_by_calls!([S: Sine, const W: usize] Predictor<'_, S, W>);

/// `past` in the model's unit, in `buf` (`x · f` per coordinate, the
/// conversion of [`crate::units`]). Non-finite inputs stay non-finite (the
/// engine names them); a finite input whose product is not is
/// [`PredictError::InputOutOfRange`].
fn model_past<'p>(
    units: Conversion,
    past: &[[f32; 2]],
    expected: usize,
    buf: &'p mut [[f32; 2]; MAX_PAST],
) -> Result<&'p [[f32; 2]], PredictError> {
    let n = past.len();
    let Some(out) = buf.get_mut(..n) else {
        return Err(PredictError::WrongPastLength { expected, got: n });
    };
    let f = units.factor();
    for (o, p) in out.iter_mut().zip(past) {
        for (o, &x) in o.iter_mut().zip(p) {
            *o = x * f;
            if x.is_finite() && !o.is_finite() {
                return Err(PredictError::InputOutOfRange);
            }
        }
    }
    Ok(out)
}

/// Outputs of positions in the model's unit, converted to the caller's in
/// place ([`caller_points`] on each).
trait CallerPoints {
    /// Converts every position with `units`.
    fn to_caller(&mut self, units: Conversion);
}

impl CallerPoints for [[f32; 2]] {
    fn to_caller(&mut self, units: Conversion) {
        caller_points(units, self);
    }
}

impl CallerPoints for [Trajectory] {
    fn to_caller(&mut self, units: Conversion) {
        for t in self {
            caller_points(units, t);
        }
    }
}

/// Model positions into the caller's unit, in place (`y / f`; nothing for
/// the identity).
fn caller_points(units: Conversion, points: &mut [[f32; 2]]) {
    if units.is_identity() {
        return;
    }
    let f = units.factor();
    for p in points {
        for v in p {
            *v /= f;
        }
    }
}
