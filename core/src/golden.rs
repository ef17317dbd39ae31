//! Golden vectors: the trainer's outputs for recorded inputs, as exact bit
//! patterns, in a sidecar file `weights/<model>.golden` next to each blob.
//!
//! The firmware and the host tests replay every case through this crate and
//! require identical bits. Layout (postcard values, like the blob):
//!
//! ```text
//! GoldenPreamble { magic: [u8; 4] = "GPGV", version: u16 = 1 }
//! GoldenInfo { model_name: &str, model_crc: u32, sine: &str, past_len: u8,
//!              future_len: u8, k: u8, n_cases: u32 }
//! n_cases × GoldenCaseWire { past: &[u8], seed: u64, endpoints: &[u8], trajectory0: &[u8] }
//! crc32: 4 bytes LE over everything before it
//! ```
//!
//! `past` holds `past_len` (x, y) f32 pairs, `endpoints` `k` pairs,
//! `trajectory0` either nothing or `future_len` pairs (sample 0's full
//! trajectory), all little endian.
//!
//! Version 2 (written for models with a point-forecast head) appends one field
//! to every case, `point: &[u8]`: nothing, or the point forecast's
//! `future_len` pairs ([`GoldenCaseWireV2`]). For a model with test-time
//! sampling, `endpoints` are the `k` reduced endpoints (the blob's protocol).

use serde::{Deserialize, Serialize};

use crate::blob::{read_f32, BlobError, CRC32, MAX_FUTURE, MAX_PAST};

/// First four bytes of a golden file.
pub const GOLDEN_MAGIC: [u8; 4] = *b"GPGV";
/// Golden format version of files without point forecasts (still written for them).
pub const GOLDEN_VERSION: u16 = 1;
/// Golden format version with a point forecast per case.
pub const GOLDEN_VERSION_POINT: u16 = 2;

/// First value of a golden file.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct GoldenPreamble {
    /// [`GOLDEN_MAGIC`].
    pub magic: [u8; 4],
    /// [`GOLDEN_VERSION`].
    pub version: u16,
}

/// What the cases were produced with.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct GoldenInfo<'a> {
    /// The model's name.
    pub model_name: &'a str,
    /// CRC-32 of the model blob the outputs belong to ([`crate::Model::crc`]).
    pub model_crc: u32,
    /// The [`crate::sine::Sine::NAME`] used.
    pub sine: &'a str,
    /// Observed steps per case.
    pub past_len: u8,
    /// Steps per trajectory.
    pub future_len: u8,
    /// Endpoints per case.
    pub k: u8,
    /// Number of cases.
    pub n_cases: u32,
}

/// One case on the wire.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct GoldenCaseWire<'a> {
    /// Observed positions, f32 LE pairs.
    pub past: &'a [u8],
    /// Latent seed.
    pub seed: u64,
    /// Expected endpoints, f32 LE pairs.
    pub endpoints: &'a [u8],
    /// Expected trajectory of sample 0, f32 LE pairs, or empty.
    pub trajectory0: &'a [u8],
}

/// One case on the wire, format version 2: a [`GoldenCaseWire`] followed by the point
/// forecast. postcard writes a nested struct as its fields in order, so the bytes are the
/// version 1 case's fields, then `point`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct GoldenCaseWireV2<'a> {
    /// The version 1 fields: past, seed, endpoints, trajectory of sample 0.
    #[serde(borrow)]
    pub case: GoldenCaseWire<'a>,
    /// Expected point forecast, f32 LE pairs, or empty.
    pub point: &'a [u8],
}

impl<'a> From<GoldenCaseWire<'a>> for GoldenCaseWireV2<'a> {
    fn from(case: GoldenCaseWire<'a>) -> Self {
        GoldenCaseWireV2 { case, point: &[] }
    }
}

/// Reads the next case of a file of `version`.
fn take_case<'a>(bytes: &mut &'a [u8], version: u16) -> Result<GoldenCaseWireV2<'a>, BlobError> {
    if version >= GOLDEN_VERSION_POINT {
        take(bytes)
    } else {
        take::<GoldenCaseWire>(bytes).map(Into::into)
    }
}

/// A decoded case.
#[derive(Clone, Debug, PartialEq)]
pub struct GoldenCase<'a> {
    /// Observed positions.
    pub past: heapless::Vec<[f32; 2], MAX_PAST>,
    /// Latent seed.
    pub seed: u64,
    endpoints: &'a [u8],
    trajectory0: &'a [u8],
    point: &'a [u8],
}

impl GoldenCase<'_> {
    /// Expected point `t` of the point forecast, if recorded.
    pub fn point_bits(&self, t: usize) -> Option<[u32; 2]> {
        recorded_pair(self.point, t)
    }
    /// Number of recorded point-forecast points (0 when none).
    pub fn point_len(&self) -> usize {
        self.point.len() / 8
    }
    /// Number of expected endpoints.
    pub fn k(&self) -> usize {
        self.endpoints.len() / 8
    }
    /// Expected endpoint `i` as bit patterns.
    pub fn endpoint_bits(&self, i: usize) -> [u32; 2] {
        pair_bits(self.endpoints, i)
    }
    /// Expected point `t` of sample 0's trajectory, if recorded.
    pub fn trajectory0_bits(&self, t: usize) -> Option<[u32; 2]> {
        recorded_pair(self.trajectory0, t)
    }
    /// Number of recorded trajectory points (0 when none).
    pub fn trajectory0_len(&self) -> usize {
        self.trajectory0.len() / 8
    }
}

/// Point `i` of a packed array of `[x, y]` f32 LE pairs as bit patterns
/// (`[0, 0]` past its end, like [`read_f32`]).
fn pair_bits(points: &[u8], i: usize) -> [u32; 2] {
    [
        read_f32(points, 2 * i).to_bits(),
        read_f32(points, 2 * i + 1).to_bits(),
    ]
}

/// [`pair_bits`] of point `t`, or `None` when the array does not hold it.
fn recorded_pair(points: &[u8], t: usize) -> Option<[u32; 2]> {
    (8 * t + 8 <= points.len()).then(|| pair_bits(points, t))
}

/// A validated golden file.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct GoldenSet<'a> {
    info: GoldenInfo<'a>,
    version: u16,
    cases: &'a [u8],
}

fn take<'a, T: Deserialize<'a>>(bytes: &mut &'a [u8]) -> Result<T, BlobError> {
    let (v, rest) = postcard::take_from_bytes::<T>(bytes).map_err(|e| match e {
        postcard::Error::DeserializeUnexpectedEnd => BlobError::Truncated,
        _ => BlobError::Malformed,
    })?;
    *bytes = rest;
    Ok(v)
}

impl<'a> GoldenSet<'a> {
    /// Checks magic, version, CRC and every case's shape.
    pub fn parse(bytes: &'a [u8]) -> Result<Self, BlobError> {
        match bytes.get(..4) {
            None => return Err(BlobError::Truncated),
            Some(m) if m != GOLDEN_MAGIC => return Err(BlobError::BadMagic),
            Some(_) => {}
        }
        let body_len = bytes.len().checked_sub(4).ok_or(BlobError::Truncated)?;
        let (body, tail) = bytes.split_at(body_len);
        let stored = match tail {
            &[a, b, c, d] => u32::from_le_bytes([a, b, c, d]),
            _ => return Err(BlobError::Truncated),
        };
        let mut cur = body;
        let pre: GoldenPreamble = take(&mut cur)?;
        if !(GOLDEN_VERSION..=GOLDEN_VERSION_POINT).contains(&pre.version) {
            return Err(BlobError::UnsupportedVersion(pre.version));
        }
        let computed = CRC32.checksum(body);
        if stored != computed {
            return Err(BlobError::ChecksumMismatch { stored, computed });
        }
        let info: GoldenInfo = take(&mut cur)?;
        if info.past_len as usize > MAX_PAST || info.future_len as usize > MAX_FUTURE {
            return Err(BlobError::ExceedsCapacity);
        }
        let set = Self {
            info,
            version: pre.version,
            cases: cur,
        };
        let mut rest = cur;
        let fl = 8 * info.future_len as usize;
        for _ in 0..info.n_cases {
            let GoldenCaseWireV2 { case: c, point } = take_case(&mut rest, pre.version)?;
            let traj_ok = c.trajectory0.is_empty() || c.trajectory0.len() == fl;
            let point_ok = point.is_empty() || point.len() == fl;
            if c.past.len() != 8 * info.past_len as usize
                || c.endpoints.len() != 8 * info.k as usize
                || !traj_ok
                || !point_ok
            {
                return Err(BlobError::BadConfig);
            }
        }
        if !rest.is_empty() {
            return Err(BlobError::TrailingBytes);
        }
        Ok(set)
    }

    /// What the cases were produced with.
    pub fn info(&self) -> &GoldenInfo<'a> {
        &self.info
    }

    /// The cases, decoded lazily (validated by [`GoldenSet::parse`]).
    pub fn cases(&self) -> impl Iterator<Item = GoldenCase<'a>> + 'a {
        let mut rest = self.cases;
        let (n, version) = (self.info.n_cases, self.version);
        (0..n).map_while(move |_| {
            let GoldenCaseWireV2 { case: c, point } = take_case(&mut rest, version).ok()?;
            let mut past = heapless::Vec::new();
            for i in 0..c.past.len() / 8 {
                past.push([read_f32(c.past, 2 * i), read_f32(c.past, 2 * i + 1)])
                    .ok()?;
            }
            Some(GoldenCase {
                past,
                seed: c.seed,
                endpoints: c.endpoints,
                trajectory0: c.trajectory0,
                point,
            })
        })
    }
}

/// FNV-1a (32-bit) over the little-endian bytes of `words`: the compact
/// per-case fingerprint the firmware prints and the host recomputes.
pub fn fnv1a(words: impl IntoIterator<Item = u32>) -> u32 {
    fnv1a_continue(0x811c_9dc5, words)
}

/// [`fnv1a`] continued from the hash state `h` (a running hash over several
/// calls).
pub fn fnv1a_continue(mut h: u32, words: impl IntoIterator<Item = u32>) -> u32 {
    for w in words {
        for byte in w.to_le_bytes() {
            h ^= byte as u32;
            h = h.wrapping_mul(0x0100_0193);
        }
    }
    h
}
