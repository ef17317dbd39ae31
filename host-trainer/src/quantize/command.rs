//! `gpecnet quantize`: the fixed-point blob, its golden file and its model card.

use anyhow::{anyhow, bail, Context, Result};
use gpecnet_core::blob::NumericKind;
use serde::{Deserialize, Serialize};

use super::{
    calibrate, evaluate_core_fixed, evaluate_reference_fixed, qgolden_bytes, quantize, QModel,
    MARGIN,
};
use crate::data::Window;
use crate::eval::{dist_metrics, DistMetrics, Metrics};

/// The machine-readable card of a fixed-point blob (`weights/<name>-q.json`);
/// the workspace tests re-evaluate the blob and require these exact numbers.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct QuantCard {
    /// Model name (file stem).
    pub name: String,
    /// File name of the f32 source blob.
    pub source: String,
    /// CRC-32 of the f32 source blob.
    pub source_crc: u32,
    /// Size of the f32 source blob in bytes.
    pub source_bytes: usize,
    /// CRC-32 of the fixed-point blob.
    pub blob_crc: u32,
    /// Size of the fixed-point blob in bytes.
    pub blob_bytes: usize,
    /// Parameters.
    pub parameters: usize,
    /// Sine of the f32 numbers (`libm` / `fast-f32`).
    pub source_sine: String,
    /// Samples per window.
    pub k: usize,
    /// Window `i` of the test set uses latent seed `base_seed + i`.
    pub base_seed: u64,
    /// SDD training windows used for calibration.
    pub calibration_windows: usize,
    /// f32 source through `gpecnet_core::Predictor` on SDD test (pixels).
    pub test_f32: Metrics,
    /// Fixed point through `gpecnet_core::Predictor` (its fixed-point engine) on SDD test (pixels).
    pub test_fixed: Metrics,
    /// Fixed-point engine scratch bytes (`16·W`) at the smallest width the model allows.
    pub scratch_bytes: usize,
    /// Distribution quality of the f32 source's K samples on SDD test (KDE NLL in nats/px,
    /// hit rates at 20 / 40 px).
    pub test_f32_dist: DistMetrics,
    /// The same for the fixed-point blob.
    pub test_fixed_dist: DistMetrics,
    /// Format-2 inference settings (absent for format-1 models).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub inference: Option<crate::ship::Inference>,
    /// The f32 source's point forecast on SDD test (K = 1 metrics), for models with a head.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub test_f32_point: Option<Metrics>,
    /// The fixed-point point forecast on SDD test.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub test_fixed_point: Option<Metrics>,
    /// Constant velocity with its window chosen on validation, on SDD test.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub test_cv: Option<crate::ship::CvBaseline>,
}

/// Every `GOLDEN_STRIDE`-th test window becomes a golden case (as in `ship`).
pub const GOLDEN_STRIDE: usize = 10;

/// `gpecnet quantize`: quantizes the f32 blob `src` (calibrating on every
/// `cal_stride`-th SDD training window, `cal_k` latent samples each) and
/// writes `<out>.gpec/.golden/.json/.md`, the numbers computed through
/// `gpecnet-core` and cross-checked bit for bit against the integer reference.
///
/// With `endpoint_only`: `encoder_dest` and
/// `predictor` are dropped (the format allows both absent), so the blob holds
/// only what endpoint prediction runs (`encoder_past` + `decoder`, about half
/// the parameters); trajectories are then the straight line from the last
/// observation to each endpoint (so ADE differs, FDE does not).
#[allow(clippy::too_many_arguments)]
pub fn quantize_blob_with(
    src: &std::path::Path,
    out: &std::path::Path,
    data_root: &std::path::Path,
    k: usize,
    base_seed: u64,
    cal_stride: usize,
    cal_k: usize,
    endpoint_only: bool,
) -> Result<QuantCard> {
    use crate::data::{load_sdd, SddSplit};
    let name = out
        .file_stem()
        .and_then(|s| s.to_str())
        .ok_or_else(|| anyhow!("--out needs a file name"))?
        .to_string();
    if name.is_empty()
        || !name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_')
    {
        bail!("model name {name:?}: use letters, digits, '-' and '_'");
    }
    let src_bytes = std::fs::read(src).with_context(|| format!("reading {}", src.display()))?;
    let src_model = gpecnet_core::Model::from_blob(&src_bytes)
        .map_err(|e| anyhow!("{}: {e}", src.display()))?;
    if src_model.numeric() != NumericKind::F32 {
        bail!("{} is not an f32 blob", src.display());
    }
    let mut model = crate::export::read_blob(&src_bytes)?;
    if endpoint_only {
        model.nets.encoder_dest.clear();
        model.nets.predictor.clear();
    }
    let train = load_sdd(data_root, SddSplit::Train)?;
    let cal_windows: Vec<Window> = train
        .windows
        .iter()
        .step_by(cal_stride.max(1))
        .cloned()
        .collect();
    eprintln!(
        "calibrating on {} SDD training windows (K = {cal_k}) ...",
        cal_windows.len()
    );
    let cal = calibrate(&model, &cal_windows, cal_k);
    let q = quantize(&model, &cal, &name)?;
    let blob = crate::export::blob_bytes(&q)?;
    let core = gpecnet_core::Model::from_blob(&blob).map_err(|e| anyhow!("{e}"))?;
    let test = load_sdd(data_root, SddSplit::Test)?;
    let sine = crate::ship::sine_of_blob(src).unwrap_or(crate::reference::SineKind::Libm);
    eprintln!(
        "evaluating f32 and fixed point on {} SDD test windows (K = {k}) ...",
        test.windows.len()
    );
    let (test_f32, pf) = crate::core_eval::evaluate_core(&src_bytes, sine, &test, k, base_seed)?;
    let test_f32_dist = dist_metrics(&test, &pf).context("empty SDD test set")?;
    let (test_fixed, pc) = evaluate_core_fixed(&blob, &test, k, base_seed)?;
    let test_fixed_dist = dist_metrics(&test, &pc).context("empty SDD test set")?;
    let (ref_fixed, pr) = evaluate_reference_fixed(&q, &test, k, base_seed)?;
    if test_fixed != ref_fixed
        || pc
            .iter()
            .zip(&pr)
            .any(|(a, b)| a.trajectories != b.trajectories)
    {
        bail!("gpecnet-core's fixed path and the integer reference disagree");
    }
    let inputs: Vec<(Vec<[f32; 2]>, u64)> = test
        .windows
        .iter()
        .enumerate()
        .step_by(GOLDEN_STRIDE)
        .map(|(i, w)| (w.obs().to_vec(), base_seed.wrapping_add(i as u64)))
        .collect();
    let golden = qgolden_bytes(&q, core.crc(), k, &inputs)?;
    let test_f32_point = crate::core_eval::evaluate_point_core(&src_bytes, sine, &test)?;
    let test_fixed_point = crate::core_eval::evaluate_point_core(&blob, sine, &test)?;
    if let Some((_, pc)) = &test_fixed_point {
        let same = pc.iter().zip(&test.windows).all(|(p, w)| {
            q.predict_point(&w.obs())
                .is_some_and(|r| p.trajectories[0].as_slice() == r.as_slice())
        });
        if !same {
            bail!("gpecnet-core's fixed point forecast and the integer reference disagree");
        }
    }
    let inference = crate::ship::Inference::of(&model);
    let test_cv = match inference {
        Some(_) => Some(crate::ship::cv_baseline(data_root, &test)?),
        None => None,
    };
    let c = core.config();
    let width = core.max_width().max(c.fdim as usize + c.zdim as usize);
    let card = QuantCard {
        name: name.clone(),
        source: src
            .file_name()
            .and_then(|s| s.to_str())
            .unwrap_or("")
            .to_string(),
        source_crc: src_model.crc(),
        source_bytes: src_bytes.len(),
        blob_crc: core.crc(),
        blob_bytes: blob.len(),
        parameters: q.parameter_count(),
        source_sine: sine.core_name().to_string(),
        k,
        base_seed,
        calibration_windows: cal.windows,
        test_f32,
        test_fixed,
        scratch_bytes: 16 * width,
        test_f32_dist,
        test_fixed_dist,
        inference,
        test_f32_point: test_f32_point.map(|p| p.0),
        test_fixed_point: test_fixed_point.map(|p| p.0),
        test_cv,
    };
    let dir = out.parent().unwrap_or(std::path::Path::new("."));
    let path = |ext: &str| dir.join(format!("{name}.{ext}"));
    crate::rundir::write_atomic(&path("gpec"), &blob)?;
    crate::rundir::write_atomic(&path("golden"), &golden)?;
    crate::rundir::write_atomic(
        &path("json"),
        serde_json::to_string_pretty(&card)?.as_bytes(),
    )?;
    crate::rundir::write_atomic(&path("md"), quant_card_md(&card, &q).as_bytes())?;
    Ok(card)
}

/// Rows for the format-2 features of a fixed-point card (empty for format-1 models): the
/// point forecast in f32 and fixed point beside the validation-chosen constant velocity, and
/// the inference settings.
fn quant_card_v2_rows(c: &QuantCard) -> String {
    let mut s = String::new();
    if let (Some(f), Some(x), Some(cv)) = (&c.test_f32_point, &c.test_fixed_point, &c.test_cv) {
        s += &format!(
            "| point forecast ADE | {:.3} | {:.3} | {:+.3} |\n| point forecast FDE | {:.3} | {:.3} | {:+.3} |\n\
| constant velocity, last {} steps (chosen on validation), ADE / FDE | {:.3} / {:.3} | same | – |\n",
            f.ade_k1,
            x.ade_k1,
            x.ade_k1 - f.ade_k1,
            f.fde_k1,
            x.fde_k1,
            x.fde_k1 - f.fde_k1,
            cv.n,
            cv.test.ade_k1,
            cv.test.fde_k1
        );
    }
    if c.inference.is_some() {
        let rows = crate::ship::card_v2_rows(c.inference.as_ref(), None, None);
        s += &rows.replace(" | – |\n", " | same | – |\n");
    }
    s
}

fn quant_card_md(c: &QuantCard, q: &QModel) -> String {
    let (f, x) = (&c.test_f32, &c.test_fixed);
    let exps: Vec<String> = crate::network::NETWORK_NAMES
        .iter()
        .zip(q.nets.in_blob_order())
        .filter(|(_, n)| !n.is_empty())
        .map(|(name, n)| {
            format!(
                "{name}: {}",
                n.iter()
                    .map(|l| format!("{}→{}", l.scale.in_exp, l.scale.out_exp))
                    .collect::<Vec<_>>()
                    .join(", ")
            )
        })
        .collect();
    format!(
        "# Model card: `{name}` (fixed point)\n\n\
Post-training quantization of `weights/{src}` to the `Int16Q15` blob kind (`weights/FORMAT.md`): int16 weights with a \
power-of-two scale per output channel, int32 biases, 16-bit activations, 64-bit accumulators, integer table sine \
(`q15-table`, saturated to ±32767, max error 3.1e-5). Inference inside the networks is pure integer (`gpecnet_core::Predictor` runs such a blob on its fixed-point engine, `Engine<Q15>`).\n\n\
| | |\n|---|---|\n\
| blob | `weights/{name}.gpec`, {bytes} bytes (f32 source: {sbytes} bytes), CRC-32 `{crc:#010x}` |\n\
| source | `{src}`, CRC-32 `{scrc:#010x}`, numbers with sine `{ssine}` |\n\
| parameters | {params} |\n\
| calibration | {cal} SDD training windows, margin {margin} |\n\
| exponents (in→out per layer) | {exps} |\n\
| fixed-point engine scratch at minimum width (`Engine<Q15, W>` rows, `16·W`) | {scratch} bytes |\n\
| networks | {nets} |\n\
| produced by | `gpecnet quantize --blob weights/{src} --out weights/{name}.gpec{flag}` |\n\n\
## SDD test set ({n} windows, pixels), both through `gpecnet-core`\n\n\
Latent seed of window `i` = {seed} + i.\n\n\
| metric | f32 source | fixed point | difference |\n|---|---|---|---|\n\
| minADE, best of K = {k} | {fa:.3} | {xa:.3} | {da:+.3} |\n\
| minFDE, best of K = {k} | {ff:.3} | {xf:.3} | {df:+.3} |\n\
| ADE, K = 1 | {fa1:.3} | {xa1:.3} | {da1:+.3} |\n\
| FDE, K = 1 | {ff1:.3} | {xf1:.3} | {df1:+.3} |\n\
{dist}\n\
## Data licence\n\n\
Derived from weights trained on the Stanford Drone Dataset (CC BY-NC-SA 3.0): attribution required, no commercial use, share alike.\n",
        name = c.name,
        src = c.source,
        nets = if q.nets.predictor.is_empty() {
            "encoder_past + decoder only (endpoint-only: the trajectory predictor is left out; \
endpoints are the product, e.g. for a drone's path planner; ADE below uses the straight line \
from the last observation to each endpoint, FDE is unaffected)"
        } else {
            "encoder_past, decoder, encoder_dest, predictor"
        },
        flag = if q.nets.predictor.is_empty() { " --endpoint-only" } else { "" },
        bytes = c.blob_bytes,
        sbytes = c.source_bytes,
        crc = c.blob_crc,
        scrc = c.source_crc,
        ssine = c.source_sine,
        params = c.parameters,
        cal = c.calibration_windows,
        margin = MARGIN,
        exps = exps.join("; "),
        scratch = c.scratch_bytes,
        n = x.n,
        seed = c.base_seed,
        k = c.k,
        fa = f.min_ade,
        xa = x.min_ade,
        da = x.min_ade - f.min_ade,
        ff = f.min_fde,
        xf = x.min_fde,
        df = x.min_fde - f.min_fde,
        fa1 = f.ade_k1,
        xa1 = x.ade_k1,
        da1 = x.ade_k1 - f.ade_k1,
        ff1 = f.fde_k1,
        xf1 = x.fde_k1,
        df1 = x.fde_k1 - f.fde_k1,
        dist = quant_card_dist_rows(&c.test_f32_dist, &c.test_fixed_dist, c.k)
            + &quant_card_v2_rows(c),
    )
}

/// The fixed-point model card's table rows for the distribution metrics of the f32 source
/// (`f`) and the fixed-point blob (`x`); each row ends in a newline, after the "FDE, K = 1" row.
pub fn quant_card_dist_rows(f: &DistMetrics, x: &DistMetrics, k: usize) -> String {
    format!(
        "| KDE NLL of the true endpoint, K = {k} (nats, px) | {fn_:.3} | {xn:.3} | {dn:+.3} |\n\
| true endpoint within 20 px of a sample, K = {k} | {f20:.2} % | {x20:.2} % | {d20:+.2} % |\n\
| true endpoint within 40 px of a sample, K = {k} | {f40:.2} % | {x40:.2} % | {d40:+.2} % |\n",
        fn_ = f.kde_nll,
        xn = x.kde_nll,
        dn = x.kde_nll - f.kde_nll,
        f20 = 100.0 * f.hit20,
        x20 = 100.0 * x.hit20,
        d20 = 100.0 * (x.hit20 - f.hit20),
        f40 = 100.0 * f.hit40,
        x40 = 100.0 * x.hit40,
        d40 = 100.0 * (x.hit40 - f.hit40),
    )
}
