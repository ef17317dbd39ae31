//! The host's one family of inference networks, generic over the numeric kind: the activation
//! ([`Act`]), a dense layer ([`Layer`]), the five networks a blob ships ([`Networks`]) and a
//! whole exported model ([`InferenceModel`]). [`F32`] is the trained model as exported and run
//! by the reference path ([`crate::reference::RefModel`]); [`Q15`] is its post-training
//! quantization ([`crate::quantize::QModel`]). The candle training model
//! (`gpecnet_train::model::Model::export_networks`) exports into [`Networks<F32>`], the blob reader
//! ([`crate::export::read_blob`]) reads into it, and [`crate::export::blob_bytes`] writes either
//! kind through the shared writer (`gpecnet-blob-writer`).

use anyhow::{bail, Result};
use gpecnet_blob_writer::{FixedScale, NumericKind, WireLayer};
use gpecnet_core::blob::Activation;
use serde::{Deserialize, Serialize};

use crate::frame::RefFrame;

/// Hyper-parameters the inference needs (mirrors the blob's `ModelConfig`).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct RefConfig {
    /// Observed steps.
    pub past_len: usize,
    /// Predicted steps.
    pub future_len: usize,
    /// Feature width.
    pub fdim: usize,
    /// Latent width.
    pub zdim: usize,
    /// Coordinate multiplier after the origin shift.
    pub data_scale: f32,
    /// Latent standard deviation at inference.
    pub sigma: f32,
    /// `initial_pos = last observed / initial_pos_divisor`.
    pub initial_pos_divisor: f32,
    /// SIREN w0 used in training (already folded into sine layers).
    pub w0: f32,
    /// Hidden activation of the model.
    pub hidden_act: Act,
    /// Heading-canonical frame over the last `m` observed steps (0 = raw orientation).
    #[serde(default)]
    pub heading_steps: usize,
    /// Test-time sampling: `N` latent samples reduced to `K` by k-means (0 = off).
    #[serde(default)]
    pub tts_samples: usize,
    /// Lloyd iterations of the test-time k-means.
    #[serde(default)]
    pub tts_iters: u8,
    /// Its initialisation: 0 = first K samples, 1 = farthest point.
    #[serde(default)]
    pub tts_init: u8,
    /// Latent clamp of a proposal model (format version 5; 0 without a proposal).
    #[serde(default)]
    pub latent_bound: f32,
    /// Radius multipliers `[r50, r90]` of a model with endpoint probabilities (format
    /// version 6: the proposal's last layer then also gives K logits); both 0 without.
    #[serde(default)]
    pub radius_scales: [f32; 2],
    /// What the numbers mean (unit, period, training data, licence): written as the blob's
    /// version-4 record; `None` for blobs before format version 4, which do not say.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub meta: Option<ModelMeta>,
}

/// The owned form of a blob's version-4 description (`gpecnet_core::blob::Meta`).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ModelMeta {
    /// Unit of positions in and out.
    pub unit: gpecnet_core::blob::PositionUnit,
    /// Metres per pixel of a pixel model with one scale, else 0.
    pub metres_per_pixel: f32,
    /// Seconds between consecutive positions.
    pub period_s: f32,
    /// The training data in words.
    pub data: String,
    /// The licence(s) of that data.
    pub licence: String,
}

impl ModelMeta {
    /// The blob's borrowed record.
    pub fn wire(&self) -> gpecnet_core::blob::Meta<'_> {
        gpecnet_core::blob::Meta {
            unit: self.unit,
            metres_per_pixel: self.metres_per_pixel,
            period_s: self.period_s,
            data: &self.data,
            licence: &self.licence,
        }
    }

    /// The description the blob `bytes` carries, `None` before format version 4 (or when the
    /// bytes are not a valid blob).
    pub fn of_blob(bytes: &[u8]) -> Option<Self> {
        let w = gpecnet_core::blob::Meta::of_blob(bytes).ok()?;
        (w.unit != gpecnet_core::blob::PositionUnit::Unknown).then(|| Self {
            unit: w.unit,
            metres_per_pixel: w.metres_per_pixel,
            period_s: w.period_s,
            data: w.data.to_string(),
            licence: w.licence.to_string(),
        })
    }
}

impl RefConfig {
    /// Whether the blob needs format version 2 (any version-2 setting is used).
    pub fn needs_v2(&self) -> bool {
        self.heading_steps > 0 || self.tts_samples > 0
    }
}

/// Activation of one layer; in a training config (`activation = "sine"` or `"relu"`), the
/// hidden activation of every MLP.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Act {
    /// Affine only (the last layer of every network).
    Linear,
    /// `max(x, 0)`, NaN passes through.
    Relu,
    /// `sin(x)`; in an exported layer the SIREN `w0` is already folded into the weights
    /// (in training: `sin(w0 · (W x + b))`, G-PECNet).
    Sine,
}

impl From<Act> for Activation {
    fn from(a: Act) -> Self {
        match a {
            Act::Linear => Activation::Linear,
            Act::Relu => Activation::Relu,
            Act::Sine => Activation::Sine,
        }
    }
}

impl From<Activation> for Act {
    fn from(a: Activation) -> Self {
        match a {
            Activation::Linear => Act::Linear,
            Activation::Relu => Act::Relu,
            Activation::Sine => Act::Sine,
        }
    }
}

/// A numeric kind of the blob format: what a layer's weights, biases and scaling are.
pub trait Numeric: Clone + Copy + std::fmt::Debug + PartialEq + 'static {
    /// One weight.
    type Weight: Copy + std::fmt::Debug + PartialEq + Into<f64>;
    /// One bias.
    type Bias: Copy + std::fmt::Debug + PartialEq + Into<f64>;
    /// The layer's scaling (none for f32).
    type Scale: Clone + std::fmt::Debug + PartialEq;
    /// The blob's numeric kind.
    const KIND: NumericKind;
    /// The layer as the blob stores it.
    fn wire(l: &Layer<Self>) -> WireLayer;
}

/// f32 weights and biases (`NumericKind::F32`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct F32;

/// int16 weights, int32 biases, power-of-two scales (`NumericKind::Int16Q15`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Q15;

/// The fixed-point scaling of a [`Q15`] layer: input and output exponents, per-channel shifts.
pub type QScale = FixedScale;

impl Numeric for F32 {
    type Weight = f32;
    type Bias = f32;
    type Scale = ();
    const KIND: NumericKind = NumericKind::F32;
    fn wire(l: &Layer<Self>) -> WireLayer {
        WireLayer::f32(l.in_dim, l.out_dim, l.act.into(), &l.w, &l.b)
    }
}

impl Numeric for Q15 {
    type Weight = i16;
    type Bias = i32;
    type Scale = QScale;
    const KIND: NumericKind = NumericKind::Int16Q15;
    fn wire(l: &Layer<Self>) -> WireLayer {
        WireLayer::q15(
            l.in_dim,
            l.out_dim,
            l.act.into(),
            &l.w,
            &l.b,
            l.scale.clone(),
        )
    }
}

/// One dense layer: `y = act(W x + b)`, `W` row-major `[out][in]`.
///
/// For an exported [`Act::Sine`] layer the SIREN factor is folded in (`W = w0 · W_train`,
/// `b = w0 · b_train`, computed in f32), so the layer is exactly `sin(W x + b)`.
#[derive(Clone, Debug, PartialEq)]
pub struct Layer<K: Numeric = F32> {
    /// Input width.
    pub in_dim: usize,
    /// Output width.
    pub out_dim: usize,
    /// Activation after the affine map.
    pub act: Act,
    /// Weights, `out_dim × in_dim`, row-major.
    pub w: Vec<K::Weight>,
    /// Biases, `out_dim` (for [`Q15`]: in accumulator units).
    pub b: Vec<K::Bias>,
    /// The scaling (`()` for [`F32`]).
    pub scale: K::Scale,
}

impl Layer<F32> {
    /// An f32 layer.
    pub fn new(in_dim: usize, out_dim: usize, act: Act, w: Vec<f32>, b: Vec<f32>) -> Self {
        Self {
            in_dim,
            out_dim,
            act,
            w,
            b,
            scale: (),
        }
    }
}

impl<K: Numeric> Layer<K> {
    /// The layer as the blob stores it.
    pub fn wire(&self) -> WireLayer {
        K::wire(self)
    }

    /// Whether every weight and bias is finite.
    pub fn is_finite(&self) -> bool {
        let w = self.w.iter().map(|&v| v.into());
        w.chain(self.b.iter().map(|&v| v.into()))
            .all(|v: f64| v.is_finite())
    }
}

/// The networks a blob ships (PECNet names; the latent encoder is training-only).
#[derive(Clone, Debug, PartialEq)]
pub struct Networks<K: Numeric = F32> {
    /// `2·past_len → fdim`.
    pub encoder_past: Vec<Layer<K>>,
    /// `fdim + zdim → 2` (the endpoint).
    pub decoder: Vec<Layer<K>>,
    /// `2 → ddim`, empty for endpoint-only models.
    pub encoder_dest: Vec<Layer<K>>,
    /// `fdim + ddim + 2 → 2·(future_len − 1)`, empty for endpoint-only models.
    pub predictor: Vec<Layer<K>>,
    /// The point-forecast head `2·past_len → 2·future_len`, empty when absent.
    pub point_head: Vec<Layer<K>>,
    /// The learned latent proposal `fdim → K·zdim` (format version 5, with
    /// [`RefConfig::latent_bound`]), empty when the latents are drawn from the prior.
    pub proposal: Vec<Layer<K>>,
}

/// The networks' names in the blob's order.
pub const NETWORK_NAMES: [&str; 5] = [
    "encoder_past",
    "decoder",
    "encoder_dest",
    "predictor",
    "point_head",
];

impl<K: Numeric> Networks<K> {
    /// The five networks in the blob's order ([`NETWORK_NAMES`]).
    pub fn in_blob_order(&self) -> [&[Layer<K>]; 5] {
        [
            &self.encoder_past,
            &self.decoder,
            &self.encoder_dest,
            &self.predictor,
            &self.point_head,
        ]
    }

    /// Weights and biases of all layers (the proposal's too).
    pub fn parameter_count(&self) -> usize {
        self.in_blob_order()
            .iter()
            .flat_map(|n| n.iter())
            .chain(&self.proposal)
            .map(|l| l.w.len() + l.b.len())
            .sum()
    }
}

/// A whole exported model: name, hyper-parameters and networks — exactly what a blob holds.
#[derive(Clone, Debug, PartialEq)]
pub struct InferenceModel<K: Numeric = F32> {
    /// Model name.
    pub name: String,
    /// Hyper-parameters.
    pub config: RefConfig,
    /// The networks.
    pub nets: Networks<K>,
}

impl<K: Numeric> InferenceModel<K> {
    /// Checks the dimensions chain as the blob format requires (and that every weight is
    /// finite).
    pub fn validate(&self) -> Result<()> {
        let c = &self.config;
        let n = &self.nets;
        let chain =
            |name: &str, net: &[Layer<K>], input: usize, output: Option<usize>| -> Result<usize> {
                let mut w = input;
                if net.is_empty() {
                    bail!("{name}: no layers");
                }
                for (i, l) in net.iter().enumerate() {
                    if l.in_dim != w || l.w.len() != l.in_dim * l.out_dim || l.b.len() != l.out_dim
                    {
                        bail!(
                            "{name} layer {i}: shape {}x{} does not chain from width {w}",
                            l.out_dim,
                            l.in_dim
                        );
                    }
                    if !l.is_finite() {
                        bail!("{name} layer {i}: non-finite weight");
                    }
                    w = l.out_dim;
                }
                if let Some(o) = output {
                    if w != o {
                        bail!("{name}: output width {w}, expected {o}");
                    }
                }
                Ok(w)
            };
        chain(
            "encoder_past",
            &n.encoder_past,
            2 * c.past_len,
            Some(c.fdim),
        )?;
        chain("decoder", &n.decoder, c.fdim + c.zdim, Some(2))?;
        if !n.predictor.is_empty() {
            let ddim = chain("encoder_dest", &n.encoder_dest, 2, None)?;
            chain(
                "predictor",
                &n.predictor,
                c.fdim + ddim + 2,
                Some(2 * (c.future_len - 1)),
            )?;
        }
        if !n.point_head.is_empty() {
            chain(
                "point_head",
                &n.point_head,
                2 * c.past_len,
                Some(2 * c.future_len),
            )?;
        }
        if !n.proposal.is_empty() {
            let out = chain("proposal", &n.proposal, c.fdim, None)?;
            let [r50, r90] = c.radius_scales;
            let scored = r90 > 0.0;
            if (scored || r50 != 0.0)
                && !(r90.is_finite() && r50 > 0.0 && r50 <= r90 && !n.point_head.is_empty())
            {
                bail!("radius multipliers {r50} / {r90}: need 0 < r50 <= r90 and a point head");
            }
            let per = c.zdim + usize::from(scored);
            if out % per != 0 || !(c.latent_bound.is_finite() && c.latent_bound > 0.0) {
                bail!(
                    "proposal: {out} outputs are not whole latents of {per} or the bound {} is not > 0",
                    c.latent_bound
                );
            }
            if c.tts_samples != 0 {
                bail!("a proposal model draws no test-time samples (tts_samples must be 0)");
            }
        }
        if c.heading_steps >= c.past_len {
            bail!(
                "heading_steps {} must be below past_len {}",
                c.heading_steps,
                c.past_len
            );
        }
        Ok(())
    }

    /// Latents of the learned proposal (0 without one): its last layer gives `K·zdim`
    /// latent components, and `K` logits after them when the model has endpoint
    /// probabilities ([`InferenceModel::is_scored`]).
    pub fn proposal_latents(&self) -> usize {
        let per = self.config.zdim + usize::from(self.is_scored());
        self.nets
            .proposal
            .last()
            .map_or(0, |l| l.out_dim / per.max(1))
    }

    /// Whether the model gives endpoint probabilities and radii (format version 6).
    pub fn is_scored(&self) -> bool {
        self.config.radius_scales[1] > 0.0
    }

    /// Whether the blob needs format version 2 (a version-2 setting or a point head).
    pub fn needs_v2(&self) -> bool {
        self.config.needs_v2() || !self.nets.point_head.is_empty()
    }

    /// The frame of `past` under this model's `heading_steps`.
    pub fn frame(&self, past: &[[f32; 2]]) -> RefFrame {
        RefFrame::of(past, self.config.heading_steps)
    }

    /// Weights and biases.
    pub fn parameter_count(&self) -> usize {
        self.nets.parameter_count()
    }
}
