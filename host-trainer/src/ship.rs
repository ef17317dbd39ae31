//! `gpecnet export`: turns a training run into shipped artefacts in `weights/`:
//! the blob, its golden vectors, machine-readable metrics and a model card.
//!
//! Every number written here is computed **through `gpecnet-core`** on the
//! SDD test set (the device's arithmetic) and cross-checked against the
//! trainer's reference path, which must agree bit for bit.

use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use serde::{Deserialize, Serialize};

use crate::checkpoint::{load_model, Which};
use crate::config::{Activation, TrainConfig};
use crate::core_eval::{evaluate_core, evaluate_reference};
use crate::data::{load_sdd, Dataset, SddSplit, PAST};
use crate::eval::{constant_velocity, evaluate_baseline, Metrics};
use crate::export::{blob_bytes, golden_bytes, golden_cases, write_atomic};
use crate::model::{Act as ModelAct, ExportedLayer};
use crate::reference::{Act, RefConfig, RefLayer, RefModel, SineKind};

/// Every `GOLDEN_STRIDE`-th test window becomes a golden case.
pub const GOLDEN_STRIDE: usize = 10;

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
}

fn convert(layers: &[ExportedLayer]) -> Vec<RefLayer> {
    layers
        .iter()
        .map(|l| RefLayer {
            in_dim: l.in_dim,
            out_dim: l.out_dim,
            act: match l.activation {
                ModelAct::Linear => Act::Linear,
                ModelAct::Relu => Act::Relu,
                ModelAct::Sine => Act::Sine,
            },
            w: l.weight.clone(),
            b: l.bias.clone(),
        })
        .collect()
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
            hidden_act: match cfg.activation {
                Activation::Sine => Act::Sine,
                Activation::Relu => Act::Relu,
            },
        },
        encoder_past: convert(&nets.encoder_past),
        decoder: convert(&nets.decoder),
        encoder_dest: convert(&nets.encoder_dest),
        predictor: convert(&nets.predictor),
    };
    m.validate()?;
    Ok((cfg, m, epoch))
}

/// Paths of a shipped model's files.
pub fn artefact_paths(out_dir: &Path, name: &str) -> [PathBuf; 4] {
    ["gpec", "golden", "json", "md"].map(|e| out_dir.join(format!("{name}.{e}")))
}

/// Exports run `run` as model `name` into `out_dir`.
pub fn ship(
    run: &Path,
    name: &str,
    out_dir: &Path,
    data_root: &Path,
    sine: SineKind,
    k: usize,
    base_seed: u64,
) -> Result<ModelCard> {
    if name.is_empty()
        || !name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_')
    {
        bail!("model name {name:?}: use letters, digits, '-' and '_'");
    }
    let (cfg, model, epoch) = model_from_run(run, name)?;
    let blob = blob_bytes(&model)?;
    let core_model = gpecnet_core::Model::from_blob(&blob).map_err(|e| anyhow::anyhow!("{e}"))?;
    let test = load_sdd(data_root, SddSplit::Test)?;
    eprintln!(
        "evaluating {name} on {} SDD test windows through gpecnet-core (K = {k}) ...",
        test.windows.len()
    );
    let (metrics, _) = evaluate_core(&blob, sine, &test, k, base_seed)?;
    let (ref_metrics, _) = evaluate_reference(&model, sine, &test, k, base_seed)?;
    if metrics != ref_metrics {
        bail!("gpecnet-core and the reference path disagree: {metrics:?} vs {ref_metrics:?}");
    }
    let inputs: Vec<(Vec<[f32; 2]>, u64)> = test
        .windows
        .iter()
        .enumerate()
        .step_by(GOLDEN_STRIDE)
        .map(|(i, w)| (w.pos[..PAST].to_vec(), base_seed.wrapping_add(i as u64)))
        .collect();
    let cases = golden_cases(&model, &inputs, k, sine);
    let golden = golden_bytes(&model, core_model.crc(), sine, k, &cases)?;
    let ckpt_val = crate::checkpoint::load(run)?.best.map(|b| b.val);
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
        endpoint_macs: core_model.endpoint_macs(k),
        config_toml: cfg.to_toml_string()?,
    };
    let [p_blob, p_golden, p_json, p_md] = artefact_paths(out_dir, name);
    write_atomic(&p_blob, &blob)?;
    write_atomic(&p_golden, &golden)?;
    write_atomic(&p_json, serde_json::to_string_pretty(&card)?.as_bytes())?;
    write_atomic(&p_md, model_card_md(&card, &test, run).as_bytes())?;
    Ok(card)
}

fn model_card_md(c: &ModelCard, test: &Dataset, run: &Path) -> String {
    let m = &c.test;
    let cv = &c.test_constant_velocity;
    let val = c.val.map_or("n/a".to_string(), |v| {
        format!(
            "minADE {:.2} / minFDE {:.2} px (K = {})",
            v.min_ade, v.min_fde, v.k
        )
    });
    format!(
        "# Model card: `{name}`\n\n\
G-PECNet endpoint predictor (PECNet CVAE with SIREN sine MLPs), exported for `gpecnet-core`.\n\n\
| | |\n|---|---|\n\
| blob | `weights/{name}.gpec`, {bytes} bytes, CRC-32 `{crc:#010x}`, f32 |\n\
| parameters | {params} |\n\
| MACs, K = {k} endpoints | {macs} |\n\
| sine for the numbers below | `{sine}` |\n\
| training data | SDD TrajNet split, 30 train scenes minus the validation scenes, with time-reversed copies |\n\
| model selection | epoch {epoch} by validation minFDE ({val}); the test set was never used in training or selection |\n\
| produced by | `gpecnet export --run {run} --name {name}` |\n\n\
## SDD test set ({n} windows, pixels), through `gpecnet-core`\n\n\
Latent seed of window `i` = {seed} + i. Reproduce: `cargo run --release -p gpecnet-trainer -- eval --blob weights/{name}.gpec`.\n\n\
| metric | this model | constant velocity |\n|---|---|---|\n\
| minADE / minFDE, best of K = {k} | {a:.2} / {f:.2} | – |\n\
| ADE / FDE, K = 1 (first sample) | {a1:.2} / {f1:.2} | {cva:.2} / {cvf:.2} |\n\
| mean FDE over the K samples | {mf:.2} | – |\n\n\
## Configuration\n\n```toml\n{cfg}```\n\n\
## Data licence\n\n\
Trained on the Stanford Drone Dataset (Robicquet et al., ECCV 2016), TrajNet split, which is licensed under \
**Creative Commons Attribution-NonCommercial-ShareAlike 3.0** (CC BY-NC-SA 3.0). These weights are derived \
from it: attribution is required, **no commercial use**, and derivatives must be shared under the same licence.\n",
        name = c.name,
        bytes = c.blob_bytes,
        crc = c.blob_crc,
        params = c.parameters,
        k = c.k,
        macs = c.endpoint_macs,
        sine = c.sine.core_name(),
        epoch = c.epoch,
        val = val,
        run = run.display(),
        n = test.windows.len(),
        seed = c.base_seed,
        a = m.min_ade,
        f = m.min_fde,
        a1 = m.ade_k1,
        f1 = m.fde_k1,
        cva = cv.ade_k1,
        cvf = cv.fde_k1,
        mf = m.mean_fde,
        cfg = c.config_toml,
    )
}

/// What `gpecnet eval` prints and returns.
#[derive(Clone, Debug)]
pub struct EvalReport {
    /// Model name from the blob.
    pub name: String,
    /// Metrics through gpecnet-core.
    pub metrics: Metrics,
    /// Constant-velocity baseline on the same windows.
    pub constant_velocity: Metrics,
    /// `Some(true)` when the blob's model card exists and its numbers are reproduced exactly.
    pub matches_card: Option<bool>,
    /// Where the picture was written.
    pub svg: Option<PathBuf>,
}

/// The sine a blob's golden sidecar names (the one its numbers were made with), if any.
pub fn sine_of_blob(blob_path: &Path) -> Option<SineKind> {
    let bytes = std::fs::read(blob_path.with_extension("golden")).ok()?;
    let set = gpecnet_core::golden::GoldenSet::parse(&bytes).ok()?;
    match set.info().sine {
        "libm" => Some(SineKind::Libm),
        "fast-f32" => Some(SineKind::Fast),
        _ => None,
    }
}

/// Evaluates a blob through `gpecnet-core` on the SDD test set, compares with
/// its model card, and draws `n_draw` predictions (every `stride`-th window).
pub fn eval_blob(
    blob_path: &Path,
    data_root: &Path,
    sine: Option<SineKind>,
    k: usize,
    base_seed: u64,
    svg: Option<&Path>,
    n_draw: usize,
) -> Result<EvalReport> {
    let blob =
        std::fs::read(blob_path).with_context(|| format!("reading {}", blob_path.display()))?;
    let model = gpecnet_core::Model::from_blob(&blob)
        .map_err(|e| anyhow::anyhow!("{}: {e}", blob_path.display()))?;
    let test = load_sdd(data_root, SddSplit::Test)?;
    let card: Option<serde_json::Value> = std::fs::read(blob_path.with_extension("json"))
        .ok()
        .and_then(|b| serde_json::from_slice(&b).ok());
    let (metrics, preds, matches_card) = if model.numeric() == gpecnet_core::NumericKind::F32 {
        let sine = sine
            .or_else(|| sine_of_blob(blob_path))
            .unwrap_or(SineKind::Libm);
        let (metrics, preds) = evaluate_core(&blob, sine, &test, k, base_seed)?;
        let card: Option<ModelCard> = card.and_then(|v| serde_json::from_value(v).ok());
        let matches = card.map(|c| {
            c.blob_crc == model.crc()
                && c.k == k
                && c.base_seed == base_seed
                && c.sine == sine
                && c.test == metrics
        });
        (metrics, preds, matches)
    } else {
        if sine.is_some() {
            bail!(
                "--sine applies to f32 blobs; {} is fixed point (integer table sine)",
                blob_path.display()
            );
        }
        let (metrics, preds) = crate::quantize::evaluate_core_fixed(&blob, &test, k, base_seed)?;
        let matches = card.map(|c| {
            let want: Option<Metrics> = c
                .get("test_fixed")
                .and_then(|t| serde_json::from_value(t.clone()).ok());
            c.get("k").and_then(|v| v.as_u64()) == Some(k as u64)
                && c.get("base_seed").and_then(|v| v.as_u64()) == Some(base_seed)
                && want == Some(metrics)
        });
        (metrics, preds, matches)
    };
    let svg = match svg {
        Some(path) => {
            let stride = (test.windows.len() / n_draw.max(1)).max(1);
            let items: Vec<_> = test
                .windows
                .iter()
                .zip(&preds)
                .step_by(stride)
                .take(n_draw)
                .collect();
            let title = format!(
                "{} on SDD test (K = {k}, through gpecnet-core): minADE {:.2} px, minFDE {:.2} px",
                model.name(),
                metrics.min_ade,
                metrics.min_fde
            );
            write_atomic(
                path,
                crate::draw::predictions_svg(&title, "px", &items, 4).as_bytes(),
            )?;
            Some(path.to_path_buf())
        }
        None => None,
    };
    Ok(EvalReport {
        name: model.name().to_string(),
        metrics,
        constant_velocity: evaluate_baseline(&test, constant_velocity),
        matches_card,
        svg,
    })
}
