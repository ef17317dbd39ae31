//! `gpecnet eval`: a shipped blob through `gpecnet-core` on the test split of a data set (after
//! the unit check of [`crate::units`]), compared with its model card when the card is about
//! the same data set, with the SDD-in-metres results converted back to pixels; and
//! `--update-card`, which adds the distribution metrics to an existing card.

use crate::planner_metrics::PlannerMetrics;
use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use serde::Serialize;

use crate::baseline::{
    constant_velocity, constant_velocity_n, evaluate_baseline, evaluate_baseline_with, select_cv_n,
};
use crate::card::{
    card_dataset, cv_baseline_of, model_card_dist_rows, refuse_empty_test, test_windows,
    validation_windows, ModelCard,
};
use crate::core_eval::evaluate_core;
use crate::data::{self, Dataset, DatasetSpec, Unit};
use crate::dist::{dist_accumulator, dist_metrics, DistMetrics};
use crate::eval::Metrics;
use crate::reference::SineKind;
use crate::rundir::write_atomic;
use crate::units::check_unit;

/// What `gpecnet eval` prints and returns.
#[derive(Clone, Debug)]
pub struct EvalReport {
    /// Model name from the blob.
    pub name: String,
    /// The data set evaluated (`sdd`, `sdd-m`, `eth_ucy:<scene>`).
    pub dataset: String,
    /// The unit of every number (checked against the blob's).
    pub unit: Unit,
    /// Metrics through gpecnet-core.
    pub metrics: Metrics,
    /// Constant-velocity baseline (last step, `n = 1`) on the same windows.
    pub constant_velocity: Metrics,
    /// Distribution quality of the K samples on the test set (KDE NLL, hit rates at 20/40 px).
    pub dist: DistMetrics,
    /// The model's single point forecast (ADE, FDE) on the test set, when it has one; `None`
    /// until a point forecast exists (printed as `null` / "n/a").
    pub point: Option<(f64, f64)>,
    /// Constant-velocity window `n` (1..=7 observed steps) chosen by the lowest FDE on the
    /// data set's validation windows, or [`FIXED_CV_N`] for a folder without `val/`.
    pub cv_n: usize,
    /// `Some(folder)` when the data set is a folder without `val/`: `cv_n` is then fixed at
    /// [`FIXED_CV_N`], not chosen.
    pub cv_fixed: Option<String>,
    /// Constant velocity with `cv_n` on the test set.
    pub cv: Metrics,
    /// Constant velocity with `n = 1..=7` on the validation scenes (element `n - 1`).
    pub cv_val: Vec<Metrics>,
    /// Number of validation windows `cv_n` was chosen on.
    pub n_val: usize,
    /// Fractions of windows with a sample within each radius of the true endpoint (dataset
    /// units: 20 and 40 px, or 0.5 and 1 m).
    pub hits: [(f64, f64); 2],
    /// SDD in metres only: the same results in pixels, scene by scene.
    pub pixels: Option<PixelEquivalent>,
    /// The same numbers per scene (the source file's stem), in the order scenes first appear.
    pub scenes: Vec<SceneRow>,
    /// The same numbers per observed speed (`|p_7 − p_0|` over the 2.8 s observed:
    /// [`crate::data::SPEED_BINS_M_S`]), for data in metres; empty for pixels.
    pub speeds: Vec<SceneRow>,
    /// The same numbers for the windows whose motion state changes, for data in metres:
    /// starters, stoppers and the rest ([`crate::data::motion_change`]); empty for pixels.
    pub changes: Vec<SceneRow>,
    /// The blob's card is about another data set (so it was not compared).
    pub card_on_other_data: bool,
    /// `Some(true)` when the blob's model card exists and its numbers (ADE/FDE and the
    /// distribution metrics) are reproduced exactly.
    pub matches_card: Option<bool>,
    /// Where the picture was written.
    pub svg: Option<PathBuf>,
    /// What a planner gets (a model with endpoint probabilities; the data set's unit).
    pub planner: Option<PlannerMetrics>,
    /// The same in pixels (SDD in metres only).
    pub planner_px: Option<PlannerMetrics>,
    /// Where the reliability diagram was written.
    pub reliability: Option<PathBuf>,
}

/// Field `key` of a model card's JSON `card`, if present and of type `T`.
fn card_field<T: serde::de::DeserializeOwned>(card: &serde_json::Value, key: &str) -> Option<T> {
    card.get(key)
        .and_then(|t| serde_json::from_value(t.clone()).ok())
}

/// SDD-in-metres results converted back to pixels scene by scene (every error divided by
/// its scene's metres per pixel), so they compare with the pixel literature.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct PixelEquivalent {
    /// Best-of-K metrics in pixels.
    pub metrics: Metrics,
    /// The point forecast's (ADE, FDE) in pixels.
    pub point: Option<(f64, f64)>,
    /// Constant velocity with the validation-chosen window, on the pixel test set.
    pub cv: Metrics,
}

/// The constant-velocity window of a folder with no `val/` to choose it on: 2 observed
/// steps (0.8 s), the window the SDD validation scenes choose.
pub const FIXED_CV_N: usize = 2;

/// One scene's share of the test windows and its numbers (the data set's unit).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SceneRow {
    /// The scene (the file stem).
    pub scene: String,
    /// Its test windows.
    pub n: usize,
    /// Best-of-K ADE and FDE.
    pub min_ade: f64,
    /// Best-of-K FDE.
    pub min_fde: f64,
    /// The point forecast's FDE (a model with a point head).
    pub point_fde: Option<f64>,
    /// Constant velocity with the report's `cv_n`: ADE.
    pub cv_ade: f64,
    /// Constant velocity with the report's `cv_n`: FDE.
    pub cv_fde: f64,
    /// Fractions of windows with a sample within each of the unit's two radii.
    pub hits: [f64; 2],
}

/// The labels of the observed-speed groups of [`EvalReport::speeds`], slowest first: the
/// data crate's bins ([`crate::data::SPEED_BINS_M_S`], the online loop's motion states).
fn speed_labels() -> [String; 4] {
    let [s, m, f] = crate::data::SPEED_BINS_M_S;
    let [a, b, c, d] = crate::data::SPEED_BIN_NAMES;
    [
        format!("{a} <{s} m/s"),
        format!("{b} {s}-{m} m/s"),
        format!("{c} {m}-{f} m/s"),
        format!("{d} >={f} m/s"),
    ]
}

/// The [`SceneRow`]s of `test` and its predictions (`point`: the point forecasts), one per
/// scene in the order scenes first appear.
fn scene_rows(
    test: &Dataset,
    preds: &[crate::eval::Prediction],
    point: Option<&[crate::eval::Prediction]>,
    cv_n: usize,
    radii: [f64; 2],
) -> Result<Vec<SceneRow>> {
    group_rows(test, preds, point, cv_n, radii, &test.scenes(), |w| {
        w.scene.clone()
    })
}

/// Rows of `test` grouped by `key` of each window, one per label of `order` that has windows
/// (labels in `order`'s order): best-of-K, point forecast, constant velocity and hit rates of
/// each group, as [`scene_rows`] per scene.
fn group_rows(
    test: &Dataset,
    preds: &[crate::eval::Prediction],
    point: Option<&[crate::eval::Prediction]>,
    cv_n: usize,
    radii: [f64; 2],
    order: &[String],
    key: impl Fn(&crate::data::Window) -> String,
) -> Result<Vec<SceneRow>> {
    let keys: Vec<String> = test.windows.iter().map(&key).collect();
    let mut out = Vec::new();
    for scene in order.iter().cloned() {
        let idx: Vec<usize> = (0..test.windows.len())
            .filter(|&i| keys[i] == scene)
            .collect();
        if idx.is_empty() {
            continue;
        }
        let sub = Dataset {
            name: scene.clone(),
            unit: test.unit,
            windows: idx.iter().map(|&i| test.windows[i].clone()).collect(),
        };
        let pick = |p: &[crate::eval::Prediction]| -> Vec<crate::eval::Prediction> {
            idx.iter().filter_map(|&i| p.get(i).cloned()).collect()
        };
        let mine = pick(preds);
        let mut acc = crate::eval::MetricsAccumulator::new();
        for (w, p) in sub.windows.iter().zip(&mine) {
            acc.add(w, p)?;
        }
        let m = acc.finish();
        let point_fde = match point {
            Some(p) => {
                let mut a = crate::eval::MetricsAccumulator::new();
                for (w, q) in sub.windows.iter().zip(pick(p)) {
                    a.add(w, &q)?;
                }
                Some(a.finish().fde_k1)
            }
            None => None,
        };
        let cv = evaluate_baseline_with(&sub, |w| constant_velocity_n(w, cv_n));
        let dist = dist_accumulator(&sub, &mine).context("one prediction per test window")?;
        out.push(SceneRow {
            scene,
            n: m.n,
            min_ade: m.min_ade,
            min_fde: m.min_fde,
            point_fde,
            cv_ade: cv.ade_k1,
            cv_fde: cv.fde_k1,
            hits: radii.map(|r| dist.within(r)),
        });
    }
    Ok(out)
}

/// What a blob is evaluated on: a data set, and the unit to assume for a blob that states
/// none ([`check_unit`]).
#[derive(Clone, Debug, PartialEq)]
pub struct EvalTarget {
    /// The data set (its test split is evaluated, its validation split picks the CV window).
    pub dataset: DatasetSpec,
    /// Unit of a blob before format version 4.
    pub assume_unit: Option<Unit>,
}

/// The data set of the default model ([`DEFAULT_BLOB`]): SDD in metres.
impl Default for EvalTarget {
    fn default() -> Self {
        Self {
            dataset: DatasetSpec::SddMetres,
            assume_unit: None,
        }
    }
}

/// The blob `gpecnet eval` evaluates when none is named: the shipped default model, the one
/// the firmware embeds (metres, trained on SDD in metres).
pub const DEFAULT_BLOB: &str = "weights/sdd-m-lp-qe.gpec";

/// The data set a blob is about, for an evaluation that names none: its model card's
/// `dataset` (`<blob>.json`, the set its shipped numbers are on), else what the blob itself
/// records (format version 4: its unit and training data; SDD in metres is `sdd-m`, SDD in
/// pixels `sdd`, an ETH/UCY leave-one-out split its scene), else `sdd` for a blob before
/// version 4 (every such shipped blob is in SDD pixels). An error, asking for `--dataset`,
/// when neither says.
pub fn own_dataset(blob_path: &Path) -> Result<DatasetSpec> {
    let card = crate::inpath::read_limited(
        &blob_path.with_extension("json"),
        crate::inpath::FileKind::Text,
    )
    .ok()
    .and_then(|b| serde_json::from_slice::<serde_json::Value>(&b).ok());
    if let Some(spec) = card.and_then(|c| {
        c.get("dataset")
            .and_then(|d| d.as_str())
            .and_then(|d| DatasetSpec::parse(d).ok())
    }) {
        return Ok(spec);
    }
    let blob = crate::inpath::read_limited(blob_path, crate::inpath::FileKind::Blob)?;
    let meta = gpecnet_core::blob::Meta::of_blob(&blob)
        .map_err(|e| anyhow::anyhow!("{}: {e}", blob_path.display()))?;
    use gpecnet_core::blob::PositionUnit;
    let eth_ucy = meta
        .data
        .strip_prefix("ETH/UCY leave-one-scene-out split of ")
        .and_then(|rest| rest.split(':').next())
        .filter(|scene| !scene.contains(' '));
    let spec = match (meta.unit, eth_ucy) {
        (PositionUnit::Unknown, _) if meta.data.is_empty() => Some(DatasetSpec::Sdd),
        (PositionUnit::Metre, Some(scene)) => DatasetSpec::parse(&format!("eth_ucy:{scene}")).ok(),
        (PositionUnit::Metre, None) if meta.data.starts_with("SDD ") => {
            Some(DatasetSpec::SddMetres)
        }
        (PositionUnit::Pixel, None) if meta.data.starts_with("SDD ") => Some(DatasetSpec::Sdd),
        _ => None,
    };
    spec.with_context(|| {
        format!(
            "{}: no model card names its data set and its recorded training data ({:?}) is \
             none of sdd, sdd-m or eth_ucy:<scene>; name the data set with --dataset",
            blob_path.display(),
            meta.data
        )
    })
}

/// Evaluates a blob through `gpecnet-core` on the test split of `target`'s data set (after
/// [`check_unit`]: a blob in another unit is refused before anything runs), compares with
/// its model card when the card is about the same data set, and draws `n_draw` predictions
/// (every `stride`-th window).
#[allow(clippy::too_many_arguments)]
pub fn eval_blob(
    blob_path: &Path,
    data_root: &Path,
    target: &EvalTarget,
    sine: Option<SineKind>,
    k: usize,
    base_seed: u64,
    svg: Option<&Path>,
    n_draw: usize,
    reliability: Option<&Path>,
) -> Result<EvalReport> {
    for (flag, out) in [("--draw", svg), ("--reliability", reliability)] {
        let Some(out) = out else { continue };
        let inputs = crate::outpath::blob_and_sidecars(blob_path);
        let mut refs: Vec<&Path> = inputs.iter().map(PathBuf::as_path).collect();
        refs.push(blob_path);
        let data_dirs = crate::outpath::data_input_dirs(data_root);
        let dirs: Vec<&Path> = data_dirs.iter().map(PathBuf::as_path).collect();
        crate::outpath::check_output(flag, out, &refs, &dirs)?;
    }
    if svg.is_some() && svg == reliability {
        bail!("--draw and --reliability name the same file");
    }
    let blob = crate::inpath::read_limited(blob_path, crate::inpath::FileKind::Blob)?;
    let model = gpecnet_core::Model::from_blob(&blob)
        .map_err(|e| anyhow::anyhow!("{}: {e}", blob_path.display()))?;
    crate::core_eval::check_k("--k", &model, k)
        .with_context(|| format!("evaluating {}", blob_path.display()))?;
    let spec = &target.dataset;
    let meta = gpecnet_core::blob::Meta::of_blob(&blob)
        .map_err(|e| anyhow::anyhow!("{}: {e}", blob_path.display()))?;
    let unit = check_unit(&model, &meta, spec, target.assume_unit)
        .with_context(|| format!("evaluating {}", blob_path.display()))?;
    // A folder without val/ is evaluated zero-shot: nothing to choose the constant-velocity
    // window on, so it is fixed (and the report says so).
    let no_val = match spec {
        DatasetSpec::Folder { dir, .. } if !Path::new(dir).join("val").exists() => {
            Some(dir.clone())
        }
        _ => None,
    };
    let Splits { test, val, pixels } = read_splits(data_root, spec, no_val.is_none())?;
    let (cv_n, cv_val, n_val) = match &val {
        None => (FIXED_CV_N, Vec::new(), 0),
        Some(val) => {
            let empty = spec.empty_files(data::Split::Val);
            let (n, sweep) = select_cv_n(val).with_context(|| match spec {
                // Empty files are named as such, not as tracks too short.
                _ if !empty.is_empty() => format!(
                    "no {spec} validation window: these data files are empty: {}",
                    empty
                        .iter()
                        .map(|p| p.display().to_string())
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
                DatasetSpec::Folder { dir, .. } => format!(
                    "no validation window in {}: its tracks are shorter than 20 steps of 0.4 s \
                     (8 s); remove val/ to evaluate with a fixed constant-velocity window",
                    Path::new(dir).join("val").display()
                ),
                _ => format!(
                    "no {spec} validation window in {}",
                    spec.location(data_root)
                ),
            })?;
            (n, sweep, val.windows.len())
        }
    };
    let card: Option<serde_json::Value> = crate::inpath::read_limited(
        &blob_path.with_extension("json"),
        crate::inpath::FileKind::Text,
    )
    .ok()
    .and_then(|b| serde_json::from_slice(&b).ok());
    // A card is only compared on its own data set.
    let card_on_other_data = card
        .as_ref()
        .is_some_and(|c| card_dataset(c).ok().as_ref() != Some(spec));
    let card = card.filter(|_| !card_on_other_data);
    let fixed = model.numeric() != gpecnet_core::NumericKind::F32;
    if fixed && sine.is_some() {
        bail!(
            "--sine applies to f32 blobs; {} is fixed point (integer table sine)",
            blob_path.display()
        );
    }
    // The sine every pass runs with (a fixed-point blob ignores it: integer table sine).
    let run_sine = sine
        .or_else(|| crate::export::sine_of_blob(blob_path))
        .unwrap_or(SineKind::Libm);
    // A model with endpoint probabilities: samples, point forecasts and planner outputs in
    // one pass, each window computed once; any other model in the separate passes.
    let (preds, point_preds, planner_outs) =
        match crate::core_eval::forecasts_core(&blob, run_sine, &test, k, base_seed)? {
            Some(f) => {
                let points = match f.points {
                    Some(p) => Some((crate::core_eval::accumulate(&test, &p)?, p)),
                    None => None,
                };
                (f.samples, points, Some(f.planner))
            }
            None => {
                let preds = if fixed {
                    crate::fixed_eval::evaluate_core_fixed(&blob, &test, k, base_seed)?.1
                } else {
                    evaluate_core(&blob, run_sine, &test, k, base_seed)?.1
                };
                (
                    preds,
                    crate::core_eval::evaluate_point_core(&blob, run_sine, &test)?,
                    crate::core_eval::planner_core(&blob, run_sine, &test, base_seed)?,
                )
            }
        };
    let metrics = crate::core_eval::accumulate(&test, &preds)?;
    let dist_acc = dist_accumulator(&test, &preds).context("one prediction per test window")?;
    let dist = dist_acc.finish().context("empty test set")?;
    let point_m = point_preds.as_ref().map(|p| p.0);
    let matches_card = card.map(|v| {
        if fixed {
            let want_point: Option<Metrics> = card_field(&v, "test_fixed_point");
            let want: Option<Metrics> = card_field(&v, "test_fixed");
            let want_dist: Option<DistMetrics> = card_field(&v, "test_fixed_dist");
            v.get("k").and_then(|v| v.as_u64()) == Some(k as u64)
                && v.get("base_seed").and_then(|v| v.as_u64()) == Some(base_seed)
                && want == Some(metrics)
                && want_dist == Some(dist)
                && want_point == point_m
        } else {
            let want_point: Option<Metrics> = card_field(&v, "test_point");
            let want_dist: Option<DistMetrics> = card_field(&v, "test_dist");
            let c: Option<ModelCard> = serde_json::from_value(v).ok();
            c.is_some_and(|c| {
                c.blob_crc == model.crc()
                    && c.k == k
                    && c.base_seed == base_seed
                    && c.sine == run_sine
                    && c.test == metrics
            }) && want_dist == Some(dist)
                && want_point == point_m
        }
    });
    let point = point_preds.as_ref().map(|p| (p.0.ade_k1, p.0.fde_k1));
    let pixels = match &pixels {
        Some(px) => Some(pixel_equivalent(
            data_root,
            &test,
            &preds,
            point_preds.as_ref().map(|p| p.1.as_slice()),
            px,
        )?),
        None => None,
    };
    let hit_radii = crate::dist::hit_radii(unit);
    let hits = hit_radii.map(|r| (r, dist_acc.within(r)));
    let scenes = scene_rows(
        &test,
        &preds,
        point_preds.as_ref().map(|p| p.1.as_slice()),
        cv_n,
        hit_radii,
    )?;
    // Per observed speed and per change of motion state: metre data only (the bins are m/s).
    let metre_rows = |labels: &[String], key: &dyn Fn(&crate::data::Window) -> usize| {
        if test.unit != Unit::Metres {
            return Ok(Vec::new());
        }
        group_rows(
            &test,
            &preds,
            point_preds.as_ref().map(|p| p.1.as_slice()),
            cv_n,
            hit_radii,
            labels,
            |w| labels[key(w)].clone(),
        )
    };
    let speeds = metre_rows(&speed_labels(), &|w| {
        crate::data::speed_bin(crate::data::observed_speed(w))
    })?;
    let changes = metre_rows(
        &crate::data::MOTION_CHANGE_NAMES.map(String::from),
        &crate::data::motion_change,
    )?;
    let (planner, planner_px) = match &planner_outs {
        Some(outs) => {
            let (p, px) = crate::card::planner_pair(data_root, spec, &test, outs)?;
            (Some(p), px)
        }
        None => (None, None),
    };
    let reliability = match (reliability, &planner_outs) {
        (Some(path), Some(outs)) => {
            let acc = crate::core_eval::planner_accumulator(&test.windows, outs, |_| Ok(1.0))?;
            let m = acc.finish();
            let title = format!(
                "{} on {spec} test: endpoint probabilities, ECE {:.4} ({} bins)",
                model.name(),
                m.ece,
                crate::planner_metrics::ECE_BINS
            );
            write_atomic(
                path,
                crate::draw::reliability_svg(&title, acc.bins()).as_bytes(),
            )?;
            Some(path.to_path_buf())
        }
        (Some(_), None) => bail!(
            "--reliability: {} has no endpoint probabilities (format version 6, `gpecnet score`)",
            blob_path.display()
        ),
        (None, _) => None,
    };
    let svg = match svg {
        Some(path) => {
            let stride = (test.windows.len() / n_draw.max(1)).max(1);
            let items: Vec<_> = test
                .windows
                .iter()
                .zip(&preds)
                .enumerate()
                .map(|(i, (w, p))| (w, p, planner_outs.as_ref().and_then(|o| o.get(i))))
                .step_by(stride)
                .take(n_draw)
                .collect();
            let u = unit.suffix();
            let title = format!(
                "{} on {spec} test (K = {k}, through gpecnet-core): minADE {:.2} {u}, minFDE {:.2} {u}",
                model.name(),
                metrics.min_ade,
                metrics.min_fde
            );
            write_atomic(
                path,
                crate::draw::predictions_svg(&title, u, &items, 4).as_bytes(),
            )?;
            Some(path.to_path_buf())
        }
        None => None,
    };
    Ok(EvalReport {
        name: model.name().to_string(),
        dataset: spec.to_string(),
        unit,
        metrics,
        constant_velocity: evaluate_baseline(&test, constant_velocity),
        dist,
        hits,
        point,
        cv_n,
        cv_fixed: no_val,
        cv: evaluate_baseline_with(&test, |w| constant_velocity_n(w, cv_n)),
        cv_val,
        n_val,
        pixels,
        scenes,
        speeds,
        changes,
        matches_card,
        card_on_other_data,
        svg,
        planner,
        planner_px,
        reliability,
    })
}

/// The SDD windows behind an `sdd-m` evaluation, in pixels: each split parsed once and
/// converted to metres for the evaluation itself ([`data::sdd_in_metres`]).
#[derive(Clone, Debug)]
pub struct SddPixels {
    /// The SDD test windows (pixels).
    pub test: Dataset,
    /// The SDD validation windows (pixels; [`validation_windows`]).
    pub val: Dataset,
}

/// The windows `gpecnet eval` reads, every data file parsed once.
struct Splits {
    /// The test windows (not empty).
    test: Dataset,
    /// The validation windows; `None` when not asked for (a folder without `val/`).
    val: Option<Dataset>,
    /// SDD in metres only: the same windows in pixels.
    pixels: Option<SddPixels>,
}

/// The test windows of `spec` and, with `with_val`, its validation windows; for SDD in
/// metres both are read once, in pixels, and converted, the pixel windows kept for the
/// pixel-equivalent numbers.
fn read_splits(data_root: &Path, spec: &DatasetSpec, with_val: bool) -> Result<Splits> {
    if *spec != DatasetSpec::SddMetres {
        let test = test_windows(data_root, spec)?;
        let val = match with_val {
            true => Some(validation_windows(data_root, spec)?),
            false => None,
        };
        return Ok(Splits {
            test,
            val,
            pixels: None,
        });
    }
    let px_test = data::load(data_root, &DatasetSpec::Sdd, data::Split::Test, &[])?;
    let test = data::sdd_in_metres(data_root, px_test.clone())?;
    refuse_empty_test(data_root, spec, &test)?;
    let px_val = validation_windows(data_root, &DatasetSpec::Sdd)?;
    let val = data::sdd_in_metres(data_root, px_val.clone())?;
    Ok(Splits {
        test,
        val: with_val.then_some(val),
        pixels: Some(SddPixels {
            test: px_test,
            val: px_val,
        }),
    })
}

/// [`PixelEquivalent`] of SDD-in-metres predictions on `test`: each window's errors divided
/// by its scene's metres per pixel; constant velocity (window chosen on the SDD validation
/// scenes) on the pixel test set itself, both from `px` (the same windows in pixels).
pub fn pixel_equivalent(
    data_root: &Path,
    test: &Dataset,
    preds: &[crate::eval::Prediction],
    point: Option<&[crate::eval::Prediction]>,
    px: &SddPixels,
) -> Result<PixelEquivalent> {
    let scales = data::sdd_metres_per_pixel(data_root)?;
    let convert = |preds: &[crate::eval::Prediction]| -> Result<Metrics> {
        let mut acc = crate::eval::MetricsAccumulator::new();
        for (w, p) in test.windows.iter().zip(preds) {
            let s = scales
                .get(&w.scene)
                .with_context(|| format!("no metres-per-pixel factor for scene {}", w.scene))?;
            acc.add_scaled(w, p, 1.0 / *s as f32 as f64)?;
        }
        Ok(acc.finish())
    };
    refuse_empty_test(data_root, &DatasetSpec::Sdd, &px.test)?;
    let cv = cv_baseline_of(&DatasetSpec::Sdd, &px.val, &px.test)?;
    Ok(PixelEquivalent {
        metrics: convert(preds)?,
        point: match point {
            Some(p) => {
                let m = convert(p)?;
                Some((m.ade_k1, m.fde_k1))
            }
            None => None,
        },
        cv: cv.test,
    })
}

/// Appends `fields` (in order) as the last members of the pretty-printed JSON object `text`,
/// formatted as `serde_json::to_string_pretty` formats a struct whose last fields they are.
fn append_json_fields(text: &str, fields: &[(&str, &DistMetrics)]) -> Result<String> {
    let end = text
        .rfind('}')
        .context("model card JSON does not end with '}'")?;
    let (body, tail) = (text[..end].trim_end(), &text[end..]);
    let mut out = body.to_string();
    for (name, d) in fields {
        let v = serde_json::to_string_pretty(d)?.replace('\n', "\n  ");
        out.push_str(&format!(",\n  {}: {v}", serde_json::to_string(name)?));
    }
    out.push('\n');
    out.push_str(tail);
    Ok(out)
}

/// Inserts `rows` after the first line of `md` that starts with `anchor`.
fn insert_md_rows(md: &str, anchor: &str, rows: &str) -> Result<String> {
    let start = md
        .find(&format!("\n{anchor}"))
        .with_context(|| format!("model card .md has no row starting with {anchor:?}"))?
        + 1;
    let eol = md[start..].find('\n').map_or(md.len(), |i| start + i + 1);
    Ok(format!("{}{rows}{}", &md[..eol], &md[eol..]))
}

/// `gpecnet eval --update-card`: adds the distribution metrics ([`DistMetrics`], K and seeds
/// of the card) to an **existing** model card (`<blob>.json` and `.md`) without touching
/// anything else: no retraining, the blob and golden file are not rewritten, and the card's
/// other bytes stay as they are. The card's ADE/FDE must be reproduced by `report` first (same
/// K, seed and sine). An f32 card gets `test_dist`; a fixed-point card gets `test_f32_dist` (its
/// f32 source, re-evaluated through gpecnet-core) and `test_fixed_dist`. A card that already
/// has the fields is checked, not rewritten. Returns what was done, in words.
pub fn update_card_dist(
    blob_path: &Path,
    data_root: &Path,
    report: &EvalReport,
    k: usize,
    base_seed: u64,
) -> Result<String> {
    let p_json = blob_path.with_extension("json");
    let p_md = blob_path.with_extension("md");
    let text = crate::inpath::read_text_limited(&p_json, crate::inpath::FileKind::Text)?;
    let v: serde_json::Value = serde_json::from_str(&text)?;
    let card_k = v.get("k").and_then(|x| x.as_u64());
    let card_seed = v.get("base_seed").and_then(|x| x.as_u64());
    if card_k != Some(k as u64) || card_seed != Some(base_seed) {
        bail!(
            "{}: card has K = {card_k:?}, seed = {card_seed:?}; run with its K and seed",
            p_json.display()
        );
    }
    let get = |key: &str| -> Option<Metrics> { card_field(&v, key) };
    let getd = |key: &str| -> Option<DistMetrics> { card_field(&v, key) };
    let fixed = v.get("test_fixed").is_some();
    let (key, fields): (&str, Vec<(&str, DistMetrics)>) = if fixed {
        if get("test_fixed") != Some(report.metrics) {
            bail!("{}: test_fixed is not reproduced", p_json.display());
        }
        let source = v
            .get("source")
            .and_then(|x| x.as_str())
            .context("fixed-point card without source")?;
        let src_path = blob_path.with_file_name(source);
        let src = crate::inpath::read_limited(&src_path, crate::inpath::FileKind::Blob)?;
        let sine = match v.get("source_sine").and_then(|x| x.as_str()) {
            Some("libm") => SineKind::Libm,
            Some("fast-f32") => SineKind::Fast,
            other => bail!("{}: unknown source_sine {other:?}", p_json.display()),
        };
        let test = data::load_sdd(data_root, data::SddSplit::Test)?;
        let (m, preds) = evaluate_core(&src, sine, &test, k, base_seed)?;
        let want = get("test_f32").context("fixed-point card without test_f32")?;
        if m != want {
            bail!(
                "{}: test_f32 of {source} is not reproduced",
                p_json.display()
            );
        }
        let f32_dist = dist_metrics(&test, &preds).context("empty SDD test set")?;
        (
            "test_fixed_dist",
            vec![
                ("test_f32_dist", f32_dist),
                ("test_fixed_dist", report.dist),
            ],
        )
    } else {
        if get("test") != Some(report.metrics)
            || v.get("blob_crc").and_then(|x| x.as_u64()).is_none()
        {
            bail!("{}: test metrics are not reproduced", p_json.display());
        }
        ("test_dist", vec![("test_dist", report.dist)])
    };
    if v.get(key).is_some() {
        for (name, d) in &fields {
            match getd(name) {
                Some(have) if have == *d => {}
                have => bail!(
                    "{}: {name} is {have:?} but the evaluation gives {d:?}",
                    p_json.display()
                ),
            }
        }
        return Ok(format!(
            "{}: already has {key}, reproduced",
            p_json.display()
        ));
    }
    let refs: Vec<(&str, &DistMetrics)> = fields.iter().map(|(n, d)| (*n, d)).collect();
    let new_text = append_json_fields(&text, &refs)?;
    // The result must be exactly what the card writers produce.
    let canonical = if fixed {
        serde_json::to_string_pretty(&serde_json::from_str::<crate::quantize_blob::QuantCard>(
            &new_text,
        )?)?
    } else {
        serde_json::to_string_pretty(&serde_json::from_str::<ModelCard>(&new_text)?)?
    };
    if canonical != new_text {
        bail!(
            "{}: the updated card would not be byte-identical to the writer's output",
            p_json.display()
        );
    }
    let md = crate::inpath::read_text_limited(&p_md, crate::inpath::FileKind::Text)?;
    let new_md = if fixed {
        insert_md_rows(
            &md,
            "| FDE, K = 1 |",
            &crate::quantize_blob::quant_card_dist_rows(&fields[0].1, &fields[1].1, k),
        )?
    } else {
        insert_md_rows(
            &md,
            "| mean FDE over the K samples |",
            &model_card_dist_rows(&report.dist, k),
        )?
    };
    write_atomic(&p_json, new_text.as_bytes())?;
    write_atomic(&p_md, new_md.as_bytes())?;
    Ok(format!(
        "{}: added {}; {}: added the rows",
        p_json.display(),
        fields
            .iter()
            .map(|(n, _)| *n)
            .collect::<Vec<_>>()
            .join(", "),
        p_md.display()
    ))
}
