//! The training loop of `gpecnet propose`: data, the proposal network, Adam, one
//! checkpoint per epoch, selection on validation, and the exported proposal with its
//! validation numbers through `gpecnet-core`.

use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use indicatif::{ProgressBar, ProgressStyle};
use serde::{Deserialize, Serialize};

use super::fit::{self, Encoded, LossSpec};
use crate::data::{self, DatasetSpec, Window};
use crate::mlp::Mlp;
use crate::optim::{Adam, AdamParams, AdamState};
use crate::proposal_file::{
    frozen_fingerprint, EpochRow, GroupVal, LayerFile, PointHeadFile, PointVal, ProposalFile,
    ProposeSettings, ValCore,
};
use crate::reference::RefModel;
use crate::rng::{Rng, RngState};
use crate::rundir::{write_atomic, RunLock};
use crate::synthetic::start_stop;

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
    /// The decoder's part under joint training (absent when it stays frozen).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    decoder: Option<NetCheckpoint>,
    /// The point head's part when it is trained beside the proposal, with its own best
    /// epoch (absent when it stays frozen).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    point: Option<PointCheckpoint>,
}

/// A tuned network's weights and optimiser (the decoder under joint training).
#[derive(Clone, Debug, Serialize, Deserialize)]
struct NetCheckpoint {
    weights: Vec<Vec<f32>>,
    adam: AdamState,
    best_weights: Vec<Vec<f32>>,
}

/// The point head's weights and optimiser, the running average of its weights that is
/// validated and exported, and its best epoch on its own validation FDE.
#[derive(Clone, Debug, Serialize, Deserialize)]
struct PointCheckpoint {
    /// Its weights, optimiser and best (averaged) weights. Nested, not flattened: serde
    /// buffers a flattened struct's numbers, which some serde_json features cannot read back
    /// as f32.
    net: NetCheckpoint,
    /// The exponential moving average of the weights over the steps ([`POINT_EMA_DECAY`]).
    average: Vec<Vec<f32>>,
    /// Its best epoch (0 = the blob's head, before any epoch).
    best_epoch: usize,
    /// Its validation FDE at that epoch (caller's unit).
    best_fde: f64,
}

/// Decay per training step of the point head's weight average. A SIREN head fine-tuned
/// with Adam jumps by several per cent of validation FDE from epoch to epoch (measured on
/// the ETH/UCY validation windows: 0.82–0.90 m at learning rate 1e-4); the average over the
/// last ~1,000 steps (about two epochs of the combined data) is what is validated, selected
/// and exported.
pub const POINT_EMA_DECAY: f32 = 0.999;

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
    /// The teacher when the settings distil ([`ProposeSettings::distill`]), built with
    /// [`fit::Teacher::of`] for this run's model and K.
    pub teacher: Option<&'a fit::Teacher>,
}

/// The random stream of the run's seed that draws the synthetic starters and stoppers
/// (stream 1 orders the batches; observation noise uses streams from
/// [`crate::train::OBS_NOISE_STREAMS`]).
const START_STOP_STREAM: u64 = 2;

/// The windows of one split and, for each, the index of the part of a combined data set
/// it comes from (0 for a single data set). The training split is cut to the settings'
/// fraction of each part's tracks.
fn windows(
    root: &Path,
    spec: &DatasetSpec,
    split: data::Split,
    s: &ProposeSettings,
) -> Result<(Vec<Window>, Vec<usize>)> {
    let parts = match spec {
        DatasetSpec::Combined(parts) if s.balance => parts.iter().collect(),
        _ => vec![spec],
    };
    let (mut out, mut part_of) = (Vec::new(), Vec::new());
    for (i, part) in parts.into_iter().enumerate() {
        let set = data::load(root, part, split, &s.val_scenes)?;
        let metric = [
            ("--starter-weight", s.starter_weight != 1.0),
            ("--synthetic-starters", s.synthetic_starters > 0.0),
            ("--synthetic-stoppers", s.synthetic_stoppers > 0.0),
        ];
        if let Some((name, _)) = metric
            .iter()
            .find(|(_, on)| *on && set.unit != data::Unit::Metres)
        {
            bail!(
                "{name} needs data in metres (starters and stoppers are defined in m/s and m); {} is in {}",
                set.name,
                set.unit.words()
            );
        }
        let windows = if split == data::Split::Train {
            data::track_fraction(set.windows, s.train_fraction)
        } else {
            set.windows
        };
        if windows.is_empty() && s.balance {
            bail!(
                "--balance: {} has no {} windows to weigh",
                set.name,
                split.dir_name()
            );
        }
        part_of.extend(std::iter::repeat_n(i, windows.len()));
        out.extend(windows);
    }
    Ok((out, part_of))
}

/// Each window's weight for `balance`: `N / (parts · n_p)` for a window of part `p` with
/// `n_p` of the `N` windows, so every part totals `N / parts`.
fn balance_weights(part_of: &[usize]) -> Vec<f32> {
    let parts = part_of.iter().max().map_or(0, |&m| m + 1);
    let mut count = vec![0usize; parts];
    for &p in part_of {
        count[p] += 1;
    }
    let n = part_of.len() as f64;
    part_of
        .iter()
        .map(|&p| (n / (parts as f64 * count[p] as f64)) as f32)
        .collect()
}

/// The training loss weight of each window: `starter_weight` for a starter
/// ([`data::motion_change`] group 0), 1 for every other, times its part's weight under
/// `balance`; `None` when all are 1.
fn window_weights(windows: &[Window], part_of: &[usize], s: &ProposeSettings) -> Option<Vec<f32>> {
    if s.starter_weight == 1.0 && !s.balance {
        return None;
    }
    let parts = if s.balance {
        balance_weights(part_of)
    } else {
        vec![1.0; windows.len()]
    };
    Some(
        windows
            .iter()
            .zip(parts)
            .map(|(w, b)| {
                if data::motion_change(w) == 0 {
                    s.starter_weight * b
                } else {
                    b
                }
            })
            .collect(),
    )
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

/// The training windows with their time-reversed and mirrored copies, then a copy of all
/// of them per speed factor, then the synthetic starters and stoppers, made from the
/// windows before the speed copies and counted as a share of those, as the settings ask;
/// and each window's part index carried along (a synthetic window's is its source's).
fn augment(
    mut ws: Vec<Window>,
    mut part_of: Vec<usize>,
    s: &ProposeSettings,
) -> (Vec<Window>, Vec<usize>) {
    if s.time_reversal {
        let rev: Vec<Window> = ws.iter().map(data::time_reversed).collect();
        ws.extend(rev);
        part_of.extend_from_within(..);
    }
    if s.mirror {
        let mir: Vec<Window> = ws.iter().map(data::mirrored).collect();
        ws.extend(mir);
        part_of.extend_from_within(..);
    }
    let base = ws.len();
    for &f in &s.speed_scales {
        let scaled: Vec<Window> = ws[..base].iter().map(|w| w.speed_scaled(f)).collect();
        ws.extend(scaled);
        part_of.extend_from_within(..base);
    }
    let mut rng = Rng::with_stream(s.seed, START_STOP_STREAM);
    for (share, make) in [
        (
            s.synthetic_starters,
            start_stop::starter as fn(&Window, &mut Rng) -> _,
        ),
        (s.synthetic_stoppers, start_stop::stopper),
    ] {
        let n = (f64::from(share) * base as f64).round() as usize;
        for (i, w) in start_stop::synthesize(&ws[..base], n, make, &mut rng) {
            part_of.push(part_of[i]);
            ws.push(w);
        }
    }
    (ws, part_of)
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
        if s.point_lr.is_some() && self.model.nets.point_head.is_empty() {
            bail!("--tune-point-head: the blob has no point head to train");
        }
        std::fs::create_dir_all(&self.out)
            .with_context(|| format!("creating {}", self.out.display()))?;
        let _lock = RunLock::acquire(&self.out)?;
        let ckpt_path = self.out.join("checkpoint.json");
        let spec = DatasetSpec::parse(&s.dataset).map_err(anyhow::Error::msg)?;
        let (train_windows, train_parts) = {
            let (ws, parts) = windows(&self.data_root, &spec, data::Split::Train, s)?;
            augment(ws, parts, s)
        };
        let (val, val_parts) = windows(&self.data_root, &spec, data::Split::Val, s)?;
        let teacher = match (&s.distill, self.teacher) {
            (Some(_), Some(t)) => {
                t.check_fits(self.model, s.k)?;
                Some(t)
            }
            (None, None) => None,
            _ => bail!("distillation needs both its settings and the teacher"),
        };
        // Each encoding of the training windows gets their loss weights and the teacher's
        // endpoints (with observation noise the windows are encoded again every epoch, noisy).
        let weights = window_weights(&train_windows, &train_parts, s);
        let prepare = |enc: Encoded| -> Result<Encoded> {
            let enc = match &weights {
                Some(w) => enc.with_weights(w.clone())?,
                None => enc,
            };
            match teacher {
                Some(t) => enc.with_teacher(t),
                None => Ok(enc),
            }
        };
        // The point head's inputs and targets are kept only when it is trained.
        let point_data = s.point_lr.is_some();
        let mut train = prepare(Encoded::of(self.model, &train_windows, point_data)?)?;
        // Validation weighs the parts under `balance` (never the starters): the epoch is
        // selected on the mean of the parts' minFDE.
        let val = Encoded::of(self.model, &val, point_data)?;
        let val = match s.balance {
            true => val.with_weights(balance_weights(&val_parts))?,
            false => val,
        };
        let decoder = fit::mlp_of(&self.model.nets.decoder, "decoder")?;
        // The point head beside the proposal: the blob's, trained on the same batches under
        // its own loss and Adam (it shares no network with the proposal, so the proposal's
        // run is the same with or without it).
        let point = s
            .point_lr
            .map(|_| fit::mlp_of(&self.model.nets.point_head, "point head"))
            .transpose()?;
        let proposal = build(s, c.fdim, c.zdim)?;
        let ds = f64::from(c.data_scale);
        let loss_spec = LossSpec {
            k: s.k,
            zdim: c.zdim,
            bound: s.bound,
            temperature: s.temperature * c.data_scale,
            prior_weight: s.prior_weight,
            distill_weight: s.distill.as_ref().map_or(0.0, |d| d.weight),
        };
        let mut adam = Adam::new(trainable(&proposal, s.codebook), AdamParams::with_lr(s.lr));
        // Joint training: the decoder's own Adam, with its own learning rate.
        let mut dec_adam = s
            .decoder_lr
            .map(|lr| Adam::new(decoder.vars(), AdamParams::with_lr(lr)));
        let mut point_adam = match (&point, s.point_lr) {
            (Some(h), Some(lr)) => Some(Adam::new(h.vars(), AdamParams::with_lr(lr))),
            _ => None,
        };
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
            decoder: match &dec_adam {
                Some(a) => Some(NetCheckpoint {
                    weights: weights_of(&decoder)?,
                    adam: a.state().clone(),
                    best_weights: weights_of(&decoder)?,
                }),
                None => None,
            },
            point: match (&point, &point_adam) {
                (Some(h), Some(a)) => Some(PointCheckpoint {
                    net: NetCheckpoint {
                        weights: weights_of(h)?,
                        adam: a.state().clone(),
                        best_weights: weights_of(h)?,
                    },
                    average: weights_of(h)?,
                    best_epoch: 0,
                    best_fde: fit::validate_point(h, &val)? / ds,
                }),
                _ => None,
            },
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
            if let (Some(a), Some(d)) = (&mut dec_adam, &old.decoder) {
                set_weights(&decoder, &d.weights)?;
                *a = Adam::from_state(decoder.vars(), a.params(), d.adam.clone())?;
            } else if dec_adam.is_some() {
                bail!(
                    "{} holds no decoder state for a joint run",
                    ckpt_path.display()
                );
            }
            match (&point, &mut point_adam, &old.point) {
                (Some(h), Some(a), Some(p)) => {
                    set_weights(h, &p.net.weights)?;
                    *a = Adam::from_state(h.vars(), a.params(), p.net.adam.clone())?;
                }
                (Some(_), _, _) => bail!(
                    "{} holds no point-head state for a run that trains it",
                    ckpt_path.display()
                ),
                _ => {}
            }
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
        // The point head's running average, validated in a network of its own.
        let mut average = ck.point.as_ref().map(|p| p.average.clone());
        let averaged = point
            .as_ref()
            .map(|_| fit::mlp_of(&self.model.nets.point_head, "point head"))
            .transpose()?;
        let mut order: Vec<u32> = (0..train.n as u32).collect();
        while ck.epoch < s.epochs {
            if s.obs_noise > 0.0 {
                train = prepare(self.noisy_encoding(&train_windows, ck.epoch)?)?;
            }
            rng.shuffle(&mut order);
            let (mut sum, mut n) = (0.0f64, 0usize);
            for chunk in order.chunks(s.batch) {
                let (f, t, w) = train.rows(chunk)?;
                let te = train.teacher_rows(chunk)?;
                let l = fit::loss(
                    &proposal,
                    &decoder,
                    &f,
                    &t,
                    w.as_ref(),
                    te.as_ref(),
                    &loss_spec,
                )?;
                match &mut dec_adam {
                    Some(da) => {
                        let grads = l.backward()?;
                        adam.step(&grads)?;
                        da.step(&grads)?;
                    }
                    None => adam.backward_step(&l)?,
                }
                if let (Some(h), Some(pa), Some(avg)) = (&point, &mut point_adam, &mut average) {
                    let (x, y, w) = train.point_rows(chunk)?;
                    pa.backward_step(&fit::point_loss(h, &x, &y, w.as_ref())?)?;
                    ema_update(avg, &weights_of(h)?);
                }
                sum += f64::from(l.to_scalar::<f32>()?);
                n += 1;
            }
            let v = fit::validate(&proposal, &decoder, &val, &loss_spec)?;
            let point_fde = match (&averaged, &average) {
                (Some(h), Some(avg)) => {
                    set_weights(h, avg)?;
                    Some(fit::validate_point(h, &val)? / ds)
                }
                _ => None,
            };
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
                val_point_fde: point_fde,
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
            if let (Some(p), Some(h), Some(pa), Some(avg), Some(fde)) =
                (&mut ck.point, &point, &point_adam, &average, point_fde)
            {
                p.net.weights = weights_of(h)?;
                p.net.adam = pa.state().clone();
                p.average = avg.clone();
                if fde < p.best_fde {
                    p.best_epoch = ck.epoch;
                    p.best_fde = fde;
                    p.net.best_weights = avg.clone();
                }
            }
            if let (Some(d), Some(da)) = (&mut ck.decoder, &dec_adam) {
                d.weights = weights_of(&decoder)?;
                d.adam = da.state().clone();
                if best {
                    d.best_weights = d.weights.clone();
                }
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
        let tuned_decoder = match &ck.decoder {
            Some(d) => {
                set_weights(&decoder, &d.best_weights)?;
                Some(decoder.export()?.iter().map(layer_file).collect())
            }
            None => None,
        };
        let point_head = match (&ck.point, &point) {
            (Some(p), Some(h)) => {
                set_weights(h, &p.net.best_weights)?;
                Some(PointHeadFile {
                    epoch: p.best_epoch,
                    val_fde: p.best_fde,
                    layers: h.export()?.iter().map(layer_file).collect(),
                })
            }
            _ => None,
        };
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
            layers: exported.iter().map(layer_file).collect(),
            val_core: None,
            decoder: tuned_decoder,
            point_head,
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

impl ProposeRun<'_> {
    /// The frozen model's encoding of `windows` with fresh observation noise for 0-based
    /// epoch `epoch`: [`crate::train::with_obs_noise`] with `obs_noise`, drawn from stream
    /// [`crate::train::OBS_NOISE_STREAMS`]` + epoch` of the run's seed (so a resumed run
    /// draws what an uninterrupted one draws).
    fn noisy_encoding(&self, windows: &[Window], epoch: usize) -> Result<Encoded> {
        let s = &self.settings;
        let mut rng = Rng::with_stream(s.seed, crate::train::OBS_NOISE_STREAMS + epoch as u64);
        let noisy: Vec<Window> = windows
            .iter()
            .map(|w| crate::train::with_obs_noise(w, s.obs_noise, &mut rng))
            .collect();
        Encoded::of(self.model, &noisy, s.point_lr.is_some())
    }

    /// [`ValCore`] of `file` joined to the frozen model.
    fn val_core(&self, file: &ProposalFile, spec: &DatasetSpec) -> Result<ValCore> {
        let mut m = self.model.clone();
        file.join(&mut m)?;
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
        let acc = crate::dist::dist_accumulator(&val, &preds).context("no validation windows")?;
        let dist = acc.finish().context("no validation windows")?;
        let radii = crate::dist::hit_radii(val.unit);
        let starters = if val.unit == data::Unit::Metres {
            let (windows, preds): (Vec<Window>, Vec<_>) = val
                .windows
                .iter()
                .zip(&preds)
                .filter(|(w, _)| data::motion_change(w) == 0)
                .map(|(w, p)| (w.clone(), p.clone()))
                .unzip();
            let group = data::Dataset {
                name: format!("{} (starters)", val.name),
                unit: val.unit,
                windows,
            };
            (!group.windows.is_empty())
                .then(|| crate::core_eval::accumulate(&group, &preds))
                .transpose()?
                .map(|m| GroupVal {
                    n: m.n,
                    min_ade: m.min_ade,
                    min_fde: m.min_fde,
                })
        } else {
            None
        };
        let point =
            crate::core_eval::evaluate_point_core(&blob, sine, &val)?.map(|(p, _)| PointVal {
                ade: p.ade_k1,
                fde: p.fde_k1,
            });
        Ok(ValCore {
            point,
            starters,
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

/// `avg ← d·avg + (1 − d)·w` with `d` = [`POINT_EMA_DECAY`], tensor by tensor.
fn ema_update(avg: &mut [Vec<f32>], w: &[Vec<f32>]) {
    for (a, w) in avg.iter_mut().zip(w) {
        for (a, w) in a.iter_mut().zip(w) {
            *a = POINT_EMA_DECAY * *a + (1.0 - POINT_EMA_DECAY) * *w;
        }
    }
}

fn layer_file(l: &crate::network::Layer) -> LayerFile {
    LayerFile {
        in_dim: l.in_dim,
        out_dim: l.out_dim,
        act: l.act,
        w: l.w.clone(),
        b: l.b.clone(),
    }
}

/// One row per epoch; the point head's validation FDE is the last column when it is
/// trained.
fn metrics_csv(rows: &[EpochRow]) -> String {
    let point = rows.iter().any(|r| r.val_point_fde.is_some());
    let mut s = String::from("epoch,loss,val_min_fde,val_clamped,val_z_norm");
    s.push_str(if point { ",val_point_fde\n" } else { "\n" });
    for r in rows {
        s.push_str(&format!(
            "{},{:.6},{:.6},{:.6},{:.4}",
            r.epoch, r.loss, r.val_min_fde, r.val_clamped, r.val_z_norm
        ));
        match r.val_point_fde {
            Some(d) if point => s.push_str(&format!(",{d:.6}\n")),
            _ => s.push('\n'),
        }
    }
    s
}
