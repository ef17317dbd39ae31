//! Every way a byte string can fail to be a usable blob.

use super::FORMAT_VERSION;

/// Which network a layer belongs to (used in errors).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum NetworkId {
    /// Past-trajectory encoder: `2·past_len → fdim`.
    EncoderPast,
    /// Endpoint decoder: `fdim + zdim → 2`.
    Decoder,
    /// Endpoint encoder: `2 → ddim` (optional).
    EncoderDest,
    /// Trajectory predictor: `fdim + ddim + 2 → 2·(future_len − 1)` (optional).
    Predictor,
    /// Point-forecast head: `2·past_len → 2·future_len` (optional, format version 2).
    PointHead,
    /// Latent proposal: `fdim → K·zdim` (optional, format version 5).
    Proposal,
}

/// Every way a byte string can fail to be a usable model blob.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum BlobError {
    /// The first four bytes are not `GPEC`.
    BadMagic,
    /// The blob's format version is not [`FORMAT_VERSION`].
    UnsupportedVersion(u16),
    /// The bytes end before the structure does.
    Truncated,
    /// The stored CRC-32 does not match the bytes.
    ChecksumMismatch {
        /// CRC stored in the blob.
        stored: u32,
        /// CRC computed over the blob.
        computed: u32,
    },
    /// A value could not be decoded (bad varint, bad enum tag, invalid UTF-8, ...).
    Malformed,
    /// Bytes left between the last network and the checksum.
    TrailingBytes,
    /// A numeric kind this build cannot run.
    UnsupportedNumeric,
    /// Dimensions or hyper-parameters are inconsistent.
    ShapeMismatch(NetworkId),
    /// A hyper-parameter is out of range (non-positive scale, zero dims, ...).
    BadConfig,
    /// More layers, history or future than this build's capacity.
    ExceedsCapacity,
    /// A weight, bias or hyper-parameter is NaN or infinite.
    NonFinite(NetworkId),
    /// A fixed-point exponent or shift is out of range or does not chain.
    BadScale(NetworkId),
}

impl core::fmt::Display for BlobError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            BlobError::BadMagic => f.write_str("not a gpecnet blob (bad magic)"),
            BlobError::UnsupportedVersion(v) => write!(
                f,
                "unsupported blob format version {v} (this reader: {FORMAT_VERSION})"
            ),
            BlobError::Truncated => f.write_str("blob is truncated"),
            BlobError::ChecksumMismatch { stored, computed } => {
                write!(
                    f,
                    "checksum mismatch: stored {stored:#010x}, computed {computed:#010x}"
                )
            }
            BlobError::Malformed => f.write_str("malformed postcard value in blob"),
            BlobError::TrailingBytes => f.write_str("unexpected bytes before the checksum"),
            BlobError::UnsupportedNumeric => {
                f.write_str("numeric kind not supported by this build")
            }
            BlobError::ShapeMismatch(n) => {
                write!(f, "layer shapes of {n:?} do not match the model config")
            }
            BlobError::BadConfig => f.write_str("model hyper-parameters out of range"),
            BlobError::ExceedsCapacity => {
                f.write_str("model exceeds this build's compile-time capacity")
            }
            BlobError::NonFinite(n) => write!(f, "non-finite value in {n:?}"),
            BlobError::BadScale(n) => write!(f, "fixed-point scales of {n:?} are inconsistent"),
        }
    }
}

impl core::error::Error for BlobError {}
