//! The weight blob: a versioned, checksummed postcard byte string, read in
//! place (zero-copy) from flash. The byte-level layout is specified in
//! `weights/FORMAT.md`; this module is its reference reader.
//!
//! A blob is a sequence of postcard values followed by a CRC-32:
//!
//! ```text
//! Preamble { magic: [u8; 4] = "GPEC", version: u16 }
//! ModelInfo { numeric: NumericKind, name: &str, config: ModelConfig }
//! Network × 4  (encoder_past, decoder, encoder_dest, predictor), each:
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

use serde::{Deserialize, Serialize};

/// The four bytes every blob starts with.
pub const MAGIC: [u8; 4] = *b"GPEC";
/// The newest format version this reader understands (it also reads version 1).
///
/// Version 2 adds [`Extensions`] after [`ModelInfo`] and a fifth network, the
/// point-forecast head, after the predictor. Writers emit version 1 whenever a
/// model uses none of that, so such blobs keep their bytes.
pub const FORMAT_VERSION: u16 = 2;
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
    /// integer inference. Layers are [`LayerWireQ`] instead of [`LayerWire`].
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

#[doc(hidden)]
/// One layer on the wire: dims, activation, and raw little-endian tensors.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct LayerWire<'a> {
    /// Input width.
    pub in_dim: u16,
    /// Output width.
    pub out_dim: u16,
    /// Activation after the affine map.
    pub activation: Activation,
    /// `out_dim × in_dim` values, row-major (`W[j][i]` at `j·in_dim + i`).
    pub weights: &'a [u8],
    /// `out_dim` values.
    pub bias: &'a [u8],
}

#[doc(hidden)]
/// One fixed-point layer on the wire ([`NumericKind::Int16Q15`]); see
/// `weights/FORMAT.md` and [`crate::fixed`] for the arithmetic.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct LayerWireQ<'a> {
    /// Input width.
    pub in_dim: u16,
    /// Output width.
    pub out_dim: u16,
    /// Activation after the affine map.
    pub activation: Activation,
    /// The input vector holds `x_i · 2^in_exp` (i16 range).
    pub in_exp: i8,
    /// The output vector holds `y_j · 2^out_exp`; 15 for `Sine` layers.
    pub out_exp: i8,
    /// `out_dim × in_dim` i16 LE, row-major.
    pub weights: &'a [u8],
    /// `out_dim` i32 LE, in accumulator units.
    pub bias: &'a [u8],
    /// `out_dim` i8: the per-channel requantisation shift.
    pub shifts: &'a [u8],
}

#[doc(hidden)]
/// Smallest exponent a fixed-point activation vector may use.
pub const MIN_EXP: i8 = -8;
#[doc(hidden)]
/// Largest exponent a fixed-point activation vector may use.
pub const MAX_EXP: i8 = 30;

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
}

/// Every way a byte string can fail to be a usable model blob.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
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

fn map_postcard(e: postcard::Error) -> BlobError {
    match e {
        postcard::Error::DeserializeUnexpectedEnd => BlobError::Truncated,
        _ => BlobError::Malformed,
    }
}

fn take<'a, T: Deserialize<'a>>(bytes: &mut &'a [u8]) -> Result<T, BlobError> {
    let (v, rest) = postcard::take_from_bytes::<T>(bytes).map_err(map_postcard)?;
    *bytes = rest;
    Ok(v)
}

/// A validated layer: dims, activation, and its tensors still in the blob.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Layer<'a> {
    in_dim: usize,
    out_dim: usize,
    activation: Activation,
    weights: &'a [u8],
    bias: &'a [u8],
    shifts: &'a [u8],
    in_exp: i8,
    out_exp: i8,
}

impl<'a> Layer<'a> {
    /// Input width.
    pub fn in_dim(&self) -> usize {
        self.in_dim
    }
    /// Output width.
    pub fn out_dim(&self) -> usize {
        self.out_dim
    }
    /// Activation.
    pub fn activation(&self) -> Activation {
        self.activation
    }
    /// `W[j][i]`, or 0 when out of range (never panics).
    #[inline]
    pub fn weight(&self, j: usize, i: usize) -> f32 {
        read_f32(self.weights, j * self.in_dim + i)
    }
    /// `b[j]`, or 0 when out of range (never panics).
    #[inline]
    pub fn bias(&self, j: usize) -> f32 {
        read_f32(self.bias, j)
    }
    #[doc(hidden)]
    /// Row `j` of `W` as raw little-endian bytes (empty when out of range).
    #[inline]
    pub fn row_bytes(&self, j: usize) -> &'a [u8] {
        let n = self.in_dim * 4;
        self.weights.get(j * n..j * n + n).unwrap_or(&[])
    }
    /// Fixed point: input exponent (0 for f32 layers).
    pub fn in_exp(&self) -> i8 {
        self.in_exp
    }
    /// Fixed point: output exponent (0 for f32 layers).
    pub fn out_exp(&self) -> i8 {
        self.out_exp
    }
    /// Fixed point: `W[j][i]` as i16, or 0 when out of range (never panics).
    #[inline]
    pub fn weight_q(&self, j: usize, i: usize) -> i16 {
        let k = (j * self.in_dim + i) * 2;
        match self.weights.get(k..k + 2) {
            Some(&[a, b]) => i16::from_le_bytes([a, b]),
            _ => 0,
        }
    }
    #[doc(hidden)]
    /// Fixed point: row `j` of `W` as raw i16 LE bytes (empty when out of range).
    #[inline]
    pub fn row_bytes_q(&self, j: usize) -> &'a [u8] {
        let n = self.in_dim * 2;
        self.weights.get(j * n..j * n + n).unwrap_or(&[])
    }
    /// Fixed point: `b[j]` as i32 accumulator units, or 0 when out of range.
    #[inline]
    pub fn bias_q(&self, j: usize) -> i32 {
        match self.bias.get(j * 4..j * 4 + 4) {
            Some(&[a, b, c, d]) => i32::from_le_bytes([a, b, c, d]),
            _ => 0,
        }
    }
    #[doc(hidden)]
    /// Fixed point: the whole layer's raw tensors `(weights, bias, shifts)`:
    /// `out_dim × in_dim` i16 LE (row-major), `out_dim` i32 LE and
    /// `out_dim` i8, for walking all rows in one pass without per-row
    /// bounds checks (empty for f32 layers' shifts).
    #[inline]
    pub fn tensors_q(&self) -> (&'a [u8], &'a [u8], &'a [u8]) {
        (self.weights, self.bias, self.shifts)
    }
    /// Fixed point: requantisation shift of channel `j`, or 0 when out of range.
    #[inline]
    pub fn shift(&self, j: usize) -> i8 {
        self.shifts.get(j).map_or(0, |&s| s as i8)
    }
    /// Multiply-accumulates of this layer.
    pub fn macs(&self) -> usize {
        self.in_dim * self.out_dim
    }
}

#[inline]
pub(crate) fn read_f32(bytes: &[u8], idx: usize) -> f32 {
    match bytes.get(idx * 4..idx * 4 + 4) {
        Some(&[a, b, c, d]) => f32::from_le_bytes([a, b, c, d]),
        _ => 0.0,
    }
}

/// A validated network: up to [`MAX_LAYERS`] layers whose widths chain.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Network<'a> {
    layers: [Option<Layer<'a>>; MAX_LAYERS],
    len: usize,
}

impl<'a> Network<'a> {
    const EMPTY: Self = Self {
        layers: [None; MAX_LAYERS],
        len: 0,
    };

    /// The layers, first to last.
    pub fn layers(&self) -> impl Iterator<Item = &Layer<'a>> {
        self.layers.iter().take(self.len).flatten()
    }
    /// Number of layers (0 for an absent optional network).
    pub fn len(&self) -> usize {
        self.len
    }
    /// Whether the network is absent.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }
    /// Input width (0 when absent).
    pub fn in_dim(&self) -> usize {
        self.layers().next().map_or(0, |l| l.in_dim)
    }
    /// Output width (0 when absent).
    pub fn out_dim(&self) -> usize {
        self.layers().last().map_or(0, |l| l.out_dim)
    }
    /// Widest layer output (the scratch buffer this network needs).
    pub fn max_width(&self) -> usize {
        self.layers()
            .map(|l| l.out_dim.max(l.in_dim))
            .max()
            .unwrap_or(0)
    }
    /// Multiply-accumulates of one pass.
    pub fn macs(&self) -> usize {
        self.layers().map(Layer::macs).sum()
    }
    /// Layer `i`, if present.
    pub fn layer(&self, i: usize) -> Option<&Layer<'a>> {
        self.layers
            .get(i)
            .and_then(Option::as_ref)
            .filter(|_| i < self.len)
    }
}

/// A validated model: a zero-copy view over a blob's bytes.
///
/// Construction checks the magic, version, CRC, every dimension, every
/// hyper-parameter and every weight (finite); afterwards inference cannot
/// fail on the model's account. The view holds only slices into the blob
/// (about 1.5 KiB on a 32-bit target: five networks of up to eight layer
/// descriptors), so a blob in flash stays in flash.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Model<'a> {
    name: &'a str,
    numeric: NumericKind,
    config: ModelConfig,
    encoder_past: Network<'a>,
    decoder: Network<'a>,
    encoder_dest: Network<'a>,
    predictor: Network<'a>,
    point_head: Network<'a>,
    ext: Extensions,
    crc: u32,
}

impl<'a> Model<'a> {
    /// Validates `bytes` as a blob and returns a view over it.
    pub fn from_blob(bytes: &'a [u8]) -> Result<Self, BlobError> {
        // Magic and version first, so a wrong file or a newer format is named
        // as such rather than as a checksum failure.
        match bytes.get(..4) {
            None => {
                return Err(if MAGIC.starts_with(bytes) {
                    BlobError::Truncated
                } else {
                    BlobError::BadMagic
                })
            }
            Some(m) if m != MAGIC => return Err(BlobError::BadMagic),
            Some(_) => {}
        }
        let mut cur = bytes;
        let pre: Preamble = take(&mut cur)?;
        if !(MIN_FORMAT_VERSION..=FORMAT_VERSION).contains(&pre.version) {
            return Err(BlobError::UnsupportedVersion(pre.version));
        }
        let body_len = bytes.len().checked_sub(4).ok_or(BlobError::Truncated)?;
        let (body, tail) = bytes.split_at(body_len);
        let stored = match tail {
            &[a, b, c, d] => u32::from_le_bytes([a, b, c, d]),
            _ => return Err(BlobError::Truncated),
        };
        let computed = CRC32.checksum(body);
        if stored != computed {
            // A blob cut short usually fails here: say so when the structure
            // itself runs out before the end.
            return Err(if parse_body(body).err() == Some(BlobError::Truncated) {
                BlobError::Truncated
            } else {
                BlobError::ChecksumMismatch { stored, computed }
            });
        }
        let mut model = parse_body(body)?;
        model.crc = computed;
        Ok(model)
    }

    /// Model name from the blob.
    pub fn name(&self) -> &'a str {
        self.name
    }
    /// Numeric kind of the weights.
    pub fn numeric(&self) -> NumericKind {
        self.numeric
    }
    /// Hyper-parameters.
    pub fn config(&self) -> &ModelConfig {
        &self.config
    }
    /// The blob's CRC-32 (identifies the exact weights; golden files refer to it).
    pub fn crc(&self) -> u32 {
        self.crc
    }
    /// The past-trajectory encoder.
    pub fn encoder_past(&self) -> &Network<'a> {
        &self.encoder_past
    }
    /// The endpoint decoder.
    pub fn decoder(&self) -> &Network<'a> {
        &self.decoder
    }
    /// The endpoint encoder (empty when the model predicts endpoints only).
    pub fn encoder_dest(&self) -> &Network<'a> {
        &self.encoder_dest
    }
    /// The trajectory predictor (empty when the model predicts endpoints only).
    pub fn predictor(&self) -> &Network<'a> {
        &self.predictor
    }
    /// Whether the model can predict the intermediate points.
    pub fn has_predictor(&self) -> bool {
        !self.predictor.is_empty()
    }
    /// The point-forecast head (empty when the model has none).
    pub fn point_head(&self) -> &Network<'a> {
        &self.point_head
    }
    /// Whether the model has a deterministic point forecast.
    pub fn has_point_head(&self) -> bool {
        !self.point_head.is_empty()
    }
    /// The version-2 settings (all 0 for a version-1 blob).
    pub fn extensions(&self) -> &Extensions {
        &self.ext
    }
    /// The widest layer of any network: the scratch width a predictor needs.
    pub fn max_width(&self) -> usize {
        let m = self.encoder_past.max_width().max(self.decoder.max_width());
        m.max(self.encoder_dest.max_width())
            .max(self.predictor.max_width())
            .max(self.point_head.max_width())
    }
    /// The scratch width a predictor for this model needs: its widest layer,
    /// and at least `fdim + zdim` (the decoder's input). Choose `W` of
    /// [`crate::Predictor`] at least this large.
    pub fn scratch_width(&self) -> usize {
        let c = &self.config;
        self.max_width().max(c.fdim as usize + c.zdim as usize)
    }
    /// The largest accepted magnitude of a normalised network input
    /// ([`crate::frame::Frame::inputs`]): [`crate::frame::MAX_INPUT`], or less
    /// for a fixed-point model whose input exponent `e` cannot represent it:
    /// `2^(15−e)`, beyond which quantisation would saturate by more than one
    /// step (up to it, the error is at most one step, `2^−e`).
    pub fn input_limit(&self) -> f32 {
        let limit = crate::frame::MAX_INPUT;
        match self.numeric {
            NumericKind::F32 => limit,
            NumericKind::Int16Q15 => {
                let e = crate::engine::in_exp(&self.encoder_past);
                limit.min(crate::fixed::pow2(15 - e as i32))
            }
        }
    }
    /// Number of weights and biases.
    pub fn parameter_count(&self) -> usize {
        [
            &self.encoder_past,
            &self.decoder,
            &self.encoder_dest,
            &self.predictor,
            &self.point_head,
        ]
        .iter()
        .flat_map(|n| n.layers())
        .map(|l| l.macs() + l.out_dim)
        .sum()
    }
    /// Multiply-accumulates to predict `k` endpoints (encoder once, the
    /// decoder's feature columns once, its latent columns and the rest `k` times).
    pub fn endpoint_macs(&self, k: usize) -> usize {
        let fdim = self.config.fdim as usize;
        let first = self.decoder.layer(0).map_or(0, |l| l.out_dim);
        self.encoder_past.macs() + first * fdim + k * (self.decoder.macs() - first * fdim)
    }
}

fn parse_body(body: &[u8]) -> Result<Model<'_>, BlobError> {
    let mut cur = body;
    let pre: Preamble = take(&mut cur)?;
    let info: ModelInfo = take(&mut cur)?;
    let v2 = pre.version >= 2;
    let ext: Extensions = if v2 {
        take(&mut cur)?
    } else {
        Extensions::default()
    };
    let mut nets = [Network::EMPTY; 5];
    let n_nets = if v2 { 5 } else { 4 };
    for net in nets.iter_mut().take(n_nets) {
        let n: u8 = take(&mut cur)?;
        if n as usize > MAX_LAYERS {
            return Err(BlobError::ExceedsCapacity);
        }
        for slot in net.layers.iter_mut().take(n as usize) {
            *slot = Some(match info.numeric {
                NumericKind::F32 => {
                    let w: LayerWire = take(&mut cur)?;
                    Layer {
                        in_dim: w.in_dim as usize,
                        out_dim: w.out_dim as usize,
                        activation: w.activation,
                        weights: w.weights,
                        bias: w.bias,
                        shifts: &[],
                        in_exp: 0,
                        out_exp: 0,
                    }
                }
                NumericKind::Int16Q15 => {
                    let w: LayerWireQ = take(&mut cur)?;
                    Layer {
                        in_dim: w.in_dim as usize,
                        out_dim: w.out_dim as usize,
                        activation: w.activation,
                        weights: w.weights,
                        bias: w.bias,
                        shifts: w.shifts,
                        in_exp: w.in_exp,
                        out_exp: w.out_exp,
                    }
                }
            });
        }
        net.len = n as usize;
    }
    if !cur.is_empty() {
        return Err(BlobError::TrailingBytes);
    }
    let [encoder_past, decoder, encoder_dest, predictor, point_head] = nets;
    let model = Model {
        name: info.name,
        numeric: info.numeric,
        config: info.config,
        encoder_past,
        decoder,
        encoder_dest,
        predictor,
        point_head,
        ext,
        crc: 0,
    };
    validate(&model)?;
    Ok(model)
}

fn validate(m: &Model<'_>) -> Result<(), BlobError> {
    let c = &m.config;
    let finite = [c.data_scale, c.sigma, c.initial_pos_divisor, c.w0]
        .iter()
        .all(|v| v.is_finite());
    if !finite || c.data_scale <= 0.0 || c.sigma < 0.0 || c.initial_pos_divisor <= 0.0 {
        return Err(BlobError::BadConfig);
    }
    if c.past_len < 2 || c.future_len < 2 || c.fdim == 0 || c.zdim == 0 {
        return Err(BlobError::BadConfig);
    }
    if c.past_len as usize > MAX_PAST || c.future_len as usize > MAX_FUTURE {
        return Err(BlobError::ExceedsCapacity);
    }
    let (fdim, zdim) = (c.fdim as usize, c.zdim as usize);
    let q = m.numeric;
    check_network(
        &m.encoder_past,
        NetworkId::EncoderPast,
        2 * c.past_len as usize,
        fdim,
        q,
    )?;
    check_network(&m.decoder, NetworkId::Decoder, fdim + zdim, 2, q)?;
    match (m.encoder_dest.is_empty(), m.predictor.is_empty()) {
        (true, true) => {}
        (false, false) => {
            let ddim = m.encoder_dest.out_dim();
            check_network(&m.encoder_dest, NetworkId::EncoderDest, 2, ddim, q)?;
            let out = 2 * (c.future_len as usize - 1);
            check_network(&m.predictor, NetworkId::Predictor, fdim + ddim + 2, out, q)?;
        }
        (true, false) => return Err(BlobError::ShapeMismatch(NetworkId::EncoderDest)),
        (false, true) => return Err(BlobError::ShapeMismatch(NetworkId::Predictor)),
    }
    if !m.point_head.is_empty() {
        let (p2, f2) = (2 * c.past_len as usize, 2 * c.future_len as usize);
        check_network(&m.point_head, NetworkId::PointHead, p2, f2, q)?;
    }
    let e = &m.ext;
    if e.heading_steps >= c.past_len || e.tts_init > 1 {
        return Err(BlobError::BadConfig);
    }
    if e.tts_samples as usize > MAX_TTS_SAMPLES {
        return Err(BlobError::ExceedsCapacity);
    }
    if q == NumericKind::Int16Q15 {
        check_boundary_exps(m)?;
    }
    Ok(())
}

/// Exponent of a network's input (first layer) and output (last layer).
fn net_exps(net: &Network<'_>) -> (i8, i8) {
    (
        net.layers().next().map_or(0, |l| l.in_exp),
        net.layers().last().map_or(0, |l| l.out_exp),
    )
}

/// Fixed point: the vectors handed between networks share one exponent
/// (features = decoder input = encoder_dest output = predictor input;
/// decoder output = encoder_dest input), so no rescaling happens between them.
fn check_boundary_exps(m: &Model<'_>) -> Result<(), BlobError> {
    let (_, f) = net_exps(&m.encoder_past);
    let (d_in, d_out) = net_exps(&m.decoder);
    if d_in != f {
        return Err(BlobError::BadScale(NetworkId::Decoder));
    }
    if !m.predictor.is_empty() {
        let (g_in, g_out) = net_exps(&m.encoder_dest);
        if g_in != d_out || g_out != f {
            return Err(BlobError::BadScale(NetworkId::EncoderDest));
        }
        if net_exps(&m.predictor).0 != f {
            return Err(BlobError::BadScale(NetworkId::Predictor));
        }
    }
    // The point head reads the same quantised input vector as encoder_past.
    if !m.point_head.is_empty() && net_exps(&m.point_head).0 != net_exps(&m.encoder_past).0 {
        return Err(BlobError::BadScale(NetworkId::PointHead));
    }
    Ok(())
}

/// Fixed point: exponents in range and chaining, shifts in range, `Sine`
/// layers output Q15.
fn check_scales(net: &Network<'_>, id: NetworkId) -> Result<(), BlobError> {
    let bad = Err(BlobError::BadScale(id));
    let mut prev: Option<i8> = None;
    for l in net.layers() {
        let exps_ok =
            (MIN_EXP..=MAX_EXP).contains(&l.in_exp) && (MIN_EXP..=MAX_EXP).contains(&l.out_exp);
        if !exps_ok || prev.is_some_and(|p| p != l.in_exp) {
            return bad;
        }
        let range = match l.activation {
            Activation::Sine => {
                if l.out_exp != 15 {
                    return bad;
                }
                crate::fixed::SINE_SHIFTS
            }
            Activation::Linear | Activation::Relu => crate::fixed::AFFINE_SHIFTS,
        };
        if !l.shifts.iter().all(|&s| range.contains(&(s as i8))) {
            return bad;
        }
        prev = Some(l.out_exp);
    }
    Ok(())
}

fn check_network(
    net: &Network<'_>,
    id: NetworkId,
    input: usize,
    output: usize,
    numeric: NumericKind,
) -> Result<(), BlobError> {
    if net.is_empty() || net.in_dim() != input || net.out_dim() != output || output == 0 {
        return Err(BlobError::ShapeMismatch(id));
    }
    let mut width = input;
    for l in net.layers() {
        if l.in_dim != width || l.out_dim == 0 {
            return Err(BlobError::ShapeMismatch(id));
        }
        let wsize = match numeric {
            NumericKind::F32 => 4,
            NumericKind::Int16Q15 => 2,
        };
        let n = l
            .in_dim
            .checked_mul(l.out_dim)
            .and_then(|n| n.checked_mul(wsize));
        let shifts_len = match numeric {
            NumericKind::F32 => 0,
            NumericKind::Int16Q15 => l.out_dim,
        };
        if n != Some(l.weights.len())
            || l.bias.len() != l.out_dim * 4
            || l.shifts.len() != shifts_len
        {
            return Err(BlobError::ShapeMismatch(id));
        }
        if numeric == NumericKind::Int16Q15 {
            // Every i16 / i32 bit pattern is a valid value.
            width = l.out_dim;
            continue;
        }
        let all_finite = l
            .weights
            .chunks_exact(4)
            .chain(l.bias.chunks_exact(4))
            .all(|b| match b {
                &[a, b, c, d] => f32::from_le_bytes([a, b, c, d]).is_finite(),
                _ => false,
            });
        if !all_finite {
            return Err(BlobError::NonFinite(id));
        }
        width = l.out_dim;
    }
    if numeric == NumericKind::Int16Q15 {
        check_scales(net, id)?;
    }
    Ok(())
}
