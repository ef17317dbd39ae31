//! A run's model, optimizer and RNG, and its epochs.

use std::time::Instant;

use anyhow::{bail, Context, Result};
use candle_core::{Device, Tensor};
use indicatif::ProgressBar;

use crate::checkpoint::{BestModel, Checkpoint, EpochMetrics};
use crate::config::TrainConfig;
use crate::eval::Metrics;
use crate::model::{Batch, Model};
use crate::optim::{Adam, AdamParams};
use crate::rng::{streams, Rng};

use super::*;

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
    /// Fresh run: weights from the INIT stream (then overwritten by those of
    /// [`TrainConfig::init`] when it names a source, [`init`]), shuffling/noise from the TRAIN
    /// stream.
    pub fn new(cfg: TrainConfig, data: PreparedData) -> Result<Self> {
        cfg.validate()?;
        set_num_threads(cfg.resolved_threads());
        keep_freed_memory();
        if cfg.data_scale == crate::config::AUTO_DATA_SCALE {
            bail!("data_scale is left to the data and not computed yet (train_new computes it)");
        }
        let model = Model::new(&cfg, &mut Rng::with_stream(cfg.seed, streams::INIT))?;
        if let Some(path) = &cfg.init {
            let src = init::load_init(std::path::Path::new(path))?;
            init::apply_init(&model, &src)?;
        }
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
        keep_freed_memory();
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
        // Observation noise: this epoch's samples from its own stream (see OBS_NOISE_STREAMS);
        // without it the prepared samples are used as they are.
        let noisy = if self.cfg.obs_noise > 0.0 {
            let stream = OBS_NOISE_STREAMS + self.epochs_done as u64;
            let mut rng = Rng::with_stream(self.cfg.seed, stream);
            Some(noisy_samples(&self.cfg, &self.data.train_windows, &mut rng))
        } else {
            None
        };
        let samples = noisy.as_deref().unwrap_or(&self.data.train);
        for (chunk, sizes) in batches {
            let batch = Batch::from_samples(chunk.iter().map(|&i| &samples[i as usize]))?;
            let eps = self.rng.normal_vec(chunk.len() * zdim, 1.0);
            let eps = Tensor::from_vec(eps, (chunk.len(), zdim), &Device::Cpu)?;
            let mask = sizes.map(|s| crate::social::block_mask(&s)).transpose()?;
            let loss = self.model.loss(&batch, &eps, mask.as_ref())?;
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
