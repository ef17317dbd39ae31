//! Training configuration (`configs/*.toml`).
//!
//! Every field has a default, equal to PECNet's `config/optimal.yaml` for SDD where PECNet has
//! the setting (network sizes, `sigma`, `zdim`, `data_scale`, loss weights, learning rate,
//! epochs, batch size), with the G-PECNet sine activation. A TOML file only needs the fields it
//! changes; unknown keys are an error (`deny_unknown_fields`) so that typos never silently fall
//! back to a default.

use std::path::Path;

use anyhow::{Context, Result};
use serde::{Deserialize, Serialize};

use crate::network::Act;

mod validate;

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
/// Windows evaluated per validation forward pass (times K rows): the training loop's chunk
/// ([`crate::train::VAL_CHUNK`] is this one), here because [`MAX_VAL_ACTIVATION_BYTES`] bounds it.
pub const VAL_CHUNK: usize = 512;
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
/// Largest `obs_noise` (the data's unit): far beyond any detector's noise in metres or in
/// SDD pixels, it only keeps the noisy positions well inside f32's exact range.
pub const MAX_OBS_NOISE: f32 = 1000.0;
/// The speed factors allowed for speed augmentation (`speed_scales`, `gpecnet propose
/// --speed-scales`): a quarter to four times the recorded speed.
pub const SPEED_SCALE_RANGE: std::ops::RangeInclusive<f32> = 0.25..=4.0;
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
    /// Multiplier applied after shifting the first observed point to the origin (PECNet's
    /// 1.86 for SDD pixels). Left out of a config file, or `"auto"` ([`AUTO_DATA_SCALE`]), a new run
    /// computes it from its training windows ([`data_scale_rule`]) and writes the number into
    /// the run's `config.toml`, so every later step (resume, export, the card) sees it.
    /// In TOML a number, or `"auto"` (what a missing key means).
    #[serde(
        default = "auto_data_scale",
        serialize_with = "data_scale_ser",
        deserialize_with = "data_scale_de"
    )]
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
    /// Observation-noise augmentation: standard deviation (the data's unit: metres for
    /// `sdd-m` and ETH/UCY, pixels for `sdd`) of i.i.d. Gaussian noise added to each coordinate
    /// of the [`crate::data::PAST`] observed positions of every training window, drawn afresh
    /// every epoch (the future is left clean). The noisy window is then put through the
    /// heading frame and the normalisation again, so the encoders, the point head and the
    /// targets are relative to the noisy observations, as the core computes them from noisy
    /// detections at inference. Validation stays clean. 0 (the default, omitted from the TOML)
    /// trains exactly as without the option, bit for bit; finite, in `[0, 1000]`.
    #[serde(skip_serializing_if = "is_zero_f32")]
    pub obs_noise: f32,
    /// Fine-tuning: the weights the run starts from instead of a fresh initialisation, a run
    /// folder (its best validation epoch) or an f32 blob (`gpecnet train --init`,
    /// [`crate::train::init`]). Recorded for the card; a resumed run continues from its own
    /// checkpoint. Omitted from the TOML when unset.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub init: Option<String>,
    /// Train on a part of the real training data: the windows of the first
    /// `ceil(train_fraction × tracks)` tracks in a fixed pseudo-random order of the tracks
    /// (a hash of scene and id, the same for every seed), so a run on 10 % of a data set sees
    /// whole tracks, as a user with less data would have. In `(0, 1]`; 1 (the default, omitted
    /// from the TOML) = all. Validation is never reduced.
    #[serde(skip_serializing_if = "is_one_f32")]
    pub train_fraction: f32,
}

/// The [`TrainConfig::data_scale`] of a config that leaves it to the data: a new run replaces
/// it by [`data_scale_rule`] of its training windows.
pub const AUTO_DATA_SCALE: f32 = 0.0;

fn auto_data_scale() -> f32 {
    AUTO_DATA_SCALE
}

fn data_scale_ser<S: serde::Serializer>(v: &f32, s: S) -> Result<S::Ok, S::Error> {
    if *v == AUTO_DATA_SCALE {
        s.serialize_str("auto")
    } else {
        s.serialize_f32(*v)
    }
}

/// A number or `"auto"`; a written 0 is refused here, since 0 is how `"auto"` is held.
fn data_scale_de<'de, D: serde::Deserializer<'de>>(d: D) -> Result<f32, D::Error> {
    #[derive(Deserialize)]
    #[serde(untagged)]
    enum Scale {
        Number(f64),
        Word(String),
    }
    match Scale::deserialize(d)? {
        Scale::Word(w) if w == "auto" => Ok(AUTO_DATA_SCALE),
        Scale::Word(w) => Err(serde::de::Error::custom(format!(
            "data_scale = \"{w}\": allowed a finite number > 0 or \"auto\""
        ))),
        Scale::Number(0.0) => Err(serde::de::Error::custom(
            "data_scale = 0 is out of range: allowed a finite number > 0 or \"auto\"",
        )),
        Scale::Number(x) => Ok(x as f32),
    }
}

/// RMS span (first observed point to endpoint) of the SDD pixel training windows that
/// PECNet's `data_scale = 1.86` was chosen for: 208.2 px.
pub const REFERENCE_SPAN: f64 = 208.2;

/// The data scale that gives windows of RMS span `rms_span` (first observed point to endpoint,
/// in the data's unit) the model units of SDD pixel windows at PECNet's 1.86
/// (docs/ethucy.md): `1.86 × 208.2 / rms_span`, rounded to 0.1. SDD in metres (7.84 m) gives
/// 49.4, ETH/UCY (5.4 m) 71.7. `None` when the span is not a finite positive number.
pub fn data_scale_rule(rms_span: f64) -> Option<f32> {
    if !(rms_span.is_finite() && rms_span > 0.0) {
        return None;
    }
    let s = 1.86 * REFERENCE_SPAN / rms_span;
    let rounded = (s * 10.0).round() / 10.0;
    (rounded > 0.0 && rounded.is_finite()).then_some(rounded as f32)
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
            obs_noise: 0.0,
            init: None,
            train_fraction: 1.0,
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
