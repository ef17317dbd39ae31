//! Training configuration (`configs/*.toml`).
//!
//! Every field has a default, equal to PECNet's `config/optimal.yaml` for SDD where PECNet has
//! the setting (network sizes, `sigma`, `zdim`, `data_scale`, loss weights, learning rate,
//! epochs, batch size), with the G-PECNet sine activation. A TOML file only needs the fields it
//! changes; unknown keys are an error (`deny_unknown_fields`) so that typos never silently fall
//! back to a default.

use std::path::Path;

use anyhow::{bail, Context, Result};
use serde::{Deserialize, Serialize};

use crate::network::Act;

pub use crate::data::DatasetSpec;

/// Largest `k` (samples per window): `gpecnet_core::blob::MAX_TTS_SAMPLES`, the most
/// samples a blob's predictor draws per window.
pub const MAX_K: usize = 1024;
/// Largest layer width (and `fdim`, `zdim`) accepted.
pub const MAX_WIDTH: usize = 4096;
/// Most hidden layers per network (a blob holds at most 8 layers per network:
/// `gpecnet_core::blob::MAX_LAYERS`).
pub const MAX_HIDDEN_LAYERS: usize = 7;
/// Largest minibatch.
pub const MAX_BATCH: usize = 1 << 20;
/// Most matmul threads.
pub const MAX_THREADS: usize = 1024;
/// Most bytes of one validation layer's activations (`VAL_CHUNK · k · width · 4`): 4 GiB.
pub const MAX_VAL_ACTIVATION_BYTES: u64 = 4 << 30;
/// Most parameters of all networks together ([`TrainConfig::total_param_count`]): 2^23 =
/// 8,388,608. Training holds each parameter four times (weight, gradient, two Adam moments;
/// 128 MiB at the limit) and a checkpoint three times; the shipped models have at most
/// about 1.9 million.
pub const MAX_PARAMETERS: u64 = 1 << 23;
/// Most rounds of social pooling (`nonlocal_pools`; PECNet uses 3): each round keeps its
/// activations for the backward pass.
pub const MAX_NONLOCAL_POOLS: usize = 16;
/// Most bytes of one training layer's activations (`batch_size · width · 4`): 4 GiB.
pub const MAX_TRAIN_ACTIVATION_BYTES: u64 = 4 << 30;

/// All hyper-parameters of one training run.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct TrainConfig {
    /// Hidden sizes of the past-trajectory encoder (input `2 * past_length`, output `fdim`).
    pub enc_past_size: Vec<usize>,
    /// Hidden sizes of the destination encoder (input 2, output `fdim`).
    pub enc_dest_size: Vec<usize>,
    /// Hidden sizes of the latent encoder (input `2 * fdim`, output `2 * zdim` = mu, logvar).
    pub enc_latent_size: Vec<usize>,
    /// Hidden sizes of the destination decoder (input `fdim + zdim`, output 2).
    pub dec_size: Vec<usize>,
    /// Hidden sizes of the trajectory predictor (input `2 * fdim + 2`, output
    /// `2 * (future_length - 1)`).
    pub predictor_hidden_size: Vec<usize>,
    /// Feature width of the past and destination encodings.
    pub fdim: usize,
    /// Latent dimension of the CVAE.
    pub zdim: usize,
    /// Standard deviation of the latent at inference (PECNet's truncation trick; 1.3).
    pub sigma: f32,
    /// Observed steps (must equal `data::PAST` = 8).
    pub past_length: usize,
    /// Predicted steps (must equal `data::FUTURE` = 12).
    pub future_length: usize,
    /// Multiplier applied after shifting the first observed point to the origin (1.86).
    pub data_scale: f32,
    /// Weight of the KL divergence term.
    pub kld_reg: f32,
    /// Weight of the average-displacement (intermediate points) loss.
    pub adl_reg: f32,
    /// Adam learning rate.
    pub learning_rate: f64,
    /// Number of training epochs (the CLI's `--epochs` overrides it).
    pub num_epochs: usize,
    /// Minibatch size (windows, after time-reversal augmentation).
    pub batch_size: usize,
    /// Hidden activation: `"sine"` (G-PECNet) or `"relu"` (PECNet).
    pub activation: Act,
    /// SIREN frequency factor `w0` (sine only).
    pub w0: f32,
    /// Coordinate scale of the networks (model units, i.e. after `data_scale`):
    /// the past and destination encoders see coordinates divided by it and the
    /// decoder and predictor outputs are multiplied by it. Folded into the
    /// first/last layers at export. SIREN needs O(1) inputs; 100 suits SDD
    /// pixels, about 2 suits ETH/UCY metres. 1 reproduces PECNet exactly.
    pub coord_scale: f32,
    /// Seed of every random stream (init, shuffling, noise, validation latents).
    pub seed: u64,
    /// The data set by name (`crate::data::DatasetSpec`): `"sdd"`, `"sdd-m"`, `"eth_ucy:<scene>"`,
    /// a data-set folder (`"./mydrone"`) or several joined by `+`.
    pub dataset: String,
    /// SDD scenes held out from `sdd/train` for validation / best-epoch selection.
    /// (Ignored for ETH/UCY, which has its own `val/` split.)
    pub val_scenes: Vec<String>,
    /// Also train on `sdd/train_extra` (`nexus_2`; in TrajNet but not in Y-Net's 30 scenes).
    pub include_train_extra: bool,
    /// Append a time-reversed copy of every training window (PECNet's augmentation).
    pub time_reversal: bool,
    /// Validate every N epochs (the last epoch is always validated).
    pub eval_every: usize,
    /// Number of samples per window for best-of-K validation metrics.
    pub k: usize,
    /// Compute threads for candle's CPU matmuls (0 = all available cores). Runs are
    /// bit-reproducible only for the same thread count, so it is part of the config and is
    /// restored on `--resume`.
    pub threads: usize,
    /// Synthetic augmentation (the paper's, `gpecnet train --augment K`): add the first
    /// `round(augment_pct / 100 × n_real)` trajectories of [`TrainConfig::synthetic_pool`] to
    /// the training windows, where `n_real` is the number of real training windows (SDD train
    /// minus the validation scenes, plus `train_extra` when enabled) before time reversal; the
    /// synthetic windows are then time-reversed like the real ones. Validation (and the test
    /// set) are never augmented. 0 (the default) = no augmentation; `[0, 100]`.
    /// Omitted from the TOML when 0, so unaugmented configs serialise as before.
    #[serde(skip_serializing_if = "is_zero_f32")]
    pub augment_pct: f32,
    /// The fixed-order synthetic pool CSV written by `gpecnet synth` (e.g.
    /// `runs/pool/pool.csv`; relative paths are relative to the working directory). Required
    /// when `augment_pct > 0`; it must hold at least the number of trajectories asked for and
    /// must be the same file when a run is resumed.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub synthetic_pool: Option<String>,
    /// Metres per pixel applied to the synthetic pool (which `gpecnet synth` writes in SDD
    /// pixels) when the data set is in metres; required there, so a pixel pool is never mixed
    /// into a metre run unconverted, and refused for a pixel data set. 0 = unset.
    #[serde(skip_serializing_if = "is_zero_f32")]
    pub synthetic_metres_per_pixel: f32,
    /// PECNet's non-local social pooling ([`crate::social`]) before the predictor. Off by
    /// default (G-PECNet and every shipped model run without it); it needs the other
    /// pedestrians at inference, so such a model trains and evaluates on the host but cannot
    /// be exported. The social keys below are omitted from the TOML while at their defaults.
    #[serde(skip_serializing_if = "is_false")]
    pub social_pooling: bool,
    /// Rounds of pooling (PECNet: 3), with the same networks each round.
    #[serde(skip_serializing_if = "is_default_pools")]
    pub nonlocal_pools: usize,
    /// Width of the theta/phi embeddings (PECNet's `non_local_dim`: 128).
    #[serde(skip_serializing_if = "is_default_nl_dim")]
    pub non_local_dim: usize,
    /// Hidden sizes of theta (`2 fdim + 2 -> non_local_dim`; PECNet: [256, 128, 64]).
    #[serde(skip_serializing_if = "is_default_nl_size")]
    pub non_local_theta_size: Vec<usize>,
    /// Hidden sizes of phi (`2 fdim + 2 -> non_local_dim`; PECNet: [256, 128, 64]).
    #[serde(skip_serializing_if = "is_default_nl_size")]
    pub non_local_phi_size: Vec<usize>,
    /// Hidden sizes of g (`2 fdim + 2 -> 2 fdim + 2`; PECNet: [256, 128, 64]).
    #[serde(skip_serializing_if = "is_default_nl_size")]
    pub non_local_g_size: Vec<usize>,
    /// Grouping: max |start frame of one − observed frame of the other| (frames; PECNet: 0).
    #[serde(skip_serializing_if = "is_default_time_thresh")]
    pub time_thresh: i64,
    /// Grouping: max min-distance between observed points, raw units (PECNet: 100 px).
    #[serde(skip_serializing_if = "is_default_dist_thresh")]
    pub dist_thresh: f64,
    /// Heading-canonical frame ([`crate::frame`]): `m > 0` rotates every window about its first
    /// observed point so that the displacement over its last `m` observed steps points along
    /// +x (`1 <= m < past_length`); 0 (the default) keeps the raw orientation. Stored in the
    /// blob; `gpecnet-core` applies the same rotation. Omitted from the TOML when 0.
    #[serde(skip_serializing_if = "is_zero_usize")]
    pub heading_steps: usize,
    /// Hidden sizes of the point-forecast head: an MLP from the normalised observed
    /// track (`2 * past_length`) to the whole normalised future (`2 * future_length`), trained
    /// on the mean Euclidean displacement (not its square) next to the CVAE and shipped in the
    /// blob. Empty (the default) = no head. Omitted from the TOML when empty.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub point_head_size: Vec<usize>,
    /// Learning-rate schedule over `num_epochs`: `"constant"` (the default; omitted from the
    /// TOML) or `"cosine"` (epoch `e` of `E` trains at
    /// `lr · (0.05 + 0.95 · (1 + cos(π e / E)) / 2)`, from `lr` down to 5 % of it).
    #[serde(skip_serializing_if = "LrSchedule::is_constant")]
    pub lr_schedule: LrSchedule,
    /// Reflection augmentation: append a mirrored copy (y negated, after the heading frame)
    /// of every training window. Omitted from the TOML when false.
    #[serde(skip_serializing_if = "is_false")]
    pub mirror: bool,
    /// Speed augmentation: for each factor `s`, append a copy of every training window with
    /// every position times `s` (after the heading frame, so about the first observed point):
    /// the same paths walked `s` times as fast, for walkers faster or slower than the training
    /// set's. Each factor finite and in `[0.25, 4]`. Empty (the default, omitted from the TOML)
    /// = none.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub speed_scales: Vec<f32>,
    /// Weight of the point head's loss (its parameters are disjoint from the CVAE's, so this
    /// only scales its effective learning rate under Adam's normalisation: keep 1).
    #[serde(skip_serializing_if = "is_one_f32")]
    pub point_reg: f32,
}

/// Learning-rate schedule (see [`TrainConfig::lr_schedule`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum LrSchedule {
    /// `learning_rate` throughout.
    #[default]
    Constant,
    /// Cosine decay from `learning_rate` to 5 % of it over `num_epochs`.
    Cosine,
}

impl LrSchedule {
    fn is_constant(&self) -> bool {
        *self == LrSchedule::Constant
    }

    /// Learning rate of 0-based epoch `epoch` of `total`, from base rate `lr`.
    pub fn lr(self, lr: f64, epoch: usize, total: usize) -> f64 {
        match self {
            LrSchedule::Constant => lr,
            LrSchedule::Cosine => {
                let t = epoch as f64 / total.max(1) as f64;
                lr * (0.05 + 0.95 * 0.5 * (1.0 + (std::f64::consts::PI * t).cos()))
            }
        }
    }
}

fn is_zero_usize(x: &usize) -> bool {
    *x == 0
}
fn is_one_f32(x: &f32) -> bool {
    *x == 1.0
}

fn is_false(x: &bool) -> bool {
    !*x
}
fn is_default_pools(x: &usize) -> bool {
    *x == 3
}
fn is_default_nl_dim(x: &usize) -> bool {
    *x == 128
}
fn is_default_nl_size(x: &[usize]) -> bool {
    x == [256, 128, 64]
}
fn is_default_time_thresh(x: &i64) -> bool {
    *x == 0
}
fn is_default_dist_thresh(x: &f64) -> bool {
    *x == 100.0
}

fn is_zero_f32(x: &f32) -> bool {
    *x == 0.0
}

impl Default for TrainConfig {
    fn default() -> Self {
        Self {
            enc_past_size: vec![512, 256],
            enc_dest_size: vec![8, 16],
            enc_latent_size: vec![8, 50],
            dec_size: vec![1024, 512, 1024],
            predictor_hidden_size: vec![1024, 512, 256],
            fdim: 16,
            zdim: 16,
            sigma: 1.3,
            past_length: crate::data::PAST,
            future_length: crate::data::FUTURE,
            data_scale: 1.86,
            kld_reg: 1.0,
            adl_reg: 1.0,
            learning_rate: 3e-4,
            num_epochs: 650,
            batch_size: 512,
            activation: Act::Sine,
            w0: 30.0,
            coord_scale: 100.0,
            seed: 1,
            dataset: "sdd".to_string(),
            val_scenes: crate::data::default_sdd_val_scenes(),
            include_train_extra: false,
            time_reversal: true,
            eval_every: 1,
            k: 20,
            threads: 0,
            augment_pct: 0.0,
            synthetic_pool: None,
            synthetic_metres_per_pixel: 0.0,
            social_pooling: false,
            nonlocal_pools: 3,
            non_local_dim: 128,
            non_local_theta_size: vec![256, 128, 64],
            non_local_phi_size: vec![256, 128, 64],
            non_local_g_size: vec![256, 128, 64],
            time_thresh: 0,
            dist_thresh: 100.0,
            heading_steps: 0,
            point_head_size: Vec::new(),
            mirror: false,
            speed_scales: Vec::new(),
            lr_schedule: LrSchedule::Constant,
            point_reg: 1.0,
        }
    }
}

impl TrainConfig {
    /// Parse a TOML string and validate it.
    pub fn from_toml_str(s: &str) -> Result<Self> {
        let cfg: Self = toml::from_str(s).context("invalid training config")?;
        cfg.validate()?;
        Ok(cfg)
    }

    /// Read, parse and validate a TOML file (read as a regular file of at most
    /// [`crate::inpath::MAX_TEXT_BYTES`]).
    pub fn from_file(path: &Path) -> Result<Self> {
        let s = crate::inpath::read_text_limited(path, crate::inpath::FileKind::Text)
            .with_context(|| format!("cannot read config {}", path.display()))?;
        Self::from_toml_str(&s).with_context(|| format!("in config {}", path.display()))
    }

    /// Serialise to TOML (round-trips through [`TrainConfig::from_toml_str`]).
    pub fn to_toml_string(&self) -> Result<String> {
        Ok(toml::to_string(self)?)
    }

    /// The parsed [`TrainConfig::dataset`].
    pub fn dataset_spec(&self) -> Result<DatasetSpec> {
        DatasetSpec::parse(&self.dataset).map_err(anyhow::Error::msg)
    }

    /// Thread count actually used (resolves `threads = 0`).
    pub fn resolved_threads(&self) -> usize {
        if self.threads > 0 {
            self.threads
        } else {
            std::thread::available_parallelism().map_or(1, |n| n.get())
        }
    }

    /// Check every value's range and the internal consistency, before any work (called by
    /// [`TrainConfig::from_toml_str`], hence at load time). Each error names the key and the
    /// allowed range.
    ///
    /// Bounds and why: `k` in `1..=`[`MAX_K`] (the most samples a blob's predictor can draw,
    /// `gpecnet_core::blob::MAX_TTS_SAMPLES`; validation also holds
    /// `VAL_CHUNK · k · widest layer` f32 activations, which must stay within
    /// [`MAX_VAL_ACTIVATION_BYTES`]); layer widths, `fdim`, `zdim` in `1..=`[`MAX_WIDTH`] and at
    /// most [`MAX_HIDDEN_LAYERS`] hidden layers per network (the blob holds at most 8 layers
    /// per network); `num_epochs`, `batch_size`, `eval_every` at least 1; `learning_rate`
    /// finite in `(0, 1]`; `data_scale`, `coord_scale`, `w0`, `point_reg` finite and `> 0`;
    /// `sigma`, `kld_reg`, `adl_reg` finite and `>= 0`; `threads` in `0..=`[`MAX_THREADS`].
    ///
    /// Every floating-point value must be finite (NaN and infinities are refused, naming the
    /// key); `nonlocal_pools` is at most [`MAX_NONLOCAL_POOLS`], `non_local_dim` at most
    /// [`MAX_WIDTH`]; all networks together have at most [`MAX_PARAMETERS`] parameters
    /// ([`TrainConfig::total_param_count`]), and `batch_size · widest layer` f32 training
    /// activations stay within [`MAX_TRAIN_ACTIVATION_BYTES`].
    pub fn validate(&self) -> Result<()> {
        if self.past_length != crate::data::PAST || self.future_length != crate::data::FUTURE {
            bail!(
                "past_length/future_length must be {}/{} (the data windows are fixed)",
                crate::data::PAST,
                crate::data::FUTURE
            );
        }
        let in_range = |key: &str, v: usize, lo: usize, hi: usize, why: &str| -> Result<()> {
            if v < lo || v > hi {
                bail!("{key} = {v} is out of range: allowed {lo}..={hi}{why}");
            }
            Ok(())
        };
        in_range("fdim", self.fdim, 1, MAX_WIDTH, "")?;
        in_range("zdim", self.zdim, 1, MAX_WIDTH, "")?;
        in_range(
            "k",
            self.k,
            1,
            MAX_K,
            " (the most samples a blob's predictor draws per window)",
        )?;
        in_range("num_epochs", self.num_epochs, 1, usize::MAX, "")?;
        in_range("batch_size", self.batch_size, 1, MAX_BATCH, "")?;
        in_range("eval_every", self.eval_every, 1, usize::MAX, "")?;
        in_range("threads", self.threads, 0, MAX_THREADS, " (0 = all cores)")?;
        in_range(
            "nonlocal_pools",
            self.nonlocal_pools,
            0,
            MAX_NONLOCAL_POOLS,
            " (each round keeps its activations for the backward pass)",
        )?;
        in_range("non_local_dim", self.non_local_dim, 0, MAX_WIDTH, "")?;
        let positive = |key: &str, v: f64| -> Result<()> {
            if !(v.is_finite() && v > 0.0) {
                bail!("{key} = {v} is out of range: allowed a finite number > 0");
            }
            Ok(())
        };
        let non_negative = |key: &str, v: f64| -> Result<()> {
            if !(v.is_finite() && v >= 0.0) {
                bail!("{key} = {v} is out of range: allowed a finite number >= 0");
            }
            Ok(())
        };
        if !(self.learning_rate.is_finite()
            && self.learning_rate > 0.0
            && self.learning_rate <= 1.0)
        {
            bail!(
                "learning_rate = {} is out of range: allowed a finite number in (0, 1]",
                self.learning_rate
            );
        }
        positive("data_scale", f64::from(self.data_scale))?;
        positive("coord_scale", f64::from(self.coord_scale))?;
        positive("point_reg", f64::from(self.point_reg))?;
        if self.activation == Act::Linear {
            bail!(
                "activation = \"linear\" is not a hidden activation: allowed \"sine\" or \"relu\""
            );
        }
        if self.activation == Act::Sine {
            positive("w0", f64::from(self.w0))?;
        } else {
            non_negative("w0", f64::from(self.w0))?;
        }
        non_negative("sigma", f64::from(self.sigma))?;
        non_negative("kld_reg", f64::from(self.kld_reg))?;
        non_negative("adl_reg", f64::from(self.adl_reg))?;
        let mut widest = self.fdim.max(self.zdim);
        for (name, v, may_be_empty) in [
            ("enc_past_size", &self.enc_past_size, false),
            ("enc_dest_size", &self.enc_dest_size, false),
            ("enc_latent_size", &self.enc_latent_size, false),
            ("dec_size", &self.dec_size, false),
            ("predictor_hidden_size", &self.predictor_hidden_size, false),
            ("non_local_theta_size", &self.non_local_theta_size, true),
            ("non_local_phi_size", &self.non_local_phi_size, true),
            ("non_local_g_size", &self.non_local_g_size, true),
            ("point_head_size", &self.point_head_size, true),
        ] {
            let lo = usize::from(!may_be_empty);
            if v.len() < lo || v.len() > MAX_HIDDEN_LAYERS {
                bail!(
                    "{name} has {} hidden layers: allowed {lo}..={MAX_HIDDEN_LAYERS} (a blob holds at most {} layers per network)",
                    v.len(),
                    MAX_HIDDEN_LAYERS + 1
                );
            }
            if let Some(&w) = v.iter().find(|&&w| w == 0 || w > MAX_WIDTH) {
                bail!("{name} has a layer of width {w}: allowed widths 1..={MAX_WIDTH}");
            }
            widest = widest.max(v.iter().copied().max().unwrap_or(0));
        }
        let params = self.total_param_count();
        if params > u128::from(MAX_PARAMETERS) {
            let (key, n) = self.largest_network();
            bail!(
                "the networks have {params} parameters, over the limit of {MAX_PARAMETERS} \
                 (training holds weights, gradients and two Adam moments of each); the largest \
                 network is {key} with {n} parameters: make its layers smaller"
            );
        }
        let train_bytes = (self.batch_size as u128) * (widest as u128) * 4;
        if train_bytes > u128::from(MAX_TRAIN_ACTIVATION_BYTES) {
            bail!(
                "batch_size = {} is out of range for layers {widest} wide: allowed 1..={} \
                 (a batch holds batch_size x {widest} f32 activations per layer, at most {} GiB)",
                self.batch_size,
                (MAX_TRAIN_ACTIVATION_BYTES as usize / (widest * 4)).max(1),
                MAX_TRAIN_ACTIVATION_BYTES >> 30
            );
        }
        let val_bytes = (crate::train::VAL_CHUNK as u128) * (self.k as u128) * (widest as u128) * 4;
        if val_bytes > u128::from(MAX_VAL_ACTIVATION_BYTES) {
            let max_k = MAX_VAL_ACTIVATION_BYTES as usize / (crate::train::VAL_CHUNK * widest * 4);
            bail!(
                "k = {} is out of range for layers {widest} wide: allowed 1..={} (validation holds {} windows x k samples x {widest} f32 activations per layer, at most {} GiB)",
                self.k,
                max_k.max(1),
                crate::train::VAL_CHUNK,
                MAX_VAL_ACTIVATION_BYTES >> 30
            );
        }
        let spec = self.dataset_spec()?;
        if self.social_pooling
            && (self.nonlocal_pools == 0
                || self.non_local_dim == 0
                || self.time_thresh < 0
                || !(self.dist_thresh.is_finite() && self.dist_thresh >= 0.0))
        {
            bail!("social pooling needs nonlocal_pools > 0, non_local_dim > 0, time_thresh >= 0 and a finite dist_thresh >= 0");
        }
        if self.heading_steps >= self.past_length {
            bail!(
                "heading_steps must be 0 (off) or in 1..{}, got {}",
                self.past_length,
                self.heading_steps
            );
        }
        if let Some(s) = self
            .speed_scales
            .iter()
            .find(|s| !(s.is_finite() && (0.25..=4.0).contains(*s)))
        {
            bail!("speed_scales: every factor must be a number in [0.25, 4], got {s}");
        }
        if !self.speed_scales.is_empty() && self.social_pooling {
            bail!("speed_scales and social_pooling cannot be combined (scaled copies have no social groups)");
        }
        if self.mirror && self.social_pooling {
            bail!("mirror and social_pooling cannot be combined (mirrored copies have no social groups)");
        }
        if self.heading_steps > 0 && self.social_pooling {
            bail!("heading_steps and social_pooling cannot be combined (each pedestrian would be rotated into its own frame before pooling)");
        }
        if !(self.augment_pct.is_finite() && (0.0..=100.0).contains(&self.augment_pct)) {
            bail!("augment_pct must be in [0, 100], got {}", self.augment_pct);
        }
        if self.include_train_extra && spec != DatasetSpec::Sdd {
            bail!(
                "include_train_extra needs dataset = \"sdd\" (train_extra is one SDD pixel scene)"
            );
        }
        let mpp = self.synthetic_metres_per_pixel;
        if !(mpp.is_finite() && mpp >= 0.0) {
            bail!("synthetic_metres_per_pixel must be a finite number >= 0, got {mpp}");
        }
        if mpp > 0.0 && spec.unit() == crate::data::Unit::Pixels {
            bail!(
                "synthetic_metres_per_pixel is set but dataset {spec} is in pixels, like the pool"
            );
        }
        if self.augment_pct > 0.0 {
            if spec.unit() == crate::data::Unit::Metres && mpp == 0.0 {
                bail!(
                    "dataset {spec} is in metres but the synthetic pool is in SDD pixels: \
                     set synthetic_metres_per_pixel (0.0377 = 7.84 m / 208.2 px, the RMS window spans of sdd-m and sdd)"
                );
            }
            if self
                .synthetic_pool
                .as_deref()
                .is_none_or(|p| p.trim().is_empty())
            {
                bail!("augment_pct = {} needs synthetic_pool = \"<pool.csv>\" (written by `gpecnet synth`)", self.augment_pct);
            }
        }
        // Every other float key (those with a range of their own were checked above).
        if let Some(key) = non_finite_key(&toml::Value::try_from(self)?, "") {
            bail!("{key} is not a finite number: NaN and infinities are refused");
        }
        Ok(())
    }

    /// The networks this config trains (key of their sizes, parameters), in u128 so that no
    /// config overflows: the encoders, decoder, predictor, the point head when present and
    /// the social networks when `social_pooling` is on.
    fn networks(&self) -> Vec<(&'static str, u128)> {
        let p = |input: usize, hidden: &[usize], output: usize| -> u128 {
            let mut n: u128 = 0;
            let mut prev = input as u128;
            for &h in hidden.iter().chain(std::iter::once(&output)) {
                n += prev * h as u128 + h as u128;
                prev = h as u128;
            }
            n
        };
        let p2 = 2 * self.past_length;
        let d = 2 * self.fdim + 2;
        let mut v = vec![
            ("enc_past_size", p(p2, &self.enc_past_size, self.fdim)),
            ("enc_dest_size", p(2, &self.enc_dest_size, self.fdim)),
            (
                "enc_latent_size",
                p(2 * self.fdim, &self.enc_latent_size, 2 * self.zdim),
            ),
            ("dec_size", p(self.fdim + self.zdim, &self.dec_size, 2)),
            (
                "predictor_hidden_size",
                p(
                    d,
                    &self.predictor_hidden_size,
                    2 * self.future_length.saturating_sub(1),
                ),
            ),
        ];
        if !self.point_head_size.is_empty() {
            v.push((
                "point_head_size",
                p(p2, &self.point_head_size, 2 * self.future_length),
            ));
        }
        if self.social_pooling {
            v.push((
                "non_local_theta_size",
                p(d, &self.non_local_theta_size, self.non_local_dim),
            ));
            v.push((
                "non_local_phi_size",
                p(d, &self.non_local_phi_size, self.non_local_dim),
            ));
            v.push(("non_local_g_size", p(d, &self.non_local_g_size, d)));
        }
        v
    }

    /// Parameters of every network this config trains (what [`MAX_PARAMETERS`] bounds).
    pub fn total_param_count(&self) -> u128 {
        self.networks().iter().map(|(_, n)| n).sum()
    }

    /// The key of the network with the most parameters, and that number.
    fn largest_network(&self) -> (&'static str, u128) {
        self.networks()
            .into_iter()
            .max_by_key(|(_, n)| *n)
            .unwrap_or(("enc_past_size", 0))
    }

    /// Number of f32 parameters of the four networks that ship to the embedded target
    /// (past encoder, decoder, destination encoder, predictor; the latent encoder is
    /// training-only).
    pub fn embedded_param_count(&self) -> usize {
        let p2 = 2 * self.past_length;
        let pred_out = 2 * (self.future_length - 1);
        mlp_params(p2, &self.enc_past_size, self.fdim)
            + mlp_params(self.fdim + self.zdim, &self.dec_size, 2)
            + mlp_params(2, &self.enc_dest_size, self.fdim)
            + mlp_params(2 * self.fdim + 2, &self.predictor_hidden_size, pred_out)
            + if self.point_head_size.is_empty() {
                0
            } else {
                mlp_params(p2, &self.point_head_size, 2 * self.future_length)
            }
    }
}

/// `key = value` of the first float in `v` (recursively: tables by dotted key, arrays by
/// index) that is NaN or infinite; `key` is `v`'s own key ("" at the top).
fn non_finite_key(v: &toml::Value, key: &str) -> Option<String> {
    match v {
        toml::Value::Float(f) if !f.is_finite() => Some(format!("{key} = {f}")),
        toml::Value::Array(a) => a
            .iter()
            .enumerate()
            .find_map(|(i, x)| non_finite_key(x, &format!("{key}[{i}]"))),
        toml::Value::Table(t) => t.iter().find_map(|(k, x)| {
            let sub = if key.is_empty() {
                k.clone()
            } else {
                format!("{key}.{k}")
            };
            non_finite_key(x, &sub)
        }),
        _ => None,
    }
}

/// Parameters (weights + biases) of an MLP `input -> hidden... -> output`.
pub fn mlp_params(input: usize, hidden: &[usize], output: usize) -> usize {
    let mut n = 0;
    let mut prev = input;
    for &h in hidden.iter().chain(std::iter::once(&output)) {
        n += prev * h + h;
        prev = h;
    }
    n
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cfg_dir() -> std::path::PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../configs")
    }

    #[test]
    fn shipped_configs_parse() {
        for name in [
            "sdd-paper",
            "sdd-small",
            "pecnet-relu",
            "quick",
            "pecnet-social",
        ] {
            let c = TrainConfig::from_file(&cfg_dir().join(format!("{name}.toml"))).unwrap();
            let back = TrainConfig::from_toml_str(&c.to_toml_string().unwrap()).unwrap();
            assert_eq!(c, back, "{name}");
        }
    }

    #[test]
    fn small_config_fits_256k() {
        let c = TrainConfig::from_file(&cfg_dir().join("sdd-small.toml")).unwrap();
        let bytes = c.embedded_param_count() * 4;
        assert!(bytes <= 256 * 1024, "{bytes} bytes");
    }

    #[test]
    fn unknown_keys_rejected() {
        assert!(TrainConfig::from_toml_str("learning_rat = 0.1").is_err());
        assert!(TrainConfig::from_toml_str("dataset = \"foo\"").is_err());
        assert!(TrainConfig::from_toml_str("dataset = \"eth_ucy:zara1\"").is_ok());
    }

    #[test]
    fn augmentation_fields() {
        // Unaugmented configs serialise without the new keys (old TOML stays identical).
        let d = TrainConfig::default().to_toml_string().unwrap();
        assert!(
            !d.contains("augment_pct") && !d.contains("synthetic_pool"),
            "{d}"
        );
        let c =
            TrainConfig::from_toml_str("augment_pct = 6\nsynthetic_pool = \"runs/pool/pool.csv\"")
                .unwrap();
        assert_eq!(c.augment_pct, 6.0);
        assert_eq!(
            TrainConfig::from_toml_str(&c.to_toml_string().unwrap()).unwrap(),
            c
        );
        assert!(
            TrainConfig::from_toml_str("augment_pct = 6").is_err(),
            "pool required"
        );
        assert!(TrainConfig::from_toml_str("augment_pct = -1").is_err());
        assert!(TrainConfig::from_toml_str("augment_pct = 101\nsynthetic_pool = \"p\"").is_err());
        // A pixel pool is never mixed into a metre data set unconverted, and the factor is
        // refused where there is nothing to convert.
        let metres = "augment_pct = 5\nsynthetic_pool = \"p\"\ndataset = \"eth_ucy:zara1\"";
        let e = TrainConfig::from_toml_str(metres).unwrap_err().to_string();
        assert!(e.contains("synthetic_metres_per_pixel"), "{e}");
        let c =
            TrainConfig::from_toml_str(&format!("{metres}\nsynthetic_metres_per_pixel = 0.0377"))
                .unwrap();
        assert!(c
            .to_toml_string()
            .unwrap()
            .contains("synthetic_metres_per_pixel = 0.0377"));
        assert!(TrainConfig::from_toml_str("synthetic_metres_per_pixel = 0.04").is_err());
        assert!(
            TrainConfig::from_toml_str("dataset = \"sdd-m\"\nsynthetic_metres_per_pixel = -1")
                .is_err()
        );
        assert!(
            TrainConfig::from_toml_str("dataset = \"sdd-m\"\ninclude_train_extra = true").is_err()
        );
    }
}
