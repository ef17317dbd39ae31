//! `gpecnet propose`: a learned latent proposal for a trained model.
//!
//! A CVAE's endpoint set is normally K latents drawn from the prior (or many more, reduced
//! by k-means, [`gpecnet_reference::tts`]). A proposal replaces the draw with K latents computed from
//! the past: a small network `f → K·zdim` (DLow, Yuan & Kitani, ECCV 2020) on the frozen
//! encoder's features, or, with `codebook`, K fixed latent vectors (its bias alone). It is
//! trained post hoc against the soft minimum over the K endpoint errors (a differentiable
//! best-of-K) plus a small weight on the prior's `½‖z‖²`. The CVAE's networks stay
//! untouched, or, with `tune_decoder` (joint training), the decoder is trained together with
//! the proposal, starting from the blob's, while the encoder and the point head stay frozen.
//! With `point_lr` the point head is trained beside them on the same batches, from the
//! blob's, under its own loss and optimiser; the running average of its weights is selected
//! on its own validation FDE.
//! A starter's window (standing when forecast, far at the horizon) may weigh more in the
//! loss (`starter_weight`), synthetic starters and stoppers on real observed pasts may be
//! added (`synthetic_starters`, `synthetic_stoppers`: [`crate::synthetic::start_stop`]),
//! the proposal may be distilled from a larger one on the same CVAE (`distill`: each
//! endpoint pulled towards the teacher's of the same index), and the parts of a combined
//! data set may weigh the same (`balance`). Every latent component is clamped to `±bound`,
//! in training exactly as in `gpecnet-core`, so the fixed-point decoder's input range is
//! respected by construction.
//!
//! The run folder holds `checkpoint.json` (after every epoch, atomically: the current and
//! the best-validation weights, the optimiser and sampler state), `metrics.csv` and, at the
//! end, `proposal.json` (the best-validation proposal, exported layers). Selection uses the
//! validation windows only; the test set is never read here.
//!
//! Files: `file.rs` (settings, `proposal.json`, the card's record, the fingerprint),
//! `fit.rs` (tensors, loss, validation pass), `run.rs` (the loop and its files), this file
//! (the command line).

mod fit;
mod run;

use std::path::PathBuf;

use anyhow::{bail, Context, Result};

use crate::data;
use crate::network::Act;
use crate::proposal_file::{Distill, ProposalFile, ProposeSettings};
pub use fit::{Encoded, LossSpec, PointData, Teacher, ValScore};
pub use run::ProposeRun;

/// `gpecnet propose`'s options (the command's help text is in the CLI).
#[derive(clap::Args, Debug)]
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
    /// Train on noisy pasts: i.i.d. Gaussian noise of standard deviation SIGMA (the blob's
    /// unit) on each coordinate of the 8 observed positions of every training window, drawn
    /// afresh every epoch, before the frozen encoder sees them (the endpoint targets are taken
    /// relative to the noisy observations, as at inference); validation stays clean.
    /// 0 = none.
    #[arg(long, value_name = "SIGMA", default_value_t = 0.0)]
    pub obs_noise: f32,
    /// Train on the windows of a fixed FRACTION of the training split's tracks, as
    /// `gpecnet train --train-fraction` (the same tracks); validation is never reduced.
    #[arg(long, value_name = "FRACTION", default_value_t = 1.0)]
    pub train_fraction: f32,
    /// Joint training: train the decoder together with the proposal, from the blob's
    /// decoder, under the same loss (its own Adam, --decoder-lr). The encoder and the point
    /// head stay frozen, so the point forecast does not change; `proposal.json` then holds
    /// the tuned decoder, and `gpecnet export --proposal` and `gpecnet score` use it.
    #[arg(long)]
    pub tune_decoder: bool,
    /// Adam learning rate of the decoder under --tune-decoder.
    #[arg(
        long,
        value_name = "LR",
        default_value_t = 1e-4,
        requires = "tune_decoder"
    )]
    pub decoder_lr: f64,
    /// Weight in the loss of a training window whose pedestrian starts walking (standing
    /// when forecast, then more than 1 m away at the horizon); every other window weighs 1.
    /// Needs data in metres.
    #[arg(long, value_name = "W", default_value_t = 1.0)]
    pub starter_weight: f32,
    /// With a combined data set (`A+B`): every part weighs the same in the training loss
    /// and in the validation score that selects the epoch, however many windows it has (a
    /// window of a part with n of the N windows weighs N / (parts · n)).
    #[arg(long)]
    pub balance: bool,
    /// Train the blob's point head too, beside the proposal: on the same windows, batches
    /// and weights (--balance, --starter-weight), under the loss `gpecnet train` gives it
    /// (mean displacement over the 12 steps plus the displacement at the horizon), with its
    /// own Adam (--point-lr); the running average of its weights over about the last 1,000
    /// steps is validated, selected on its own validation FDE and exported (the blob's head
    /// when no epoch beats it). The proposal trains exactly as without it; `proposal.json`
    /// then holds the head, and `gpecnet score` (the radii around the point forecast) and
    /// `gpecnet export --proposal` use it.
    #[arg(long)]
    pub tune_point_head: bool,
    /// Adam learning rate of the point head under --tune-point-head.
    #[arg(
        long,
        value_name = "LR",
        default_value_t = 1e-4,
        requires = "tune_point_head"
    )]
    pub point_lr: f64,
    /// Speed augmentation, comma separated factors: for each factor s, a copy of every
    /// training window (and of its time-reversed and mirrored copies) walked s times as
    /// fast (the path kept, every displacement from the first observed position times s),
    /// as `speed_scales` in `gpecnet train`'s config. Each in [0.25, 4], at most 8 factors
    /// (each one adds a copy of the whole training split). Validation stays as recorded.
    #[arg(long, value_name = "S,...", value_delimiter = ',')]
    pub speed_scales: Vec<f32>,
    /// Synthetic starters: add SHARE times as many training windows (counting the
    /// time-reversed and mirrored copies, not the speed copies) made from real pedestrians
    /// standing when forecast, who stay put for 0-7 steps and then walk off in a random
    /// direction at 0.8-1.6 m/s (their observed positions as recorded). In [0, 1]; needs
    /// data in metres. They are starters, so --starter-weight weighs them too.
    #[arg(long, value_name = "SHARE", default_value_t = 0.0)]
    pub synthetic_starters: f32,
    /// Synthetic stoppers: add SHARE times as many training windows made from real
    /// pedestrians walking when forecast (at least 0.8 m/s), who go on at their last
    /// velocity for 0-6 steps, slow down over two and then stand. In [0, 1]; needs data in
    /// metres.
    #[arg(long, value_name = "SHARE", default_value_t = 0.0)]
    pub synthetic_stoppers: f32,
    /// Distil from a teacher: a blob with a learned proposal of the same K on the same CVAE
    /// (its encoder and decoder identical to --blob's; e.g. weights/sdd-m-lp-host.gpec for
    /// weights/sdd-m-tiny.gpec). Each of the proposal's K endpoints is pulled towards the
    /// teacher's endpoint of the same index, with weight --distill-weight, beside the
    /// best-of-K loss against the truth. Selection stays on validation minFDE.
    #[arg(long, value_name = "FILE")]
    pub teacher: Option<PathBuf>,
    /// Weight of the distance to the teacher's endpoints (the best-of-K term weighs 1).
    #[arg(long, value_name = "W", default_value_t = 1.0, requires = "teacher")]
    pub distill_weight: f32,
}

/// Hidden activation of a proposal network.
#[derive(Clone, Copy, Debug, clap::ValueEnum)]
pub enum ActArg {
    /// `max(x, 0)`.
    Relu,
    /// `sin(x)`.
    Sine,
}

/// The most latents a proposal may give: the core's limit
/// (`gpecnet_core::blob::MAX_PROPOSAL_LATENTS`).
pub const MAX_PROPOSAL_K: usize = gpecnet_core::blob::MAX_PROPOSAL_LATENTS;

/// The most `--speed-scales` factors: each one adds a copy of the whole (time-reversed and
/// mirrored) training split, so 8 already make it 9 times larger.
pub const MAX_SPEED_SCALES: usize = 8;

/// The largest `--distill-weight`: past it the best-of-K term against the truth no longer
/// counts.
pub const MAX_DISTILL_WEIGHT: f32 = 100.0;

/// The largest `--starter-weight`: starters are 1–15 % of a training split, so a larger
/// weight would let a few windows decide every step.
pub const MAX_STARTER_WEIGHT: f32 = 100.0;

impl ProposeArgs {
    /// Every numeric option in its range, before anything is read or allocated; each error
    /// names the option and the range (the training config's bounds where they apply).
    pub fn check_options(&self) -> Result<()> {
        use crate::config::{MAX_BATCH, MAX_HIDDEN_LAYERS, MAX_THREADS, MAX_WIDTH};
        let in_range = |name: &str, v: usize, lo: usize, hi: usize, why: &str| -> Result<()> {
            if v < lo || v > hi {
                bail!("{name} {v} is out of range: allowed {lo}..={hi}{why}");
            }
            Ok(())
        };
        in_range(
            "--k",
            self.k,
            1,
            MAX_PROPOSAL_K,
            " (the most latents a proposal model gives, gpecnet-core's limit)",
        )?;
        in_range("--epochs", self.epochs, 1, usize::MAX, "")?;
        in_range("--batch", self.batch, 1, MAX_BATCH, "")?;
        in_range(
            "--threads",
            self.threads,
            0,
            MAX_THREADS,
            " (0 = all cores)",
        )?;
        if !self.codebook {
            if self.hidden.is_empty() || self.hidden.len() > MAX_HIDDEN_LAYERS {
                bail!(
                    "--hidden has {} layers: allowed 1..={MAX_HIDDEN_LAYERS} (a blob holds at most {} layers per network; --codebook for none)",
                    self.hidden.len(),
                    MAX_HIDDEN_LAYERS + 1
                );
            }
            if let Some(&w) = self.hidden.iter().find(|&&w| w == 0 || w > MAX_WIDTH) {
                bail!("--hidden has a layer of width {w}: allowed widths 1..={MAX_WIDTH}");
            }
        }
        for (name, lr) in [
            ("--lr", self.lr),
            ("--decoder-lr", self.decoder_lr),
            ("--point-lr", self.point_lr),
        ] {
            if !(lr.is_finite() && lr > 0.0 && lr <= 1.0) {
                bail!("{name} {lr} is out of range: allowed a finite number in (0, 1]");
            }
        }
        // Not 0: a batch of starters alone would weigh nothing and its loss divide by 0.
        if !(self.starter_weight > 0.0 && self.starter_weight <= MAX_STARTER_WEIGHT) {
            bail!(
                "--starter-weight {} is out of range: allowed a number in (0, {MAX_STARTER_WEIGHT}]",
                self.starter_weight
            );
        }
        for (name, share) in [
            ("--synthetic-starters", self.synthetic_starters),
            ("--synthetic-stoppers", self.synthetic_stoppers),
        ] {
            if !(share.is_finite() && (0.0..=1.0).contains(&share)) {
                bail!("{name} {share} is out of range: allowed a share in [0, 1] of the training windows");
            }
        }
        if !(self.distill_weight > 0.0 && self.distill_weight <= MAX_DISTILL_WEIGHT) {
            bail!(
                "--distill-weight {} is out of range: allowed a number in (0, {MAX_DISTILL_WEIGHT}]",
                self.distill_weight
            );
        }
        for (name, v) in [("--temperature", self.temperature), ("--bound", self.bound)] {
            if !(v.is_finite() && v > 0.0) {
                bail!("{name} {v} is out of range: allowed a finite number > 0");
            }
        }
        if self.speed_scales.len() > MAX_SPEED_SCALES {
            bail!(
                "--speed-scales has {} factors: allowed at most {MAX_SPEED_SCALES} (each adds a copy of the training split)",
                self.speed_scales.len()
            );
        }
        let range = crate::config::SPEED_SCALE_RANGE;
        if let Some(f) = self
            .speed_scales
            .iter()
            .find(|f| !(f.is_finite() && range.contains(*f)))
        {
            bail!(
                "--speed-scales has the factor {f}: allowed numbers in [{}, {}]",
                range.start(),
                range.end()
            );
        }
        let max_noise = crate::config::MAX_OBS_NOISE;
        if !(self.obs_noise.is_finite() && (0.0..=max_noise).contains(&self.obs_noise)) {
            bail!(
                "--obs-noise {} is out of range: allowed a finite number in [0, {max_noise}] (the blob's unit)",
                self.obs_noise
            );
        }
        if !(self.train_fraction.is_finite()
            && self.train_fraction > 0.0
            && self.train_fraction <= 1.0)
        {
            bail!(
                "--train-fraction {} is out of range: allowed a finite number in (0, 1]",
                self.train_fraction
            );
        }
        if !(self.prior_weight.is_finite() && self.prior_weight >= 0.0) {
            bail!(
                "--prior-weight {} is out of range: allowed a finite number >= 0",
                self.prior_weight
            );
        }
        Ok(())
    }

    /// The proposal's size for the frozen `model`, before any allocation: at most the
    /// training config's parameter limit, and one batch's decoder activations (`batch · k`
    /// decodes) within its activation limit.
    fn check_size(&self, model: &crate::reference::RefModel) -> Result<()> {
        use crate::config::{MAX_PARAMETERS, MAX_TRAIN_ACTIVATION_BYTES};
        let c = &model.config;
        let hidden: &[usize] = if self.codebook { &[] } else { &self.hidden };
        let widths: Vec<u128> = std::iter::once(c.fdim)
            .chain(hidden.iter().copied())
            .chain(std::iter::once(self.k * c.zdim))
            .map(|w| w as u128)
            .collect();
        let params: u128 = widths.windows(2).map(|w| w[0] * w[1] + w[1]).sum();
        if params > u128::from(MAX_PARAMETERS) {
            bail!(
                "the proposal ({} -> {hidden:?} -> K·zdim = {}) has {params} parameters, over the limit of {MAX_PARAMETERS}: make --hidden or --k smaller",
                c.fdim,
                self.k * c.zdim
            );
        }
        let widest = model
            .nets
            .decoder
            .iter()
            .map(|l| l.out_dim.max(l.in_dim))
            .chain(widths.iter().map(|&w| w as usize))
            .max()
            .unwrap_or(0) as u128;
        let bytes = (self.batch as u128) * (self.k as u128) * widest * 4;
        if bytes > u128::from(MAX_TRAIN_ACTIVATION_BYTES) {
            bail!(
                "--batch {} with --k {}: one batch decodes {} endpoints through layers up to {widest} wide ({bytes} bytes of activations), over the limit of {MAX_TRAIN_ACTIVATION_BYTES} bytes: make --batch smaller",
                self.batch,
                self.k,
                (self.batch as u128) * (self.k as u128)
            );
        }
        Ok(())
    }

    /// Runs the command.
    pub fn run(&self) -> Result<ProposalFile> {
        self.check_options()?;
        crate::train::set_num_threads(if self.threads == 0 {
            std::thread::available_parallelism().map_or(1, |n| n.get())
        } else {
            self.threads
        });
        let bytes = crate::inpath::read_limited(&self.blob, crate::inpath::FileKind::Blob)?;
        let model = crate::export::read_blob(&bytes)
            .with_context(|| format!("reading {}", self.blob.display()))?;
        let core = gpecnet_core::Model::from_blob(&bytes)
            .map_err(|e| anyhow::anyhow!("{}: {e}", self.blob.display()))?;
        let crc = core.crc();
        self.check_size(&model)?;
        // The blob's unit and clock must be the data's, and the run folder outside the
        // data and apart from the blob's files.
        let spec = data::DatasetSpec::parse(&self.dataset).map_err(anyhow::Error::msg)?;
        if self.balance && !matches!(spec, data::DatasetSpec::Combined(_)) {
            bail!(
                "--balance weighs the parts of a combined data set (`A+B`); {} is one data set",
                self.dataset
            );
        }
        let meta = gpecnet_core::blob::Meta::of_blob(&bytes)
            .map_err(|e| anyhow::anyhow!("{}: {e}", self.blob.display()))?;
        data::units::check_unit(&core, &meta, &spec, None)
            .with_context(|| format!("proposing latents for {}", self.blob.display()))?;
        let teacher = match &self.teacher {
            Some(path) => {
                let bytes = crate::inpath::read_limited(path, crate::inpath::FileKind::Blob)?;
                let crc = gpecnet_core::Model::from_blob(&bytes)
                    .map_err(|e| anyhow::anyhow!("--teacher {}: {e}", path.display()))?
                    .crc();
                let t = crate::export::read_blob(&bytes)
                    .with_context(|| format!("reading --teacher {}", path.display()))?;
                let t = fit::Teacher::of(&t, &model, self.k)
                    .with_context(|| format!("--teacher {}", path.display()))?;
                Some((t, crc))
            }
            None => None,
        };
        let mut sidecars = crate::outpath::blob_and_sidecars(&self.blob).to_vec();
        if let Some(t) = &self.teacher {
            sidecars.extend(crate::outpath::blob_and_sidecars(t));
            sidecars.push(t.clone());
        }
        let mut inputs: Vec<&std::path::Path> = sidecars.iter().map(PathBuf::as_path).collect();
        inputs.push(&self.blob);
        let data_dirs = crate::outpath::data_input_dirs(&self.data);
        let dirs: Vec<&std::path::Path> = data_dirs.iter().map(PathBuf::as_path).collect();
        for file in ["proposal.json", "checkpoint.json", "metrics.csv"] {
            crate::outpath::check_output("--out", &self.out.join(file), &inputs, &dirs)?;
        }
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
            obs_noise: self.obs_noise,
            train_fraction: self.train_fraction,
            decoder_lr: self.tune_decoder.then_some(self.decoder_lr),
            starter_weight: self.starter_weight,
            balance: self.balance,
            point_lr: self.tune_point_head.then_some(self.point_lr),
            speed_scales: self.speed_scales.clone(),
            synthetic_starters: self.synthetic_starters,
            synthetic_stoppers: self.synthetic_stoppers,
            distill: match (&self.teacher, &teacher) {
                (Some(path), Some((_, crc))) => Some(Distill {
                    teacher: path.display().to_string(),
                    teacher_crc: *crc,
                    weight: self.distill_weight,
                }),
                _ => None,
            },
        };
        ProposeRun {
            model: &model,
            settings,
            data_root: self.data.clone(),
            out: self.out.clone(),
            resume: self.resume,
            source: self.blob.clone(),
            teacher: teacher.as_ref().map(|(t, _)| t),
        }
        .run()
    }
}
