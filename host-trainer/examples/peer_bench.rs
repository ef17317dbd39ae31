//! The gpecnet side of the side-by-side peer benchmark (`scripts/peers/bench.sh`,
//! `docs/peers.md`): dumps the exact inputs, latents and core outputs that the peers
//! (onnxruntime, PyTorch eager) are fed and checked against, and times `gpecnet-core` and the
//! trainer on the same cases, one thread, printing JSON.
//!
//! ```text
//! cargo run --release -p gpecnet-trainer --example peer_bench -- dump --blob weights/sdd-small.gpec --out target/peers/sdd-small
//! cargo run --release -p gpecnet-trainer --example peer_bench -- infer --blob weights/sdd-small.gpec
//! cargo run --release -p gpecnet-trainer --example peer_bench -- forecast --blob weights/sdd-m-lp.gpec --out target/peers/sdd-m-lp
//! cargo run --release -p gpecnet-trainer --example peer_bench -- train-data --config host-trainer/configs/sdd-small.toml --out target/peers/train-sdd-small
//! cargo run --release -p gpecnet-trainer --example peer_bench -- train --config host-trainer/configs/sdd-small.toml --threads 1
//! ```
//!
//! Arrays are written as raw little-endian f32 files next to a `manifest.json` that gives each
//! one's file and shape (`numpy.fromfile(path, "<f4").reshape(shape)`). Latents follow the
//! core's sampler exactly: window `i` of the SDD test set uses seed `i`, and its `k`-th latent
//! is the `k`-th group of `zdim` draws of `gpecnet_core::prng::Gaussian::new(i)`, each times
//! `sigma`; the single-pedestrian case is test window 0, seed 0.
//!
//! Timing: each case is called until `--min-ms` have passed, `--reps` times; the JSON holds the
//! median seconds per call. Wall-clock numbers live in `docs/peers.md`, never in tests.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{anyhow, bail, Context, Result};
use clap::{Parser, Subcommand};
use gpecnet_core::batch::HostBatchPredictor;
use gpecnet_core::frame::Frame;
use gpecnet_core::prng::Gaussian;
use gpecnet_core::{LibmSine, Model, Predictor};
use gpecnet_trainer::config::TrainConfig;
use gpecnet_trainer::core_eval::queries;
use gpecnet_trainer::data::{self, load_sdd, SddSplit, Window};
use gpecnet_trainer::train::{prepare_data, Trainer};
use serde_json::json;

/// Scratch width of the host predictor (the widest shipped model, sdd-paper, needs 1,024).
const WIDTH: usize = 1024;
/// The single-pedestrian sample counts.
const PED_KS: [usize; 4] = [1, 20, 200, 1000];
/// Samples per window for the whole test set.
const SET_K: usize = 20;
/// Windows on which `infer` checks the batched path against the scalar one before timing.
const CHECK_WINDOWS: usize = 64;

#[derive(Parser)]
#[command(about = "gpecnet side of scripts/peers/bench.sh (dump inputs, time core and trainer)")]
struct Cli {
    #[command(subcommand)]
    cmd: Cmd,
}

#[derive(Subcommand)]
enum Cmd {
    /// Write x, z, pos, frame and the core's outputs for the SDD test set (K = 20) and the
    /// single pedestrian (test window 0, K = 1000) as raw f32 + manifest.json.
    Dump {
        /// f32 blob.
        #[arg(long)]
        blob: PathBuf,
        /// Output folder.
        #[arg(long)]
        out: PathBuf,
        /// Data root holding sdd/.
        #[arg(long, default_value_os_t = data::default_data_root())]
        data: PathBuf,
    },
    /// Time the core (scalar Predictor and HostBatchPredictor, checked bit-identical) on one
    /// pedestrian (K = 1, 20, 200, 1000) and the whole test set (K = 20); two JSON lines.
    Infer {
        /// Blob.
        #[arg(long)]
        blob: PathBuf,
        /// Data root holding sdd/.
        #[arg(long, default_value_os_t = data::default_data_root())]
        data: PathBuf,
        /// Minimum time of one repetition of a case.
        #[arg(long, default_value_t = 300)]
        min_ms: u64,
        /// Repetitions per case (the median is reported).
        #[arg(long, default_value_t = 5)]
        reps: usize,
        /// Repetitions of the whole-test-set case (default: --reps).
        #[arg(long)]
        set_reps: Option<usize>,
        /// Time only the batched path (skip the scalar one, which takes a minute per call
        /// on sdd-paper's test set).
        #[arg(long)]
        batched_only: bool,
        /// Batched path without AVX2 (`gpecnet_core::batch::set_wide_vectors(false)`; the
        /// same bits): reported as `gpecnet-batch-sse2`.
        #[arg(long)]
        sse2: bool,
    },
    /// The whole forecast of a proposal model (`Predictor::predict_forecast`: its K endpoints,
    /// probabilities, point forecast, radii) on a data set's test split: writes the graph's
    /// inputs (x, pos) and the core's outputs as raw f32 + manifest.json, then times the core
    /// on one pedestrian, 16 pedestrians and the whole test split; one JSON line.
    Forecast {
        /// Proposal blob (f32: the ONNX graph is checked against it).
        #[arg(long)]
        blob: PathBuf,
        /// Data set (default: `sdd-m` for a metre blob, `sdd` for a pixel one).
        #[arg(long)]
        dataset: Option<String>,
        /// Output folder of the dump.
        #[arg(long)]
        out: PathBuf,
        /// Data root.
        #[arg(long, default_value_os_t = data::default_data_root())]
        data: PathBuf,
        /// Minimum time of one repetition of a case.
        #[arg(long, default_value_t = 300)]
        min_ms: u64,
        /// Repetitions per case (the median is reported).
        #[arg(long, default_value_t = 5)]
        reps: usize,
    },
    /// Write a config's training samples (obs, dest, future, initial_pos) + the config.
    TrainData {
        /// Training config TOML.
        #[arg(long)]
        config: PathBuf,
        /// Output folder.
        #[arg(long)]
        out: PathBuf,
        /// Data root.
        #[arg(long, default_value_os_t = data::default_data_root())]
        data: PathBuf,
    },
    /// Time training epochs of a config at a thread count (one warm-up epoch first).
    Train {
        /// Training config TOML.
        #[arg(long)]
        config: PathBuf,
        /// Threads (the config's `threads`).
        #[arg(long, default_value_t = 1)]
        threads: usize,
        /// Timed epochs (the median is reported).
        #[arg(long, default_value_t = 2)]
        epochs: usize,
        /// Data root.
        #[arg(long, default_value_os_t = data::default_data_root())]
        data: PathBuf,
    },
}

/// Raw arrays + their shapes, written as `<name>.f32` and listed in `manifest.json`.
struct Arrays {
    dir: PathBuf,
    list: serde_json::Map<String, serde_json::Value>,
}

impl Arrays {
    fn new(dir: &Path) -> Result<Self> {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
        Ok(Self {
            dir: dir.to_path_buf(),
            list: serde_json::Map::new(),
        })
    }

    fn put(&mut self, name: &str, shape: &[usize], data: &[f32]) -> Result<()> {
        let n: usize = shape.iter().product();
        if n != data.len() {
            bail!(
                "{name}: shape {shape:?} holds {n} values, got {}",
                data.len()
            );
        }
        let bytes: Vec<u8> = data.iter().flat_map(|v| v.to_le_bytes()).collect();
        let file = format!("{name}.f32");
        std::fs::write(self.dir.join(&file), bytes)?;
        self.list
            .insert(name.into(), json!({ "file": file, "shape": shape }));
        Ok(())
    }

    fn finish(self, meta: serde_json::Value) -> Result<()> {
        let mut m = meta;
        m["arrays"] = serde_json::Value::Object(self.list);
        std::fs::write(
            self.dir.join("manifest.json"),
            serde_json::to_string_pretty(&m)?,
        )?;
        Ok(())
    }
}

fn read(path: &Path) -> Result<Vec<u8>> {
    std::fs::read(path).with_context(|| format!("reading {}", path.display()))
}

/// The scalar predictor of `model` (libm sine, scratch width [`WIDTH`]).
fn predictor<'a>(model: Model<'a>) -> Result<Box<Predictor<'a, LibmSine, WIDTH>>> {
    Ok(Box::new(
        Predictor::<LibmSine, WIDTH>::new(model).map_err(|e| anyhow!("{e}"))?,
    ))
}

/// The batched predictor of `model`, same sine and scratch width as [`predictor`].
fn batch_predictor<'a>(model: Model<'a>) -> Result<Box<HostBatchPredictor<'a, LibmSine, WIDTH>>> {
    Ok(Box::new(
        HostBatchPredictor::<LibmSine, WIDTH>::new(model).map_err(|e| anyhow!("{e}"))?,
    ))
}

/// `k` latents of seed `seed`, as the engine draws them (`sigma · N(0, 1)`, `zdim` per sample).
fn latents(seed: u64, k: usize, zdim: usize, sigma: f32) -> Vec<f32> {
    let mut g = Gaussian::new(seed);
    (0..k * zdim).map(|_| sigma * g.next()).collect()
}

fn test_windows(root: &Path) -> Result<Vec<Window>> {
    let t = load_sdd(root, SddSplit::Test).map_err(|e| anyhow!("SDD test set: {e}"))?;
    if t.windows.is_empty() {
        bail!("the SDD test set under {} is empty", root.display());
    }
    Ok(t.windows)
}

fn dump(blob: &Path, out: &Path, root: &Path) -> Result<()> {
    let bytes = read(blob)?;
    let model = Model::from_blob(&bytes).map_err(|e| anyhow!("{}: {e}", blob.display()))?;
    let c = *model.config();
    let (zdim, fl) = (c.zdim as usize, c.future_len as usize);
    let windows = test_windows(root)?;
    let n = windows.len();
    let mut p = predictor(model)?;
    let (has_point, has_traj) = (model.has_point_head(), model.has_predictor());
    let (mut x, mut z, mut pos, mut origin, mut rot) =
        (Vec::new(), Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let (mut ends, mut point, mut traj) = (Vec::new(), Vec::new(), Vec::new());
    let pasts: Vec<_> = windows.iter().map(Window::obs).collect();
    let queries = queries(&pasts, |i| i as u64);
    // The batched path gives the scalar path's bits (core's tests/batch_vs_scalar.rs; `infer`
    // checks it again) and is what makes the sdd-paper dump take seconds, not minutes.
    let mut bp = batch_predictor(model)?;
    let mut all = vec![[0.0f32; 2]; n * SET_K];
    bp.predict_samples_many(&queries, SET_K, &mut all)
        .map_err(|e| anyhow!("{e}"))?;
    ends.extend(all.iter().flatten());
    if has_traj {
        let mut trajs = vec![gpecnet_core::Trajectory::new(); n * SET_K];
        bp.predict_trajectories_many(&queries, SET_K, &mut trajs)
            .map_err(|e| anyhow!("{e}"))?;
        for t in &trajs {
            traj.extend(t.iter().flatten());
        }
    }
    for (i, w) in windows.iter().enumerate() {
        let past = w.obs();
        let (frame, pts) = Frame::inputs(&past, &model).map_err(|e| anyhow!("window {i}: {e}"))?;
        x.extend(pts.iter().take(past.len()).flatten());
        let q = frame.predictor_position(past[past.len() - 1]);
        pos.extend([q[0] / c.initial_pos_divisor, q[1] / c.initial_pos_divisor]);
        origin.extend(frame.origin());
        rot.extend(frame.rotation().unwrap_or([1.0, 0.0]));
        z.extend(latents(i as u64, SET_K, zdim, c.sigma));
        if has_point {
            let t = p
                .predict_point(&past)
                .map_err(|e| anyhow!("window {i}: {e}"))?;
            point.extend(t.iter().flatten());
        }
    }
    let kmax = PED_KS[PED_KS.len() - 1];
    let past0 = windows[0].obs();
    let mut ped = vec![[0.0f32; 2]; kmax];
    p.predict_samples(&past0, 0, &mut ped)
        .map_err(|e| anyhow!("window 0: {e}"))?;
    let mut a = Arrays::new(out)?;
    let inx = 2 * c.past_len as usize;
    a.put("x", &[n, inx], &x)?;
    a.put("z", &[n, SET_K, zdim], &z)?;
    a.put("pos", &[n, 2], &pos)?;
    a.put("origin", &[n, 2], &origin)?;
    a.put("rot", &[n, 2], &rot)?;
    a.put("core_endpoints", &[n, SET_K, 2], &ends)?;
    if has_point {
        a.put("core_point", &[n, fl, 2], &point)?;
    }
    if has_traj {
        a.put("core_traj", &[n, SET_K, fl, 2], &traj)?;
    }
    a.put("ped_z", &[1, kmax, zdim], &latents(0, kmax, zdim, c.sigma))?;
    a.put(
        "ped_core_endpoints",
        &[1, kmax, 2],
        &ped.iter().flatten().copied().collect::<Vec<_>>(),
    )?;
    a.finish(json!({
        "model": model.name(),
        "blob": blob.display().to_string(),
        "sine": "libm",
        "data_scale": c.data_scale,
        "sigma": c.sigma,
        "zdim": zdim,
        "past_len": c.past_len,
        "future_len": fl,
        "heading": model.extensions().heading_steps > 0,
        "n_windows": n,
        "k": SET_K,
        "ped_window": 0,
        "ped_ks": PED_KS,
        "seeds": "window i: seed i; single pedestrian: window 0, seed 0",
    }))?;
    println!(
        "wrote {} ({} windows x K = {SET_K}, single pedestrian K = {kmax})",
        out.display(),
        n
    );
    Ok(())
}

/// Pedestrians of the "several pedestrians" case of `forecast` (one drone frame's tracks).
const CROWD: usize = 16;

/// `peer_bench forecast`: see [`Cmd::Forecast`].
fn forecast(
    blob: &Path,
    dataset: Option<&str>,
    out: &Path,
    root: &Path,
    min_ms: u64,
    reps: usize,
) -> Result<()> {
    use gpecnet_trainer::data::{DatasetSpec, Split};
    let bytes = read(blob)?;
    let model = Model::from_blob(&bytes).map_err(|e| anyhow!("{}: {e}", blob.display()))?;
    if !model.has_proposal() {
        bail!(
            "{}: not a proposal model (use `dump` and `infer`)",
            model.name()
        );
    }
    let metres = matches!(
        gpecnet_core::blob::Meta::of_blob(&bytes).map(|m| m.unit),
        Ok(gpecnet_core::blob::PositionUnit::Metre)
    );
    let name = dataset.unwrap_or(if metres { "sdd-m" } else { "sdd" });
    let ds = DatasetSpec::parse(name).map_err(|e| anyhow!("--dataset {name}: {e}"))?;
    let windows = data::load(root, &ds, Split::Test, &[])
        .map_err(|e| anyhow!("{name} test split: {e}"))?
        .windows;
    if windows.len() < CROWD {
        bail!("{name}: {} test windows, fewer than {CROWD}", windows.len());
    }
    let c = *model.config();
    let pasts: Vec<_> = windows.iter().map(Window::obs).collect();
    let n = pasts.len();
    let mut p = predictor(model)?;
    let one = |p: &mut Predictor<'_, LibmSine, WIDTH>, i: usize| {
        p.predict_forecast::<64>(&pasts[i], i as u64)
            .map_err(|e| anyhow!("window {i}: {e}"))
    };
    let f0 = one(&mut p, 0)?;
    let k = f0.endpoints.len();
    let (mut x, mut pos, mut origin, mut rot) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let (mut ends, mut probs, mut point, mut radii) =
        (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for (i, past) in pasts.iter().enumerate() {
        let (frame, pts) = Frame::inputs(past, &model).map_err(|e| anyhow!("window {i}: {e}"))?;
        x.extend(pts.iter().take(past.len()).flatten());
        let q = frame.predictor_position(past[past.len() - 1]);
        pos.extend([q[0] / c.initial_pos_divisor, q[1] / c.initial_pos_divisor]);
        origin.extend(frame.origin());
        rot.extend(frame.rotation().unwrap_or([1.0, 0.0]));
        let f = one(&mut p, i)?;
        ends.extend(f.endpoints.iter().flatten());
        probs.extend(f.probabilities.iter().copied());
        point.extend(f.point.unwrap_or([f32::NAN; 2]));
        let r = f.radii.map_or([f32::NAN; 2], |r| [r.r50, r.r90]);
        radii.extend(r);
    }
    let mut a = Arrays::new(out)?;
    a.put("x", &[n, 2 * c.past_len as usize], &x)?;
    a.put("pos", &[n, 2], &pos)?;
    a.put("origin", &[n, 2], &origin)?;
    a.put("rot", &[n, 2], &rot)?;
    a.put("core_endpoints", &[n, k, 2], &ends)?;
    a.put("core_prob", &[n, k], &probs)?;
    a.put("core_point_end", &[n, 2], &point)?;
    a.put("core_radii", &[n, 2], &radii)?;
    a.finish(json!({
        "model": model.name(),
        "blob": blob.display().to_string(),
        "dataset": name,
        "unit": if metres { "m" } else { "px" },
        "sine": "libm",
        "data_scale": c.data_scale,
        "n_windows": n,
        "k": k,
        "learned": f0.learned,
        "crowd": CROWD,
    }))?;
    let mut cases = serde_json::Map::new();
    let s = time_case(min_ms, reps, || one(&mut p, 0).map(|_| ()))?;
    cases.insert("ped".into(), json!(s));
    let s = time_case(min_ms, reps, || {
        (0..CROWD).try_for_each(|i| one(&mut p, i).map(|_| ()))
    })?;
    cases.insert(format!("crowd{CROWD}"), json!(s));
    let s = time_case(min_ms, reps, || {
        (0..n).try_for_each(|i| one(&mut p, i).map(|_| ()))
    })?;
    cases.insert("set".into(), json!(s));
    // The batched path: the same forecasts (checked bit for bit on every window first).
    let queries = queries(&pasts, |i| i as u64);
    let mut bp = batch_predictor(model)?;
    let (mut be, mut bprob) = (vec![[0.0f32; 2]; n * k], vec![0.0f32; n * k]);
    let mut bout = vec![
        gpecnet_core::planner::PlannerOutput {
            learned: false,
            point: None,
            radii: None,
        };
        n
    ];
    let mut batch = |m: usize,
                     bp: &mut HostBatchPredictor<'_, LibmSine, WIDTH>,
                     be: &mut [[f32; 2]],
                     bprob: &mut [f32]| {
        bp.predict_forecasts::<64>(
            &queries[..m],
            k,
            &mut be[..m * k],
            &mut bprob[..m * k],
            &mut bout[..m],
        )
        .map_err(|e| anyhow!("{e}"))
    };
    batch(n, &mut bp, &mut be, &mut bprob)?;
    let same = ends
        .iter()
        .map(|v| v.to_bits())
        .eq(be.iter().flatten().map(|v| v.to_bits()))
        && probs
            .iter()
            .map(|v| v.to_bits())
            .eq(bprob.iter().map(|v| v.to_bits()));
    if !same {
        bail!(
            "the batched forecasts differ from the scalar ones on {}",
            model.name()
        );
    }
    let mut batched = serde_json::Map::new();
    let crowd = format!("crowd{CROWD}");
    for (case, m) in [("ped", 1), (crowd.as_str(), CROWD), ("set", n)] {
        let s = time_case(min_ms, reps, || batch(m, &mut bp, &mut be, &mut bprob))?;
        batched.insert(case.to_string(), json!(s));
    }
    let rows = [
        ("gpecnet", "Predictor::predict_forecast (K endpoints, probabilities, point forecast, radii), one window at a time", cases),
        ("gpecnet-batch", "HostBatchPredictor::predict_forecasts (8 lanes, AVX2 where the CPU has it), the case's windows in one call; the same bits", batched),
    ];
    for (imp, api, cases) in rows {
        println!(
            "{}",
            json!({
                "impl": imp,
                "model": model.name(),
                "api": format!("{api}; libm sine, 1 thread"),
                "dataset": name,
                "n_windows": n,
                "seconds_per_call": cases,
            })
        );
    }
    Ok(())
}

/// Median seconds per call of `f`: `reps` repetitions, each calling `f` until `min_ms` have
/// passed. The first call warms up; when it alone took `min_ms` or more it counts as the first
/// repetition (the whole-test-set calls of sdd-paper take a minute on the scalar path).
fn time_case(min_ms: u64, reps: usize, mut f: impl FnMut() -> Result<()>) -> Result<f64> {
    let min = std::time::Duration::from_millis(min_ms);
    let t0 = Instant::now();
    f()?;
    let first = t0.elapsed();
    let mut per_call = Vec::with_capacity(reps);
    if first >= min {
        per_call.push(first.as_secs_f64());
    }
    while per_call.len() < reps.max(1) {
        let (t0, mut calls) = (Instant::now(), 0u64);
        while calls == 0 || t0.elapsed() < min {
            f()?;
            calls += 1;
        }
        per_call.push(t0.elapsed().as_secs_f64() / calls as f64);
    }
    per_call.sort_by(f64::total_cmp);
    Ok(per_call[per_call.len() / 2])
}

/// What `infer` times, and how long.
struct Timing {
    /// Minimum milliseconds of one repetition.
    min_ms: u64,
    /// Repetitions per one-pedestrian case.
    reps: usize,
    /// Repetitions of the whole-test-set case.
    set_reps: usize,
    /// Time the scalar path too.
    scalar: bool,
    /// Batched path without AVX2.
    sse2: bool,
}

fn infer(blob: &Path, root: &Path, t: &Timing) -> Result<()> {
    let (min_ms, reps, set_reps) = (t.min_ms, t.reps, t.set_reps);
    gpecnet_core::batch::set_wide_vectors(!t.sse2);
    let bytes = read(blob)?;
    let model = Model::from_blob(&bytes).map_err(|e| anyhow!("{}: {e}", blob.display()))?;
    let windows = test_windows(root)?;
    let pasts: Vec<_> = windows.iter().map(Window::obs).collect();
    let queries = queries(&pasts, |i| i as u64);
    let kmax = PED_KS[PED_KS.len() - 1];
    let mut p = predictor(model)?;
    let mut bp = batch_predictor(model)?;
    // The batched path must give the scalar path's bits (the core's own tests prove it on every
    // shipped blob and the whole test set; this guards the benchmark against timing a wrong
    // call, on the first CHECK_WINDOWS windows to keep sdd-paper's run short).
    let (mut a, mut b) = (vec![[0.0f32; 2]; kmax], vec![[0.0f32; 2]; kmax]);
    p.predict_samples(&pasts[0], 0, &mut a)
        .map_err(|e| anyhow!("{e}"))?;
    bp.predict_samples(&pasts[0], 0, &mut b)
        .map_err(|e| anyhow!("{e}"))?;
    let mut set_a = vec![[0.0f32; 2]; pasts.len() * SET_K];
    let mut set_b = vec![[0.0f32; 2]; pasts.len() * SET_K];
    let nc = CHECK_WINDOWS.min(pasts.len());
    for (i, past) in pasts.iter().take(nc).enumerate() {
        p.predict_samples(past, i as u64, &mut set_a[i * SET_K..(i + 1) * SET_K])
            .map_err(|e| anyhow!("window {i}: {e}"))?;
    }
    bp.predict_samples_many(&queries[..nc], SET_K, &mut set_b[..nc * SET_K])
        .map_err(|e| anyhow!("{e}"))?;
    let bits = |v: &[[f32; 2]]| v.iter().flatten().map(|x| x.to_bits()).collect::<Vec<_>>();
    let identical = bits(&a) == bits(&b) && bits(&set_a) == bits(&set_b);
    if !identical {
        bail!(
            "the batched path differs from the scalar path on {}",
            model.name()
        );
    }
    let mut scalar = serde_json::Map::new();
    let mut batched = serde_json::Map::new();
    for k in PED_KS.into_iter().filter(|_| t.scalar) {
        let s = time_case(min_ms, reps, || {
            p.predict_samples(&pasts[0], 0, &mut a[..k])
                .map_err(|e| anyhow!("{e}"))
        })?;
        scalar.insert(format!("ped_k{k}"), json!(s));
    }
    for k in PED_KS {
        let s = time_case(min_ms, reps, || {
            bp.predict_samples(&pasts[0], 0, &mut b[..k])
                .map_err(|e| anyhow!("{e}"))
        })?;
        batched.insert(format!("ped_k{k}"), json!(s));
    }
    if t.scalar {
        let s = time_case(min_ms, set_reps, || {
            for (i, past) in pasts.iter().enumerate() {
                p.predict_samples(past, i as u64, &mut set_a[i * SET_K..(i + 1) * SET_K])
                    .map_err(|e| anyhow!("window {i}: {e}"))?;
            }
            Ok(())
        })?;
        scalar.insert(format!("set_k{SET_K}"), json!(s));
    }
    let s = time_case(min_ms, set_reps, || {
        bp.predict_samples_many(&queries, SET_K, &mut set_b)
            .map_err(|e| anyhow!("{e}"))
    })?;
    batched.insert(format!("set_k{SET_K}"), json!(s));
    let (batch_name, batch_api) = if t.sse2 {
        (
            "gpecnet-batch-sse2",
            "HostBatchPredictor (8 lanes, SSE2 only): predict_samples / predict_samples_many over all windows",
        )
    } else {
        (
            "gpecnet-batch",
            "HostBatchPredictor (8 lanes, AVX2 where the CPU has it): predict_samples / predict_samples_many over all windows",
        )
    };
    let scalar_row = (
        "gpecnet",
        "Predictor::predict_samples, one window at a time",
        scalar,
    );
    let rows = [
        Some(scalar_row).filter(|_| t.scalar),
        Some((batch_name, batch_api, batched)),
    ];
    for (name, api, cases) in rows.into_iter().flatten() {
        println!(
            "{}",
            json!({
                "impl": name,
                "model": model.name(),
                "api": format!("{api}; libm sine, 1 thread, bit-identical to each other"),
                "n_windows": pasts.len(),
                "seconds_per_call": cases,
            })
        );
    }
    Ok(())
}

fn load_config(path: &Path) -> Result<TrainConfig> {
    TrainConfig::from_file(path).with_context(|| format!("reading {}", path.display()))
}

fn train_data(config: &Path, out: &Path, root: &Path) -> Result<()> {
    let cfg = load_config(config)?;
    let d = prepare_data(&cfg, root)?;
    let n = d.train.len();
    let (mut obs, mut dest, mut fut, mut init) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for s in &d.train {
        obs.extend(s.obs.iter().flatten());
        let (last, inter) = s
            .future
            .split_last()
            .ok_or_else(|| anyhow!("empty future"))?;
        dest.extend(last);
        fut.extend(inter.iter().flatten());
        init.extend(s.initial_pos);
    }
    let mut a = Arrays::new(out)?;
    a.put("obs", &[n, obs.len() / n.max(1)], &obs)?;
    a.put("dest", &[n, 2], &dest)?;
    a.put("future", &[n, fut.len() / n.max(1)], &fut)?;
    a.put("initial_pos", &[n, 2], &init)?;
    a.finish(json!({ "config": config.display().to_string(), "n_train": n, "cfg": cfg }))?;
    println!("wrote {} ({n} training samples)", out.display());
    Ok(())
}

fn train(config: &Path, threads: usize, epochs: usize, root: &Path) -> Result<()> {
    let mut cfg = load_config(config)?;
    cfg.threads = threads;
    let batch = cfg.batch_size;
    let d = prepare_data(&cfg, root)?;
    let n = d.train.len();
    let mut t = Trainer::new(cfg, d)?;
    t.train_epoch(None)?; // warm-up
    let mut times = Vec::new();
    for _ in 0..epochs.max(1) {
        let t0 = Instant::now();
        t.train_epoch(None)?;
        times.push(t0.elapsed().as_secs_f64());
    }
    let mut s = times.clone();
    s.sort_by(f64::total_cmp);
    println!(
        "{}",
        json!({
            "impl": "gpecnet",
            "config": config.display().to_string(),
            "threads": threads,
            "n_train": n,
            "batch_size": batch,
            "epoch_seconds": times,
            "median": s[s.len() / 2],
        })
    );
    Ok(())
}

fn main() -> Result<()> {
    match Cli::parse().cmd {
        Cmd::Dump { blob, out, data } => dump(&blob, &out, &data),
        Cmd::Infer {
            blob,
            data,
            min_ms,
            reps,
            set_reps,
            batched_only,
            sse2,
        } => {
            let timing = Timing {
                min_ms,
                reps,
                set_reps: set_reps.unwrap_or(reps),
                scalar: !batched_only,
                sse2,
            };
            infer(&blob, &data, &timing)
        }
        Cmd::Forecast {
            blob,
            dataset,
            out,
            data,
            min_ms,
            reps,
        } => forecast(&blob, dataset.as_deref(), &out, &data, min_ms, reps),
        Cmd::TrainData { config, out, data } => train_data(&config, &out, &data),
        Cmd::Train {
            config,
            threads,
            epochs,
            data,
        } => train(&config, threads, epochs, &data),
    }
}
