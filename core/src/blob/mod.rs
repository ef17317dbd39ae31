//! The weight blob: a versioned, checksummed postcard byte string, read in
//! place (zero-copy) from flash. The byte-level layout is specified in
//! `weights/FORMAT.md`; this module is its reference reader.
//!
//! A blob is a sequence of postcard values followed by a CRC-32:
//!
//! ```text
//! Preamble { magic: [u8; 4] = "GPEC", version: u16 }
//! ModelInfo { numeric: NumericKind, name: &str, config: ModelConfig }
//! Extensions (version 2 on), Meta { unit, metres_per_pixel, period_s, data, licence } (version 4 on)
//! latent_bound: f32 (version 5 on)
//! radius_scales: [f32; 2] (version 6 on: r50 and r90 multipliers, both 0 without probabilities)
//! Network × 4  (encoder_past, decoder, encoder_dest, predictor; point_head from
//!     version 2, proposal from version 5), each:
//!     n_layers: u8, then n_layers × LayerWire { in_dim: u16, out_dim: u16,
//!         activation: Activation, weights: &[u8], bias: &[u8] }
//!     (or, for NumericKind::Int16Q15, LayerWireQ { in_dim, out_dim, activation,
//!         in_exp: i8, out_exp: i8, weights: &[u8], bias: &[u8], shifts: &[u8] })
//! crc32: 4 bytes, little endian, CRC-32/ISO-HDLC of every preceding byte
//! ```
//!
//! [`Model::from_blob`] accepts any byte string and returns either a
//! validated [`Model`] or a [`BlobError`]: it never panics and never reads
//! out of bounds (see `core/tests/blob_corruption.rs`, which flips every bit
//! and tries every truncation of a real blob, and `fuzz/`).
//!
//! ```
//! use gpecnet_core::{BlobError, Model};
//! assert_eq!(Model::from_blob(b"not a blob").unwrap_err(), BlobError::BadMagic);
//! assert_eq!(Model::from_blob(b"GP").unwrap_err(), BlobError::Truncated);
//! ```

//!
//! The reader is split by job: `header.rs` (magic, version, CRC, the values
//! before the networks), `layer.rs` (the wire layers and the validated
//! [`Layer`] view of one layer's tensors), `model.rs` ([`Network`], [`Model`]
//! and the body parser), `validate.rs` (shape, finiteness and fixed-point
//! scale rules) and `error.rs` ([`BlobError`], [`NetworkId`]).

mod error;
mod header;
mod layer;
mod model;
pub mod signed;
mod validate;

pub use error::{BlobError, NetworkId};
pub use header::{
    Activation, Extensions, Meta, ModelConfig, NumericKind, PositionUnit, ALIGNED_FORMAT_VERSION,
    FORMAT_VERSION, MAGIC, MAX_FUTURE, MAX_LAYERS, MAX_META_TEXT, MAX_PAST, MAX_PROPOSAL_LATENTS,
    MAX_TTS_SAMPLES, META_FORMAT_VERSION, MIN_FORMAT_VERSION, PROPOSAL_FORMAT_VERSION,
    SCORE_FORMAT_VERSION,
};
#[doc(hidden)]
pub use header::{ModelInfo, Preamble, CRC32};
pub(crate) use layer::read_f32;
#[doc(hidden)]
pub use layer::{pow2, LayerWire, LayerWireQ, AFFINE_SHIFTS, MAX_EXP, MIN_EXP, SINE_SHIFTS};
pub use layer::{Layer, TENSOR_ALIGN};
pub use model::{Model, Network};
