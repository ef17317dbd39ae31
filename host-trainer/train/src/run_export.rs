//! `gpecnet export`: turns a training run into shipped artefacts in `weights/`:
//! the blob, its golden vectors, machine-readable metrics and a model card.
//!
//! Every number written here is computed **through `gpecnet-core`** on the
//! test set of the run's data set (the device's arithmetic) and cross-checked
//! against the trainer's reference path, which must agree bit for bit. The
//! model-card layout, the data sets' validation and test windows and the
//! constant-velocity baseline are [`crate::card`]'s, shared with `gpecnet
//! quantize` and `gpecnet eval` (`gpecnet-ship`).

use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};

use crate::baseline::{constant_velocity, evaluate_baseline};
use crate::card::{
    card_v2_rows, cv_baseline, golden_stride, model_card_dist_rows, planner_rows, score_fact_row,
    test_planner, test_windows, CardData, CardMd, Inference, ModelCard,
};
use crate::checkpoint::{load_model, Which};
use crate::config::TrainConfig;
use crate::core_eval::{evaluate_core, evaluate_reference};
use crate::data::{DatasetSpec, PAST};
use crate::dist::dist_metrics;
use crate::export::{blob_bytes, golden_bytes, golden_cases};
use crate::network::RefConfig;
use crate::reference::{RefModel, SineKind};

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
pub fn blob_meta(cfg: &TrainConfig) -> Result<crate::network::ModelMeta> {
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
    if cfg.obs_noise > 0.0 {
        data.push_str(&format!(
            ", observed positions with i.i.d. Gaussian noise of {} {} per coordinate, fresh every epoch",
            cfg.obs_noise,
            spec.unit().suffix()
        ));
    }
    Ok(crate::network::ModelMeta {
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
    let proposal = settings
        .apply(&mut model, k)?
        .zip(settings.proposal.as_ref());
    if let Some((p, _)) = &proposal {
        note_proposal_data(&mut model, &cfg.dataset_spec()?, p)?;
    }
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
        proposal: proposal
            .as_ref()
            .map(|(p, path)| crate::proposal_file::ProposalCard::of(p, path)),
        score: match &settings.score {
            Some(p) => Some(crate::score_file::ScoreCard::of(
                &crate::score_file::ScoreFile::read(p)?,
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

/// A proposal (and a decoder or point head trained with it) that learned from other data than the CVAE
/// `run_data`: the blob's training data names that data set too, and its licence is every
/// data set's, so the card and the blob state everything the model learned from.
pub fn note_proposal_data(
    m: &mut RefModel,
    run_data: &DatasetSpec,
    p: &crate::proposal_file::ProposalFile,
) -> Result<()> {
    let spec = DatasetSpec::parse(&p.settings.dataset).map_err(anyhow::Error::msg)?;
    if &spec == run_data {
        return Ok(());
    }
    let Some(meta) = m.config.meta.as_mut() else {
        return Ok(());
    };
    let what = match (p.decoder.is_some(), p.point_head.is_some()) {
        (true, true) => "decoder, point head and latent proposal",
        (true, false) => "decoder and latent proposal",
        (false, true) => "point head and latent proposal",
        (false, false) => "latent proposal",
    };
    meta.data
        .push_str(&format!("; the {what} also trained on {spec}"));
    // Every distinct data set once: the run's, then the proposal's others.
    let mut parts: Vec<DatasetSpec> = Vec::new();
    for d in [run_data.clone(), spec] {
        let flat = match d {
            DatasetSpec::Combined(ps) => ps,
            one => vec![one],
        };
        for d in flat {
            if !parts.contains(&d) {
                parts.push(d);
            }
        }
    }
    meta.licence = match parts.len() {
        1 => parts[0].licence(),
        _ => DatasetSpec::Combined(parts).licence(),
    };
    for (what, text) in [("training data", &meta.data), ("licence", &meta.licence)] {
        if text.len() > gpecnet_core::blob::MAX_META_TEXT {
            bail!(
                "the blob's {what} in words is {} bytes, over the format's {}: {text}",
                text.len(),
                gpecnet_core::blob::MAX_META_TEXT
            );
        }
    }
    Ok(())
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

/// The human-readable card of an f32 blob: `n` test windows, exported from the run folder `run`.
pub fn model_card_md(
    c: &ModelCard,
    n: usize,
    run: &Path,
    meta: Option<&crate::network::ModelMeta>,
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
            "| latent proposal | {}; validation minFDE {} {u} (K = {}) at its epoch {} (`docs/latents.md`); trained by `{}`{}{} |\n",
            p.shape,
            p.val_min_fde,
            p.k,
            p.epoch,
            p.command,
            if p.decoder_tuned {
                "; the decoder was trained with it (joint training), so the blob's decoder is not the run's"
            } else {
                ""
            },
            p.point_head.as_ref().map_or(String::new(), |h| format!(
                "; the point head was trained beside it (validation FDE {} {u} at its epoch {}), so the blob's point head is not the run's",
                h.val_fde, h.epoch
            ))
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
    /// Writes the settings into `m` (checked: `N >= k`, finite positive sigma); returns the
    /// proposal file it joined, read once, for the blob's data description and the card.
    pub fn apply(
        &self,
        m: &mut RefModel,
        k: usize,
    ) -> Result<Option<crate::proposal_file::ProposalFile>> {
        if let Some(s) = self.sigma {
            if !(s.is_finite() && s > 0.0) {
                bail!("--sigma must be a positive number, got {s}");
            }
            m.config.sigma = s;
        }
        if let Some(n) = self.tts.filter(|&n| n > 0) {
            if n < k || n > gpecnet_core::blob::MAX_TTS_SAMPLES {
                bail!(
                    "--tts {n} with --k {k}: test-time sampling draws --tts samples and reduces \
                     them to --k endpoints by k-means, so --tts must be 0 (plain sampling) or \
                     between --k = {k} and {}",
                    gpecnet_core::blob::MAX_TTS_SAMPLES
                );
            }
            m.config.tts_samples = n;
            m.config.tts_iters = 3;
            m.config.tts_init = 0;
        }
        let mut joined = None;
        if let Some(path) = &self.proposal {
            let p = crate::proposal_file::ProposalFile::read(path)?;
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
            p.join(m)
                .map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
            joined = Some(p);
        }
        if let Some(path) = &self.score {
            if self.proposal.is_none() {
                bail!("--score needs the --proposal it was fitted with");
            }
            crate::score::attach(m, path)?;
        }
        Ok(joined)
    }
}
