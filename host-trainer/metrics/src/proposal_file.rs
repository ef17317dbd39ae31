//! The files of a proposal run: its settings and epoch rows, the exported proposal
//! (`proposal.json`) with its validation numbers through `gpecnet-core`, the model card's
//! record of it, and the fingerprint that ties a proposal to the frozen model it was
//! trained for.

use std::path::Path;

use anyhow::{Context, Result};
use serde::{Deserialize, Serialize};

use crate::network::{Act, Layer};
use crate::reference::RefModel;

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
    /// Standard deviation (the data's unit) of the i.i.d. Gaussian noise on the observed
    /// positions of the training windows, fresh every epoch; 0 (absent from older files) = none.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub obs_noise: f32,
    /// The part of the training split's tracks trained on (`gpecnet_data::track_fraction`);
    /// 1 (absent from older files) = all.
    #[serde(default = "one", skip_serializing_if = "is_one")]
    pub train_fraction: f32,
    /// Adam learning rate of the decoder when it is trained together with the proposal
    /// (joint training: `gpecnet propose --tune-decoder`); `None` (absent from older files) =
    /// the decoder stays frozen.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub decoder_lr: Option<f64>,
    /// Weight of a *starter*'s window in the loss (standing when forecast, then more than
    /// 1 m away at the horizon: `gpecnet_data::motion_change`); every other window weighs 1.
    /// 1 (absent from older files) = no re-weighting.
    #[serde(default = "one", skip_serializing_if = "is_one")]
    pub starter_weight: f32,
    /// Each part of a combined data set (`A+B`) weighs the same in the training loss and in
    /// the validation score that selects the epoch, however many windows it has; false
    /// (absent from older files) = every window weighs the same.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub balance: bool,
    /// Adam learning rate of the point head when it is trained beside the proposal
    /// (`gpecnet propose --tune-point-head`), from the blob's, on the same windows and
    /// weights, selected on its own validation point FDE; `None` (absent from older files)
    /// = the point head stays frozen.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub point_lr: Option<f64>,
    /// Speed augmentation: for each factor `s`, a copy of every training window (and of its
    /// time-reversed and mirrored copies) walked `s` times as fast
    /// (`gpecnet_data::Window::speed_scaled`); empty (absent from older files) = none.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub speed_scales: Vec<f32>,
    /// Synthetic starters added to the training windows, as a share of the real ones (with
    /// their time-reversed and mirrored copies): real standing pasts with a synthetic
    /// departure (`gpecnet_trainer::synthetic::start_stop`); 0 (absent from older files) =
    /// none.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub synthetic_starters: f32,
    /// Synthetic stoppers added the same way: real walking pasts with a synthetic halt; 0
    /// (absent from older files) = none.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub synthetic_stoppers: f32,
    /// Distillation from a larger proposal on the same CVAE; `None` (absent from older
    /// files) = none.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub distill: Option<Distill>,
}

/// Distillation of a proposal from a teacher: a blob with a proposal of the same K on the
/// same frozen encoder and decoder ([`frozen_fingerprint`]). Each of the K endpoints of a
/// training window is pulled towards the teacher's endpoint of the same index: the loss
/// gains `weight` times the mean distance between them.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Distill {
    /// The teacher blob's path as given.
    pub teacher: String,
    /// Its CRC-32 (`gpecnet_core::Model::crc`): a resumed run must have the same teacher.
    pub teacher_crc: u32,
    /// The distillation term's weight.
    pub weight: f32,
}

impl ProposeSettings {
    /// The `gpecnet propose` options of the settings that are not at their defaults, each
    /// with its leading space, in the order the card's command writes them (after
    /// `--bound`).
    fn optional_options(&self) -> String {
        let when = |on: bool, option: String| if on { option } else { String::new() };
        let list = |v: &[f32]| v.iter().map(f32::to_string).collect::<Vec<_>>().join(",");
        [
            when(!self.time_reversal, " --no-time-reversal".into()),
            when(!self.mirror, " --no-mirror".into()),
            when(
                self.obs_noise > 0.0,
                format!(" --obs-noise {}", self.obs_noise),
            ),
            when(
                self.train_fraction < 1.0,
                format!(" --train-fraction {}", self.train_fraction),
            ),
            self.decoder_lr.map_or(String::new(), |lr| {
                format!(" --tune-decoder --decoder-lr {lr}")
            }),
            when(
                self.starter_weight != 1.0,
                format!(" --starter-weight {}", self.starter_weight),
            ),
            when(self.balance, " --balance".into()),
            self.point_lr.map_or(String::new(), |lr| {
                format!(" --tune-point-head --point-lr {lr}")
            }),
            when(
                !self.speed_scales.is_empty(),
                format!(" --speed-scales {}", list(&self.speed_scales)),
            ),
            when(
                self.synthetic_starters > 0.0,
                format!(" --synthetic-starters {}", self.synthetic_starters),
            ),
            when(
                self.synthetic_stoppers > 0.0,
                format!(" --synthetic-stoppers {}", self.synthetic_stoppers),
            ),
            self.distill.as_ref().map_or(String::new(), |d| {
                format!(" --teacher {} --distill-weight {}", d.teacher, d.weight)
            }),
        ]
        .concat()
    }
}

fn one() -> f32 {
    1.0
}

fn is_one(x: &f32) -> bool {
    *x == 1.0
}

fn is_zero(x: &f32) -> bool {
    *x == 0.0
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
    /// Validation FDE of the point head trained beside the proposal (caller's unit;
    /// `None` when it stays frozen).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub val_point_fde: Option<f64>,
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
    /// The decoder trained together with the proposal (`settings.decoder_lr` set), exported
    /// layers; `None` = the frozen model's decoder.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub decoder: Option<Vec<LayerFile>>,
    /// The point head trained beside the proposal (`settings.point_lr` set) at its own best
    /// validation epoch; `None` = the frozen model's point head.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub point_head: Option<PointHeadFile>,
}

/// A point head trained beside a proposal, selected on its own validation point FDE.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct PointHeadFile {
    /// Its best validation epoch (1-based).
    pub epoch: usize,
    /// Its validation FDE at that epoch (caller's unit; weighted as the run's validation).
    pub val_fde: f64,
    /// Exported layers (last one linear, `2 · FUTURE` outputs).
    pub layers: Vec<LayerFile>,
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
    /// KDE NLL of the true endpoint under the K endpoints (nats; `crate::dist::kde_nll`).
    pub kde_nll: f64,
    /// The two hit radii (0.5 / 1 m, or 20 / 40 px).
    pub radii: [f64; 2],
    /// Share of windows with an endpoint within each radius.
    pub hits: [f64; 2],
    /// The same best-of-K numbers on the validation windows whose pedestrian starts walking
    /// (`gpecnet_data::motion_change`), for data in metres with at least one such window.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub starters: Option<GroupVal>,
    /// The point forecast's ADE / FDE on the same windows (a model with a point head).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub point: Option<PointVal>,
}

/// The point forecast's errors on the validation windows.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct PointVal {
    /// Mean displacement over the forecast steps.
    pub ade: f64,
    /// Mean displacement at the horizon.
    pub fde: f64,
}

/// Best-of-K numbers of one group of validation windows.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct GroupVal {
    /// Windows.
    pub n: usize,
    /// minADE, best of K.
    pub min_ade: f64,
    /// minFDE, best of K.
    pub min_fde: f64,
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
        layers_of(&self.layers)
    }

    /// The tuned decoder's layers, if the decoder was trained with the proposal.
    pub fn decoder_layers(&self) -> Option<Vec<Layer>> {
        self.decoder.as_deref().map(layers_of)
    }

    /// The point head's layers, if it was trained beside the proposal.
    pub fn point_head_layers(&self) -> Option<Vec<Layer>> {
        self.point_head.as_ref().map(|p| layers_of(&p.layers))
    }

    /// Joins the proposal to `m`, the frozen model it was trained for: its layers become
    /// the proposal network, its bound the latent bound, test-time sampling is off, and a
    /// decoder or point head trained with it replaces the frozen one. Refused when `m` is
    /// not that model ([`frozen_fingerprint`]) or a tuned network's shape differs.
    pub fn join(&self, m: &mut RefModel) -> Result<()> {
        if self.frozen != frozen_fingerprint(m) {
            anyhow::bail!("this proposal was trained for other encoder/decoder weights");
        }
        let shapes = |ls: &[Layer]| -> Vec<(usize, usize, Act)> {
            ls.iter().map(|l| (l.in_dim, l.out_dim, l.act)).collect()
        };
        if let Some(dec) = self.decoder_layers() {
            if shapes(&dec) != shapes(&m.nets.decoder) {
                anyhow::bail!("the proposal's tuned decoder has another shape than the model's");
            }
            m.nets.decoder = dec;
        }
        if let Some(head) = self.point_head_layers() {
            if shapes(&head) != shapes(&m.nets.point_head) {
                anyhow::bail!("the proposal's tuned point head has another shape than the model's");
            }
            m.nets.point_head = head;
        }
        m.config.tts_samples = 0;
        m.nets.proposal = self.layers();
        m.config.latent_bound = self.settings.bound;
        Ok(())
    }

    /// Reads `proposal.json`.
    pub fn read(path: &Path) -> Result<Self> {
        let text = crate::inpath::read_text_limited(path, crate::inpath::FileKind::Text)?;
        serde_json::from_str(&text).with_context(|| format!("reading {}", path.display()))
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
    /// Whether the decoder was trained together with the proposal (joint training); the
    /// blob then holds that decoder, not the frozen model's.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub decoder_tuned: bool,
    /// The point head trained beside the proposal; the blob then holds that head, not the
    /// frozen model's.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub point_head: Option<PointHeadCard>,
}

/// A point head trained beside the proposal, in the model card.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PointHeadCard {
    /// Its best validation epoch.
    pub epoch: usize,
    /// Its validation FDE at that epoch (the blob's unit, 4 decimals).
    pub val_fde: String,
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
                "gpecnet propose --blob {} --dataset {} --seed {} --k {}{hidden} --epochs {} --batch {} --lr {} --prior-weight {} --temperature {} --bound {}{} --out {}",
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
                s.optional_options(),
                path.parent().map_or(".".into(), |d| d.display().to_string()),
            ),
            decoder_tuned: p.decoder.is_some(),
            point_head: p.point_head.as_ref().map(|h| PointHeadCard {
                epoch: h.epoch,
                val_fde: format!("{:.4}", h.val_fde),
            }),
        }
    }
}

fn layers_of(ls: &[LayerFile]) -> Vec<Layer> {
    ls.iter()
        .map(|l| Layer::new(l.in_dim, l.out_dim, l.act, l.w.clone(), l.b.clone()))
        .collect()
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
