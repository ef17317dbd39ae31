//! # gpecnet-core
//!
//! G-PECNet pedestrian endpoint prediction for microcontrollers: `#![no_std]`,
//! no heap, no `unsafe`, no panics on any input or blob bytes.
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
//! let model = Model::from_blob(blob)?;                 // validates magic, CRC, shapes, weights
//! let mut p = Predictor::<LibmSine, 128>::new(&model)?; // 128 = scratch width (stack/static)
//! let past = [[512.0, 300.0], [514.0, 301.0], [516.5, 302.0], [519.0, 303.5],
//!             [521.0, 304.5], [523.5, 305.0], [526.0, 306.0], [528.0, 307.5]];
//! let endpoints = p.predict_endpoints::<20>(&past, /* seed */ 1, /* k */ 20)?;
//! for e in &endpoints {
//!     // pixel (or metre) coordinates, same frame as `past`
//!     let _ = (e[0], e[1]);
//! }
//! # Ok(()) }
//! ```
//!
//! ## Modules
//! - [`blob`]: the weight-blob reader (format: `weights/FORMAT.md`) and [`Model`].
//! - [`predictor`]: the inference path and its exact arithmetic order.
//! - [`prng`]: the specified latent sampler (SplitMix64 → xoshiro128++ → Box–Muller).
//! - [`sine`]: reference (`libm`), fast fixed-order f32, and micromath sines.
//! - [`math`]: fixed-order single-precision `sin`/`ln` used by the above.
//! - [`golden`]: golden-vector sidecar files for bit-exact verification.
//!
//! ## Features
//! - `defmt`: `defmt::Format` on public types, for logging on a device.
//! - `micromath`: `sine::MicromathSine`, micromath's approximate sine.
//!
//! ## Resource use
//! `Model` is a ~500-byte view. `Predictor<S, W>` holds `20·W` bytes of
//! scratch (the widest layer must fit in `W`). See [`predictor`] for stack use.
#![no_std]
#![forbid(unsafe_code)]
#![deny(missing_docs)]
// No panicking helpers in library code; slice indexing is used only where
// validation at load time proves the bounds (see `blob::validate`).
#![cfg_attr(
    not(test),
    deny(clippy::unwrap_used, clippy::expect_used, clippy::panic)
)]

pub mod blob;
pub mod cluster;
pub mod fixed;
pub mod frame;
pub mod golden;
pub mod math;
pub mod predictor;
pub mod prng;
pub mod sampling;
pub mod sine;

pub use blob::{Activation, BlobError, Model, ModelConfig, NumericKind};
pub use fixed::FixedPredictor;
pub use predictor::{PredictError, Predictor, Trajectory};
pub use sine::{FastSine, LibmSine, Sine};

/// Either error a caller of this crate can meet.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Error {
    /// The blob was rejected.
    Blob(BlobError),
    /// A prediction was refused.
    Predict(PredictError),
}

impl From<BlobError> for Error {
    fn from(e: BlobError) -> Self {
        Error::Blob(e)
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
        }
    }
}

impl core::error::Error for Error {}
