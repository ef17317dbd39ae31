//! `gpecnet export`: turns a training run into shipped artefacts in `weights/`:
//! the blob, its golden vectors, machine-readable metrics and a model card.
//!
//! Every number written here is computed **through `gpecnet-core`** on the
//! test set of the run's data set (the device's arithmetic) and cross-checked
//! against the trainer's reference path, which must agree bit for bit. The
//! model-card layout, the data sets' validation and test windows and the
//! constant-velocity baseline live here too, for `quantize` and `eval`
//! (`crate::blob_eval`) to share.

use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use serde::{Deserialize, Serialize};

use crate::checkpoint::{load_model, Which};
use crate::config::TrainConfig;
use crate::core_eval::{evaluate_core, evaluate_reference};
use crate::data::{self, default_sdd_val_scenes, Dataset, DatasetSpec, Split, PAST};
use crate::eval::{
    constant_velocity, constant_velocity_n, dist_metrics, evaluate_baseline,
    evaluate_baseline_with, select_cv_n, DistMetrics, Metrics,
};
use crate::export::{blob_bytes, golden_bytes, golden_cases};
use crate::planner_metrics::PlannerMetrics;
use crate::reference::{RefConfig, RefModel, SineKind};

/// Every `GOLDEN_STRIDE`-th test window becomes a golden case (on test sets of up to
/// `GOLDEN_STRIDE · MAX_GOLDEN_CASES` windows; see [`golden_stride`]).
pub const GOLDEN_STRIDE: usize = 10;

/// Most golden cases of one model (SDD's 2,829 test windows give 283): larger test sets (UNIV:
/// 24,334 windows) take a longer stride so a golden file still fits an MCU image beside its
/// blob and replays in QEMU in seconds.
pub const MAX_GOLDEN_CASES: usize = 283;

/// The stride between golden cases on a test set of `n` windows: [`GOLDEN_STRIDE`], or the
/// smallest longer one that keeps at most [`MAX_GOLDEN_CASES`] cases.
pub fn golden_stride(n: usize) -> usize {
    GOLDEN_STRIDE.max(n.div_ceil(MAX_GOLDEN_CASES))
}

/// The machine-readable model card (`weights/<name>.json`); the workspace
/// tests re-evaluate the blob and require these exact numbers.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ModelCard {
    /// Model name (file stem).
    pub name: String,
    /// CRC-32 of the blob.
    pub blob_crc: u32,
    /// Blob size in bytes.
    pub blob_bytes: usize,
    /// Parameters.
    pub parameters: usize,
    /// Sine used for the numbers and golden vectors.
    pub sine: SineKind,
    /// Samples per window.
    pub k: usize,
    /// Window `i` of the test set uses latent seed `base_seed + i`.
    pub base_seed: u64,
    /// Test-set metrics through gpecnet-core (pixels).
    pub test: Metrics,
    /// Constant-velocity baseline on the same windows.
    pub test_constant_velocity: Metrics,
    /// Epoch selected on validation.
    pub epoch: usize,
    /// Validation metrics of that epoch (from training).
    pub val: Option<Metrics>,
    /// Multiply-accumulates for K endpoints.
    pub endpoint_macs: usize,
    /// The training configuration (TOML).
    pub config_toml: String,
    /// Distribution quality on the test set through gpecnet-core (same K and seeds as
    /// `test`): KDE NLL of the true endpoint (nats, px) and the fraction of windows with a
    /// sample within 20 / 40 px of the true endpoint.
    pub test_dist: DistMetrics,
    /// Format-2 inference settings (absent for format-1 models).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub inference: Option<Inference>,
    /// The point forecast on the test set (K = 1: `ade_k1`/`fde_k1`), for models with a head.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub test_point: Option<Metrics>,
    /// The point forecast on validation at its selected epoch (from training).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub val_point: Option<Metrics>,
    /// Constant velocity with its window chosen on validation, on the test set.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub test_cv: Option<CvBaseline>,
    /// The data set of the numbers (`sdd`, `sdd-m`, `eth_ucy:<scene>`); absent on cards
    /// written before data sets had names, whose numbers are on `sdd`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dataset: Option<String>,
    /// The learned latent proposal's provenance (format version 5 models only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub proposal: Option<crate::propose::ProposalCard>,
    /// The endpoint probabilities' provenance (format version 6 models only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub score: Option<crate::score::ScoreCard>,
    /// What a planner gets, on the test set through gpecnet-core (the data set's unit).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub test_planner: Option<PlannerMetrics>,
    /// The same with distances in pixels (SDD in metres only, scene by scene).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub test_planner_px: Option<PlannerMetrics>,
}

impl ModelCard {
    /// The data set the card's numbers are on (`sdd` for cards that do not say).
    pub fn dataset_spec(&self) -> Result<DatasetSpec> {
        DatasetSpec::parse(self.dataset.as_deref().unwrap_or("sdd")).map_err(anyhow::Error::msg)
    }
}

/// The data set a model card (JSON) is about: its `dataset` field, `sdd` when absent.
pub fn card_dataset(card: &serde_json::Value) -> Result<DatasetSpec> {
    DatasetSpec::parse(
        card.get("dataset")
            .and_then(|v| v.as_str())
            .unwrap_or("sdd"),
    )
    .map_err(anyhow::Error::msg)
}

/// The validation windows commands select on for `spec`: the SDD validation scenes
/// ([`default_sdd_val_scenes`]) or the ETH/UCY scene's `val/` folder.
pub fn validation_windows(data_root: &Path, spec: &DatasetSpec) -> Result<Dataset> {
    Ok(data::load(
        data_root,
        spec,
        Split::Val,
        &default_sdd_val_scenes(),
    )?)
}

/// The test windows of `spec`, refusing an empty set.
pub fn test_windows(data_root: &Path, spec: &DatasetSpec) -> Result<Dataset> {
    let test = data::load(data_root, spec, Split::Test, &[])?;
    if test.windows.is_empty() {
        bail!(
            "the {spec} test set under {} has no window",
            data_root.display()
        );
    }
    Ok(test)
}

/// The inference settings a format-2 blob carries (see `gpecnet_core::blob::Extensions`).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Inference {
    /// Heading-canonical frame over the last `heading_steps` observed steps (0 = off).
    pub heading_steps: usize,
    /// Latent standard deviation.
    pub sigma: f32,
    /// Test-time samples reduced to K by k-means (0 = plain sampling).
    pub tts_samples: usize,
    /// Lloyd iterations.
    pub tts_iters: u8,
    /// k-means initialisation: 0 = first K samples, 1 = farthest point.
    pub tts_init: u8,
    /// Whether the blob has a point-forecast head.
    pub point_head: bool,
    /// Latents of a learned proposal (format version 5; 0 = drawn from the prior).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub proposal_latents: usize,
    /// Their clamp `±latent_bound` (0 without a proposal).
    #[serde(default, skip_serializing_if = "is_zero_f32")]
    pub latent_bound: f32,
}

fn is_zero(v: &usize) -> bool {
    *v == 0
}

fn is_zero_f32(v: &f32) -> bool {
    *v == 0.0
}

impl Inference {
    /// The settings of `m` when it uses any format-2 feature.
    pub fn of(m: &RefModel) -> Option<Inference> {
        m.needs_v2().then_some(Inference {
            heading_steps: m.config.heading_steps,
            sigma: m.config.sigma,
            tts_samples: m.config.tts_samples,
            tts_iters: m.config.tts_iters,
            tts_init: m.config.tts_init,
            point_head: !m.nets.point_head.is_empty(),
            proposal_latents: m.proposal_latents(),
            latent_bound: m.config.latent_bound,
        })
    }
}

/// Constant velocity from the mean velocity of the last `n` observed steps, `n` chosen on
/// the SDD validation scenes ([`crate::eval::select_cv_n`]), evaluated on the test set.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct CvBaseline {
    /// Observed steps averaged.
    pub n: usize,
    /// Test metrics (K = 1).
    pub test: Metrics,
}

/// [`CvBaseline`] on `test`, `n` chosen on the validation windows of `spec` under
/// `data_root` ([`validation_windows`]).
pub fn cv_baseline(data_root: &Path, spec: &DatasetSpec, test: &Dataset) -> Result<CvBaseline> {
    let val = validation_windows(data_root, spec)?;
    let (n, _) = select_cv_n(&val).with_context(|| format!("no {spec} validation window"))?;
    Ok(CvBaseline {
        n,
        test: evaluate_baseline_with(test, |w| constant_velocity_n(w, n)),
    })
}

/// A card row that says so when the point forecast is worse than constant velocity on the
/// test set (FDE), so a planner knows to prefer the baseline there; empty otherwise. `tail`
/// closes the row (the other columns).
pub fn point_vs_cv_row(point: &Metrics, cv: &CvBaseline, digits: usize, tail: &str) -> String {
    if point.fde_k1 <= cv.test.fde_k1 {
        return String::new();
    }
    format!(
        "| point forecast vs constant velocity | **worse** on this test set: FDE {:.d$} vs {:.d$} (+{:.d$}); prefer constant velocity over the last {} steps as the single forecast here | {tail}\n",
        point.fde_k1,
        cv.test.fde_k1,
        point.fde_k1 - cv.test.fde_k1,
        cv.n,
        d = digits
    )
}

/// The model-card rows of the format-2 features (each ends in a newline): the point forecast
/// beside the validation-chosen constant velocity, and the inference settings. Empty for
/// format-1 models, whose cards keep their bytes.
pub fn card_v2_rows(
    inf: Option<&Inference>,
    point: Option<&Metrics>,
    cv: Option<&CvBaseline>,
    digits: usize,
) -> String {
    let mut s = String::new();
    if let (Some(p), Some(cv)) = (point, cv) {
        s += &format!(
            "| point forecast (deterministic head), ADE / FDE | {:.d$} / {:.d$} | {:.d$} / {:.d$} (constant velocity, last {} steps, chosen on validation) |\n",
            p.ade_k1, p.fde_k1, cv.test.ade_k1, cv.test.fde_k1, cv.n, d = digits
        );
        s += &point_vs_cv_row(p, cv, digits, "– |");
    }
    if let Some(i) = inf {
        s += &format!(
            "| inference | heading frame over {} step(s); sigma {}; {} | – |\n",
            i.heading_steps,
            i.sigma,
            if i.proposal_latents > 0 {
                format!(
                    "a learned proposal gives the {} latents (each component clamped to ±{}; the sigma is unused)",
                    i.proposal_latents, i.latent_bound
                )
            } else if i.tts_samples > 0 {
                format!(
                    "{} latent samples reduced to K by k-means ({} Lloyd iterations, {} init)",
                    i.tts_samples,
                    i.tts_iters,
                    if i.tts_init == 1 {
                        "farthest-point"
                    } else {
                        "first-K"
                    }
                )
            } else {
                "plain sampling".to_string()
            }
        );
    }
    s
}

/// Builds the in-memory exported model of a run (best validation epoch).
pub fn model_from_run(run: &Path, name: &str) -> Result<(TrainConfig, RefModel, usize)> {
    let (cfg, model, epoch) = load_model(run, Which::Best)?;
    let nets = model.export_networks().context("exporting networks")?;
    let m = RefModel {
        name: name.to_string(),
        config: RefConfig {
            past_len: cfg.past_length,
            future_len: cfg.future_length,
            fdim: cfg.fdim,
            zdim: cfg.zdim,
            data_scale: cfg.data_scale,
            sigma: cfg.sigma,
            initial_pos_divisor: 1000.0,
            w0: cfg.w0,
            hidden_act: cfg.activation,
            heading_steps: cfg.heading_steps,
            tts_samples: 0,
            latent_bound: 0.0,
            radius_scales: [0.0; 2],
            tts_iters: 0,
            tts_init: 0,
            meta: Some(blob_meta(&cfg)?),
        },
        nets,
    };
    m.validate()?;
    Ok((cfg, m, epoch))
}

/// The version-4 description of a model trained with `cfg`: the data set's unit, the
/// benchmarks' 0.4 s period, the training data in words and its licence.
pub fn blob_meta(cfg: &TrainConfig) -> Result<crate::reference::ModelMeta> {
    let spec = cfg.dataset_spec()?;
    let mut data = spec.describe_training(&cfg.val_scenes);
    if cfg.include_train_extra {
        data.push_str(" plus sdd/train_extra");
    }
    if cfg.augment_pct > 0.0 {
        data.push_str(&format!(
            " plus {} % synthetic trajectories (gpecnet synth)",
            cfg.augment_pct
        ));
    }
    if cfg.time_reversal {
        data.push_str(", with time-reversed copies");
    }
    Ok(crate::reference::ModelMeta {
        unit: match spec.unit() {
            crate::data::Unit::Pixels => gpecnet_core::blob::PositionUnit::Pixel,
            crate::data::Unit::Metres => gpecnet_core::blob::PositionUnit::Metre,
        },
        metres_per_pixel: 0.0,
        period_s: crate::data::PERIOD_S,
        data,
        licence: spec.licence().to_string(),
    })
}

/// Paths of a shipped model's files.
pub fn artefact_paths(out_dir: &Path, name: &str) -> [PathBuf; 4] {
    ["gpec", "golden", "json", "md"].map(|e| out_dir.join(format!("{name}.{e}")))
}

/// Exports run `run` as model `name` into `out_dir`; refuses to replace existing artefacts
/// of that name ([`ship_with`] with `force = false`).
pub fn ship(
    run: &Path,
    name: &str,
    out_dir: &Path,
    data_root: &Path,
    settings: ExportSettings,
) -> Result<ModelCard> {
    ship_with(run, name, out_dir, data_root, settings, false, None)
}

/// Exports run `run` as model `name` into `out_dir` as one verified set
/// ([`crate::outpath::ArtefactWriter`]); existing artefacts of that name are replaced only
/// with `force`; with `sign`, the blob is written signed (the golden file and the cards
/// describe the blob inside, whose bytes and CRC signing does not change).
pub fn ship_with(
    run: &Path,
    name: &str,
    out_dir: &Path,
    data_root: &Path,
    settings: ExportSettings,
    force: bool,
    sign: Option<&crate::signing::SignSpec>,
) -> Result<ModelCard> {
    let ExportSettings {
        sine, k, base_seed, ..
    } = settings.clone();
    if name.is_empty()
        || !name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_')
    {
        bail!("model name {name:?}: use letters, digits, '-' and '_'");
    }
    let writer = crate::outpath::ArtefactWriter::begin(
        "--out",
        out_dir,
        name,
        force,
        &run_inputs(run)
            .iter()
            .map(PathBuf::as_path)
            .collect::<Vec<_>>(),
        &crate::outpath::data_input_dirs(data_root)
            .iter()
            .map(PathBuf::as_path)
            .collect::<Vec<_>>(),
    )?;
    let (cfg, mut model, epoch) = model_from_run(run, name)?;
    settings.apply(&mut model, k)?;
    let blob = blob_bytes(&model)?;
    let core_model = gpecnet_core::Model::from_blob(&blob).map_err(|e| anyhow::anyhow!("{e}"))?;
    let spec = cfg.dataset_spec()?;
    let test = test_windows(data_root, &spec)?;
    eprintln!(
        "evaluating {name} on {} {spec} test windows through gpecnet-core (K = {k}) ...",
        test.windows.len()
    );
    let (metrics, preds) = evaluate_core(&blob, sine, &test, k, base_seed)?;
    let test_dist = dist_metrics(&test, &preds).context("empty test set")?;
    let (ref_metrics, _) = evaluate_reference(&model, sine, &test, k, base_seed)?;
    if metrics != ref_metrics {
        bail!("gpecnet-core and the reference path disagree: {metrics:?} vs {ref_metrics:?}");
    }
    let inputs: Vec<(Vec<[f32; 2]>, u64)> = test
        .windows
        .iter()
        .enumerate()
        .step_by(golden_stride(test.windows.len()))
        .map(|(i, w)| (w.pos[..PAST].to_vec(), base_seed.wrapping_add(i as u64)))
        .collect();
    let cases = golden_cases(&model, &inputs, k, sine)?;
    let golden = golden_bytes(&model, core_model.crc(), sine.core_name(), k, &cases)?;
    let ckpt = crate::checkpoint::load(run)?;
    let ckpt_val = ckpt.best.map(|b| b.val);
    let val_point = ckpt.best_point.map(|b| b.val);
    let test_point = match crate::core_eval::evaluate_point_core(&blob, sine, &test)? {
        Some((m, preds)) => {
            let r: Vec<_> = test
                .windows
                .iter()
                .map(|w| model.predict_point(&w.obs(), sine))
                .collect();
            let same = preds.iter().zip(&r).all(|(p, r)| {
                r.as_ref()
                    .is_some_and(|r| p.trajectories[0].as_slice() == r.as_slice())
            });
            if !same {
                bail!("gpecnet-core and the reference path disagree on the point forecast");
            }
            Some(m)
        }
        None => None,
    };
    let test_cv = Some(cv_baseline(data_root, &spec, &test)?).filter(|_| model.needs_v2());
    let planner = test_planner(data_root, &spec, &blob, sine, &test, base_seed, &model)?;
    let card = ModelCard {
        name: name.to_string(),
        blob_crc: core_model.crc(),
        blob_bytes: blob.len(),
        parameters: model.parameter_count(),
        sine,
        k,
        base_seed,
        test: metrics,
        test_constant_velocity: evaluate_baseline(&test, constant_velocity),
        epoch,
        val: ckpt_val,
        endpoint_macs: core_model.endpoint_macs(gpecnet_core::sampling::samples_needed(
            core_model.extensions(),
            k,
        )) + core_model.point_head().macs(),
        config_toml: cfg.to_toml_string()?,
        test_dist,
        inference: Inference::of(&model),
        test_point,
        val_point: val_point.filter(|_| test_point.is_some()),
        test_cv,
        dataset: (spec != DatasetSpec::Sdd).then(|| spec.to_string()),
        proposal: match &settings.proposal {
            Some(p) => Some(crate::propose::ProposalCard::of(
                &crate::propose::ProposalFile::read(p)?,
                p,
            )),
            None => None,
        },
        score: match &settings.score {
            Some(p) => Some(crate::score::ScoreCard::of(
                &crate::score::ScoreFile::read(p)?,
                p,
            )),
            None => None,
        },
        test_planner: planner.map(|p| p.0),
        test_planner_px: planner.and_then(|p| p.1),
    };
    let blob = match sign {
        Some(s) => s.sign(&blob)?,
        None => blob,
    };
    writer.commit(
        &blob,
        &golden,
        serde_json::to_string_pretty(&card)?.as_bytes(),
        model_card_md(&card, test.windows.len(), run, model.config.meta.as_ref()).as_bytes(),
    )?;
    Ok(card)
}

/// The planner metrics of a blob with endpoint probabilities on `test` through
/// gpecnet-core, and in pixels for SDD in metres; `None` for other blobs. The probabilities
/// must equal those of `reference` (the reference path) bit for bit.
pub fn test_planner(
    data_root: &Path,
    spec: &DatasetSpec,
    blob: &[u8],
    sine: SineKind,
    test: &Dataset,
    base_seed: u64,
    reference: &RefModel,
) -> Result<Option<(PlannerMetrics, Option<PlannerMetrics>)>> {
    let Some(outs) = crate::core_eval::planner_core(blob, sine, test, base_seed)? else {
        return Ok(None);
    };
    let k = reference.proposal_latents();
    let same = crate::core_eval::probabilities_match(&test.windows, &outs, |past| {
        reference.probabilities(past, k, sine)
    });
    if !same {
        bail!("gpecnet-core and the reference path disagree on the probabilities");
    }
    planner_pair(data_root, spec, test, &outs).map(Some)
}

/// [`crate::core_eval::planner_metrics`] of `outs` in the data set's unit, and in pixels
/// for SDD in metres.
pub fn planner_pair(
    data_root: &Path,
    spec: &DatasetSpec,
    test: &Dataset,
    outs: &[crate::core_eval::PlannerOut],
) -> Result<(PlannerMetrics, Option<PlannerMetrics>)> {
    let own = crate::core_eval::planner_metrics(&test.windows, outs, |_| Ok(1.0))?;
    let px = if *spec == DatasetSpec::SddMetres {
        let scales = data::sdd_metres_per_pixel(data_root)?;
        Some(crate::core_eval::planner_metrics(
            &test.windows,
            outs,
            |w| {
                let s = scales
                    .get(&w.scene)
                    .with_context(|| format!("no metres-per-pixel factor for scene {}", w.scene))?;
                Ok(1.0 / *s as f32 as f64)
            },
        )?)
    } else {
        None
    };
    Ok((own, px))
}

/// The model card's fact row of a model's endpoint probabilities (ends in a newline).
pub fn score_fact_row(p: &crate::score::ScoreCard) -> String {
    format!(
        "| endpoint probabilities and radii | K logit rows on the proposal's hidden layer (L2 {}, inverse temperature {:.3}) and radius multipliers {:.3} / {:.3}, all chosen on validation (P(top = closest) {:.3}, ECE {:.4}, r50 / r90 coverage {:.1} % / {:.1} %; `docs/planner.md`); fitted by `{}` |\n",
        p.l2,
        p.inverse_temperature,
        p.radius_scales[0],
        p.radius_scales[1],
        p.val.top_is_closest,
        p.val.ece,
        100.0 * p.val.r50_coverage,
        100.0 * p.val.r90_coverage,
        p.command
    )
}

/// The model card's table rows of the planner metrics (each ends in a newline; three
/// columns, the third `–`), with the pixel values beside for SDD in metres.
pub fn planner_rows(
    p: &PlannerMetrics,
    px: Option<&PlannerMetrics>,
    u: &str,
    digits: usize,
) -> String {
    let both = |own: f64, pxv: Option<f64>, d: usize| match pxv {
        Some(v) => format!("{own:.d$} {u} ({v:.2} px)"),
        None => format!("{own:.d$} {u}"),
    };
    let rows = [
        (
            "brier-minFDE (minFDE + (1 − p of the closest endpoint)², Argoverse 2)".to_string(),
            both(p.brier_min_fde, px.map(|x| x.brier_min_fde), digits),
        ),
        (
            "P(most probable endpoint = closest endpoint)".to_string(),
            format!("{:.3} (equal weights: 1/K)", p.top_is_closest),
        ),
        (
            "FDE of the most probable endpoint / of the probability-weighted mean / of the point forecast".to_string(),
            format!(
                "{} / {} / {}",
                both(p.top_fde, px.map(|x| x.top_fde), digits),
                both(p.weighted_fde, px.map(|x| x.weighted_fde), digits),
                both(p.point_fde, px.map(|x| x.point_fde), digits)
            ),
        ),
        (
            format!("calibration error of the probabilities ({} equal bins), all / top-label", crate::planner_metrics::ECE_BINS),
            format!("{:.4} / {:.4}", p.ece, p.top_ece),
        ),
        (
            format!("NLL of the probability-weighted mixture (nats, {u}; Scott's bandwidth) vs equal weights"),
            format!("{:.3} vs {:.3}", p.mixture_nll, p.uniform_nll),
        ),
        (
            "truth within r50 / r90 of the point forecast (goal 50 % / 90 %)".to_string(),
            format!("{:.1} % / {:.1} %", 100.0 * p.r50_coverage, 100.0 * p.r90_coverage),
        ),
        (
            "r90, 10th / 50th / 90th percentile over windows".to_string(),
            format!(
                "{} / {} / {}",
                both(p.r90_percentiles[0], px.map(|x| x.r90_percentiles[0]), digits),
                both(p.r90_percentiles[1], px.map(|x| x.r90_percentiles[1]), digits),
                both(p.r90_percentiles[2], px.map(|x| x.r90_percentiles[2]), digits)
            ),
        ),
    ];
    rows.iter()
        .map(|(k, v)| format!("| {k} | {v} | – |\n"))
        .collect()
}

/// The files `gpecnet export --run RUN` reads (the run folder's checkpoints and config, or
/// the checkpoint file itself): no output may be one of them.
fn run_inputs(run: &Path) -> Vec<PathBuf> {
    let mut v = vec![run.to_path_buf()];
    if run.is_dir() {
        for f in ["checkpoint.bin", "checkpoint.prev.bin", "config.toml"] {
            v.push(run.join(f));
        }
    }
    v
}

/// A model card in markdown, as both card writers (`gpecnet export`, `gpecnet quantize`)
/// lay it out: the title, an introduction, a two-column table of facts, then sections.
pub struct CardMd(String);

impl CardMd {
    /// `# Model card: <title>`, the introduction paragraph, and the head of the facts table.
    pub fn new(title: &str, intro: &str) -> Self {
        Self(format!(
            "# Model card: {title}\n\n{intro}\n\n| | |\n|---|---|\n"
        ))
    }

    /// One row of the facts table.
    pub fn fact(mut self, key: &str, value: impl std::fmt::Display) -> Self {
        self.0 += &format!("| {key} | {value} |\n");
        self
    }

    /// A new `## heading` section (after a blank line) starting with `text`.
    pub fn section(mut self, heading: &str, text: &str) -> Self {
        self.0 += &format!("\n## {heading}\n\n{text}");
        self
    }

    /// The head of a table: its `columns` and the separator row.
    pub fn table(mut self, columns: &[&str]) -> Self {
        self.0 += &format!(
            "| {} |\n|{}\n",
            columns.join(" | "),
            "---|".repeat(columns.len())
        );
        self
    }

    /// One table row of `cells`.
    pub fn row(mut self, cells: &[&str]) -> Self {
        self.0 += &format!("| {} |\n", cells.join(" | "));
        self
    }

    /// Text as it is (e.g. rows that end in a newline).
    pub fn text(mut self, text: &str) -> Self {
        self.0 += text;
        self
    }

    /// The markdown.
    pub fn finish(self) -> String {
        self.0
    }
}

/// What a card says about the data and units of a blob: the unit suffix, the facts rows
/// (unit and period, training data) and the licence section. `None` (blobs before format
/// version 4) gives the SDD pixel text every card of those versions has.
pub struct CardData {
    /// Unit suffix of every number (`px` or `m`).
    pub unit: &'static str,
    /// The test set in words, e.g. `SDD test set (2829 windows, pixels)`.
    pub test_set: String,
    /// The `eval` flags that select this data set (empty for `sdd`).
    pub dataset_flag: String,
    /// Facts rows (each ends in a newline).
    pub facts: String,
    /// The licence section's text.
    pub licence: String,
}

/// SDD's licence text on the cards.
const SDD_LICENCE_TEXT: &str = "Trained on the Stanford Drone Dataset (Robicquet et al., ECCV 2016), TrajNet split, which is licensed under \
**Creative Commons Attribution-NonCommercial-ShareAlike 3.0** (CC BY-NC-SA 3.0). These weights are derived \
from it: attribution is required, **no commercial use**, and derivatives must be shared under the same licence.\n";

impl CardData {
    /// The card text for a blob of `meta` evaluated on `spec` (`n` test windows).
    pub fn new(meta: Option<&crate::reference::ModelMeta>, spec: &DatasetSpec, n: usize) -> Self {
        let Some(meta) = meta else {
            return Self {
                unit: "px",
                test_set: format!("SDD test set ({n} windows, pixels)"),
                dataset_flag: String::new(),
                facts: "| training data | SDD TrajNet split, 30 train scenes minus the validation scenes, with time-reversed copies |\n".to_string(),
                licence: SDD_LICENCE_TEXT.to_string(),
            };
        };
        let (unit, words) = (spec.unit().suffix(), spec.unit().words());
        let mut licence = if spec.uses_sdd() {
            SDD_LICENCE_TEXT.to_string()
        } else {
            format!("Trained on {}. Licence: {}.\n", meta.data, meta.licence)
        };
        if meta.data.contains("synthetic") {
            licence += "The synthetic trajectories come from `gpecnet synth` (this repository, MIT OR Apache-2.0).\n";
        }
        Self {
            unit,
            test_set: format!("{spec} test set ({n} windows, {words})"),
            dataset_flag: if *spec == DatasetSpec::Sdd {
                String::new()
            } else {
                format!(" --dataset {spec}")
            },
            facts: format!(
                "| unit and clock | positions in {words} (`{}`), one every {} s (8 observed = {:.1} s, 12 predicted = {:.1} s) |\n\
| training data | {} |\n\
| data licence | {} |\n",
                meta.unit.suffix(),
                meta.period_s,
                8.0 * meta.period_s,
                12.0 * meta.period_s,
                meta.data,
                meta.licence
            ),
            licence,
        }
    }
}

/// The human-readable card of an f32 blob: `n` test windows, exported from the run folder `run`.
pub fn model_card_md(
    c: &ModelCard,
    n: usize,
    run: &Path,
    meta: Option<&crate::reference::ModelMeta>,
) -> String {
    let spec = c.dataset_spec().unwrap_or(DatasetSpec::Sdd);
    let data = CardData::new(meta, &spec, n);
    let u = data.unit;
    let (m, cv) = (&c.test, &c.test_constant_velocity);
    let val = c.val.map_or("n/a".to_string(), |v| {
        format!(
            "minADE {:.2} / minFDE {:.2} {u} (K = {})",
            v.min_ade, v.min_fde, v.k
        )
    });
    let (name, k) = (&c.name, c.k);
    let macs_note = if c.inference.is_some() {
        " (all samples drawn, and the point head)"
    } else {
        ""
    };
    let flags = c.inference.map_or(String::new(), |i| {
        let tts = if i.tts_samples > 0 {
            format!(" --tts {}", i.tts_samples)
        } else {
            String::new()
        };
        let proposal = c
            .proposal
            .as_ref()
            .map_or(String::new(), |p| format!(" --tts 0 --proposal {}", p.file));
        let score = c
            .score
            .as_ref()
            .map_or(String::new(), |p| format!(" --score {}", p.file));
        format!(" --sigma {}{tts}{proposal}{score}", i.sigma)
    });
    let digits = if u == "m" { 3 } else { 2 };
    let f = |v: f64| format!("{v:.digits$}");
    let dist = if u == "px" {
        model_card_dist_rows(&c.test_dist, k)
    } else {
        format!(
            "| KDE NLL of the true endpoint under the K = {k} samples (nats, m; log-density floored at −20) | {:.3} | – |\n",
            c.test_dist.kde_nll
        )
    };
    CardMd::new(
        &format!("`{name}`"),
        "G-PECNet endpoint predictor (PECNet CVAE with SIREN sine MLPs), exported for `gpecnet-core`.",
    )
    .fact(
        "blob",
        format!(
            "`weights/{name}.gpec`, {} bytes, CRC-32 `{:#010x}`, f32",
            c.blob_bytes, c.blob_crc
        ),
    )
    .fact("parameters", c.parameters)
    .fact(&format!("MACs, K = {k} endpoints{macs_note}"), c.endpoint_macs)
    .fact("sine for the numbers below", format!("`{}`", c.sine.core_name()))
    .text(&data.facts)
    .fact("model selection", format!("epoch {} by validation minFDE ({val}); the test set was never used in training or selection", c.epoch))
    .fact("produced by", format!("`gpecnet export --run {} --name {name}{flags}`", run.display()))
    .text(&c.proposal.as_ref().map_or(String::new(), |p| {
        format!(
            "| latent proposal | {}; validation minFDE {} {u} (K = {}) at its epoch {} (`docs/latents.md`); trained by `{}` |\n",
            p.shape, p.val_min_fde, p.k, p.epoch, p.command
        )
    }))
    .text(&c.score.as_ref().map_or(String::new(), score_fact_row))
    .section(
        &format!("{}, through `gpecnet-core`", data.test_set),
        &format!(
            "Latent seed of window `i` = {} + i. Reproduce: `cargo run --release -p gpecnet-trainer -- eval --blob weights/{name}.gpec{}`.\n\n",
            c.base_seed, data.dataset_flag
        ),
    )
    .table(&["metric", "this model", "constant velocity"])
    .row(&[
        &format!("minADE / minFDE, best of K = {k}"),
        &format!("{} / {}", f(m.min_ade), f(m.min_fde)),
        "–",
    ])
    .row(&[
        "ADE / FDE, K = 1 (first sample)",
        &format!("{} / {}", f(m.ade_k1), f(m.fde_k1)),
        &format!("{} / {}", f(cv.ade_k1), f(cv.fde_k1)),
    ])
    .row(&["mean FDE over the K samples", &f(m.mean_fde), "–"])
    .text(&dist)
    .text(&card_v2_rows(c.inference.as_ref(), c.test_point.as_ref(), c.test_cv.as_ref(), digits))
    .text(&c.test_planner.as_ref().map_or(String::new(), |p| {
        planner_rows(p, c.test_planner_px.as_ref(), u, digits)
    }))
    .section("Configuration", &format!("```toml\n{}```\n", c.config_toml))
    .section("Data licence", &data.licence)
    .finish()
}

/// What `gpecnet export` evaluates with (sine, K, seeds) and the inference settings it
/// writes into the blob (format 2 when any is used).
#[derive(Clone, Debug, PartialEq)]
pub struct ExportSettings {
    /// Sine of the reported numbers and golden vectors.
    pub sine: SineKind,
    /// Samples per window.
    pub k: usize,
    /// Test window `i` uses latent seed `base_seed + i`.
    pub base_seed: u64,
    /// Latent sigma (default: the training config's).
    pub sigma: Option<f32>,
    /// Test-time samples N (0 / `None` = plain sampling); 3 Lloyd iterations, first-K init
    /// (the best of the validation grid in `docs/tts.md`).
    pub tts: Option<usize>,
    /// A learned latent proposal (`gpecnet propose`'s `proposal.json`) trained for this very
    /// encoder and decoder; it replaces the prior's draws (format version 5).
    pub proposal: Option<PathBuf>,
    /// Endpoint probabilities and radii (`gpecnet score`'s `score.json`) fitted for this very
    /// model and proposal (format version 6).
    pub score: Option<PathBuf>,
}

impl ExportSettings {
    /// Writes the settings into `m` (checked: `N >= k`, finite positive sigma).
    pub fn apply(&self, m: &mut RefModel, k: usize) -> Result<()> {
        if let Some(s) = self.sigma {
            if !(s.is_finite() && s > 0.0) {
                bail!("--sigma must be a positive number, got {s}");
            }
            m.config.sigma = s;
        }
        if let Some(n) = self.tts.filter(|&n| n > 0) {
            if n < k || n > gpecnet_core::blob::MAX_TTS_SAMPLES {
                bail!(
                    "--tts {n}: test-time samples must be at least K = {k} and at most {}",
                    gpecnet_core::blob::MAX_TTS_SAMPLES
                );
            }
            m.config.tts_samples = n;
            m.config.tts_iters = 3;
            m.config.tts_init = 0;
        }
        if let Some(path) = &self.proposal {
            let p = crate::propose::ProposalFile::read(path)?;
            if p.frozen != crate::propose::frozen_fingerprint(m) {
                bail!(
                    "{}: this proposal was trained for other encoder/decoder weights",
                    path.display()
                );
            }
            if p.settings.k != k {
                bail!(
                    "{}: the proposal gives {} latents, the card evaluates K = {k}",
                    path.display(),
                    p.settings.k
                );
            }
            if m.config.tts_samples != 0 {
                bail!("a proposal model draws no test-time samples: use --tts 0");
            }
            m.nets.proposal = p.layers();
            m.config.latent_bound = p.settings.bound;
        }
        if let Some(path) = &self.score {
            if self.proposal.is_none() {
                bail!("--score needs the --proposal it was fitted with");
            }
            crate::score::attach(m, path)?;
        }
        Ok(())
    }
}

/// The model card's table rows for [`DistMetrics`] (each ends in a newline; they follow the
/// "mean FDE over the K samples" row).
pub fn model_card_dist_rows(d: &DistMetrics, k: usize) -> String {
    format!(
        "| KDE NLL of the true endpoint under the K = {k} samples (nats, px; log-density floored at −20) | {nll:.3} | – |\n\
| true endpoint within 20 / 40 px of a sample, K = {k} | {h20:.1} % / {h40:.1} % | – |\n",
        nll = d.kde_nll,
        h20 = 100.0 * d.hit20,
        h40 = 100.0 * d.hit40,
    )
}
