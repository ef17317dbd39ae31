//! A model pack: several models (name, weight blob, golden file) in one byte
//! area, so one firmware image can replay any set of models. `cargo xtask qemu`
//! links each MCU class's golden image once with an empty area of a fixed size
//! and writes each batch of models into a copy of that image, instead of
//! compiling and linking one image per batch.
//!
//! Layout (every integer a little-endian `u32`; offsets from the pack's first
//! byte, which the firmware places at an 8-byte aligned address):
//!
//! ```text
//! 0    magic  b"GMPK"
//! 4    version  1
//! 8    count  number of models
//! 12   0 (reserved)
//! 16   count entries of 24 bytes:
//!        name offset, name length, blob offset, blob length, golden offset, golden length
//! then the names (UTF-8), the blobs (each at an offset that is a multiple of 8, so
//! a blob's tensors are word aligned as `include_bytes!` into an aligned static
//! would leave them) and the golden files; the rest of the area is zero.
//! ```
//!
//! [`write()`] builds a pack into a caller's buffer (no allocation) and
//! [`ModelPack::parse`] reads one, checking every entry, so a pack that does not
//! hold what it says is an error, never a partial replay.

use crate::EmbeddedModel;

/// The pack's first four bytes.
pub const MAGIC: [u8; 4] = *b"GMPK";
/// The layout version this crate writes and reads.
pub const VERSION: u32 = 1;
/// Bytes before the first entry.
pub const HEADER_LEN: usize = 16;
/// Bytes per entry.
pub const ENTRY_LEN: usize = 24;
/// Most models one pack holds (the replay lists them in one image).
pub const MAX_MODELS: usize = 64;
/// Blob alignment within the pack.
const BLOB_ALIGN: usize = 8;

/// Why a pack could not be written or read.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum PackError {
    /// The first bytes are not [`MAGIC`] (nothing was written into the area).
    BadMagic,
    /// A version this crate does not read.
    BadVersion,
    /// No model, or more than [`MAX_MODELS`].
    BadCount,
    /// An entry's range lies outside the pack, or a blob is not 8-byte aligned.
    BadEntry,
    /// A model name is empty or not UTF-8.
    BadName,
    /// [`write()`]: the models do not fit the buffer.
    TooLarge,
}

impl PackError {
    /// The error as the replay's error line reports it.
    pub fn what(self) -> &'static str {
        match self {
            PackError::BadMagic => "model pack: no pack written into the image (bad magic)",
            PackError::BadVersion => "model pack: unknown layout version",
            PackError::BadCount => "model pack: no model, or too many",
            PackError::BadEntry => "model pack: an entry lies outside the pack or is misaligned",
            PackError::BadName => "model pack: a model name is empty or not UTF-8",
            PackError::TooLarge => "model pack: the models do not fit the area",
        }
    }
}

/// The most bytes one model can take in a pack: its entry, name, blob and golden
/// file, and the padding before its blob. A set of models fits an area of `n`
/// bytes when [`HEADER_LEN`] plus the sum of this over the models is at most `n`.
pub fn max_entry_len(name_len: usize, blob_len: usize, golden_len: usize) -> usize {
    ENTRY_LEN + name_len + (BLOB_ALIGN - 1) + blob_len + golden_len
}

fn put(out: &mut [u8], at: usize, v: u32) {
    out[at..at + 4].copy_from_slice(&v.to_le_bytes());
}

fn get(bytes: &[u8], at: usize) -> Option<u32> {
    let b = bytes.get(at..at.checked_add(4)?)?;
    Some(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
}

/// Writes `models` (name, blob, golden file) as a pack into `out` and zeroes the
/// rest of it; returns the bytes used.
pub fn write(models: &[(&str, &[u8], &[u8])], out: &mut [u8]) -> Result<usize, PackError> {
    if models.is_empty() || models.len() > MAX_MODELS {
        return Err(PackError::BadCount);
    }
    if models.iter().any(|(name, _, _)| name.is_empty()) {
        return Err(PackError::BadName);
    }
    let need = HEADER_LEN
        + models
            .iter()
            .map(|(n, b, g)| max_entry_len(n.len(), b.len(), g.len()))
            .sum::<usize>();
    if need > out.len() || need > u32::MAX as usize {
        return Err(PackError::TooLarge);
    }
    out.fill(0);
    out[..4].copy_from_slice(&MAGIC);
    put(out, 4, VERSION);
    put(out, 8, models.len() as u32);
    let mut at = HEADER_LEN + models.len() * ENTRY_LEN;
    let mut place = |out: &mut [u8], bytes: &[u8], align: usize| {
        at = at.next_multiple_of(align);
        out[at..at + bytes.len()].copy_from_slice(bytes);
        at += bytes.len();
        (at - bytes.len()) as u32
    };
    for (i, (name, blob, golden)) in models.iter().enumerate() {
        let e = HEADER_LEN + i * ENTRY_LEN;
        let name_at = place(out, name.as_bytes(), 1);
        let blob_at = place(out, blob, BLOB_ALIGN);
        let golden_at = place(out, golden, 1);
        for (k, v) in [
            name_at,
            name.len() as u32,
            blob_at,
            blob.len() as u32,
            golden_at,
            golden.len() as u32,
        ]
        .into_iter()
        .enumerate()
        {
            put(out, e + 4 * k, v);
        }
    }
    Ok(at)
}

/// A pack read from a `'static` area (flash), every entry checked.
#[derive(Clone, Copy)]
pub struct ModelPack {
    bytes: &'static [u8],
    count: usize,
}

impl ModelPack {
    /// Reads the pack at the start of `bytes`: its header and every entry.
    pub fn parse(bytes: &'static [u8]) -> Result<ModelPack, PackError> {
        if bytes.get(..4) != Some(&MAGIC[..]) {
            return Err(PackError::BadMagic);
        }
        if get(bytes, 4) != Some(VERSION) {
            return Err(PackError::BadVersion);
        }
        let count = get(bytes, 8).ok_or(PackError::BadCount)? as usize;
        if count == 0 || count > MAX_MODELS {
            return Err(PackError::BadCount);
        }
        let pack = ModelPack { bytes, count };
        for i in 0..count {
            pack.entry(i)?;
        }
        Ok(pack)
    }

    /// Number of models.
    pub fn len(&self) -> usize {
        self.count
    }

    /// Whether the pack holds no model (never, once parsed).
    pub fn is_empty(&self) -> bool {
        self.count == 0
    }

    /// Model `i` (in the order written); `None` past the end.
    pub fn get(&self, i: usize) -> Option<EmbeddedModel> {
        self.entry(i).ok()
    }

    fn entry(&self, i: usize) -> Result<EmbeddedModel, PackError> {
        if i >= self.count {
            return Err(PackError::BadCount);
        }
        let e = HEADER_LEN + i * ENTRY_LEN;
        let field = |k: usize| get(self.bytes, e + 4 * k).map(|v| v as usize);
        let range = |k: usize| -> Result<&'static [u8], PackError> {
            let (at, len) = field(k).zip(field(k + 1)).ok_or(PackError::BadEntry)?;
            let end = at.checked_add(len).ok_or(PackError::BadEntry)?;
            self.bytes.get(at..end).ok_or(PackError::BadEntry)
        };
        let name = core::str::from_utf8(range(0)?).map_err(|_| PackError::BadName)?;
        if name.is_empty() {
            return Err(PackError::BadName);
        }
        let blob = range(2)?;
        if field(2).is_none_or(|at| at % BLOB_ALIGN != 0) {
            return Err(PackError::BadEntry);
        }
        Ok(EmbeddedModel {
            name,
            blob,
            golden: range(4)?,
        })
    }
}
