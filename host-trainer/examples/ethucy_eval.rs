//! ETH/UCY leave-one-scene-out: the test table of `docs/ethucy.md`, through `gpecnet-core`.
//!
//! For each scene, the run `<runs>/<scene>` (trained by `gpecnet train --config
//! host-trainer/configs/ethucy-tiny.toml --dataset eth_ucy:<scene>`, best validation epoch):
//!
//! 1. inference settings: latent `sigma` and test-time samples `N` (0 = plain sampling, else N
//!    samples reduced to K = 20 by k-means, first-K init, 3 Lloyd iterations). Given on the
//!    command line (`--settings scene:sigma:N,...`, as chosen with `gpecnet select`), or else
//!    chosen here with the same function `gpecnet select` runs (`select::select`, on the
//!    scene's **validation** split): lowest validation minFDE, ties by minADE;
//! 2. the model is exported in memory with those settings (`export::blob_bytes`) and evaluated
//!    once on the scene's **test** split through `gpecnet-core` (libm sine; seed of window `i`
//!    is `i`): minADE/minFDE of K = 20 (best of 20) and the point forecast's ADE/FDE, metres;
//! 3. constant velocity over the last `n` observed steps, `n` in 1..=7 chosen on the scene's
//!    validation split (`eval::select_cv_n`), on the test split.
//!
//! ```sh
//! cargo run --release -p gpecnet-trainer --example ethucy_eval -- \
//!     [--runs runs/ethucy] [--data DIR] [--scenes eth,hotel] [--settings eth:1.3:80,...]
//! ```

use std::collections::HashMap;
use std::path::PathBuf;

use anyhow::{bail, Context, Result};
use gpecnet_trainer::baseline::{constant_velocity_n, evaluate_baseline_with, select_cv_n};
use gpecnet_trainer::core_eval::{evaluate_core, evaluate_point_core};
use gpecnet_trainer::data::{default_data_root, load_eth_ucy, EthUcySplit, ETH_UCY_SCENES};
use gpecnet_trainer::export::blob_bytes;
use gpecnet_trainer::reference::SineKind;
use gpecnet_trainer::run_export::{model_from_run, ExportSettings};
use gpecnet_trainer::select::{best, select, table};

/// Endpoints per window.
const K: usize = 20;
/// Latent spreads tried on validation.
const SIGMAS: [f32; 3] = [0.8, 1.0, 1.3];
/// Test-time samples tried on validation.
const TTS: [usize; 2] = [0, 80];
/// PECNet's published minADE/minFDE (K = 20, metres).
const PECNET: [(&str, f64, f64); 5] = [
    ("eth", 0.54, 0.87),
    ("hotel", 0.18, 0.24),
    ("univ", 0.35, 0.60),
    ("zara1", 0.22, 0.39),
    ("zara2", 0.17, 0.30),
];

struct Args {
    runs: PathBuf,
    data: PathBuf,
    scenes: Vec<String>,
    settings: HashMap<String, (f32, usize)>,
}

fn parse_args() -> Result<Args> {
    let mut a = Args {
        runs: PathBuf::from("runs/ethucy"),
        data: default_data_root(),
        scenes: ETH_UCY_SCENES.iter().map(|s| s.to_string()).collect(),
        settings: HashMap::new(),
    };
    let mut it = std::env::args().skip(1);
    while let Some(flag) = it.next() {
        let val = it.next().with_context(|| format!("{flag} needs a value"))?;
        match flag.as_str() {
            "--runs" => a.runs = PathBuf::from(val),
            "--data" => a.data = PathBuf::from(val),
            "--scenes" => a.scenes = val.split(',').map(str::to_string).collect(),
            "--settings" => {
                for item in val.split(',') {
                    let parts: Vec<&str> = item.split(':').collect();
                    let [scene, sigma, n] = parts[..] else {
                        bail!("--settings items are scene:sigma:N, got {item:?}");
                    };
                    a.settings
                        .insert(scene.to_string(), (sigma.parse()?, n.parse()?));
                }
            }
            _ => bail!("unknown argument {flag:?} (--runs, --data, --scenes, --settings)"),
        }
    }
    Ok(a)
}

/// One scene's row.
struct Row {
    scene: String,
    epoch: usize,
    sigma: f32,
    tts: usize,
    min_ade: f64,
    min_fde: f64,
    point: Option<(f64, f64)>,
    cv_n: usize,
    cv: (f64, f64),
    n_test: usize,
    blob_bytes: usize,
    params: usize,
}

fn run_scene(a: &Args, scene: &str) -> Result<Row> {
    let run = a.runs.join(scene);
    let (sigma, tts) = match a.settings.get(scene) {
        Some(&s) => s,
        None => {
            let (rows, point) = select(&run, &a.data, &SIGMAS, &TTS, K, SineKind::Libm)?;
            eprint!("{scene}: {}", table(K, &rows, point.as_ref()));
            let best = best(&rows).context("empty selection grid")?;
            (best.sigma, best.tts)
        }
    };
    let (cfg, mut model, epoch) = model_from_run(&run, scene)?;
    let settings = ExportSettings {
        sine: SineKind::Libm,
        k: K,
        base_seed: 0,
        sigma: Some(sigma),
        tts: Some(tts),
        proposal: None,
        score: None,
    };
    settings.apply(&mut model, K)?;
    let blob = blob_bytes(&model)?;

    let test = load_eth_ucy(&a.data, scene, EthUcySplit::Test)?;
    let val = load_eth_ucy(&a.data, scene, EthUcySplit::Val)?;
    if test.is_empty() {
        bail!("{scene}: empty test split");
    }
    let (m, _) = evaluate_core(&blob, SineKind::Libm, &test, K, 0)?;
    let point =
        evaluate_point_core(&blob, SineKind::Libm, &test)?.map(|(p, _)| (p.ade_k1, p.fde_k1));
    let (cv_n, _) = select_cv_n(&val).context("empty validation split")?;
    let cv = evaluate_baseline_with(&test, |w| constant_velocity_n(w, cv_n));
    let row = Row {
        scene: scene.to_string(),
        epoch,
        sigma,
        tts,
        min_ade: m.min_ade,
        min_fde: m.min_fde,
        point,
        cv_n,
        cv: (cv.ade_k1, cv.fde_k1),
        n_test: test.len(),
        blob_bytes: blob.len(),
        params: cfg.embedded_param_count(),
    };
    eprintln!(
        "{scene}: test n={} sigma {sigma} N {tts}: minADE {:.3} minFDE {:.3}",
        row.n_test, row.min_ade, row.min_fde
    );
    Ok(row)
}

fn main() -> Result<()> {
    let a = parse_args()?;
    let mut rows = Vec::new();
    for s in &a.scenes {
        rows.push(run_scene(&a, s)?);
    }
    println!("| scene | test windows | best epoch | sigma | N | minADE / minFDE (K = 20) | point ADE / FDE | CV n | CV ADE / FDE | PECNet minADE / minFDE | params | f32 blob |");
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|");
    let mut sum = [0.0f64; 8];
    for r in &rows {
        let pec = PECNET.iter().find(|p| p.0 == r.scene);
        let (pa, pf) = r.point.unwrap_or((f64::NAN, f64::NAN));
        println!(
            "| {} | {} | {} | {} | {} | {:.2} / {:.2} | {:.2} / {:.2} | {} | {:.2} / {:.2} | {} | {} | {} B |",
            r.scene,
            r.n_test,
            r.epoch,
            r.sigma,
            r.tts,
            r.min_ade,
            r.min_fde,
            pa,
            pf,
            r.cv_n,
            r.cv.0,
            r.cv.1,
            pec.map_or("–".to_string(), |p| format!("{:.2} / {:.2}", p.1, p.2)),
            r.params,
            r.blob_bytes
        );
        let pec = pec.map_or((f64::NAN, f64::NAN), |p| (p.1, p.2));
        for (s, v) in sum
            .iter_mut()
            .zip([r.min_ade, r.min_fde, pa, pf, r.cv.0, r.cv.1, pec.0, pec.1])
        {
            *s += v;
        }
    }
    if rows.len() > 1 {
        let n = rows.len() as f64;
        let m: Vec<f64> = sum.iter().map(|s| s / n).collect();
        println!(
            "| average (of scenes) | | | | | {:.2} / {:.2} | {:.2} / {:.2} | | {:.2} / {:.2} | {:.2} / {:.2} | | |",
            m[0], m[1], m[2], m[3], m[4], m[5], m[6], m[7]
        );
    }
    Ok(())
}
