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
#[doc(hidden)]
pub mod cluster;
pub mod engine;
pub mod fixed;
pub mod float;
pub mod frame;
#[doc(hidden)]
pub mod golden;
#[doc(hidden)]
pub mod math;
pub mod predictor;
#[doc(hidden)]
pub mod prng;
pub mod sampling;
pub mod sine;
pub mod tracks;

pub use blob::{Activation, BlobError, Model, ModelConfig, NumericKind};
pub use engine::Engine;
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
