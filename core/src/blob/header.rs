//! The values before the networks (magic, format version, numeric kind,
//! name, hyper-parameters, version-2 extensions, version-4 description), the
//! trailing CRC-32 and the postcard helper every part of the reader uses.

use serde::{Deserialize, Serialize};

use super::BlobError;

/// The four bytes every blob starts with.
pub const MAGIC: [u8; 4] = *b"GPEC";
/// The newest format version this reader understands (it also reads versions 1 to 4).
///
/// Version 2 adds [`Extensions`] after [`ModelInfo`] and a fifth network, the
/// point-forecast head, after the predictor. Version 3 keeps version 2's
/// values and puts a padding byte string before every weight and bias
/// tensor so that the tensor's first byte lies at a multiple of
/// [`TENSOR_ALIGN`](super::TENSOR_ALIGN) from the blob's start (the word
/// loads of the Cortex-M kernels' fast paths). Version 4 adds [`Meta`] after
/// the extensions: the unit of positions, the sample period, the training
/// data and its licence. The writer emits version 4 when it is given a
/// [`Meta`] and version 3 otherwise. Version 5 adds a learned latent
/// proposal: its latent bound after [`Meta`] and a sixth network after the
/// point-forecast head; the writer emits it only for a model that has one.
/// Version 6 adds endpoint probabilities and radii: two f32 radius
/// multipliers after the latent bound, and `K` logit rows after the `K·zdim`
/// latent rows of the proposal's last layer; the writer emits it only for a
/// model that has them.
pub const FORMAT_VERSION: u16 = 6;
/// The first format version that may carry endpoint probabilities and radii.
pub const SCORE_FORMAT_VERSION: u16 = 6;
/// The first format version that may carry a latent proposal network.
pub const PROPOSAL_FORMAT_VERSION: u16 = 5;
/// Most latents a proposal may give per prediction (the endpoints it returns).
pub const MAX_PROPOSAL_LATENTS: usize = 64;
/// The first format version that describes its unit, clock and data ([`Meta`]).
pub const META_FORMAT_VERSION: u16 = 4;
/// Longest [`Meta::data`] or [`Meta::licence`] text (bytes).
pub const MAX_META_TEXT: usize = 512;
/// The first format version whose tensors are aligned (padding before each
/// weight and bias tensor).
pub const ALIGNED_FORMAT_VERSION: u16 = 3;
/// The oldest format version this reader understands.
pub const MIN_FORMAT_VERSION: u16 = 1;
/// Most layers one network may have.
pub const MAX_LAYERS: usize = 8;
/// Longest observed history a model may take (steps).
pub const MAX_PAST: usize = 16;
/// Longest predicted future a model may produce (steps).
pub const MAX_FUTURE: usize = 32;
/// Most test-time samples ([`Extensions::tts_samples`]) a blob may ask for.
pub const MAX_TTS_SAMPLES: usize = 1024;
#[doc(hidden)]
/// The checksum: CRC-32/ISO-HDLC (the zlib/PNG/Ethernet CRC).
pub const CRC32: crc::Crc<u32> = crc::Crc::<u32>::new(&crc::CRC_32_ISO_HDLC);

/// How weights are stored.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum NumericKind {
    /// IEEE-754 binary32, little endian, 4 bytes per value.
    F32,
    /// Fixed point (`crate::fixed`): int16 weights with a power-of-two scale
    /// per output channel, int32 biases, Q-format 16-bit activations, pure
    /// integer inference. Layers are [`LayerWireQ`](super::LayerWireQ) instead of [`LayerWire`](super::LayerWire).
    Int16Q15,
}

/// A layer's activation.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Activation {
    /// `y = W x + b`.
    Linear,
    /// `y = max(W x + b, 0)` (NaN passes through).
    Relu,
    /// `y = sin(W x + b)`: SIREN's `sin(w0 (W x + b))` with `w0` folded into `W` and `b`.
    Sine,
}

#[doc(hidden)]
/// First value of a blob.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Preamble {
    /// [`MAGIC`].
    pub magic: [u8; 4],
    /// [`FORMAT_VERSION`].
    pub version: u16,
}

/// Model hyper-parameters that inference needs, as stored in the blob.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ModelConfig {
    /// Observed steps (8 for the benchmarks).
    pub past_len: u8,
    /// Predicted steps (12 for the benchmarks); the endpoint is the last.
    pub future_len: u8,
    /// Width of the past-trajectory features.
    pub fdim: u16,
    /// Width of the latent.
    pub zdim: u16,
    /// Multiplier applied to origin-shifted coordinates (PECNet: 1.86).
    pub data_scale: f32,
    /// Standard deviation of the latent at inference (PECNet: 1.3).
    pub sigma: f32,
    /// `initial_pos = last observed position / initial_pos_divisor` (PECNet: 1000).
    pub initial_pos_divisor: f32,
    /// SIREN frequency used in training, already folded into the weights (informational).
    pub w0: f32,
    /// The model's hidden activation (informational; each layer carries its own).
    pub hidden_activation: Activation,
}

#[doc(hidden)]
/// Everything after the preamble and before the networks.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ModelInfo<'a> {
    /// How the weights are stored.
    pub numeric: NumericKind,
    /// Human-readable model name (e.g. `sdd-small`).
    pub name: &'a str,
    /// Hyper-parameters.
    pub config: ModelConfig,
}

/// Version-2 settings, between [`ModelInfo`] and the networks (absent in version 1,
/// where every field reads as 0).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Extensions {
    /// Heading-canonical frame ([`crate::frame`]): 0 = raw orientation; `m` in
    /// `1..past_len` = rotate by the displacement over the last `m` observed steps.
    pub heading_steps: u8,
    /// Test-time sampling ([`crate::cluster`]): 0 = the `K` endpoints are `K`
    /// latent samples; `N > 0` = draw `N` samples and reduce them to `K` by k-means.
    pub tts_samples: u16,
    /// Lloyd iterations of that k-means.
    pub tts_iters: u8,
    /// Its initialisation: 0 = the first `K` samples, 1 = farthest-point.
    pub tts_init: u8,
}

/// The unit of the positions a model takes and returns.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum PositionUnit {
    /// Not recorded: every blob before format version 4 reads as this. The
    /// shipped SDD models of those versions are in SDD image pixels.
    Unknown,
    /// Metres in a ground-plane world frame.
    Metre,
    /// Image pixels ([`Meta::metres_per_pixel`] gives the scale when one
    /// scale applies to every scene, else it is 0).
    Pixel,
}

impl PositionUnit {
    /// Short suffix for printing: `"m"`, `"px"` or `"?"`.
    pub fn suffix(self) -> &'static str {
        match self {
            PositionUnit::Unknown => "?",
            PositionUnit::Metre => "m",
            PositionUnit::Pixel => "px",
        }
    }
}

/// Version-4 description of what a model's numbers mean, between
/// [`Extensions`] and the networks. Blobs before version 4 read as
/// [`Meta::UNKNOWN`].
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Meta<'a> {
    /// Unit of every position in and out.
    pub unit: PositionUnit,
    /// For [`PositionUnit::Pixel`]: metres per pixel when one scale applies
    /// (finite, > 0), else 0. Always 0 for the other units.
    pub metres_per_pixel: f32,
    /// Seconds between consecutive positions of the history and of the
    /// forecast (0.4 for the benchmarks); finite and > 0 in version 4, 0 when
    /// unknown (older versions).
    pub period_s: f32,
    /// The training data in words (data sets, scenes), UTF-8, at most
    /// [`MAX_META_TEXT`] bytes.
    pub data: &'a str,
    /// The licence(s) of that data (e.g. `CC BY-NC-SA 3.0` for SDD), at most
    /// [`MAX_META_TEXT`] bytes; empty when none is stated.
    pub licence: &'a str,
}

impl Meta<'static> {
    /// What a blob before format version 4 says: nothing.
    pub const UNKNOWN: Meta<'static> = Meta {
        unit: PositionUnit::Unknown,
        metres_per_pixel: 0.0,
        period_s: 0.0,
        data: "",
        licence: "",
    };
}

fn map_postcard(e: postcard::Error) -> BlobError {
    match e {
        postcard::Error::DeserializeUnexpectedEnd => BlobError::Truncated,
        _ => BlobError::Malformed,
    }
}

pub(super) fn take<'a, T: Deserialize<'a>>(bytes: &mut &'a [u8]) -> Result<T, BlobError> {
    let (v, rest) = postcard::take_from_bytes::<T>(bytes).map_err(map_postcard)?;
    *bytes = rest;
    Ok(v)
}
