//! Test-time sampling sweep on SDD **validation** windows (never the test set).
//!
//! For each shipped f32 blob (`sdd-tiny`, `sdd-small`) and latent spread
//! sigma in {1.0, 1.3}: draw N endpoints per window through `gpecnet-core`
//! (`Predictor::predict_samples`, libm sine, seed = window index), reduce
//! them to K = 20 centres with `gpecnet_core::cluster::kmeans_reduce`, and
//! report minADE / minFDE of the 20 centres (ADE on the straight line from
//! the last observation to each endpoint, `core_eval::linear_fill`).
//!
//! sigma != the blob's value: the blob is read into the trainer's
//! `RefModel`, its `config.sigma` edited and re-exported in memory
//! (`export::blob_bytes`), then run through the core. The first windows are
//! cross-checked bit for bit against the reference path
//! (`RefModel::predict`) with the same sigma.
//!
//! Samples are a prefix stream: the first N of 500 draws with one seed are
//! exactly the N draws of a call with N, so each window is predicted once.
//!
//! ```sh
//! cargo run --release -p gpecnet-trainer --example tts_sweep [-- --data DIR]
//! ```

use anyhow::{anyhow, bail, Context, Result};
use gpecnet_core::cluster::{kmeans_reduce, Init};
use gpecnet_core::{LibmSine, Model, Predictor};
use gpecnet_trainer::core_eval::{linear_fill, HOST_WIDTH};
use gpecnet_trainer::data::{
    default_data_root, default_sdd_val_scenes, load_sdd, split_by_scene, Dataset, SddSplit, PAST,
};
use gpecnet_trainer::eval::{Metrics, MetricsAccumulator, Prediction};
use gpecnet_trainer::export::{blob_bytes, read_blob};
use gpecnet_trainer::reference::SineKind;

/// Centres kept per window.
const K: usize = 20;
/// Samples drawn per window (values of N).
const NS: [usize; 7] = [20, 40, 60, 80, 100, 200, 500];
/// Largest N.
const NMAX: usize = 500;
/// Lloyd iteration counts.
const ITERS: [u8; 3] = [3, 5, 10];
/// Latent spreads.
const SIGMAS: [f32; 2] = [1.0, 1.3];
/// Windows cross-checked against the reference path per (model, sigma).
const REF_CHECK: usize = 16;

/// One row of the sweep: N samples, and (init, iters) when N > K.
#[derive(Clone, Copy)]
struct Setting {
    n: usize,
    km: Option<(Init, u8)>,
}

fn settings() -> Vec<Setting> {
    let mut v = Vec::new();
    for &n in &NS {
        if n == K {
            v.push(Setting { n, km: None });
            continue;
        }
        for init in [Init::First, Init::Farthest] {
            for &it in &ITERS {
                v.push(Setting {
                    n,
                    km: Some((init, it)),
                });
            }
        }
    }
    v
}

fn init_name(i: Init) -> &'static str {
    match i {
        Init::First => "first",
        Init::Farthest => "farthest",
    }
}

/// Distance evaluations of `kmeans_reduce` as implemented in the core:
/// N·K·iters for the Lloyd steps, plus N·K·(K−1)/2 for the farthest-point
/// initialisation (the nearest chosen centre is recomputed, no heap).
fn dist_evals(s: Setting) -> usize {
    match s.km {
        None => 0,
        Some((init, it)) => {
            let lloyd = s.n * K * usize::from(it);
            match init {
                Init::First => lloyd,
                Init::Farthest => lloyd + s.n * K * (K - 1) / 2,
            }
        }
    }
}

/// The blob with its latent sigma replaced (byte-identical when unchanged).
fn blob_with_sigma(orig: &[u8], sigma: f32) -> Result<Vec<u8>> {
    let mut m = read_blob(orig)?;
    if blob_bytes(&m)? != orig {
        bail!("export round trip is not byte-identical");
    }
    m.config.sigma = sigma;
    blob_bytes(&m)
}

/// Metrics of every setting for one (blob, sigma).
fn sweep(blob: &[u8], val: &Dataset, settings: &[Setting]) -> Result<Vec<Metrics>> {
    let model = Model::from_blob(blob).map_err(|e| anyhow!("{e}"))?;
    let refm = read_blob(blob)?;
    // Per window: the K centres of every setting.
    let per_window: Vec<Vec<Vec<[f32; 2]>>> =
        gpecnet_trainer::core_eval::parallel_map(val.windows.len(), |i| {
            let w = &val.windows[i];
            let past = w.obs();
            let mut p = Box::new(
                Predictor::<LibmSine, HOST_WIDTH>::new(model).map_err(|e| anyhow!("{e}"))?,
            );
            let mut samples = vec![[0.0f32; 2]; NMAX];
            p.predict_samples(&past, i as u64, &mut samples)
                .map_err(|e| anyhow!("{}#{}: {e}", w.scene, w.ped_id))?;
            if i < REF_CHECK {
                let r = refm.predict(&past, i as u64, NMAX, SineKind::Libm, false);
                let same = r.endpoints.len() == samples.len()
                    && r.endpoints.iter().zip(samples.iter()).all(|(a, b)| {
                        a[0].to_bits() == b[0].to_bits() && a[1].to_bits() == b[1].to_bits()
                    });
                if !same {
                    bail!("window {i}: core and reference path differ");
                }
            }
            settings
                .iter()
                .map(|s| match s.km {
                    None => Ok(samples[..s.n].to_vec()),
                    Some((init, it)) => {
                        let mut c = vec![[0.0f32; 2]; K];
                        kmeans_reduce(&samples[..s.n], &mut c, it, init)
                            .map_err(|e| anyhow!("{e}"))?;
                        Ok(c)
                    }
                })
                .collect()
        })?;
    let mut out = Vec::with_capacity(settings.len());
    for si in 0..settings.len() {
        let mut acc = MetricsAccumulator::new();
        for (w, cs) in val.windows.iter().zip(&per_window) {
            let last = w.obs()[PAST - 1];
            let pred = Prediction {
                trajectories: cs[si].iter().map(|e| linear_fill(last, *e)).collect(),
            };
            acc.add(w, &pred).map_err(|e| anyhow!("{e:?}"))?;
        }
        out.push(acc.finish());
    }
    Ok(out)
}

fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().collect();
    let root = match args.iter().position(|a| a == "--data") {
        Some(i) => args
            .get(i + 1)
            .map(std::path::PathBuf::from)
            .context("--data needs a directory")?,
        None => default_data_root(),
    };
    let train = load_sdd(&root, SddSplit::Train).map_err(|e| anyhow!("{e}"))?;
    let (_, val) = split_by_scene(train, &default_sdd_val_scenes());
    eprintln!("{} validation windows", val.windows.len());
    let weights = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../weights");
    let settings = settings();

    println!("| model | sigma | N | init | iters | minADE (K = 20) | minFDE (K = 20) | decoder evals | distance evals |");
    println!("|---|---|---|---|---|---|---|---|---|");
    let mut best: Vec<(String, f32, Setting, Metrics)> = Vec::new();
    for name in ["sdd-tiny", "sdd-small"] {
        let orig = std::fs::read(weights.join(format!("{name}.gpec")))
            .with_context(|| format!("reading {name}.gpec"))?;
        let blob_sigma = Model::from_blob(&orig)
            .map_err(|e| anyhow!("{e}"))?
            .config()
            .sigma;
        let mut model_best: Option<(String, f32, Setting, Metrics)> = None;
        for &sigma in &SIGMAS {
            let blob = if sigma == blob_sigma {
                orig.clone()
            } else {
                blob_with_sigma(&orig, sigma)?
            };
            let t = std::time::Instant::now();
            let ms = sweep(&blob, &val, &settings)?;
            eprintln!("{name} sigma {sigma}: {:.1} s", t.elapsed().as_secs_f64());
            for (s, m) in settings.iter().zip(&ms) {
                let (init, it) = match s.km {
                    None => ("plain".to_string(), "–".to_string()),
                    Some((i, it)) => (init_name(i).to_string(), it.to_string()),
                };
                println!(
                    "| {name} | {sigma} | {} | {init} | {it} | {:.2} | {:.2} | {} | {} |",
                    s.n,
                    m.min_ade,
                    m.min_fde,
                    s.n,
                    dist_evals(*s)
                );
                if model_best.as_ref().is_none_or(|b| m.min_fde < b.3.min_fde) {
                    model_best = Some((name.to_string(), sigma, *s, *m));
                }
            }
        }
        best.extend(model_best);
    }
    println!();
    println!("Best minFDE per model (validation):");
    println!();
    println!("| model | sigma | N | init | iters | minADE | minFDE |");
    println!("|---|---|---|---|---|---|---|");
    for (name, sigma, s, m) in best {
        let (init, it) = match s.km {
            None => ("plain".to_string(), "–".to_string()),
            Some((i, it)) => (init_name(i).to_string(), it.to_string()),
        };
        println!(
            "| {name} | {sigma} | {} | {init} | {it} | {:.2} | {:.2} |",
            s.n, m.min_ade, m.min_fde
        );
    }
    Ok(())
}
