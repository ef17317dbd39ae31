//! Model cards: their JSON fields ([`ModelCard`]), their Markdown layout ([`CardMd`],
//! [`CardData`]), the data sets' validation and test windows, the golden-case stride and
//! the constant-velocity baseline, shared by `gpecnet export`, `quantize` and `eval`.

use std::path::Path;

use anyhow::{bail, Context, Result};
use serde::{Deserialize, Serialize};

use crate::baseline::{constant_velocity_n, evaluate_baseline_with, select_cv_n};
use crate::data::{self, default_sdd_val_scenes, Dataset, DatasetSpec, Split};
use crate::dist::DistMetrics;
use crate::eval::Metrics;
use crate::planner_metrics::PlannerMetrics;
use crate::reference::{RefModel, SineKind};

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
    pub proposal: Option<crate::proposal_file::ProposalCard>,
    /// The endpoint probabilities' provenance (format version 6 models only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub score: Option<crate::score_file::ScoreCard>,
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
    refuse_empty_test(data_root, spec, &test)?;
    Ok(test)
}

/// An error when `test`, the test windows of `spec` under `data_root` however they were
/// read, is empty, as [`test_windows`] refuses it (naming where they were looked for).
pub fn refuse_empty_test(data_root: &Path, spec: &DatasetSpec, test: &Dataset) -> Result<()> {
    if test.windows.is_empty() {
        // A folder's own test/ is named, not the benchmark data root it does not use.
        if let DatasetSpec::Folder { dir, .. } = spec {
            bail!(
                "{}: no window: no track is 20 steps of 0.4 s (8 s) long without a gap longer \
                 than max_gap_s (docs/own-data.md)",
                Path::new(dir).join("test").display()
            );
        }
        bail!(
            "the {spec} test set in {} has no window",
            spec.location(data_root)
        );
    }
    Ok(())
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
/// the SDD validation scenes ([`crate::baseline::select_cv_n`]), evaluated on the test set.
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
    cv_baseline_of(spec, &validation_windows(data_root, spec)?, test)
}

/// [`CvBaseline`] on `test`, `n` chosen on `val`: the validation windows of `spec`
/// ([`validation_windows`]) that the caller has already read.
pub fn cv_baseline_of(spec: &DatasetSpec, val: &Dataset, test: &Dataset) -> Result<CvBaseline> {
    let (n, _) = select_cv_n(val).with_context(|| format!("no {spec} validation window"))?;
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
pub fn score_fact_row(p: &crate::score_file::ScoreCard) -> String {
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
    pub fn new(meta: Option<&crate::network::ModelMeta>, spec: &DatasetSpec, n: usize) -> Self {
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
        // A model that learned from SDD and other data sets (a combined set, or a proposal
        // trained on more than its CVAE) states every one's licence beside SDD's terms.
        if spec.uses_sdd() && meta.licence != DatasetSpec::Sdd.licence() {
            licence += &format!(
                "It also learned from other data sets; every one's licence: {}.\n",
                meta.licence
            );
        }
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
