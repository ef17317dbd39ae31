//! `gpecnet propose`: a learned latent proposal for a **frozen** model.
//!
//! A CVAE's endpoint set is normally K latents drawn from the prior (or many more, reduced
//! by k-means, [`crate::tts`]). A proposal replaces the draw with K latents computed from
//! the past: a small network `f → K·zdim` (DLow, Yuan & Kitani, ECCV 2020) on the frozen
//! encoder's features, or, with `codebook`, K fixed latent vectors (its bias alone). It is
//! trained post hoc, the CVAE's networks untouched, against the soft minimum over the K
//! endpoint errors (a differentiable best-of-K) plus a small weight on the prior's
//! `½‖z‖²`. Every latent component is clamped to `±bound`, in training exactly as in
//! `gpecnet-core`, so the fixed-point decoder's input range is respected by construction.
//!
//! The run folder holds `checkpoint.json` (after every epoch, atomically: the current and
//! the best-validation weights, the optimiser and sampler state), `metrics.csv` and, at the
//! end, `proposal.json` (the best-validation proposal, exported layers). Selection uses the
//! validation windows only; the test set is never read here.
//!
//! Files: `fit.rs` (tensors, loss, validation pass), this file (options, the loop, the
//! files).

mod fit;

use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use indicatif::{ProgressBar, ProgressStyle};
use serde::{Deserialize, Serialize};

use crate::data::{self, DatasetSpec, Window};
use crate::model::Mlp;
use crate::network::{Act, Layer};
use crate::optim::{Adam, AdamParams, AdamState};
use crate::reference::RefModel;
use crate::rng::{Rng, RngState};
use crate::rundir::{write_atomic, RunLock};
pub use fit::{Encoded, LossSpec, ValScore};

/// What a proposal run is (a resumed run must match it exactly).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ProposeSettings {
    /// CRC-32 of the frozen f32 blob.
    pub blob_crc: u32,
    /// Data set name (`sdd-m`, `sdd`, ...).
    pub dataset: String,
    /// SDD validation scenes.
    pub val_scenes: Vec<String>,
    /// Seed of the initialisation and the batch order.
    pub seed: u64,
    /// Latents per window.
    pub k: usize,
    /// Hidden widths of the proposal network (empty with `codebook`).
    pub hidden: Vec<usize>,
    /// Hidden activation.
    pub act: Act,
    /// K fixed latents (the bias of one layer whose weights stay 0).
    pub codebook: bool,
    /// Epochs.
    pub epochs: usize,
    /// Windows per batch.
    pub batch: usize,
    /// Adam learning rate.
    pub lr: f64,
    /// Weight of `½‖z‖²`.
    pub prior_weight: f32,
    /// Soft-min temperature in the caller's unit.
    pub temperature: f32,
    /// Latent clamp `±bound`.
    pub bound: f32,
    /// Time-reversed copies of the training windows.
    pub time_reversal: bool,
    /// Mirrored (y → −y) copies of the training windows.
    pub mirror: bool,
}

/// One epoch's numbers.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct EpochRow {
    /// Epoch (1-based).
    pub epoch: usize,
    /// Mean training loss (normalised units).
    pub loss: f64,
    /// Validation minFDE (caller's unit).
    pub val_min_fde: f64,
    /// Validation share of clamped latent components.
    pub val_clamped: f64,
    /// Validation mean latent norm.
    pub val_z_norm: f64,
}

/// Everything needed to continue a run.
#[derive(Clone, Debug, Serialize, Deserialize)]
struct Checkpoint {
    settings: ProposeSettings,
    epoch: usize,
    weights: Vec<Vec<f32>>,
    adam: AdamState,
    rng: RngState,
    best_epoch: usize,
    best_weights: Vec<Vec<f32>>,
    rows: Vec<EpochRow>,
}

/// The exported proposal (`proposal.json`).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ProposalFile {
    /// The run's settings.
    pub settings: ProposeSettings,
    /// [`frozen_fingerprint`] of the model it was trained for.
    pub frozen: u32,
    /// The frozen blob's path as given to `gpecnet propose`.
    #[serde(default)]
    pub source: String,
    /// The best validation epoch.
    pub epoch: usize,
    /// Its validation numbers.
    pub val: EpochRow,
    /// The layers (last one linear, `K·zdim` outputs).
    pub layers: Vec<LayerFile>,
    /// The selected proposal with its model, through `gpecnet-core` on the validation windows.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub val_core: Option<ValCore>,
}

/// Validation numbers of the selected proposal computed through `gpecnet-core` (the f32
/// blob the export would write), in the data set's unit: the set's distribution quality
/// beside its minFDE, so a set that wins minFDE by spreading its points shows it.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ValCore {
    /// Windows.
    pub n: usize,
    /// minADE, best of K.
    pub min_ade: f64,
    /// minFDE, best of K.
    pub min_fde: f64,
    /// Mean FDE over the K endpoints.
    pub mean_fde: f64,
    /// KDE NLL of the true endpoint under the K endpoints (nats; `crate::eval::kde_nll`).
    pub kde_nll: f64,
    /// The two hit radii (0.5 / 1 m, or 20 / 40 px).
    pub radii: [f64; 2],
    /// Share of windows with an endpoint within each radius.
    pub hits: [f64; 2],
}

/// One exported layer.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct LayerFile {
    /// Input width.
    pub in_dim: usize,
    /// Output width.
    pub out_dim: usize,
    /// Activation.
    pub act: Act,
    /// Row-major weights.
    pub w: Vec<f32>,
    /// Biases.
    pub b: Vec<f32>,
}

impl ProposalFile {
    /// The layers as the trainer's exported layers.
    pub fn layers(&self) -> Vec<Layer> {
        self.layers
            .iter()
            .map(|l| Layer::new(l.in_dim, l.out_dim, l.act, l.w.clone(), l.b.clone()))
            .collect()
    }

    /// Reads `proposal.json`.
    pub fn read(path: &Path) -> Result<Self> {
        let text = crate::inpath::read_text_limited(path, crate::inpath::FileKind::Text)?;
        serde_json::from_str(&text).with_context(|| format!("reading {}", path.display()))
    }
}

/// A proposal run.
pub struct ProposeRun<'a> {
    /// The frozen model.
    pub model: &'a RefModel,
    /// Its settings.
    pub settings: ProposeSettings,
    /// Data root.
    pub data_root: PathBuf,
    /// Run folder.
    pub out: PathBuf,
    /// Continue the run in `out`.
    pub resume: bool,
    /// The frozen blob's path (for the record).
    pub source: PathBuf,
}

fn windows(
    root: &Path,
    spec: &DatasetSpec,
    split: data::Split,
    s: &ProposeSettings,
) -> Result<Vec<Window>> {
    Ok(data::load(root, spec, split, &s.val_scenes)?.windows)
}

fn build(s: &ProposeSettings, fdim: usize, zdim: usize) -> Result<Mlp> {
    let mut rng = Rng::new(s.seed);
    let out = s.k * zdim;
    let mlp = Mlp::new(fdim, &s.hidden, out, s.act, 1.0, &mut rng)?;
    // Start every latent as a draw of the prior (sigma 1) with a weak dependence on the
    // features, so the first epochs already see the decoder's whole range.
    let last = mlp.layers().last().context("empty proposal")?;
    let scale = if s.codebook { 0.0 } else { 0.1 };
    last.weight
        .set(&(last.weight.as_tensor() * scale)?)
        .map_err(anyhow::Error::from)?;
    let b =
        candle_core::Tensor::from_vec(rng.normal_vec(out, 1.0), out, &candle_core::Device::Cpu)?;
    last.bias.set(&b)?;
    Ok(mlp)
}

fn trainable(mlp: &Mlp, codebook: bool) -> Vec<candle_core::Var> {
    if codebook {
        mlp.layers().iter().map(|l| l.bias.clone()).collect()
    } else {
        mlp.vars()
    }
}

fn weights_of(mlp: &Mlp) -> Result<Vec<Vec<f32>>> {
    mlp.vars()
        .iter()
        .map(|v| Ok(v.as_tensor().flatten_all()?.to_vec1::<f32>()?))
        .collect()
}

fn set_weights(mlp: &Mlp, w: &[Vec<f32>]) -> Result<()> {
    let vars = mlp.vars();
    if vars.len() != w.len() {
        bail!(
            "checkpoint holds {} tensors, the proposal has {}",
            w.len(),
            vars.len()
        );
    }
    for (v, w) in vars.iter().zip(w) {
        let t = candle_core::Tensor::from_slice(w, v.shape(), &candle_core::Device::Cpu)?;
        v.set(&t)?;
    }
    Ok(())
}

fn augment(mut ws: Vec<Window>, s: &ProposeSettings) -> Vec<Window> {
    if s.time_reversal {
        let rev: Vec<Window> = ws.iter().map(data::time_reversed).collect();
        ws.extend(rev);
    }
    if s.mirror {
        let mir: Vec<Window> = ws
            .iter()
            .map(|w| {
                let mut m = w.clone();
                m.pos.iter_mut().for_each(|p| p[1] = -p[1]);
                m
            })
            .collect();
        ws.extend(mir);
    }
    ws
}

impl ProposeRun<'_> {
    /// Trains (or continues) the run and writes `proposal.json`; returns it.
    pub fn run(&self) -> Result<ProposalFile> {
        let s = &self.settings;
        let c = &self.model.config;
        if s.k == 0 || s.batch == 0 || s.epochs == 0 {
            bail!("k, batch and epochs must be at least 1");
        }
        if !(s.bound.is_finite() && s.bound > 0.0) {
            bail!("--bound must be finite and > 0, got {}", s.bound);
        }
        if !(s.temperature.is_finite() && s.temperature > 0.0) {
            bail!(
                "--temperature must be finite and > 0, got {}",
                s.temperature
            );
        }
        std::fs::create_dir_all(&self.out)
            .with_context(|| format!("creating {}", self.out.display()))?;
        let _lock = RunLock::acquire(&self.out)?;
        let ckpt_path = self.out.join("checkpoint.json");
        let spec = DatasetSpec::parse(&s.dataset).map_err(anyhow::Error::msg)?;
        let train = augment(windows(&self.data_root, &spec, data::Split::Train, s)?, s);
        let val = windows(&self.data_root, &spec, data::Split::Val, s)?;
        let train = Encoded::of(self.model, &train)?;
        let val = Encoded::of(self.model, &val)?;
        let decoder = fit::frozen_mlp(&self.model.nets.decoder)?;
        let proposal = build(s, c.fdim, c.zdim)?;
        let ds = f64::from(c.data_scale);
        let loss_spec = LossSpec {
            k: s.k,
            zdim: c.zdim,
            bound: s.bound,
            temperature: s.temperature * c.data_scale,
            prior_weight: s.prior_weight,
        };
        let mut adam = Adam::new(trainable(&proposal, s.codebook), AdamParams::with_lr(s.lr));
        let mut rng = Rng::with_stream(s.seed, 1);
        let mut ck = Checkpoint {
            settings: s.clone(),
            epoch: 0,
            weights: weights_of(&proposal)?,
            adam: adam.state().clone(),
            rng: rng.state(),
            best_epoch: 0,
            best_weights: weights_of(&proposal)?,
            rows: Vec::new(),
        };
        if ckpt_path.exists() {
            if !self.resume {
                bail!(
                    "{} holds a run; continue it with --resume or choose another --out",
                    self.out.display()
                );
            }
            let text =
                crate::inpath::read_text_limited(&ckpt_path, crate::inpath::FileKind::Checkpoint)?;
            let old: Checkpoint = serde_json::from_str(&text)
                .with_context(|| format!("reading {}", ckpt_path.display()))?;
            if old.settings != *s {
                bail!(
                    "{} was made with other settings ({:?}); refusing to mix runs",
                    ckpt_path.display(),
                    old.settings
                );
            }
            set_weights(&proposal, &old.weights)?;
            adam = Adam::from_state(
                trainable(&proposal, s.codebook),
                AdamParams::with_lr(s.lr),
                old.adam.clone(),
            )?;
            rng = Rng::from_state(&old.rng);
            ck = old;
        }
        let bar = ProgressBar::new(s.epochs as u64);
        bar.set_style(
            ProgressStyle::with_template("{prefix} [{bar:30}] {pos}/{len} epochs {msg} ({eta})")
                .unwrap_or_else(|_| ProgressStyle::default_bar()),
        );
        bar.set_prefix(format!("propose seed {}", s.seed));
        bar.set_position(ck.epoch as u64);
        let mut order: Vec<u32> = (0..train.n as u32).collect();
        while ck.epoch < s.epochs {
            rng.shuffle(&mut order);
            let (mut sum, mut n) = (0.0f64, 0usize);
            for chunk in order.chunks(s.batch) {
                let (f, t) = train.rows(chunk)?;
                let l = fit::loss(&proposal, &decoder, &f, &t, &loss_spec)?;
                adam.backward_step(&l)?;
                sum += f64::from(l.to_scalar::<f32>()?);
                n += 1;
            }
            let v = fit::validate(&proposal, &decoder, &val, &loss_spec)?;
            if !v.min_fde.is_finite() || val.n == 0 {
                bail!(
                    "epoch {}: validation minFDE is {} on {} windows; nothing to select on",
                    ck.epoch + 1,
                    v.min_fde,
                    val.n
                );
            }
            ck.epoch += 1;
            let row = EpochRow {
                epoch: ck.epoch,
                loss: sum / n.max(1) as f64,
                val_min_fde: v.min_fde / ds,
                val_clamped: v.clamped,
                val_z_norm: v.z_norm,
            };
            let best = ck
                .rows
                .iter()
                .find(|r| r.epoch == ck.best_epoch)
                .is_none_or(|b| row.val_min_fde < b.val_min_fde);
            ck.weights = weights_of(&proposal)?;
            if best {
                ck.best_epoch = ck.epoch;
                ck.best_weights = ck.weights.clone();
            }
            bar.set_message(format!(
                "val minFDE {:.4} (best {:.4} @ {})",
                row.val_min_fde,
                if best {
                    row.val_min_fde
                } else {
                    ck.rows
                        .iter()
                        .find(|r| r.epoch == ck.best_epoch)
                        .map_or(f64::NAN, |r| r.val_min_fde)
                },
                ck.best_epoch
            ));
            ck.rows.push(row);
            ck.adam = adam.state().clone();
            ck.rng = rng.state();
            write_atomic(&ckpt_path, serde_json::to_string(&ck)?.as_bytes())?;
            write_atomic(
                &self.out.join("metrics.csv"),
                metrics_csv(&ck.rows).as_bytes(),
            )?;
            bar.inc(1);
        }
        bar.finish();
        set_weights(&proposal, &ck.best_weights)?;
        let exported = proposal.export()?;
        let val_row = ck
            .rows
            .iter()
            .find(|r| r.epoch == ck.best_epoch)
            .cloned()
            .context("no epoch recorded")?;
        let file = ProposalFile {
            settings: s.clone(),
            frozen: frozen_fingerprint(self.model),
            source: self.source.display().to_string(),
            epoch: ck.best_epoch,
            val: val_row,
            layers: exported
                .iter()
                .map(|l| LayerFile {
                    in_dim: l.in_dim,
                    out_dim: l.out_dim,
                    act: l.act,
                    w: l.w.clone(),
                    b: l.b.clone(),
                })
                .collect(),
            val_core: None,
        };
        let file = ProposalFile {
            val_core: Some(self.val_core(&file, &spec)?),
            ..file
        };
        write_atomic(
            &self.out.join("proposal.json"),
            serde_json::to_string_pretty(&file)?.as_bytes(),
        )?;
        Ok(file)
    }
}

/// A proposal's provenance in a model card.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ProposalCard {
    /// The `proposal.json` the export read.
    pub file: String,
    /// The network in words (`16 → 10 (relu) → 320 (linear), clamp ±8`).
    pub shape: String,
    /// Latents.
    pub k: usize,
    /// Its best validation epoch.
    pub epoch: usize,
    /// Validation minFDE at that epoch (the blob's unit, 4 decimals).
    pub val_min_fde: String,
    /// The `gpecnet propose` command that trains it.
    pub command: String,
}

impl ProposalCard {
    /// The card of `p`, read from `path`.
    pub fn of(p: &ProposalFile, path: &Path) -> Self {
        let s = &p.settings;
        let mut shape: Vec<String> = p
            .layers
            .first()
            .map(|l| l.in_dim.to_string())
            .into_iter()
            .collect();
        for l in &p.layers {
            shape.push(format!("{} ({})", l.out_dim, act_name(l.act)));
        }
        let hidden = if s.codebook {
            " --codebook".to_string()
        } else {
            format!(
                " --hidden {} --act {}",
                s.hidden
                    .iter()
                    .map(usize::to_string)
                    .collect::<Vec<_>>()
                    .join(","),
                act_name(s.act)
            )
        };
        Self {
            file: path.display().to_string(),
            shape: format!("{}, clamp ±{}", shape.join(" → "), s.bound),
            k: s.k,
            epoch: p.epoch,
            val_min_fde: format!("{:.4}", p.val.val_min_fde),
            command: format!(
                "gpecnet propose --blob {} --dataset {} --seed {} --k {}{hidden} --epochs {} --batch {} --lr {} --prior-weight {} --temperature {} --bound {}{}{} --out {}",
                p.source,
                s.dataset,
                s.seed,
                s.k,
                s.epochs,
                s.batch,
                s.lr,
                s.prior_weight,
                s.temperature,
                s.bound,
                if s.time_reversal { "" } else { " --no-time-reversal" },
                if s.mirror { "" } else { " --no-mirror" },
                path.parent().map_or(".".into(), |d| d.display().to_string()),
            ),
        }
    }
}

fn act_name(a: Act) -> &'static str {
    match a {
        Act::Linear => "linear",
        Act::Relu => "relu",
        Act::Sine => "sine",
    }
}

/// CRC-32 of the f32 bytes of the frozen networks (`encoder_past`, then `decoder`: each
/// layer's weights, then biases) and of `data_scale` and the heading frame: a proposal
/// fits exactly the model it was trained on.
pub fn frozen_fingerprint(m: &RefModel) -> u32 {
    let mut d = gpecnet_core::blob::CRC32.digest();
    for l in m.nets.encoder_past.iter().chain(&m.nets.decoder) {
        for v in l.w.iter().chain(&l.b) {
            d.update(&v.to_le_bytes());
        }
    }
    d.update(&m.config.data_scale.to_le_bytes());
    d.update(&(m.config.heading_steps as u64).to_le_bytes());
    d.finalize()
}

impl ProposeRun<'_> {
    /// [`ValCore`] of `file` joined to the frozen model.
    fn val_core(&self, file: &ProposalFile, spec: &DatasetSpec) -> Result<ValCore> {
        let mut m = self.model.clone();
        m.config.tts_samples = 0;
        m.nets.proposal = file.layers();
        m.config.latent_bound = file.settings.bound;
        let blob = crate::export::blob_bytes(&m)?;
        let val = data::load(
            &self.data_root,
            spec,
            data::Split::Val,
            &file.settings.val_scenes,
        )?;
        let k = file.settings.k;
        let sine = crate::reference::SineKind::Libm;
        let (metrics, preds) = crate::core_eval::evaluate_core(&blob, sine, &val, k, 0)?;
        let acc = crate::eval::dist_accumulator(&val, &preds).context("no validation windows")?;
        let dist = acc.finish().context("no validation windows")?;
        let radii = crate::eval::hit_radii(val.unit);
        Ok(ValCore {
            n: metrics.n,
            min_ade: metrics.min_ade,
            min_fde: metrics.min_fde,
            mean_fde: metrics.mean_fde,
            kde_nll: dist.kde_nll,
            radii,
            hits: radii.map(|r| acc.within(r)),
        })
    }
}

fn metrics_csv(rows: &[EpochRow]) -> String {
    let mut s = String::from("epoch,loss,val_min_fde,val_clamped,val_z_norm\n");
    for r in rows {
        s.push_str(&format!(
            "{},{:.6},{:.6},{:.6},{:.4}\n",
            r.epoch, r.loss, r.val_min_fde, r.val_clamped, r.val_z_norm
        ));
    }
    s
}

/// `gpecnet propose`: train a latent proposal for a frozen f32 blob.
///
/// Example (the shipped metric model's proposal, one seed, about N minutes on one core):
///   gpecnet propose --blob weights/sdd-m-tiny.gpec --dataset sdd-m --seed 0 --out runs/prop/s0
#[derive(clap::Args, Debug)]
#[command(verbatim_doc_comment)]
pub struct ProposeArgs {
    /// The frozen f32 blob (its encoder and decoder are used as they are).
    #[arg(long, value_name = "FILE")]
    pub blob: PathBuf,
    /// Training and validation data (`sdd`, `sdd-m`, `eth_ucy:<scene>`, a folder); the test
    /// split is never read.
    #[arg(long, value_name = "SPEC", default_value = "sdd-m")]
    pub dataset: String,
    /// Data root holding sdd/ and eth_ucy/.
    #[arg(long, value_name = "DIR", default_value_os_t = data::default_data_root())]
    pub data: PathBuf,
    /// Run folder (created; refused when it holds a run unless --resume).
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// Continue the run in --out (the settings must be the same).
    #[arg(long)]
    pub resume: bool,
    /// Seed of the initialisation and batch order.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Latents per window (the endpoint count the model will return).
    #[arg(long, default_value_t = 20)]
    pub k: usize,
    /// Hidden widths of the proposal network, comma separated.
    #[arg(long, value_delimiter = ',', default_value = "64")]
    pub hidden: Vec<usize>,
    /// Hidden activation.
    #[arg(long, value_enum, default_value = "relu")]
    pub act: ActArg,
    /// K fixed latent vectors instead of a network (no hidden layer, weights 0).
    #[arg(long)]
    pub codebook: bool,
    /// Epochs.
    #[arg(long, default_value_t = 60)]
    pub epochs: usize,
    /// Windows per batch.
    #[arg(long, default_value_t = 256)]
    pub batch: usize,
    /// Adam learning rate.
    #[arg(long, default_value_t = 1e-3)]
    pub lr: f64,
    /// Weight of the prior term ½‖z‖².
    #[arg(long, default_value_t = 0.02)]
    pub prior_weight: f32,
    /// Soft-min temperature, in the blob's unit (metres for sdd-m).
    #[arg(long, default_value_t = 0.05)]
    pub temperature: f32,
    /// Each latent component is clamped to ±bound (as gpecnet-core does).
    #[arg(long, default_value_t = 8.0)]
    pub bound: f32,
    /// No time-reversed copies of the training windows.
    #[arg(long)]
    pub no_time_reversal: bool,
    /// No mirrored copies of the training windows.
    #[arg(long)]
    pub no_mirror: bool,
    /// Threads (0 = all cores).
    #[arg(long, default_value_t = 1)]
    pub threads: usize,
}

/// Hidden activation of a proposal network.
#[derive(Clone, Copy, Debug, clap::ValueEnum)]
pub enum ActArg {
    /// `max(x, 0)`.
    Relu,
    /// `sin(x)`.
    Sine,
}

impl ProposeArgs {
    /// Runs the command.
    pub fn run(&self) -> Result<ProposalFile> {
        crate::train::set_num_threads(if self.threads == 0 {
            std::thread::available_parallelism().map_or(1, |n| n.get())
        } else {
            self.threads
        });
        let bytes = crate::inpath::read_limited(&self.blob, crate::inpath::FileKind::Blob)?;
        let model = crate::export::read_blob(&bytes)
            .with_context(|| format!("reading {}", self.blob.display()))?;
        let crc = gpecnet_core::Model::from_blob(&bytes)
            .map_err(|e| anyhow::anyhow!("{}: {e}", self.blob.display()))?
            .crc();
        let settings = ProposeSettings {
            blob_crc: crc,
            dataset: self.dataset.clone(),
            val_scenes: data::default_sdd_val_scenes(),
            seed: self.seed,
            k: self.k,
            hidden: if self.codebook {
                Vec::new()
            } else {
                self.hidden.clone()
            },
            act: match self.act {
                ActArg::Relu => Act::Relu,
                ActArg::Sine => Act::Sine,
            },
            codebook: self.codebook,
            epochs: self.epochs,
            batch: self.batch,
            lr: self.lr,
            prior_weight: self.prior_weight,
            temperature: self.temperature,
            bound: self.bound,
            time_reversal: !self.no_time_reversal,
            mirror: !self.no_mirror,
        };
        ProposeRun {
            model: &model,
            settings,
            data_root: self.data.clone(),
            out: self.out.clone(),
            resume: self.resume,
            source: self.blob.clone(),
        }
        .run()
    }
}
