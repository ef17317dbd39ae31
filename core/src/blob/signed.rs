//! Signed blobs: an Ed25519 signature (RFC 8032, PureEdDSA) over a whole
//! blob, a key id and a monotonic model version, so a flight computer runs
//! only weights it was told to trust and never an older release.
//!
//! A signed blob is a complete blob of any format version, unchanged, then
//! an 82-byte trailer (`weights/FORMAT.md`, "Signed blobs"):
//!
//! ```text
//! offset  size  field
//!      0     4  magic "GSIG"
//!      4     2  trailer version, u16 LE = 1
//!      6     8  key id: the first 8 bytes of the signer's Ed25519 public key
//!     14     4  model_version, u32 LE (monotonic per product)
//!     18    64  Ed25519 signature over every byte before it (the blob, then
//!               trailer bytes 0..18)
//! ```
//!
//! [`Model::from_blob`](crate::Model::from_blob) reads the blob of a signed blob and ignores the
//! trailer (the golden replay and the host tools work on signed and unsigned
//! blobs alike; the blob's CRC, and so every prediction, is unchanged by
//! signing). With the cargo feature `signed`, [`Model::from_signed_blob`](crate::Model::from_signed_blob)
//! accepts a blob only when its signature verifies under one of the trusted
//! keys and its version is at least the caller's minimum, in this order of
//! checks: trailer present ([`SignError::UnsignedBlob`]), trailer version
//! ([`SignError::BadTrailer`]), key id ([`SignError::UnknownKey`]), the
//! signature ([`SignError::BadSignature`], by `ed25519-dalek`'s
//! `verify_strict`: no weak keys, canonical encodings), the version
//! ([`SignError::RolledBack`]), and last the blob itself
//! ([`SignError::Blob`]). Nothing of an unauthenticated blob is parsed.

use core::fmt;

use super::BlobError;

/// The trailer's first bytes.
pub const SIGNATURE_MAGIC: [u8; 4] = *b"GSIG";
/// The trailer version this reader knows.
pub const SIGNATURE_VERSION: u16 = 1;
/// Bytes of the trailer.
pub const TRAILER_LEN: usize = 82;
/// Bytes of the trailer the signature covers (all but the signature).
pub const SIGNED_TRAILER_LEN: usize = 18;

/// The trailer of a signed blob.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Trailer {
    /// Trailer version (1).
    pub version: u16,
    /// The first 8 bytes of the signer's public key.
    pub key_id: [u8; 8],
    /// The model's release number.
    pub model_version: u32,
    /// The Ed25519 signature.
    pub signature: [u8; 64],
}

/// A signed blob's parts: the blob, the signed message (blob and trailer
/// head) and the trailer; `None` when `bytes` do not end in a trailer.
pub fn split(bytes: &[u8]) -> Option<(&[u8], &[u8], Trailer)> {
    let start = bytes.len().checked_sub(TRAILER_LEN)?;
    let (blob, t) = bytes.split_at(start);
    let (head, signature) = t.split_at(SIGNED_TRAILER_LEN);
    let (magic, rest) = head.split_at(4);
    if magic != SIGNATURE_MAGIC {
        return None;
    }
    let message = bytes.get(..start + SIGNED_TRAILER_LEN)?;
    let le16 = |b: &[u8]| b.try_into().map(u16::from_le_bytes).ok();
    let le32 = |b: &[u8]| b.try_into().map(u32::from_le_bytes).ok();
    Some((
        blob,
        message,
        Trailer {
            version: le16(rest.get(..2)?)?,
            key_id: rest.get(2..10)?.try_into().ok()?,
            model_version: le32(rest.get(10..14)?)?,
            signature: signature.try_into().ok()?,
        },
    ))
}

/// The trailer head (bytes 0..18) for `key_id` and `model_version`: what a
/// signer appends to the blob before signing blob ‖ head.
pub fn trailer_head(key_id: [u8; 8], model_version: u32) -> [u8; SIGNED_TRAILER_LEN] {
    let mut h = [0u8; SIGNED_TRAILER_LEN];
    for (o, b) in h.iter_mut().zip(
        SIGNATURE_MAGIC
            .iter()
            .chain(&SIGNATURE_VERSION.to_le_bytes())
            .chain(&key_id)
            .chain(&model_version.to_le_bytes()),
    ) {
        *o = *b;
    }
    h
}

/// A public key the caller trusts, with its id (the key's first 8 bytes).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct TrustedKey {
    /// The Ed25519 public key (32 bytes, RFC 8032 encoding).
    pub public_key: [u8; 32],
}

impl TrustedKey {
    /// The key `public_key`.
    pub const fn new(public_key: [u8; 32]) -> Self {
        TrustedKey { public_key }
    }

    /// Its id: the first 8 bytes of the public key.
    pub fn id(&self) -> [u8; 8] {
        let mut id = [0u8; 8];
        id.copy_from_slice(&self.public_key[..8]);
        id
    }
}

/// Why a signed blob was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum SignError {
    /// The bytes do not end in a signature trailer.
    UnsignedBlob,
    /// The trailer's version is not one this reader knows.
    BadTrailer,
    /// No trusted key has the trailer's key id.
    UnknownKey,
    /// The signature does not verify under the trusted key (a changed
    /// byte anywhere, or a forgery), or the key is weak or non-canonical.
    BadSignature,
    /// The blob's version is below the minimum the caller accepts.
    RolledBack {
        /// The blob's `model_version`.
        have: u32,
        /// The caller's minimum.
        min: u32,
    },
    /// The signature verified but the blob inside is not valid.
    Blob(BlobError),
}

impl fmt::Display for SignError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SignError::UnsignedBlob => f.write_str("the blob is not signed"),
            SignError::BadTrailer => f.write_str("unknown signature trailer version"),
            SignError::UnknownKey => f.write_str("signed by a key that is not trusted"),
            SignError::BadSignature => f.write_str("the signature does not verify"),
            SignError::RolledBack { have, min } => {
                write!(f, "model version {have} is older than the minimum {min}")
            }
            SignError::Blob(e) => write!(f, "signed, but the blob is invalid: {e}"),
        }
    }
}

impl core::error::Error for SignError {}

impl From<BlobError> for SignError {
    fn from(e: BlobError) -> Self {
        SignError::Blob(e)
    }
}

/// RFC 8032 PureEdDSA verification of `signature` on `message` under
/// `public_key` (`ed25519-dalek`'s `verify_strict`).
#[cfg(feature = "signed")]
pub fn verify(
    public_key: &[u8; 32],
    message: &[u8],
    signature: &[u8; 64],
) -> Result<(), SignError> {
    let key =
        ed25519_dalek::VerifyingKey::from_bytes(public_key).map_err(|_| SignError::BadSignature)?;
    let sig = ed25519_dalek::Signature::from_bytes(signature);
    key.verify_strict(message, &sig)
        .map_err(|_| SignError::BadSignature)
}

/// The checks of [`Model::from_signed_blob`](super::Model::from_signed_blob)
/// before the blob is parsed: the blob's bytes and its version.
#[cfg(feature = "signed")]
pub(crate) fn authenticate<'a>(
    bytes: &'a [u8],
    keys: &[TrustedKey],
    min_version: u32,
) -> Result<(&'a [u8], u32), SignError> {
    let (blob, message, t) = split(bytes).ok_or(SignError::UnsignedBlob)?;
    if t.version != SIGNATURE_VERSION {
        return Err(SignError::BadTrailer);
    }
    let key = keys
        .iter()
        .find(|k| k.id() == t.key_id)
        .ok_or(SignError::UnknownKey)?;
    verify(&key.public_key, message, &t.signature)?;
    if t.model_version < min_version {
        return Err(SignError::RolledBack {
            have: t.model_version,
            min: min_version,
        });
    }
    Ok((blob, t.model_version))
}
