//! The constant-velocity baselines of `docs/baselines.md`: velocity averaged over the last
//! `n = 1..=7` observed steps, ADE/FDE (pixels, K = 1) on the SDD validation scenes (held out
//! of `sdd/train`, as in training) and on the SDD test set; `n` chosen on validation; and the
//! distribution metrics (KDE NLL, hit rates at 20 / 40 px) of every shipped model card in
//! `weights/`. Prints Markdown.
//!
//! ```sh
//! cargo run --release -p gpecnet-trainer --example cv_baselines [-- DATA_ROOT [WEIGHTS_DIR]]
//! ```

use std::path::PathBuf;

use anyhow::{Context, Result};
use gpecnet_trainer::baseline::{cv_sweep, select_cv_n};
use gpecnet_trainer::data::{
    default_data_root, default_sdd_val_scenes, load_sdd, split_by_scene, SddSplit,
};
use gpecnet_trainer::dist::DistMetrics;

fn main() -> Result<()> {
    let mut args = std::env::args().skip(1);
    let root = args.next().map_or_else(default_data_root, PathBuf::from);
    let weights = args
        .next()
        .map_or_else(|| PathBuf::from("weights"), PathBuf::from);
    let (_, val) = split_by_scene(load_sdd(&root, SddSplit::Train)?, &default_sdd_val_scenes());
    let test = load_sdd(&root, SddSplit::Test)?;
    let (chosen, val_sweep) = select_cv_n(&val).context("no SDD validation window")?;
    let test_sweep = cv_sweep(&test);
    anyhow::ensure!(!test.windows.is_empty(), "no SDD test window");

    println!(
        "## Constant velocity, n = 1..7 (SDD, pixels, K = 1)\n\n\
Validation: {} windows (scenes {}, held out of `sdd/train`); test: {} windows.\n",
        val.windows.len(),
        default_sdd_val_scenes().join(", "),
        test.windows.len()
    );
    println!("| n (observed steps averaged) | val ADE | val FDE | test ADE | test FDE |");
    println!("|---|---|---|---|---|");
    for (i, (v, t)) in val_sweep.iter().zip(&test_sweep).enumerate() {
        let n = i + 1;
        let mark = if n == chosen { " **(chosen)**" } else { "" };
        println!(
            "| {n}{mark} | {:.2} | {:.2} | {:.2} | {:.2} |",
            v.ade_k1, v.fde_k1, t.ade_k1, t.fde_k1
        );
    }
    let best_test = test_sweep
        .iter()
        .enumerate()
        .min_by(|a, b| a.1.fde_k1.total_cmp(&b.1.fde_k1))
        .map_or(0, |(i, _)| i + 1);
    println!(
        "\nValidation picks n = {chosen} (lowest validation FDE); on test the lowest FDE is at n = {best_test}{}.",
        if best_test == chosen {
            ", the same n"
        } else {
            ", so the validation choice is not the best on test"
        }
    );
    println!(
        "Test FDE at the chosen n: {:.2} px; at n = 1 (last step): {:.2} px; best on test: {:.2} px.",
        test_sweep[chosen - 1].fde_k1,
        test_sweep[0].fde_k1,
        test_sweep[best_test - 1].fde_k1
    );

    let mut cards: Vec<PathBuf> = std::fs::read_dir(&weights)
        .with_context(|| format!("reading {}", weights.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "json"))
        .collect();
    cards.sort();
    println!(
        "\n## Shipped models: distribution of the K = 20 endpoints on SDD test\n\n\
From the model cards (`{}/<name>.json`), computed through gpecnet-core, seed of window i = i.\n",
        weights.display()
    );
    println!("| model | minFDE (K = 20) px | KDE NLL (nats, px) | within 20 px | within 40 px |");
    println!("|---|---|---|---|---|");
    for p in cards {
        let v: serde_json::Value = serde_json::from_slice(&std::fs::read(&p)?)?;
        let (mkey, dkey) = if v.get("test_fixed").is_some() {
            ("test_fixed", "test_fixed_dist")
        } else {
            ("test", "test_dist")
        };
        let Some(m) = v.get(mkey) else { continue };
        let name = v.get("name").and_then(|x| x.as_str()).unwrap_or("?");
        let fde = m
            .get("min_fde")
            .and_then(|x| x.as_f64())
            .unwrap_or(f64::NAN);
        match v
            .get(dkey)
            .and_then(|d| serde_json::from_value::<DistMetrics>(d.clone()).ok())
        {
            Some(d) => println!(
                "| `{name}` | {fde:.2} | {:.3} | {:.2} % | {:.2} % |",
                d.kde_nll,
                100.0 * d.hit20,
                100.0 * d.hit40
            ),
            None => println!("| `{name}` | {fde:.2} | – | – | – |"),
        }
    }
    Ok(())
}
