//! A validated model ([`Model`]) of up to six networks ([`Network`]), and
//! the parser of a blob's body.

use super::header::take;
#[cfg(feature = "signed")]
use super::signed::{SignError, TrustedKey};
use super::validate::validate;
use super::{
    Activation, BlobError, Extensions, Layer, Meta, ModelConfig, ModelInfo, NumericKind,
    PositionUnit, Preamble, ALIGNED_FORMAT_VERSION, CRC32, FORMAT_VERSION, MAGIC, MAX_LAYERS,
    META_FORMAT_VERSION, MIN_FORMAT_VERSION, PROPOSAL_FORMAT_VERSION, SCORE_FORMAT_VERSION,
    TENSOR_ALIGN,
};

/// A validated network: up to [`MAX_LAYERS`] layers whose widths chain.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Network<'a> {
    pub(super) layers: [Option<Layer<'a>>; MAX_LAYERS],
    pub(super) len: usize,
}

impl<'a> Network<'a> {
    pub(super) const EMPTY: Self = Self {
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
/// (about 1.8 KiB on a 32-bit target: six networks of up to eight layer
/// descriptors), so a blob in flash stays in flash. Of the version-4 [`Meta`]
/// record the view keeps the numbers (unit, metres per pixel, period:
/// [`Model::unit`], [`Model::period_s`]); [`Meta::of_blob`] reads the texts.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Model<'a> {
    pub(super) name: &'a str,
    pub(super) numeric: NumericKind,
    pub(super) config: ModelConfig,
    pub(super) encoder_past: Network<'a>,
    pub(super) decoder: Network<'a>,
    pub(super) encoder_dest: Network<'a>,
    pub(super) predictor: Network<'a>,
    pub(super) point_head: Network<'a>,
    pub(super) proposal: Network<'a>,
    pub(super) latent_bound: f32,
    pub(super) radius_scales: [f32; 2],
    pub(super) ext: Extensions,
    pub(super) crc: u32,
    pub(super) unit: PositionUnit,
    pub(super) metres_per_pixel: f32,
    pub(super) period_s: f32,
}

impl<'a> Model<'a> {
    /// Validates `bytes` as a blob and returns a view over it. A signed
    /// blob ([`super::signed`]) is read without its trailer, unverified: use
    /// [`Model::from_signed_blob`] (feature `signed`) to require a signature.
    pub fn from_blob(bytes: &'a [u8]) -> Result<Self, BlobError> {
        match super::signed::split(bytes) {
            // A trailer-looking tail on an unsigned blob (4 bytes "GSIG" at
            // that offset by chance) falls back to the whole bytes.
            Some((blob, _, _)) => {
                Self::from_unsigned(blob).or_else(|e| Self::from_unsigned(bytes).map_err(|_| e))
            }
            None => Self::from_unsigned(bytes),
        }
    }

    /// A signed blob's model, after checking that its signature verifies
    /// under one of `keys` and its version is at least `min_version` (the
    /// order of the checks: [`super::signed`]); with the blob's
    /// `model_version`. An unsigned blob is [`SignError::UnsignedBlob`].
    ///
    /// Costs one Ed25519 verification (once per boot or update, not per
    /// prediction; `cargo xtask profile` measures it on the Cortex-M4F).
    #[cfg(feature = "signed")]
    pub fn from_signed_blob(
        bytes: &'a [u8],
        keys: &[TrustedKey],
        min_version: u32,
    ) -> Result<(Self, u32), SignError> {
        let (blob, version) = super::signed::authenticate(bytes, keys, min_version)?;
        Ok((Self::from_unsigned(blob)?, version))
    }

    /// [`Model::from_blob`] of bytes without a trailer.
    fn from_unsigned(bytes: &'a [u8]) -> Result<Self, BlobError> {
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
    /// The unit of every position the model takes and returns
    /// ([`PositionUnit::Unknown`] for blobs before format version 4).
    pub fn unit(&self) -> PositionUnit {
        self.unit
    }
    /// For a pixel model trained at one ground scale: its metres per pixel
    /// (finite, > 0); `None` for metre models, pixel models of several
    /// scales (the SDD models) and blobs before format version 4.
    pub fn metres_per_pixel(&self) -> Option<f32> {
        (self.metres_per_pixel > 0.0).then_some(self.metres_per_pixel)
    }
    /// Seconds between consecutive positions of the history and of the
    /// forecast (0.4 for every shipped model); `None` for blobs before
    /// format version 4, which do not record it.
    pub fn period_s(&self) -> Option<f32> {
        (self.period_s > 0.0).then_some(self.period_s)
    }
    /// Hyper-parameters.
    pub fn config(&self) -> &ModelConfig {
        &self.config
    }
    /// The blob's CRC-32 (identifies the exact weights; golden files refer to it).
    pub fn crc(&self) -> u32 {
        self.crc
    }
    /// Whether every weight and bias tensor of this view starts at a
    /// 4-byte ([`TENSOR_ALIGN`]) aligned address: a version-3 blob placed at
    /// an aligned address (e.g. inside a `#[repr(C, align(8))]` wrapper).
    /// Only speed depends on it: the Cortex-M4/M7 kernels check each row's
    /// address and take their word-load paths (`LDRD`, `VLDM`) where it is
    /// aligned, the one-word-at-a-time path elsewhere; other targets never
    /// look. Results are the same bits either way.
    pub fn tensors_aligned(&self) -> bool {
        self.all_layers().all(|l| {
            (l.weights.as_ptr() as usize | l.bias.as_ptr() as usize).is_multiple_of(TENSOR_ALIGN)
        })
    }
    /// The six networks in blob order (encoder_past, decoder, encoder_dest,
    /// predictor, point_head, proposal; absent ones empty).
    fn networks(&self) -> [&Network<'a>; 6] {
        [
            &self.encoder_past,
            &self.decoder,
            &self.encoder_dest,
            &self.predictor,
            &self.point_head,
            &self.proposal,
        ]
    }
    /// Every layer of every network, in blob order.
    fn all_layers(&self) -> impl Iterator<Item = &Layer<'a>> {
        self.networks().into_iter().flat_map(Network::layers)
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
    /// The learned latent proposal (format version 5; empty when the model
    /// draws its latents from the prior): `fdim → K·zdim` on the encoder's
    /// features, K = [`Model::proposal_latents`]. See [`crate::sampling`].
    pub fn proposal(&self) -> &Network<'a> {
        &self.proposal
    }
    /// Whether the model computes its latents with a proposal network.
    pub fn has_proposal(&self) -> bool {
        !self.proposal.is_empty()
    }
    /// The latents one prediction of a proposal model gives (its most
    /// endpoints), 0 without a proposal: its last layer has `K·zdim` rows, or
    /// `K·(zdim + 1)` with endpoint probabilities ([`Model::has_probabilities`]).
    pub fn proposal_latents(&self) -> usize {
        let per = (self.config.zdim as usize) + usize::from(self.has_probabilities());
        self.proposal.out_dim() / per.max(1)
    }
    /// Whether the model gives a learned probability for each endpoint and
    /// the radii of its point forecast (format version 6, [`crate::planner`]).
    pub fn has_probabilities(&self) -> bool {
        self.radius_scales[1] > 0.0
    }
    /// The radius multipliers `[r50, r90]` of the point forecast, calibrated
    /// on validation (both 0 without probabilities, [`crate::planner`]).
    pub fn radius_scales(&self) -> [f32; 2] {
        self.radius_scales
    }
    /// Every proposed latent component is clamped to `±latent_bound`
    /// before the decoder (0 without a proposal).
    pub fn latent_bound(&self) -> f32 {
        self.latent_bound
    }
    /// The version-2 settings (all 0 for a version-1 blob).
    pub fn extensions(&self) -> &Extensions {
        &self.ext
    }
    /// The widest layer of any network: the scratch width a predictor needs.
    /// A proposal's last layer counts by its input width only: the engine
    /// computes one latent (`zdim` of its rows, within
    /// [`Model::scratch_width`]) at a time.
    pub fn max_width(&self) -> usize {
        let proposal = self
            .proposal
            .layers()
            .map(|l| l.in_dim)
            .chain(
                self.proposal
                    .layers()
                    .take(self.proposal.len().saturating_sub(1))
                    .map(|l| l.out_dim),
            )
            .max()
            .unwrap_or(0);
        self.networks()
            .into_iter()
            .take(5)
            .map(Network::max_width)
            .max()
            .unwrap_or(0)
            .max(proposal)
            .max(self.logit_count())
    }
    /// The logits the probabilities need at once (K with probabilities, else 0).
    fn logit_count(&self) -> usize {
        if self.has_probabilities() {
            self.proposal_latents()
        } else {
            0
        }
    }
    /// The scratch width a predictor for this model needs: its widest layer
    /// (and K with endpoint probabilities: the logits are computed at once),
    /// and at least `fdim + zdim` (the decoder's input). Choose `W` of
    /// [`crate::Predictor`] at least this large.
    pub fn scratch_width(&self) -> usize {
        let c = &self.config;
        self.max_width().max(c.fdim as usize + c.zdim as usize)
    }
    /// Number of weights and biases.
    pub fn parameter_count(&self) -> usize {
        self.all_layers().map(|l| l.macs() + l.out_dim).sum()
    }
    /// Multiply-accumulates to predict `k` endpoints (encoder once, the
    /// decoder's feature columns once, its latent columns and the rest `k` times;
    /// with a proposal, per latent its hidden layers and `zdim` rows of its
    /// last layer).
    pub fn endpoint_macs(&self, k: usize) -> usize {
        let fdim = self.config.fdim as usize;
        let first = self.decoder.layer(0).map_or(0, |l| l.out_dim);
        let proposal = match self.proposal.layers().last() {
            None => 0,
            Some(last) => {
                let hidden = self.proposal.macs().saturating_sub(last.macs());
                let rows = (self.config.zdim as usize).saturating_mul(last.in_dim);
                k.saturating_mul(hidden.saturating_add(rows))
            }
        };
        let per_sample = self.decoder.macs().saturating_sub(first * fdim);
        (self.encoder_past.macs() + first * fdim)
            .saturating_add(k.saturating_mul(per_sample))
            .saturating_add(proposal)
    }
}

fn parse_body(body: &[u8]) -> Result<Model<'_>, BlobError> {
    let mut cur = body;
    let pre: Preamble = take(&mut cur)?;
    let info: ModelInfo = take(&mut cur)?;
    let v2 = pre.version >= 2;
    let aligned = pre.version >= ALIGNED_FORMAT_VERSION;
    let ext: Extensions = if v2 {
        take(&mut cur)?
    } else {
        Extensions::default()
    };
    let meta = if pre.version >= META_FORMAT_VERSION {
        let meta: Meta = take(&mut cur)?;
        check_meta(&meta)?;
        meta
    } else {
        Meta::UNKNOWN
    };
    let latent_bound: f32 = if pre.version >= PROPOSAL_FORMAT_VERSION {
        take(&mut cur)?
    } else {
        0.0
    };
    let radius_scales: [f32; 2] = if pre.version >= SCORE_FORMAT_VERSION {
        take(&mut cur)?
    } else {
        [0.0; 2]
    };
    // The networks are parsed straight into the model (no second set of six
    // network tables on the stack: the Cortex-M0's 16 KiB of RAM counts them).
    let mut model = Model {
        name: info.name,
        numeric: info.numeric,
        config: info.config,
        encoder_past: Network::EMPTY,
        decoder: Network::EMPTY,
        encoder_dest: Network::EMPTY,
        predictor: Network::EMPTY,
        point_head: Network::EMPTY,
        proposal: Network::EMPTY,
        latent_bound,
        radius_scales,
        ext,
        crc: 0,
        unit: meta.unit,
        metres_per_pixel: meta.metres_per_pixel,
        period_s: meta.period_s,
    };
    let n_nets = if pre.version >= PROPOSAL_FORMAT_VERSION {
        6
    } else if v2 {
        5
    } else {
        4
    };
    let nets = [
        &mut model.encoder_past,
        &mut model.decoder,
        &mut model.encoder_dest,
        &mut model.predictor,
        &mut model.point_head,
        &mut model.proposal,
    ];
    for net in nets.into_iter().take(n_nets) {
        let n: u8 = take(&mut cur)?;
        if n as usize > MAX_LAYERS {
            return Err(BlobError::ExceedsCapacity);
        }
        for slot in net.layers.iter_mut().take(n as usize) {
            *slot = Some(take_layer(&mut cur, body, info.numeric, aligned)?);
        }
        net.len = n as usize;
    }
    if !cur.is_empty() {
        return Err(BlobError::TrailingBytes);
    }
    validate(&model)?;
    Ok(model)
}

impl<'a> Meta<'a> {
    /// The description of the blob `bytes` after validating it completely
    /// (as [`Model::from_blob`]): [`Meta::UNKNOWN`] for blobs before format
    /// version 4, whose unit and clock are not recorded.
    ///
    /// ```
    /// # let bytes = include_bytes!("../../../weights/sdd-m-tiny-qe.gpec");
    /// use gpecnet_core::blob::{Meta, PositionUnit};
    /// let meta = Meta::of_blob(bytes)?;
    /// assert_eq!((meta.unit, meta.period_s), (PositionUnit::Metre, 0.4));
    /// # Ok::<(), gpecnet_core::BlobError>(())
    /// ```
    pub fn of_blob(bytes: &'a [u8]) -> Result<Self, BlobError> {
        Model::from_blob(bytes)?;
        let mut cur = bytes;
        let pre: Preamble = take(&mut cur)?;
        let _: ModelInfo = take(&mut cur)?;
        if pre.version < META_FORMAT_VERSION {
            return Ok(Meta::UNKNOWN);
        }
        let _: Extensions = take(&mut cur)?;
        take(&mut cur)
    }

    /// Seconds between consecutive history and forecast positions, `None`
    /// when the blob does not say (before format version 4).
    pub fn period(&self) -> Option<f32> {
        (self.period_s > 0.0).then_some(self.period_s)
    }
}

/// The rules of a version-4 [`Meta`] (`weights/FORMAT.md`): a stated unit
/// (metre or pixel), a period in `(0, 60]` seconds, a metres-per-pixel factor
/// that is 0 or finite and positive (and 0 for a metre model), and texts of
/// at most [`MAX_META_TEXT`](super::MAX_META_TEXT) bytes; else
/// [`BlobError::BadConfig`].
fn check_meta(m: &Meta<'_>) -> Result<(), BlobError> {
    let mpp = m.metres_per_pixel;
    let ok = match m.unit {
        PositionUnit::Unknown => false,
        PositionUnit::Metre => mpp == 0.0,
        PositionUnit::Pixel => mpp == 0.0 || (mpp.is_finite() && mpp > 0.0),
    } && m.period_s.is_finite()
        && m.period_s > 0.0
        && m.period_s <= 60.0
        && m.data.len() <= super::MAX_META_TEXT
        && m.licence.len() <= super::MAX_META_TEXT;
    if ok {
        Ok(())
    } else {
        Err(BlobError::BadConfig)
    }
}

/// A version-3 tensor: `pad: &[u8]`, then `tensor: &[u8]`. The padding is
/// canonical: fewer than [`TENSOR_ALIGN`] zero bytes, and the tensor's first
/// byte lies at a multiple of [`TENSOR_ALIGN`] from the blob's start
/// (`body`); anything else is [`BlobError::Malformed`].
fn take_aligned<'a>(cur: &mut &'a [u8], body: &'a [u8]) -> Result<&'a [u8], BlobError> {
    let pad: &[u8] = take(cur)?;
    let tensor: &[u8] = take(cur)?;
    let offset = (tensor.as_ptr() as usize).wrapping_sub(body.as_ptr() as usize);
    if pad.len() >= TENSOR_ALIGN
        || pad.iter().any(|&b| b != 0)
        || !offset.is_multiple_of(TENSOR_ALIGN)
    {
        return Err(BlobError::Malformed);
    }
    Ok(tensor)
}

/// One layer of any format version, field by field (postcard writes a
/// struct as its fields in order, so this reads exactly
/// [`LayerWire`](super::LayerWire) (f32) or
/// [`LayerWireQ`](super::LayerWireQ) (fixed point) of versions 1 and 2); version 3
/// (`aligned`) has [`take_aligned`] padding before the weights and before
/// the bias.
fn take_layer<'a>(
    cur: &mut &'a [u8],
    body: &'a [u8],
    numeric: NumericKind,
    aligned: bool,
) -> Result<Layer<'a>, BlobError> {
    let tensor = |cur: &mut &'a [u8]| {
        if aligned {
            take_aligned(cur, body)
        } else {
            take(cur)
        }
    };
    let in_dim: u16 = take(cur)?;
    let out_dim: u16 = take(cur)?;
    let activation: Activation = take(cur)?;
    let (in_exp, out_exp) = match numeric {
        NumericKind::F32 => (0, 0),
        NumericKind::Int16Q15 => (take::<i8>(cur)?, take::<i8>(cur)?),
    };
    let weights = tensor(cur)?;
    let bias = tensor(cur)?;
    let shifts: &[u8] = match numeric {
        NumericKind::F32 => &[],
        NumericKind::Int16Q15 => take(cur)?,
    };
    Ok(Layer {
        in_dim: in_dim as usize,
        out_dim: out_dim as usize,
        activation,
        weights,
        bias,
        shifts,
        in_exp,
        out_exp,
        short_shifts: shifts.iter().all(|&s| (-31..=32).contains(&(s as i8))),
    })
}
