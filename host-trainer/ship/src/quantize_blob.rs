//! `gpecnet quantize`: the fixed-point blob, its golden file and its model card.

use crate::planner_metrics::PlannerMetrics;
use anyhow::{anyhow, bail, Context, Result};
use gpecnet_core::blob::NumericKind;
use serde::{Deserialize, Serialize};

use crate::card::CardMd;
use crate::dist::{dist_metrics, DistMetrics};
use crate::eval::Metrics;
use crate::fixed_eval::{evaluate_core_fixed, evaluate_reference_fixed};
use crate::quantize::{qgolden_bytes, quantize_with_data, QModel, MARGIN};

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
    pub inference: Option<crate::card::Inference>,
    /// The f32 source's point forecast on SDD test (K = 1 metrics), for models with a head.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub test_f32_point: Option<Metrics>,
    /// The fixed-point point forecast on SDD test.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub test_fixed_point: Option<Metrics>,
    /// Constant velocity with its window chosen on validation, on SDD test.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub test_cv: Option<crate::card::CvBaseline>,
    /// The data set of the calibration and the numbers (absent: `sdd`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dataset: Option<String>,
    /// What a planner gets from the fixed-point model on test (the data set's unit; a model
    /// with endpoint probabilities only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub test_fixed_planner: Option<PlannerMetrics>,
    /// The same in pixels (SDD in metres only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub test_fixed_planner_px: Option<PlannerMetrics>,
}

/// Every `GOLDEN_STRIDE`-th test window becomes a golden case (as in `ship`; longer on large
/// test sets, [`crate::card::golden_stride`]).
pub const GOLDEN_STRIDE: usize = crate::card::GOLDEN_STRIDE;

/// `gpecnet quantize`: quantizes the f32 blob `src` (calibrating on every
/// `cal_stride`-th training window of `dataset` — for the SDD-based sets the whole of
/// `sdd/train`, validation scenes included, as every shipped fixed-point model was —
/// `cal_k` latent samples each; `None` takes the source card's data set, else `sdd`) and
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
    dataset: Option<&crate::data::DatasetSpec>,
    force: bool,
    sign: Option<&crate::signing::SignSpec>,
) -> Result<QuantCard> {
    use crate::data::{DatasetSpec, Split};
    if cal_stride == 0 {
        bail!("--cal-stride 0 is out of range: allowed 1 or more (calibrate on every N-th training window)");
    }
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
    let dir = out.parent().unwrap_or(std::path::Path::new("."));
    let src_files = crate::outpath::blob_and_sidecars(src);
    let mut inputs: Vec<&std::path::Path> = src_files.iter().map(|p| p.as_path()).collect();
    inputs.push(src);
    let data_dirs = crate::outpath::data_input_dirs(data_root);
    let dirs: Vec<&std::path::Path> = data_dirs.iter().map(|p| p.as_path()).collect();
    let writer = crate::outpath::ArtefactWriter::begin("--out", dir, &name, force, &inputs, &dirs)?;
    let src_bytes = crate::inpath::read_limited(src, crate::inpath::FileKind::Blob)?;
    let src_model = gpecnet_core::Model::from_blob(&src_bytes)
        .map_err(|e| anyhow!("{}: {e}", src.display()))?;
    if src_model.numeric() != NumericKind::F32 {
        bail!("{} is not an f32 blob", src.display());
    }
    crate::core_eval::check_k("--k", &src_model, k)
        .with_context(|| format!("quantizing {}", src.display()))?;
    let spec = match dataset {
        Some(d) => d.clone(),
        None => match crate::inpath::read_limited(
            &src.with_extension("json"),
            crate::inpath::FileKind::Text,
        ) {
            Ok(b) => {
                crate::card::card_dataset(&serde_json::from_slice(&b).with_context(|| {
                    format!("{}: not a model card", src.with_extension("json").display())
                })?)?
            }
            Err(_) => DatasetSpec::Sdd,
        },
    };
    let src_meta = gpecnet_core::blob::Meta::of_blob(&src_bytes)
        .map_err(|e| anyhow!("{}: {e}", src.display()))?;
    crate::units::check_unit(&src_model, &src_meta, &spec, None)
        .with_context(|| format!("quantizing {}", src.display()))?;
    let mut model = crate::export::read_blob(&src_bytes)?;
    if endpoint_only {
        model.nets.encoder_dest.clear();
        model.nets.predictor.clear();
    }
    let train = crate::data::load(data_root, &spec, Split::Train, &[])?;
    // Every `cal_stride`-th training window (what `quantize_with_data` calibrates on).
    let cal_windows = train.windows.len().div_ceil(cal_stride.max(1));
    eprintln!("calibrating on {cal_windows} {spec} training windows (K = {cal_k}) ...");
    let q = quantize_with_data(&model, &train, cal_stride, cal_k, &name)?;
    let blob = crate::export::blob_bytes(&q)?;
    let core = gpecnet_core::Model::from_blob(&blob).map_err(|e| anyhow!("{e}"))?;
    let test = crate::card::test_windows(data_root, &spec)?;
    let sine = crate::export::sine_of_blob(src).unwrap_or(crate::reference::SineKind::Libm);
    eprintln!(
        "evaluating f32 and fixed point on {} {spec} test windows (K = {k}) ...",
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
        .step_by(crate::card::golden_stride(test.windows.len()))
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
    let (test_fixed_planner, test_fixed_planner_px) =
        match crate::core_eval::planner_core(&blob, sine, &test, base_seed)? {
            Some(outs) => {
                let k = q.proposal_latents();
                let same = crate::core_eval::probabilities_match(&test.windows, &outs, |past| {
                    q.probabilities(past, k)
                });
                if !same {
                    bail!("gpecnet-core's fixed probabilities and the integer reference disagree");
                }
                let (p, px) = crate::card::planner_pair(data_root, &spec, &test, &outs)?;
                (Some(p), px)
            }
            None => (None, None),
        };
    let inference = crate::card::Inference::of(&model);
    let test_cv = match inference {
        Some(_) => Some(crate::card::cv_baseline(data_root, &spec, &test)?),
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
        calibration_windows: cal_windows,
        test_f32,
        test_fixed,
        scratch_bytes: 16 * width,
        test_f32_dist,
        test_fixed_dist,
        inference,
        test_f32_point: test_f32_point.map(|p| p.0),
        test_fixed_point: test_fixed_point.map(|p| p.0),
        test_cv,
        dataset: (spec != DatasetSpec::Sdd).then(|| spec.to_string()),
        test_fixed_planner,
        test_fixed_planner_px,
    };
    check_fixed_tolerance(test_f32.min_fde, test_fixed.min_fde, spec.unit(), force)
        .with_context(|| format!("quantizing {} to {name}", src.display()))?;
    let data = crate::card::CardData::new(q.config.meta.as_ref(), &spec, test.windows.len());
    let md = quant_card_md(&card, &exponents(&q), q.nets.predictor.is_empty(), &data);
    let blob = match sign {
        Some(s) => s.sign(&blob)?,
        None => blob,
    };
    writer.commit(
        &blob,
        &golden,
        serde_json::to_string_pretty(&card)?.as_bytes(),
        md.as_bytes(),
    )?;
    Ok(card)
}

/// Largest accepted difference between the fixed-point and the f32 test minFDE of a
/// pixel model (0.5 px; the shipped fixed-point models differ by at most 0.006 px).
pub const MAX_FIXED_FDE_DIFF_PX: f64 = 0.5;
/// The same for a metre model (0.02 m, about 0.5 px at SDD's typical 0.04 m per pixel).
pub const MAX_FIXED_FDE_DIFF_M: f64 = 0.02;

/// Refuses (unless `force`) a fixed-point model whose test minFDE (`fixed_fde`) differs
/// from its f32 source's (`f32_fde`) by more than [`MAX_FIXED_FDE_DIFF_PX`] /
/// [`MAX_FIXED_FDE_DIFF_M`] (by `unit`): such a quantization lost accuracy that the card
/// would only report, not prevent. A NaN difference is refused too.
pub fn check_fixed_tolerance(
    f32_fde: f64,
    fixed_fde: f64,
    unit: crate::data::Unit,
    force: bool,
) -> Result<()> {
    let (tol, u) = match unit {
        crate::data::Unit::Pixels => (MAX_FIXED_FDE_DIFF_PX, "px"),
        crate::data::Unit::Metres => (MAX_FIXED_FDE_DIFF_M, "m"),
    };
    let diff = fixed_fde - f32_fde;
    if force || diff.abs() <= tol {
        return Ok(());
    }
    bail!(
        "the fixed-point model has test minFDE {fixed_fde:.3} {u}, its f32 source {f32_fde:.3} {u}: \
         a difference of {diff:+.3} {u}, over the tolerance of {tol} {u}; nothing was written \
         (use --force to write it anyway)"
    )
}

/// One row of the fixed-point card's comparison table: `label`, the f32 source's value, the
/// fixed-point value and their difference, each through `fmt` (with the sign forced on the
/// difference).
fn diff_row(label: &str, f: f64, x: f64, fmt: impl Fn(f64, bool) -> String) -> String {
    format!(
        "| {label} | {} | {} | {} |\n",
        fmt(f, false),
        fmt(x, false),
        fmt(x - f, true)
    )
}

/// Three decimals (`{:.3}` / `{:+.3}`).
fn dec3(v: f64, signed: bool) -> String {
    if signed {
        format!("{v:+.3}")
    } else {
        format!("{v:.3}")
    }
}

/// Percent with two decimals (`{:.2} %` / `{:+.2} %`) of a fraction.
fn pct2(v: f64, signed: bool) -> String {
    let v = 100.0 * v;
    if signed {
        format!("{v:+.2} %")
    } else {
        format!("{v:.2} %")
    }
}

/// Rows for the format-2 features of a fixed-point card (empty for format-1 models): the
/// point forecast in f32 and fixed point beside the validation-chosen constant velocity, and
/// the inference settings.
fn quant_card_v2_rows(c: &QuantCard) -> String {
    let mut s = String::new();
    if let (Some(f), Some(x), Some(cv)) = (&c.test_f32_point, &c.test_fixed_point, &c.test_cv) {
        s += &diff_row("point forecast ADE", f.ade_k1, x.ade_k1, dec3);
        s += &diff_row("point forecast FDE", f.fde_k1, x.fde_k1, dec3);
        s += &format!(
            "| constant velocity, last {} steps (chosen on validation), ADE / FDE | {:.3} / {:.3} | same | – |\n",
            cv.n, cv.test.ade_k1, cv.test.fde_k1
        );
        s += &crate::card::point_vs_cv_row(x, cv, 3, "same | – |");
    }
    if c.inference.is_some() {
        let rows = crate::card::card_v2_rows(c.inference.as_ref(), None, None, 2);
        s += &rows.replace(" | – |\n", " | same | – |\n");
    }
    s
}

/// The exponents of every layer of `q`'s networks, one entry per network
/// (`encoder_past: 6→15, 15→10`).
fn exponents(q: &QModel) -> Vec<String> {
    crate::network::NETWORK_NAMES
        .iter()
        .zip(q.nets.in_blob_order())
        .chain(std::iter::once((&"proposal", q.nets.proposal.as_slice())))
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
        .collect()
}

/// The human-readable card of a fixed-point blob: `exps` from [`exponents`];
/// `endpoint_only` when the trajectory predictor was left out.
fn quant_card_md(
    c: &QuantCard,
    exps: &[String],
    endpoint_only: bool,
    data: &crate::card::CardData,
) -> String {
    let (f, x) = (&c.test_f32, &c.test_fixed);
    let (name, src, k) = (&c.name, &c.source, c.k);
    let (nets, flag) = if endpoint_only {
        (
            "encoder_past + decoder only (endpoint-only: the trajectory predictor is left out; \
endpoints are the product, e.g. for a drone's path planner; ADE below uses the straight line \
from the last observation to each endpoint, FDE is unaffected)",
            " --endpoint-only",
        )
    } else {
        ("encoder_past, decoder, encoder_dest, predictor", "")
    };
    CardMd::new(
        &format!("`{name}` (fixed point)"),
        &format!(
            "Post-training quantization of `weights/{src}` to the `Int16Q15` blob kind (`weights/FORMAT.md`): int16 weights with a \
power-of-two scale per output channel, int32 biases, 16-bit activations, 64-bit accumulators, integer table sine \
(`q15-table`, saturated to ±32767, max error 3.1e-5). Inference inside the networks is pure integer (`gpecnet_core::Predictor` runs such a blob on its fixed-point engine, `Engine<Q15>`)."
        ),
    )
    .fact(
        "blob",
        format!(
            "`weights/{name}.gpec`, {} bytes (f32 source: {} bytes), CRC-32 `{:#010x}`",
            c.blob_bytes, c.source_bytes, c.blob_crc
        ),
    )
    .fact(
        "source",
        format!(
            "`{src}`, CRC-32 `{:#010x}`, numbers with sine `{}`",
            c.source_crc, c.source_sine
        ),
    )
    .fact("parameters", c.parameters)
    .text(if data.unit == "px" && c.dataset.is_none() { "" } else { &data.facts })
    .fact(
        "calibration",
        format!(
            "{} {} training windows, margin {MARGIN}",
            c.calibration_windows,
            c.dataset.as_deref().map_or("SDD", |d| d)
        ),
    )
    .fact("exponents (in→out per layer)", exps.join("; "))
    .fact(
        "fixed-point engine scratch at minimum width (`Engine<Q15, W>` rows, `16·W`)",
        format!("{} bytes", c.scratch_bytes),
    )
    .fact("networks", nets)
    .fact(
        "produced by",
        format!("`gpecnet quantize --blob weights/{src} --out weights/{name}.gpec{flag}`"),
    )
    .section(
        &format!("{}, both through `gpecnet-core`", data.test_set),
        &format!("Latent seed of window `i` = {} + i.\n\n", c.base_seed),
    )
    .table(&["metric", "f32 source", "fixed point", "difference"])
    .text(&diff_row(&format!("minADE, best of K = {k}"), f.min_ade, x.min_ade, dec3))
    .text(&diff_row(&format!("minFDE, best of K = {k}"), f.min_fde, x.min_fde, dec3))
    .text(&diff_row("ADE, K = 1", f.ade_k1, x.ade_k1, dec3))
    .text(&diff_row("FDE, K = 1", f.fde_k1, x.fde_k1, dec3))
    .text(&if data.unit == "px" {
        quant_card_dist_rows(&c.test_f32_dist, &c.test_fixed_dist, k)
    } else {
        diff_row(
            &format!("KDE NLL of the true endpoint, K = {k} (nats, m)"),
            c.test_f32_dist.kde_nll,
            c.test_fixed_dist.kde_nll,
            dec3,
        )
    })
    .text(&quant_card_v2_rows(c))
    .text(&c.test_fixed_planner.as_ref().map_or(String::new(), |p| {
        format!(
            "\n## What a planner gets (fixed point, through `gpecnet-core`)\n\nEach endpoint's probability and the point forecast's radii r50 / r90 (`gpecnet_core::planner`; `docs/planner.md` defines every number).\n\n| metric | this model | |\n|---|---|---|\n{}",
            crate::card::planner_rows(p, c.test_fixed_planner_px.as_ref(), data.unit, if data.unit == "m" { 3 } else { 2 })
        )
    }))
    .section(
        "Data licence",
        if c.dataset.as_deref().is_none_or(|d| d.starts_with("sdd")) {
            "Derived from weights trained on the Stanford Drone Dataset (CC BY-NC-SA 3.0): attribution required, no commercial use, share alike.\n"
        } else {
            &data.licence
        },
    )
    .finish()
}

/// The fixed-point model card's table rows for the distribution metrics of the f32 source
/// (`f`) and the fixed-point blob (`x`); each row ends in a newline, after the "FDE, K = 1" row.
pub fn quant_card_dist_rows(f: &DistMetrics, x: &DistMetrics, k: usize) -> String {
    diff_row(
        &format!("KDE NLL of the true endpoint, K = {k} (nats, px)"),
        f.kde_nll,
        x.kde_nll,
        dec3,
    ) + &diff_row(
        &format!("true endpoint within 20 px of a sample, K = {k}"),
        f.hit20,
        x.hit20,
        pct2,
    ) + &diff_row(
        &format!("true endpoint within 40 px of a sample, K = {k}"),
        f.hit40,
        x.hit40,
        pct2,
    )
}
