//! # gpecnet-core
//!
//! G-PECNet pedestrian endpoint prediction for microcontrollers: `#![no_std]`,
//! no heap, no panics on any input or blob bytes; `unsafe` only in one private
//! module of target kernels (Cortex-M4/M7 inline assembly, the x86-64 AVX2
//! dispatch; see below).
//!
//! G-PECNet (Garg & Rameshan, ICLR 2024 tiny paper) is PECNet (Mangalam et
//! al., ECCV 2020) with its ReLUs replaced by SIREN sines. Given the last 8
//! observed positions of a pedestrian (0.4 s apart) it samples `K` plausible
//! positions 4.8 s ahead (the endpoint), and optionally the 11 points in
//! between. This crate is the inference half: the trainer (`gpecnet-trainer`)
//! exports weight blobs that this crate reads **in place** — a blob linked
//! into flash with `include_bytes!` is never copied into RAM.
//!
//! ```
//! # fn demo(blob: &'static [u8]) -> Result<(), gpecnet_core::Error> {
//! use gpecnet_core::{LibmSine, Model, Predictor};
//!
//! let model = Model::from_blob(blob)?;    // validates magic, CRC, shapes, weights
//! // Any valid blob, f32 or fixed point; 128 = scratch width (>= model.scratch_width()).
//! let mut p = Predictor::<LibmSine, 128>::new(model)?;
//! let past = [[512.0, 300.0], [514.0, 301.0], [516.5, 302.0], [519.0, 303.5],
//!             [521.0, 304.5], [523.5, 305.0], [526.0, 306.0], [528.0, 307.5]];
//! if p.model().has_point_head() {
//!     let forecast = p.predict_point(&past)?;         // the single best guess
//!     let _endpoint = forecast.last();
//! }
//! let mut ends = [[0.0f32; 2]; 20];                  // caller-owned output
//! p.predict_endpoint_set::<128>(&past, /* seed */ 1, &mut ends)?;
//! for e in &ends {
//!     let _ = (e[0], e[1]);                           // same units and frame as `past`
//! }
//! # Ok(()) }
//! ```
//!
//! A cooperative (async) task can yield between samples:
//! [`Predictor::start`] encodes the track once, each
//! [`Predictor::next_endpoint`] draws one sample, and
//! [`sampling::reduce`] turns the drawn samples into the model's endpoint set
//! (`core/examples/embassy_task.rs`).
//!
//! ## What an integrator uses
//! - [`Model`] (validate a blob once), [`Predictor`] (any blob, kind chosen at
//!   run time; owns its model view, so it can live in a `static`),
//!   [`Trajectory`], the errors [`Error`] = [`BlobError`] | [`PredictError`],
//!   and a [`Sine`] for f32 blobs ([`LibmSine`] is the reference the shipped
//!   golden files use; [`FastSine`] is 5–10× cheaper on an FPU and
//!   bit-reproducible, but not bit-identical to `LibmSine`).
//! - [`units`]: [`Predictor::with_units`] checks the caller's declared unit
//!   (metres, pixels, pixels of a known ground scale) against the model's
//!   ([`Model::unit`], [`Model::period_s`]) and converts exactly.
//! - [`tracks`]: fixed-capacity, id-keyed track tables that turn detections
//!   into the 8-step histories a prediction needs: `TimedTrackTable` takes
//!   timestamped detections at any camera rate and resamples them onto the
//!   model's period; `TrackTable` takes frames already at that period.
//! - [`Engine`] with [`float::Float`] or [`fixed::Q15`]: one backend only,
//!   when the kind is known at build time (less flash).
//! - On a host: [`batch::BatchPredictor`] (the same bits as [`Predictor`],
//!   several times faster: samples and tracks side by side, one weight read
//!   per `L` samples; ~100 KiB, box it).
//! - Limits: [`frame::MAX_COORDINATE`], [`Model::input_limit`],
//!   [`Model::scratch_width`], [`blob::MAX_PAST`], [`blob::MAX_FUTURE`],
//!   [`sampling::samples_needed`].
//!
//! ## Modules
//! - [`blob`]: the weight-blob reader (format: `weights/FORMAT.md`) and [`Model`].
//! - [`camera`]: image detections of a moving, gimballed camera → ground points (NED metres) and back.
//! - [`predictor`]: [`Predictor`], run-time dispatch over the one engine.
//! - [`engine`]: the computation, step by step, generic over a numeric backend.
//! - [`batch`]: the same computation for `L` samples (of one or many tracks)
//!   side by side, bit-identical, for hosts.
//! - [`float`], [`fixed`]: the f32 and the integer (Q15) backends.
//! - [`frame`]: input guards and the coordinate frame the networks see.
//! - [`sampling`]: the blob's endpoint protocol (plain or test-time sampling).
//! - [`sine`]: reference (`libm`), fast fixed-order f32, and micromath sines.
//! - [`units`]: the caller's unit against the model's, and the conversion.
//! - [`tracks`]: track tables (detections → histories; `tracks::timed` at any camera rate).
//!
//! Hidden from the documentation (used by the trainer, the tests and the
//! firmware; not part of the semver surface, see `tests/public-api.txt`):
//! `cluster`, `golden`, `math`, `prng`, the blob's wire structs and the
//! fixed-point quantisation helpers.
//!
//! ## `unsafe`
//! The crate is `#![deny(unsafe_code)]`; the one exception is the private
//! `kernels` module (`#[allow(unsafe_code)]`), one submodule per target,
//! each block with a `SAFETY:` note: on
//! `cfg(all(target_arch = "arm", target_feature = "dsp"))` (`thumbv7em`)
//! the dense layers' inner loops in inline assembly (`SMLALD` for Q15,
//! `VMLA.F32` for f32, `docs/kernels.md`); on x86-64 the CPUID check and
//! the call into the batched f32 lanes compiled with AVX2
//! ([`batch::set_wide_vectors`], `docs/host-speed.md`); with the
//! `softfloat` feature on an Arm core without an FPU, the exported `f32`
//! multiply, add and subtract (`__aeabi_fmul`, `__aeabi_fadd`,
//! `__aeabi_fsub`) and their calls into compiler-builtins. Every target keeps
//! the portable loops of [`fixed`], [`float`] and the lanes, which are the
//! reference; both give the same bits.
//!
//! ## Features
//! - `defmt`: `defmt::Format` on public types, for logging on a device.
//! - `micromath`: `sine::MicromathSine`, micromath's approximate sine.
//! - `signed`: Ed25519 verification of signed blobs (`Model::from_signed_blob`).
//! - `softfloat`: on a core without an FPU (Cortex-M0/M0+, `thumbv6m`), a
//!   faster `f32` multiply, add and subtract, bit-exact with
//!   compiler-builtins' (which stay for zeros, subnormals, infinities and NaN):
//!   15 % fewer instructions in the Cortex-M0's f32 golden replay
//!   (`docs/kernels.md`). Off by default: it defines the `__aeabi_*` symbols,
//!   which a program may define itself.
//!
//! ## Resource use
//! `Model` is a ~1.5 KiB view (the weights stay in the blob).
//! `Predictor<S, W>` is `20·W` bytes of scratch plus the model view
//! (4,128 B for `W = 128` on a Cortex-M4F); a call uses under 3.1 KiB of stack
//! with a 128-sample buffer (`cargo xtask profile` measures both; see
//! [`engine`]).
#![no_std]
// `unsafe` only in the private `kernels` module (Cortex-M4/M7 inline
// assembly, the x86-64 AVX2 dispatch, the soft-float exports), allowed there alone.
#![deny(unsafe_code)]
#![deny(missing_docs)]
// No panicking helpers in library code; slice indexing is used only where
// validation at load time proves the bounds (see `blob::validate`).
#![cfg_attr(
    not(test),
    deny(clippy::unwrap_used, clippy::expect_used, clippy::panic)
)]

pub mod backend;
pub mod batch;
pub mod blob;
pub mod camera;
#[doc(hidden)]
pub mod cluster;
pub mod engine;
pub mod fixed;
pub mod float;
pub mod frame;
#[doc(hidden)]
pub mod golden;
#[allow(unsafe_code)]
mod kernels;
mod lanes;
#[doc(hidden)]
pub mod math;
pub mod online;
pub mod output;
pub mod planner;
pub mod predictor;
#[doc(hidden)]
pub mod prng;
pub mod sampling;
pub mod sine;
pub mod tracks;
pub mod units;

pub use blob::{Activation, BlobError, Model, ModelConfig, NumericKind};
pub use engine::Engine;
pub use predictor::{PredictError, Predictor, Trajectory};
pub use sine::{FastSine, LibmSine, Sine};

/// Either error a caller of this crate can meet.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum Error {
    /// The blob was rejected.
    Blob(BlobError),
    /// A prediction was refused.
    Predict(PredictError),
    /// The caller's unit cannot be used with the model ([`units`]).
    Unit(units::UnitError),
}

impl From<BlobError> for Error {
    fn from(e: BlobError) -> Self {
        Error::Blob(e)
    }
}

impl From<units::UnitError> for Error {
    fn from(e: units::UnitError) -> Self {
        Error::Unit(e)
    }
}

impl From<PredictError> for Error {
    fn from(e: PredictError) -> Self {
        Error::Predict(e)
    }
}

impl core::fmt::Display for Error {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Error::Blob(e) => write!(f, "{e}"),
            Error::Predict(e) => write!(f, "{e}"),
            Error::Unit(e) => write!(f, "{e}"),
        }
    }
}

impl core::error::Error for Error {}
