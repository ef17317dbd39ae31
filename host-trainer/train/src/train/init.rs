//! Where a fine-tuning run starts ([`TrainConfig::init`], `gpecnet train --init PATH`).
//!
//! * A **run folder** (one holding `checkpoint.bin`): the weights of its best validation
//!   epoch (of its last epoch when it validated none), every network including the latent
//!   encoder. Its config is the run's.
//! * An **f32 blob** (`.gpec`, as `gpecnet export` writes it and `weights/` ships it): the
//!   networks it holds. The latent encoder, which only training uses and no blob holds, starts
//!   from the new run's seed, as in a fresh run; a learned proposal in the blob is left out
//!   (refit it with `gpecnet propose` on the new data). Its config is the training config
//!   recorded beside it, `config_toml` of `<name>.json` (written by `gpecnet export`, shipped
//!   with every model in `weights/`); without that file, `--config` must give the recipe the
//!   blob was trained with. A fixed-point blob is refused: start from its f32 original and
//!   quantize the result.
//!
//! Either way the new run keeps the source's architecture and data scale: a `--config` given
//! as well may change how to train (learning rate, epochs, batch, augmentation, data set,
//! seed) but not a key the weights depend on ([`ARCHITECTURE_KEYS`]). The optimizer state
//! starts fresh; the epochs count from 1.

use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};

use crate::checkpoint;
use crate::config::{TrainConfig, AUTO_DATA_SCALE};
use crate::model::Model;
use crate::network::Networks;

/// The config keys a source's weights fix: a fine-tuning run must keep their values.
pub const ARCHITECTURE_KEYS: &[&str] = &[
    "enc_past_size",
    "enc_dest_size",
    "enc_latent_size",
    "dec_size",
    "predictor_hidden_size",
    "point_head_size",
    "fdim",
    "zdim",
    "activation",
    "w0",
    "coord_scale",
    "data_scale",
    "heading_steps",
    "social_pooling",
];

/// The weights a fine-tuning run starts from.
#[derive(Clone, Debug)]
pub enum InitWeights {
    /// Every tensor of a run's model, in `Model::vars` order.
    Run(Vec<Vec<f32>>),
    /// The networks of an f32 blob (w0 and the coordinate scales folded in).
    Blob(Box<Networks>),
}

/// A loaded `--init` source.
#[derive(Clone, Debug)]
pub struct InitSource {
    /// The path as given.
    pub path: PathBuf,
    /// The source's training config (`None`: a blob without its `<name>.json`).
    pub config: Option<TrainConfig>,
    /// Its weights.
    pub weights: InitWeights,
    /// A blob's own hyper-parameters (what a config used with it must agree with).
    pub blob_config: Option<crate::network::RefConfig>,
    /// What was loaded, in words (for the run's first line).
    pub what: String,
}

/// The training config recorded beside a blob: `config_toml` of the `.json` of the same name.
fn blob_config(blob: &Path) -> Result<Option<TrainConfig>> {
    let side = blob.with_extension("json");
    if !side.exists() {
        return Ok(None);
    }
    let text = crate::inpath::read_text_limited(&side, crate::inpath::FileKind::Text)
        .with_context(|| format!("cannot read {}", side.display()))?;
    let v: serde_json::Value =
        serde_json::from_str(&text).with_context(|| format!("{} is not JSON", side.display()))?;
    let Some(toml) = v.get("config_toml").and_then(|t| t.as_str()) else {
        return Ok(None);
    };
    let cfg = TrainConfig::from_toml_str(toml)
        .with_context(|| format!("the config_toml of {}", side.display()))?;
    Ok(Some(cfg))
}

/// Load `path`: a run folder or an f32 blob (see the module docs).
pub fn load_init(path: &Path) -> Result<InitSource> {
    if path.is_dir() {
        let ckpt = checkpoint::load(path)
            .map_err(anyhow::Error::new)
            .with_context(|| format!("--init {}: not a training run folder", path.display()))?;
        let config = ckpt.config()?;
        let (weights, what) = match ckpt.best {
            Some(b) => (
                b.weights,
                format!("run {} (epoch {})", path.display(), b.epoch),
            ),
            None => (
                ckpt.weights,
                format!("run {} (last epoch {})", path.display(), ckpt.epochs_done),
            ),
        };
        return Ok(InitSource {
            path: path.to_path_buf(),
            config: Some(config),
            weights: InitWeights::Run(weights),
            blob_config: None,
            what,
        });
    }
    let bytes = crate::inpath::read_limited(path, crate::inpath::FileKind::Blob)
        .with_context(|| format!("--init {}", path.display()))?;
    let model = crate::export::read_blob(&bytes).with_context(|| {
        format!(
            "--init {}: neither a run folder nor an f32 blob",
            path.display()
        )
    })?;
    let config = blob_config(path)?;
    if let Some(c) = &config {
        let d = blob_diff(c, &model.config);
        if !d.is_empty() {
            bail!(
                "--init {}: the training config in {} does not describe this blob ({})",
                path.display(),
                path.with_extension("json").display(),
                d.join("; ")
            );
        }
    }
    Ok(InitSource {
        path: path.to_path_buf(),
        config,
        what: format!("blob {} ({})", path.display(), model.name),
        weights: InitWeights::Blob(Box::new(model.nets)),
        blob_config: Some(model.config),
    })
}

/// The hyper-parameters a blob fixes that `c` states otherwise, as `key: config / blob`:
/// the feature and latent widths, the data scale, the heading frame and (for sine models)
/// `w0` (the layer shapes are checked when the weights are set).
fn blob_diff(c: &TrainConfig, r: &crate::network::RefConfig) -> Vec<String> {
    let mut d = Vec::new();
    let mut check = |key: &str, a: String, b: String| {
        if a != b {
            d.push(format!("{key}: {a} / {b}"));
        }
    };
    check("fdim", c.fdim.to_string(), r.fdim.to_string());
    check("zdim", c.zdim.to_string(), r.zdim.to_string());
    check(
        "data_scale",
        c.data_scale.to_string(),
        r.data_scale.to_string(),
    );
    check(
        "heading_steps",
        c.heading_steps.to_string(),
        r.heading_steps.to_string(),
    );
    if c.activation == crate::network::Act::Sine {
        check("w0", c.w0.to_string(), r.w0.to_string());
    }
    d
}

/// The config of a run that starts from `src`: `given` (a `--config`) when there is one,
/// which must keep every [`ARCHITECTURE_KEYS`] value of the source's config (a data scale
/// left to the data takes the source's), else the source's own. `init` is set to the source's
/// path. Errors name the keys that differ, or say that a blob without its `.json` needs
/// `--config`.
pub fn init_config(src: &InitSource, given: Option<TrainConfig>) -> Result<TrainConfig> {
    let mut cfg = match (given, &src.config) {
        (Some(mut g), Some(s)) => {
            if g.data_scale == AUTO_DATA_SCALE {
                g.data_scale = s.data_scale;
            }
            let d = architecture_diff(s, &g)?;
            if !d.is_empty() {
                bail!(
                    "--config changes what the weights of --init {} depend on ({}); keep the \
                     source's values, or train from scratch without --init",
                    src.path.display(),
                    d.join("; ")
                );
            }
            g
        }
        (Some(g), None) => {
            if g.data_scale == AUTO_DATA_SCALE {
                bail!(
                    "--init {}: the blob's data scale must be the config's; set data_scale in \
                     --config to the recipe's",
                    src.path.display()
                );
            }
            g
        }
        (None, Some(s)) => s.clone(),
        (None, None) => bail!(
            "--init {}: no training config beside the blob ({} is missing); give --config \
             with the recipe it was trained with",
            src.path.display(),
            src.path.with_extension("json").display()
        ),
    };
    if let Some(r) = &src.blob_config {
        let d = blob_diff(&cfg, r);
        if !d.is_empty() {
            bail!(
                "--config does not describe the blob --init {} (config / blob: {})",
                src.path.display(),
                d.join("; ")
            );
        }
    }
    cfg.init = Some(src.path.to_string_lossy().into_owned());
    Ok(cfg)
}

/// [`ARCHITECTURE_KEYS`] whose values differ between `a` and `b`, as `key: a -> b`.
pub fn architecture_diff(a: &TrainConfig, b: &TrainConfig) -> Result<Vec<String>> {
    let ta: toml::Table = toml::from_str(&a.to_toml_string()?)?;
    let tb: toml::Table = toml::from_str(&b.to_toml_string()?)?;
    let show = |v: Option<&toml::Value>| v.map_or("(default)".to_string(), |v| v.to_string());
    Ok(ARCHITECTURE_KEYS
        .iter()
        .filter(|k| show(ta.get(**k)) != show(tb.get(**k)))
        .map(|k| format!("{k}: {} -> {}", show(ta.get(*k)), show(tb.get(*k))))
        .collect())
}

/// Overwrite `model`'s weights with `src`'s (see the module docs for what each kind of
/// source sets). Errors say which network does not fit.
pub fn apply_init(model: &Model, src: &InitSource) -> Result<()> {
    match &src.weights {
        InitWeights::Run(w) => model
            .set_weights(w)
            .with_context(|| format!("--init {}", src.path.display())),
        InitWeights::Blob(nets) => model.import_networks(nets).with_context(|| {
            format!(
                "--init {}: the blob does not fit the config",
                src.path.display()
            )
        }),
    }
}
