//! The training loop (`gpecnet train`).
//!
//! * Data: SDD `train` minus the validation scenes (or ETH/UCY `<scene>/train`), plus, with
//!   `augment_pct > 0`, the first `augment_pct` % (of the real count) of the synthetic pool;
//!   every window plus its time-reversed copy (PECNet), normalised with [`data::normalize`].
//! * Each epoch: seeded shuffle, minibatches of `batch_size`, Adam on PECNet's loss, then
//!   (every `eval_every` epochs and at the last) best-of-K validation in raw units with latents
//!   `z ~ N(0, sigma^2)` drawn from a validation RNG re-seeded identically every time, so
//!   epochs are compared on the same draws. The best epoch is chosen by validation min FDE;
//!   the test set is never read.
//! * After every epoch: `checkpoint.bin` (atomic; the one before kept as
//!   `checkpoint.prev.bin`), `metrics.csv`, `metrics.jsonl`, `curves.svg` in the run
//!   directory; `config.toml` and `data-fingerprint.json` once at the start.
//! * Run-folder safety ([`crate::rundir`]): one run per folder (lock file), no silent
//!   overwrite of a non-empty folder, `--resume` checks config and data.
//!
//! Determinism: all randomness comes from [`crate::rng`]; candle's CPU matmul thread count is
//! pinned from `TrainConfig::threads` via `RAYON_NUM_THREADS` (read by candle for every
//! matmul) before the first tensor operation. Two runs with the same config, data and thread
//! count produce bit-identical weights, and `--resume` continues bit-exactly. The variable, not
//! a local `rayon::ThreadPool`, is the knob on purpose: candle 0.11 sizes every CPU matmul from
//! `candle_core::utils::get_num_threads()`, which reads `RAYON_NUM_THREADS` itself (falling back
//! to the machine's core count), whatever pool the call runs in.

use std::io::{IsTerminal, Write};
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{bail, Context, Result};
use candle_core::{Device, Tensor};
use indicatif::{MultiProgress, ProgressBar, ProgressDrawTarget, ProgressStyle};

use crate::checkpoint::{self, BestModel, Checkpoint, EpochMetrics};
use crate::config::{DatasetSpec, TrainConfig};
use crate::data::{self, Sample, Unit, Window, FUTURE, PAST};
use crate::eval::{Metrics, MetricsAccumulator, Prediction};
use crate::model::{Batch, Model};
use crate::optim::{Adam, AdamParams};
use crate::rng::{streams, Rng};
use crate::rundir::{self, RunLock};

/// Windows evaluated per validation forward pass (times K rows).
pub const VAL_CHUNK: usize = 512;

/// Pin candle's CPU matmul parallelism to `n` threads (see the module docs). Must be called
/// before the first tensor operation of the process to also size rayon's global pool.
pub fn set_num_threads(n: usize) {
    let n = n.max(1).to_string();
    if std::env::var("RAYON_NUM_THREADS").ok().as_deref() != Some(n.as_str()) {
        std::env::set_var("RAYON_NUM_THREADS", n);
    }
}

/// Training and validation data, ready for the loop.
#[derive(Clone, Debug)]
pub struct PreparedData {
    /// Normalised training samples: the real windows, then the synthetic ones, then (when
    /// enabled) the time-reversed copies of both in the same order.
    pub train: Vec<Sample>,
    /// Real training windows (before time reversal).
    pub n_real: usize,
    /// Synthetic windows added by `augment_pct` (before time reversal).
    pub n_synthetic: usize,
    /// Validation windows (raw, or in the heading-canonical frame when the config asks).
    pub val: Vec<Window>,
    /// Unit of the raw coordinates.
    pub unit: Unit,
    /// Social groups of `train` (indices; [`social_train_groups`]); empty without
    /// `social_pooling`.
    pub groups: Vec<Vec<u32>>,
    /// Fingerprint of the raw windows (checked by `--resume`).
    pub fingerprint: DataFingerprint,
}

/// Social groups of the training windows (`social_pooling`): PECNet's star grouping
/// ([`crate::social::group_windows`]) of the real windows, file by file; synthetic windows
/// are singletons; the time-reversed copies (the second half of `train` when `reversed`) form
/// the same groups as their originals (PECNet reuses each batch's mask).
pub fn social_train_groups(
    cfg: &TrainConfig,
    train: &[Window],
    n_real: usize,
    reversed: bool,
) -> Vec<Vec<u32>> {
    let n_fwd = if reversed {
        train.len() / 2
    } else {
        train.len()
    };
    let mut groups: Vec<Vec<u32>> =
        crate::social::group_windows(&train[..n_real], cfg.time_thresh, cfg.dist_thresh)
            .into_iter()
            .map(|g| g.into_iter().map(|i| i as u32).collect())
            .collect();
    groups.extend((n_real..n_fwd).map(|i| vec![i as u32]));
    if reversed {
        let rev: Vec<Vec<u32>> = groups
            .iter()
            .map(|g| g.iter().map(|&i| i + n_fwd as u32).collect())
            .collect();
        groups.extend(rev);
    }
    groups
}

/// The synthetic windows `cfg` adds to `n_real` real training windows: the first
/// `round(augment_pct / 100 × n_real)` trajectories of `cfg.synthetic_pool`
/// ([`crate::synth::sample::take_first_pct`]); none when `augment_pct` is 0.
pub fn synthetic_windows(cfg: &TrainConfig, n_real: usize) -> Result<Vec<Window>> {
    if cfg.augment_pct <= 0.0 {
        return Ok(Vec::new());
    }
    let Some(path) = cfg.synthetic_pool.as_deref() else {
        bail!("augment_pct = {} needs synthetic_pool", cfg.augment_pct);
    };
    let pool = crate::synth::sample::read_pool(Path::new(path))?;
    crate::synth::sample::take_first_pct(&pool, f64::from(cfg.augment_pct), n_real)
        .with_context(|| format!("augmenting from {path}"))
}

/// Load and prepare the data a config asks for. Never touches the test split.
pub fn prepare_data(cfg: &TrainConfig, data_root: &Path) -> Result<PreparedData> {
    let (train, val) = match cfg.dataset_spec()? {
        DatasetSpec::Sdd => {
            let all = data::load_sdd(data_root, data::SddSplit::Train)?;
            for s in &cfg.val_scenes {
                if !all.windows.iter().any(|w| &w.scene == s) {
                    bail!("validation scene {s:?} is not in {}", all.name);
                }
            }
            let (mut train, val) = data::split_by_scene(all, &cfg.val_scenes);
            if cfg.include_train_extra {
                let extra = data::load_sdd(data_root, data::SddSplit::TrainExtra)?;
                train.windows.extend(extra.windows);
            }
            (train, val)
        }
        DatasetSpec::EthUcy(scene) => (
            data::load_eth_ucy(data_root, &scene, data::EthUcySplit::Train)?,
            data::load_eth_ucy(data_root, &scene, data::EthUcySplit::Val)?,
        ),
    };
    if train.is_empty() || val.is_empty() {
        bail!(
            "empty split: {} training and {} validation windows",
            train.len(),
            val.len()
        );
    }
    let unit = train.unit;
    let mut train = train;
    let n_real = train.len();
    let synthetic = synthetic_windows(cfg, n_real)?;
    let n_synthetic = synthetic.len();
    train.windows.extend(synthetic);
    let fingerprint = DataFingerprint::of(&train.windows, n_real, &val.windows);
    let train = if cfg.time_reversal {
        train.with_time_reversed()
    } else {
        train
    };
    let groups = if cfg.social_pooling {
        social_train_groups(cfg, &train.windows, n_real, cfg.time_reversal)
    } else {
        Vec::new()
    };
    // Heading-canonical frame: every window (each time-reversed copy by its own heading).
    // ADE/FDE are rotation-invariant, so validation runs in the canonical frame too.
    let canon = |ws: Vec<Window>| -> Vec<Window> {
        if cfg.heading_steps == 0 {
            ws
        } else {
            ws.iter()
                .map(|w| crate::frame::canonical_window(w, cfg.heading_steps).0)
                .collect()
        }
    };
    let mut train_windows = canon(train.windows);
    if cfg.mirror {
        let mirrored: Vec<Window> = train_windows
            .iter()
            .map(|w| {
                let mut m = w.clone();
                for p in m.pos.iter_mut() {
                    p[1] = -p[1];
                }
                m
            })
            .collect();
        train_windows.extend(mirrored);
    }
    Ok(PreparedData {
        fingerprint,
        groups,
        train: train_windows
            .iter()
            .map(|w| data::normalize(w, cfg.data_scale))
            .collect(),
        val: canon(val.windows),
        unit,
        n_real,
        n_synthetic,
    })
}

/// Mean training loss parts of one epoch.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TrainLoss {
    /// Total loss.
    pub total: f64,
    /// Endpoint MSE.
    pub rcl: f64,
    /// KLD.
    pub kld: f64,
    /// Intermediate-points MSE.
    pub adl: f64,
    /// Point-head loss (0 without a head).
    pub point: f64,
}

/// Model + optimizer + RNG + history: the whole mutable state of a run.
pub struct Trainer {
    cfg: TrainConfig,
    data: PreparedData,
    model: Model,
    adam: Adam,
    rng: Rng,
    epochs_done: usize,
    history: Vec<EpochMetrics>,
    best: Option<BestModel>,
    best_point: Option<BestModel>,
}

impl Trainer {
    /// Fresh run: weights from the INIT stream, shuffling/noise from the TRAIN stream.
    pub fn new(cfg: TrainConfig, data: PreparedData) -> Result<Self> {
        cfg.validate()?;
        set_num_threads(cfg.resolved_threads());
        let model = Model::new(&cfg, &mut Rng::with_stream(cfg.seed, streams::INIT))?;
        let adam = Adam::new(model.vars(), AdamParams::with_lr(cfg.learning_rate));
        let rng = Rng::with_stream(cfg.seed, streams::TRAIN);
        Ok(Self {
            cfg,
            data,
            model,
            adam,
            rng,
            epochs_done: 0,
            history: Vec::new(),
            best: None,
            best_point: None,
        })
    }

    /// Continue from a checkpoint (its config must be the one `data` was prepared with).
    pub fn from_checkpoint(ckpt: Checkpoint, data: PreparedData) -> Result<Self> {
        let cfg = ckpt.config()?;
        set_num_threads(cfg.resolved_threads());
        let model = Model::new(&cfg, &mut Rng::new(0))?;
        model
            .set_weights(&ckpt.weights)
            .context("checkpoint weights do not match its config")?;
        let adam = Adam::from_state(
            model.vars(),
            AdamParams::with_lr(cfg.learning_rate),
            ckpt.adam.clone(),
        )
        .context("checkpoint optimizer state does not match its config")?;
        Ok(Self {
            rng: ckpt.rng(),
            cfg,
            data,
            model,
            adam,
            epochs_done: ckpt.epochs_done,
            history: ckpt.history,
            best: ckpt.best,
            best_point: ckpt.best_point,
        })
    }

    /// The config.
    pub fn config(&self) -> &TrainConfig {
        &self.cfg
    }

    /// Override the total number of epochs (`--epochs`).
    pub fn set_num_epochs(&mut self, n: usize) {
        self.cfg.num_epochs = n;
    }

    /// The model (current weights).
    pub fn model(&self) -> &Model {
        &self.model
    }

    /// Finished epochs.
    pub fn epochs_done(&self) -> usize {
        self.epochs_done
    }

    /// Per-epoch metrics so far.
    pub fn history(&self) -> &[EpochMetrics] {
        &self.history
    }

    /// Best epoch so far.
    pub fn best(&self) -> Option<&BestModel> {
        self.best.as_ref()
    }

    /// The prepared data.
    pub fn data(&self) -> &PreparedData {
        &self.data
    }

    /// Number of minibatches per epoch.
    pub fn batches_per_epoch(&self) -> usize {
        self.data.train.len().div_ceil(self.cfg.batch_size)
    }

    /// One pass over the shuffled training set. Does not advance `epochs_done`
    /// (see [`Trainer::run_epoch`]).
    pub fn train_epoch(&mut self, bar: Option<&ProgressBar>) -> Result<TrainLoss> {
        let lr = self.cfg.lr_schedule.lr(
            self.cfg.learning_rate,
            self.epochs_done,
            self.cfg.num_epochs,
        );
        self.adam.set_lr(lr);
        let mut order: Vec<u32> = (0..self.data.train.len() as u32).collect();
        self.rng.shuffle(&mut order);
        let zdim = self.model.zdim();
        let mut acc = TrainLoss::default();
        let mut nb = 0usize;
        // Social pooling: shuffle whole groups and pack them (never split) into batches.
        let batches: Vec<(Vec<u32>, Option<Vec<usize>>)> = if self.model.has_social() {
            let mut gorder: Vec<u32> = (0..self.data.groups.len() as u32).collect();
            self.rng.shuffle(&mut gorder);
            let shuffled: Vec<&[u32]> = gorder
                .iter()
                .map(|&g| self.data.groups[g as usize].as_slice())
                .collect();
            crate::social::pack_groups(&shuffled, self.cfg.batch_size)
                .iter()
                .map(|groups| {
                    let rows = groups.iter().flat_map(|g| g.iter().copied()).collect();
                    (rows, Some(groups.iter().map(|g| g.len()).collect()))
                })
                .collect()
        } else {
            order
                .chunks(self.cfg.batch_size)
                .map(|c| (c.to_vec(), None))
                .collect()
        };
        for (chunk, sizes) in batches {
            let batch = Batch::from_samples(chunk.iter().map(|&i| &self.data.train[i as usize]))?;
            let eps = self.rng.normal_vec(chunk.len() * zdim, 1.0);
            let eps = Tensor::from_vec(eps, (chunk.len(), zdim), &Device::Cpu)?;
            let mask = sizes.map(|s| crate::social::block_mask(&s)).transpose()?;
            let loss = self.model.loss_masked(&batch, &eps, mask.as_ref())?;
            self.adam.backward_step(&loss.total)?;
            let total = loss.total.to_scalar::<f32>()?;
            if !total.is_finite() {
                bail!(
                    "training diverged: loss is {total} at epoch {}",
                    self.epochs_done + 1
                );
            }
            acc.total += f64::from(total);
            acc.rcl += f64::from(loss.rcl);
            acc.kld += f64::from(loss.kld);
            acc.adl += f64::from(loss.adl);
            acc.point += f64::from(loss.point);
            nb += 1;
            if let Some(b) = bar {
                b.inc(1);
            }
        }
        let n = nb.max(1) as f64;
        Ok(TrainLoss {
            total: acc.total / n,
            rcl: acc.rcl / n,
            kld: acc.kld / n,
            adl: acc.adl / n,
            point: acc.point / n,
        })
    }

    /// Best-of-K validation of the current weights, in raw units.
    pub fn validate(&self) -> Result<Metrics> {
        validate_model(&self.model, &self.cfg, &self.data.val)
    }

    /// Train one epoch, validate when due, update best / history.
    pub fn run_epoch(&mut self, bar: Option<&ProgressBar>) -> Result<EpochMetrics> {
        let t0 = Instant::now();
        let loss = self.train_epoch(bar)?;
        self.epochs_done += 1;
        let epoch = self.epochs_done;
        let due = epoch.is_multiple_of(self.cfg.eval_every) || epoch >= self.cfg.num_epochs;
        let val = if due { Some(self.validate()?) } else { None };
        let val_point = if due {
            validate_point(&self.model, &self.cfg, &self.data.val)?
        } else {
            None
        };
        if let Some(v) = val {
            if self.best.as_ref().is_none_or(|b| v.min_fde < b.val.min_fde) {
                self.best = Some(BestModel {
                    epoch,
                    val: v,
                    weights: self.model.weights()?,
                });
            }
        }
        if let Some(v) = val_point {
            if self
                .best_point
                .as_ref()
                .is_none_or(|b| v.fde_k1 < b.val.fde_k1)
            {
                self.best_point = Some(BestModel {
                    epoch,
                    val: v,
                    weights: self.model.weights()?,
                });
            }
        }
        let m = EpochMetrics {
            epoch,
            train_loss: loss.total,
            train_rcl: loss.rcl,
            train_kld: loss.kld,
            train_adl: loss.adl,
            val,
            seconds: t0.elapsed().as_secs_f64(),
            train_point: loss.point,
            val_point,
        };
        self.history.push(m.clone());
        Ok(m)
    }

    /// Snapshot of the complete state.
    pub fn checkpoint(&self) -> Result<Checkpoint> {
        Ok(Checkpoint {
            config_toml: self.cfg.to_toml_string()?,
            epochs_done: self.epochs_done,
            weights: self.model.weights()?,
            adam: self.adam.state().clone(),
            rng: self.rng.state(),
            best: self.best.clone(),
            history: self.history.clone(),
            best_point: self.best_point.clone(),
        })
    }

    /// Best epoch of the point head so far (by validation FDE), when the model has one.
    pub fn best_point(&self) -> Option<&BestModel> {
        self.best_point.as_ref()
    }
}

/// Validation of the point head (K = 1 metrics of its deterministic forecast), or `None`
/// when the model has no head.
pub fn validate_point(
    model: &Model,
    cfg: &TrainConfig,
    windows: &[Window],
) -> Result<Option<Metrics>> {
    if model.point_head.is_none() {
        return Ok(None);
    }
    let mut acc = MetricsAccumulator::new();
    for chunk in windows.chunks(VAL_CHUNK) {
        let obs: Vec<f32> = chunk
            .iter()
            .flat_map(|w| {
                let s = data::normalize(w, cfg.data_scale);
                s.obs.into_iter().flatten()
            })
            .collect();
        let obs = Tensor::from_vec(obs, (chunk.len(), 2 * PAST), &Device::Cpu)?;
        let Some(pred) = model.point_forecast(&obs)? else {
            return Ok(None);
        };
        let fut = pred.flatten_all()?.to_vec1::<f32>()?;
        for (i, w) in chunk.iter().enumerate() {
            let mut t = [[0.0f32; 2]; FUTURE];
            for (s, p) in t.iter_mut().enumerate() {
                let b = (i * FUTURE + s) * 2;
                *p = data::denormalize_point([fut[b], fut[b + 1]], w.pos[0], cfg.data_scale);
            }
            acc.add(w, &Prediction::single(t))?;
        }
    }
    Ok(Some(acc.finish()))
}

/// Best-of-K validation of `model` on raw `windows`: K = `cfg.k` futures per window with
/// `z ~ N(0, sigma^2)` from a fresh VALIDATION-stream RNG (identical draws every call),
/// mapped back to raw units (`p / data_scale + p0`).
///
/// With social pooling the windows are grouped like the training data
/// ([`crate::social::group_windows`]), packed into chunks without splitting groups, and each
/// of the K samples is pooled over its own copy of the chunk (the same latents as without
/// pooling: row `i * K + j` is sample `j` of window `i`).
pub fn validate_model(model: &Model, cfg: &TrainConfig, windows: &[Window]) -> Result<Metrics> {
    if model.has_social() {
        return validate_social(model, cfg, windows);
    }
    let mut rng = Rng::with_stream(cfg.seed, streams::VALIDATION);
    let k = cfg.k;
    let zdim = model.zdim();
    let mut acc = MetricsAccumulator::new();
    for chunk in windows.chunks(VAL_CHUNK) {
        let samples: Vec<Sample> = chunk
            .iter()
            .map(|w| data::normalize(w, cfg.data_scale))
            .collect();
        let rows = chunk.len() * k;
        let mut obs: Vec<f32> = Vec::with_capacity(rows * 2 * PAST);
        let mut init: Vec<f32> = Vec::with_capacity(rows * 2);
        for s in &samples {
            for _ in 0..k {
                obs.extend(s.obs.iter().flatten());
                init.extend(s.initial_pos);
            }
        }
        let obs = Tensor::from_vec(obs, (rows, 2 * PAST), &Device::Cpu)?;
        let init = Tensor::from_vec(init, (rows, 2), &Device::Cpu)?;
        let z = Tensor::from_vec(
            rng.normal_vec(rows * zdim, cfg.sigma),
            (rows, zdim),
            &Device::Cpu,
        )?;
        let fut = model
            .sample_future(&obs, &init, &z)?
            .flatten_all()?
            .to_vec1::<f32>()?;
        for (i, w) in chunk.iter().enumerate() {
            let trajectories = (0..k)
                .map(|j| {
                    let base = (i * k + j) * FUTURE * 2;
                    let mut t = [[0.0f32; 2]; FUTURE];
                    for (s, p) in t.iter_mut().enumerate() {
                        let q = [fut[base + 2 * s], fut[base + 2 * s + 1]];
                        *p = data::denormalize_point(q, w.pos[0], cfg.data_scale);
                    }
                    t
                })
                .collect();
            acc.add(w, &Prediction { trajectories })?;
        }
    }
    Ok(acc.finish())
}

fn validate_social(model: &Model, cfg: &TrainConfig, windows: &[Window]) -> Result<Metrics> {
    let mut rng = Rng::with_stream(cfg.seed, streams::VALIDATION);
    let (k, zdim) = (cfg.k, model.zdim());
    let groups: Vec<Vec<u32>> =
        crate::social::group_windows(windows, cfg.time_thresh, cfg.dist_thresh)
            .into_iter()
            .map(|g| g.into_iter().map(|i| i as u32).collect())
            .collect();
    let mut acc = MetricsAccumulator::new();
    for chunk_groups in crate::social::pack_groups(&groups, VAL_CHUNK) {
        let idx: Vec<usize> = chunk_groups
            .iter()
            .flat_map(|g| g.iter().map(|&i| i as usize))
            .collect();
        let sizes: Vec<usize> = chunk_groups.iter().map(|g| g.len()).collect();
        let mask = crate::social::block_mask(&sizes)?;
        let n = idx.len();
        let samples: Vec<Sample> = idx
            .iter()
            .map(|&i| data::normalize(&windows[i], cfg.data_scale))
            .collect();
        let obs: Vec<f32> = samples
            .iter()
            .flat_map(|s| s.obs.iter().flatten())
            .copied()
            .collect();
        let init: Vec<f32> = samples.iter().flat_map(|s| s.initial_pos).collect();
        let obs = Tensor::from_vec(obs, (n, 2 * PAST), &Device::Cpu)?;
        let init = Tensor::from_vec(init, (n, 2), &Device::Cpu)?;
        let z_all = rng.normal_vec(n * k * zdim, cfg.sigma);
        // fut[j]: [n, FUTURE, 2] flattened, for sample j of every window.
        let mut fut = Vec::with_capacity(k);
        for j in 0..k {
            let z: Vec<f32> = (0..n)
                .flat_map(|i| {
                    z_all[(i * k + j) * zdim..(i * k + j + 1) * zdim]
                        .iter()
                        .copied()
                })
                .collect();
            let z = Tensor::from_vec(z, (n, zdim), &Device::Cpu)?;
            fut.push(
                model
                    .sample_future_masked(&obs, &init, &z, Some(&mask))?
                    .flatten_all()?
                    .to_vec1::<f32>()?,
            );
        }
        for (i, &wi) in idx.iter().enumerate() {
            let w = &windows[wi];
            let trajectories = fut
                .iter()
                .map(|f| {
                    let base = i * FUTURE * 2;
                    let mut t = [[0.0f32; 2]; FUTURE];
                    for (s, p) in t.iter_mut().enumerate() {
                        let q = [f[base + 2 * s], f[base + 2 * s + 1]];
                        *p = data::denormalize_point(q, w.pos[0], cfg.data_scale);
                    }
                    t
                })
                .collect();
            acc.add(w, &Prediction { trajectories })?;
        }
    }
    Ok(acc.finish())
}

/// Options of one `gpecnet train` invocation.
#[derive(Clone, Debug)]
pub struct TrainOptions {
    /// Data root (`shared/data`).
    pub data_root: PathBuf,
    /// Run directory (checkpoint, metrics, curves).
    pub run_dir: PathBuf,
    /// Override `num_epochs` (total epochs of the run, also when resuming).
    pub epochs: Option<usize>,
    /// No progress bars / per-epoch lines.
    pub quiet: bool,
    /// Stop (as if killed) after this many epochs of this invocation; for tests.
    pub stop_after: Option<usize>,
    /// New runs: start even when the run directory already holds files (overwriting
    /// `config.toml`, `metrics.*`, `curves.svg`); never overrides a checkpoint or a lock.
    pub force: bool,
}

/// Result of a training invocation.
#[derive(Clone, Debug)]
pub struct TrainSummary {
    /// Finished epochs of the run (in total).
    pub epochs_done: usize,
    /// Validation metrics of the last validated epoch.
    pub last_val: Option<Metrics>,
    /// Best epoch and its validation metrics.
    pub best: Option<(usize, Metrics)>,
    /// The run directory.
    pub run_dir: PathBuf,
    /// Unit of the metrics.
    pub unit: Unit,
}

/// Start a new run in `opts.run_dir`: takes the run lock ([`crate::rundir`]), refuses a
/// folder with a checkpoint (continue it with `--resume`) and, unless `opts.force`, a folder
/// that holds any other file; writes `config.toml` and the data fingerprint, then trains.
pub fn train_new(cfg: TrainConfig, opts: &TrainOptions) -> Result<TrainSummary> {
    let mut cfg = cfg;
    if let Some(n) = opts.epochs {
        cfg.num_epochs = n;
    }
    cfg.validate()?;
    std::fs::create_dir_all(&opts.run_dir)
        .with_context(|| format!("cannot create {}", opts.run_dir.display()))?;
    let _lock = RunLock::acquire(&opts.run_dir)?;
    rundir::remove_stale_temp_files(&opts.run_dir);
    let ckpt_path = opts.run_dir.join(checkpoint::CHECKPOINT_FILE);
    if ckpt_path.exists() || opts.run_dir.join(checkpoint::PREV_FILE).exists() {
        bail!(
            "{} already exists: continue it with `gpecnet train --resume --out {}` or pick another --out",
            ckpt_path.display(),
            opts.run_dir.display()
        );
    }
    let existing = rundir::existing_entries(&opts.run_dir)?;
    if !existing.is_empty() && !opts.force {
        bail!(
            "{} is not empty ({}) and has no checkpoint: a new run would overwrite config.toml, \
             metrics.csv, metrics.jsonl and curves.svg there. Pick another --out, or pass --force \
             to overwrite",
            opts.run_dir.display(),
            existing.join(", ")
        );
    }
    set_num_threads(cfg.resolved_threads());
    // Nothing is written before the data load: a run that fails there (wrong --data, a bad
    // file) leaves the folder as it was, so the corrected command needs no --force.
    let data = prepare_data(&cfg, &opts.data_root)?;
    std::fs::write(opts.run_dir.join("config.toml"), cfg.to_toml_string()?)?;
    data.fingerprint.save(&opts.run_dir)?;
    let trainer = Trainer::new(cfg, data)?;
    run_loop(trainer, opts)
}

/// Continue the run in `opts.run_dir` from its checkpoint.
pub fn train_resume(opts: &TrainOptions) -> Result<TrainSummary> {
    train_resume_checked(opts, None)
}

/// Continue the run in `opts.run_dir` from its checkpoint (falling back to the previous one,
/// with a warning, when the newest is unusable). Takes the run lock and removes stale temp
/// files first. Refuses when `expected` (a config given with `--resume`) or the folder's
/// `config.toml` differs from the checkpoint's config (`num_epochs` aside: `--epochs` may
/// extend a run), or when the data differ from the fingerprint stored at the start of the
/// run; the errors say what differs.
pub fn train_resume_checked(
    opts: &TrainOptions,
    expected: Option<&TrainConfig>,
) -> Result<TrainSummary> {
    if opts.epochs == Some(0) {
        bail!("--epochs = 0 is out of range: allowed 1 or more");
    }
    if !opts.run_dir.is_dir() {
        bail!(
            "{} does not exist: nothing to resume (start a run with --config)",
            opts.run_dir.display()
        );
    }
    let _lock = RunLock::acquire(&opts.run_dir)?;
    rundir::remove_stale_temp_files(&opts.run_dir);
    let ckpt = checkpoint::load_for_resume(&opts.run_dir)?;
    let cfg = ckpt.config()?;
    if let Some(e) = expected {
        let d = config_diff(&cfg, e)?;
        if !d.is_empty() {
            bail!(
                "--config differs from the config of the run in {} ({}); resume without --config or start a new run in another --out",
                opts.run_dir.display(),
                d.join("; ")
            );
        }
    }
    let toml_path = opts.run_dir.join("config.toml");
    if let Ok(text) = std::fs::read_to_string(&toml_path) {
        let folder = TrainConfig::from_toml_str(&text)
            .with_context(|| format!("in {}", toml_path.display()))?;
        let d = config_diff(&cfg, &folder)?;
        if !d.is_empty() {
            bail!(
                "{} does not match the checkpoint's config ({}): the folder mixes two runs; refusing to resume",
                toml_path.display(),
                d.join("; ")
            );
        }
    }
    set_num_threads(cfg.resolved_threads());
    let data = prepare_data(&cfg, &opts.data_root)?;
    match DataFingerprint::load(&opts.run_dir)? {
        Some(stored) => {
            let d = stored.diff(&data.fingerprint);
            if !d.is_empty() {
                bail!(
                    "the data under {} differ from the data the run in {} started with: {}; \
                     resume with the same data (--data) or start a new run",
                    opts.data_root.display(),
                    opts.run_dir.display(),
                    d.join("; ")
                );
            }
        }
        None => {
            eprintln!(
                "warning: {} has no {} (a run from an older gpecnet): the data cannot be checked; recording the current data",
                opts.run_dir.display(),
                DataFingerprint::FILE
            );
            data.fingerprint.save(&opts.run_dir)?;
        }
    }
    let mut trainer = Trainer::from_checkpoint(ckpt, data)?;
    if let Some(n) = opts.epochs {
        trainer.set_num_epochs(n);
    }
    run_loop(trainer, opts)
}

/// Keys whose values differ between two configs (`num_epochs` is ignored), as
/// `key: a -> b`.
pub fn config_diff(a: &TrainConfig, b: &TrainConfig) -> Result<Vec<String>> {
    let ta: toml::Table = toml::from_str(&a.to_toml_string()?)?;
    let tb: toml::Table = toml::from_str(&b.to_toml_string()?)?;
    let mut keys: Vec<&String> = ta.keys().chain(tb.keys()).collect();
    keys.sort();
    keys.dedup();
    let show = |v: Option<&toml::Value>| v.map_or("(default)".to_string(), |v| v.to_string());
    Ok(keys
        .into_iter()
        .filter(|k| k.as_str() != "num_epochs" && ta.get(*k) != tb.get(*k))
        .map(|k| format!("{k}: {} -> {}", show(ta.get(k)), show(tb.get(k))))
        .collect())
}

/// What a run was trained on: window counts per scene and a hash of every window, stored
/// beside the checkpoint as `data-fingerprint.json` when a run starts and compared on
/// `--resume` (a missing or changed scene is refused, not silently resumed).
#[derive(Clone, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct DataFingerprint {
    /// Real training windows (before time reversal / mirroring).
    pub n_train: usize,
    /// Synthetic (augmentation) windows.
    pub n_synthetic: usize,
    /// Validation windows.
    pub n_val: usize,
    /// Real training windows per scene.
    pub train_scenes: std::collections::BTreeMap<String, usize>,
    /// Validation windows per scene.
    pub val_scenes: std::collections::BTreeMap<String, usize>,
    /// FNV-1a 64 over every window (scene, ped id, frames, position bits) in load order,
    /// training then validation, hex.
    pub hash: String,
}

impl DataFingerprint {
    /// File name inside a run directory.
    pub const FILE: &'static str = "data-fingerprint.json";

    /// Fingerprint of real training, synthetic and validation windows.
    pub fn of(train: &[Window], n_real: usize, val: &[Window]) -> Self {
        let mut h: u64 = 0xcbf2_9ce4_8422_2325;
        let mut eat = |bytes: &[u8]| {
            for &b in bytes {
                h ^= u64::from(b);
                h = h.wrapping_mul(0x0000_0100_0000_01b3);
            }
        };
        for w in train.iter().chain(val) {
            eat(w.scene.as_bytes());
            eat(&[0xff]);
            eat(&w.ped_id.to_bits().to_le_bytes());
            for f in &w.frames {
                eat(&f.to_le_bytes());
            }
            for p in &w.pos {
                eat(&p[0].to_bits().to_le_bytes());
                eat(&p[1].to_bits().to_le_bytes());
            }
        }
        let count = |ws: &[Window]| {
            let mut m = std::collections::BTreeMap::new();
            for w in ws {
                *m.entry(w.scene.clone()).or_insert(0) += 1;
            }
            m
        };
        let n_real = n_real.min(train.len());
        Self {
            n_train: n_real,
            n_synthetic: train.len() - n_real,
            n_val: val.len(),
            train_scenes: count(&train[..n_real]),
            val_scenes: count(val),
            hash: format!("{h:016x}"),
        }
    }

    /// Read `run_dir/data-fingerprint.json`; `None` when absent.
    pub fn load(run_dir: &Path) -> Result<Option<Self>> {
        let p = run_dir.join(Self::FILE);
        match std::fs::read(&p) {
            Ok(b) => {
                Ok(Some(serde_json::from_slice(&b).with_context(|| {
                    format!("cannot parse {}", p.display())
                })?))
            }
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
            Err(e) => Err(e).with_context(|| format!("cannot read {}", p.display())),
        }
    }

    /// Write `run_dir/data-fingerprint.json` (atomically).
    pub fn save(&self, run_dir: &Path) -> Result<()> {
        let p = run_dir.join(Self::FILE);
        crate::rundir::write_atomic(&p, serde_json::to_string_pretty(self)?.as_bytes())
            .with_context(|| format!("cannot write {}", p.display()))
    }

    /// What differs from `now` (empty when the same data), in words.
    pub fn diff(&self, now: &Self) -> Vec<String> {
        let mut out = Vec::new();
        for (what, a, b) in [
            ("training", &self.train_scenes, &now.train_scenes),
            ("validation", &self.val_scenes, &now.val_scenes),
        ] {
            let missing: Vec<&str> = a
                .keys()
                .filter(|k| !b.contains_key(*k))
                .map(|k| k.as_str())
                .collect();
            let added: Vec<&str> = b
                .keys()
                .filter(|k| !a.contains_key(*k))
                .map(|k| k.as_str())
                .collect();
            let changed: Vec<String> = a
                .iter()
                .filter_map(|(k, n)| {
                    b.get(k)
                        .filter(|m| *m != n)
                        .map(|m| format!("{k} {n} -> {m} windows"))
                })
                .collect();
            if !missing.is_empty() {
                out.push(format!("{what} scenes missing now: {}", missing.join(", ")));
            }
            if !added.is_empty() {
                out.push(format!(
                    "{what} scenes not in the run: {}",
                    added.join(", ")
                ));
            }
            if !changed.is_empty() {
                out.push(format!("{what} scenes changed: {}", changed.join(", ")));
            }
        }
        for (what, a, b) in [
            ("training windows", self.n_train, now.n_train),
            ("synthetic windows", self.n_synthetic, now.n_synthetic),
            ("validation windows", self.n_val, now.n_val),
        ] {
            if a != b {
                out.push(format!("{what}: {a} -> {b}"));
            }
        }
        if out.is_empty() && self.hash != now.hash {
            out.push(format!(
                "same scenes and counts but different window contents (hash {} -> {})",
                self.hash, now.hash
            ));
        }
        out
    }
}

fn bar_style(template: &str) -> ProgressStyle {
    ProgressStyle::with_template(template)
        .unwrap_or_else(|_| ProgressStyle::default_bar())
        .progress_chars("=> ")
}

fn run_loop(mut trainer: Trainer, opts: &TrainOptions) -> Result<TrainSummary> {
    let total = trainer.config().num_epochs;
    let show = !opts.quiet && std::io::stderr().is_terminal();
    let mp = MultiProgress::with_draw_target(if show {
        ProgressDrawTarget::stderr()
    } else {
        ProgressDrawTarget::hidden()
    });
    let ebar = mp.add(ProgressBar::new(total as u64));
    ebar.set_style(bar_style(
        "epochs  [{elapsed_precise}] {bar:30} {pos}/{len} ETA {eta_precise} {msg}",
    ));
    ebar.set_position(trainer.epochs_done() as u64);
    ebar.reset_eta();
    let bbar = mp.add(ProgressBar::new(trainer.batches_per_epoch() as u64));
    bbar.set_style(bar_style("batches {bar:30} {pos}/{len} ETA {eta}"));
    let unit = trainer.data().unit;
    let mut ran = 0usize;
    while trainer.epochs_done() < total {
        if opts.stop_after.is_some_and(|n| ran >= n) {
            break;
        }
        bbar.reset();
        let m = trainer.run_epoch(Some(&bbar))?;
        ran += 1;
        checkpoint::save(&opts.run_dir, &trainer.checkpoint()?)?;
        write_metrics(&opts.run_dir, trainer.history())?;
        if let Err(e) = plot_curves(&opts.run_dir.join("curves.svg"), trainer.history(), unit) {
            mp.suspend(|| eprintln!("warning: could not plot curves: {e}"));
        }
        let line = epoch_line(&m, unit);
        ebar.set_message(
            m.val
                .map(|v| format!("val minFDE {:.2} {unit}", v.min_fde))
                .unwrap_or_default(),
        );
        ebar.inc(1);
        if show {
            let _ = mp.println(line);
        } else if !opts.quiet {
            eprintln!("{line}");
        }
    }
    bbar.finish_and_clear();
    ebar.finish();
    Ok(TrainSummary {
        epochs_done: trainer.epochs_done(),
        last_val: trainer.history().iter().rev().find_map(|m| m.val),
        best: trainer.best().map(|b| (b.epoch, b.val)),
        run_dir: opts.run_dir.clone(),
        unit,
    })
}

fn epoch_line(m: &EpochMetrics, unit: Unit) -> String {
    let mut s = format!(
        "epoch {:4}  loss {:.4} (rcl {:.4} kld {:.4} adl {:.4})  {:.1}s",
        m.epoch, m.train_loss, m.train_rcl, m.train_kld, m.train_adl, m.seconds
    );
    if let Some(p) = m.val_point {
        s += &format!("  point ADE {:.2} FDE {:.2} {unit}", p.ade_k1, p.fde_k1);
    }
    if let Some(v) = m.val {
        s += &format!(
            "  val minADE {:.2} minFDE {:.2} {unit} (K={})",
            v.min_ade, v.min_fde, v.k
        );
    }
    s
}

/// Write `metrics.csv` and `metrics.jsonl` (whole history, atomically).
pub fn write_metrics(run_dir: &Path, history: &[EpochMetrics]) -> Result<()> {
    let mut jsonl = String::new();
    let mut rows = Vec::with_capacity(history.len());
    for m in history {
        let v =
            |f: fn(&Metrics) -> f64| m.val.as_ref().map(|x| f(x).to_string()).unwrap_or_default();
        rows.push([
            m.epoch.to_string(),
            m.train_loss.to_string(),
            m.train_rcl.to_string(),
            m.train_kld.to_string(),
            m.train_adl.to_string(),
            v(|x| x.min_ade),
            v(|x| x.min_fde),
            v(|x| x.ade_k1),
            v(|x| x.fde_k1),
            v(|x| x.mean_ade),
            v(|x| x.mean_fde),
            format!("{:.3}", m.seconds),
        ]);
        jsonl += &serde_json::to_string(m)?;
        jsonl.push('\n');
    }
    let csv = crate::csvfile::to_csv(
        &[
            "epoch",
            "train_loss",
            "train_rcl",
            "train_kld",
            "train_adl",
            "val_min_ade",
            "val_min_fde",
            "val_ade_k1",
            "val_fde_k1",
            "val_mean_ade",
            "val_mean_fde",
            "seconds",
        ],
        rows,
    )?;
    crate::rundir::write_atomic(&run_dir.join("metrics.csv"), csv.as_bytes())?;
    crate::rundir::write_atomic(&run_dir.join("metrics.jsonl"), jsonl.as_bytes())?;
    Ok(())
}

/// Plot training loss parts (log scale) and validation min ADE/FDE to an SVG file.
/// Uses plotters' SVG backend without any font feature (no fontconfig needed).
pub fn plot_curves(path: &Path, history: &[EpochMetrics], unit: Unit) -> Result<()> {
    use plotters::prelude::*;
    if history.is_empty() {
        return Ok(());
    }
    let err = |e: &dyn std::fmt::Display| anyhow::anyhow!("{e}");
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (1100, 420)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| err(&e))?;
        let (left, right) = root.split_horizontally(550);
        let xmax = history.last().map_or(1, |m| m.epoch).max(2) as f64;
        let xmin = history.first().map_or(1, |m| m.epoch) as f64;

        type Series = (&'static str, fn(&EpochMetrics) -> f64, RGBColor);
        let series: [Series; 3] = [
            ("total", |m| m.train_loss, BLACK),
            ("rcl (endpoint MSE)", |m| m.train_rcl, BLUE),
            ("adl (path MSE)", |m| m.train_adl, RED),
        ];
        let vals: Vec<f64> = history
            .iter()
            .flat_map(|m| series.iter().map(move |s| s.1(m)))
            .filter(|v| v.is_finite() && *v > 0.0)
            .collect();
        let lo = vals.iter().cloned().fold(f64::INFINITY, f64::min).max(1e-9);
        let hi = vals.iter().cloned().fold(0.0, f64::max).max(lo * 10.0);
        let mut c = ChartBuilder::on(&left)
            .caption("training loss", ("sans-serif", 18))
            .margin(10)
            .x_label_area_size(35)
            .y_label_area_size(60)
            .build_cartesian_2d(xmin..xmax, (lo * 0.8..hi * 1.25).log_scale())
            .map_err(|e| err(&e))?;
        c.configure_mesh()
            .x_desc("epoch")
            .draw()
            .map_err(|e| err(&e))?;
        for (name, f, color) in series {
            c.draw_series(LineSeries::new(
                history.iter().map(|m| (m.epoch as f64, f(m).max(lo))),
                color,
            ))
            .map_err(|e| err(&e))?
            .label(name)
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], color));
        }
        c.configure_series_labels()
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .draw()
            .map_err(|e| err(&e))?;

        let pts: Vec<(f64, f64, f64)> = history
            .iter()
            .filter_map(|m| m.val.map(|v| (m.epoch as f64, v.min_ade, v.min_fde)))
            .collect();
        if !pts.is_empty() {
            let ymax = pts.iter().map(|p| p.2.max(p.1)).fold(0.0, f64::max) * 1.1;
            let mut c = ChartBuilder::on(&right)
                .caption(format!("validation best-of-K ({unit})"), ("sans-serif", 18))
                .margin(10)
                .x_label_area_size(35)
                .y_label_area_size(50)
                .build_cartesian_2d(xmin..xmax, 0.0..ymax.max(1e-6))
                .map_err(|e| err(&e))?;
            c.configure_mesh()
                .x_desc("epoch")
                .draw()
                .map_err(|e| err(&e))?;
            c.draw_series(LineSeries::new(pts.iter().map(|p| (p.0, p.1)), BLUE))
                .map_err(|e| err(&e))?
                .label("minADE")
                .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLUE));
            c.draw_series(LineSeries::new(pts.iter().map(|p| (p.0, p.2)), RED))
                .map_err(|e| err(&e))?
                .label("minFDE")
                .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], RED));
            c.configure_series_labels()
                .background_style(WHITE.mix(0.8))
                .border_style(BLACK)
                .draw()
                .map_err(|e| err(&e))?;
        }
        root.present().map_err(|e| err(&e))?;
    }
    let mut bytes = Vec::new();
    bytes.write_all(svg.as_bytes())?;
    crate::rundir::write_atomic(path, &bytes)?;
    Ok(())
}
