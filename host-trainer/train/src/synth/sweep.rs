//! `gpecnet sweep`: the paper's augmentation sweep (train with the first K % of the synthetic
//! pool for several K, including 0, on one protocol) and its table.
//!
//! For every K: a run in `<out>/aug-<K>` trained with the given config, `augment_pct = K`,
//! `synthetic_pool = <pool>` (K = 0: no pool) and the same epochs and seed; the model selected
//! on the validation scenes (best validation minFDE) is exported in memory
//! ([`crate::run_export::model_from_run`] + [`crate::export::blob_bytes`]) and evaluated on the SDD
//! test set **through `gpecnet-core`** ([`crate::core_eval::evaluate_core`], libm sine,
//! latent seed of test window `i` = `base_seed + i`). The pool is generated once
//! ([`super::cli::run_synth`]) if its file does not exist, and read from the file afterwards.
//!
//! A run directory that already holds a finished run with the same config is only
//! re-evaluated; an unfinished one is resumed (bit-exactly); one with a different config is an
//! error. So an interrupted sweep is continued by rerunning the same command, and several
//! processes may train disjoint `--pcts` subsets into the same `--out` before one command with
//! all of them writes the complete table. `sweep.md` and `sweep.csv` are rewritten after every
//! point with the rows finished so far.

use std::fmt::Write as _;
use std::path::PathBuf;

use anyhow::{bail, Context, Result};

use crate::checkpoint;
use crate::config::TrainConfig;
use crate::core_eval::evaluate_core;
use crate::data::{load_sdd, SddSplit};
use crate::eval::Metrics;
use crate::export::blob_bytes;
use crate::reference::SineKind;
use crate::rundir::write_atomic;
use crate::train::{prepare_data, train_new, train_resume, TrainOptions};

/// Everything a sweep needs.
#[derive(Clone, Debug)]
pub struct SweepOptions {
    /// The base config (its `augment_pct` / `synthetic_pool` are overridden per point).
    pub config: TrainConfig,
    /// Epochs of every run (overrides the config's `num_epochs`).
    pub epochs: Option<usize>,
    /// Augmentation percentages (0 = the unaugmented baseline).
    pub pcts: Vec<f32>,
    /// Data root holding `sdd/`.
    pub data_root: PathBuf,
    /// The synthetic pool CSV (generated there when missing).
    pub pool: PathBuf,
    /// Seed of the pool when it has to be generated.
    pub pool_seed: u64,
    /// Size of the pool when it has to be generated.
    pub pool_n: usize,
    /// Output directory (`aug-<K>/` runs, `sweep.md`, `sweep.csv`).
    pub out: PathBuf,
    /// Samples per test window (best-of-K).
    pub k: usize,
    /// Latent seed of test window `i` is `base_seed + i`.
    pub base_seed: u64,
    /// No per-epoch lines.
    pub quiet: bool,
    /// The command line, written into `sweep.md`.
    pub command: String,
}

/// One finished point of the sweep.
#[derive(Clone, Debug)]
pub struct SweepRow {
    /// Augmentation percentage.
    pub pct: f32,
    /// Real training windows (before time reversal).
    pub n_real: usize,
    /// Synthetic windows added (before time reversal).
    pub n_synthetic: usize,
    /// Training samples per epoch (after time reversal).
    pub n_train: usize,
    /// Epochs trained.
    pub epochs: usize,
    /// Epoch selected on validation.
    pub best_epoch: usize,
    /// Validation metrics of that epoch (trainer, raw pixels).
    pub val: Metrics,
    /// SDD test metrics of that epoch's model through gpecnet-core.
    pub test: Metrics,
    /// Training wall time, seconds (sum over epochs).
    pub train_seconds: f64,
}

/// Directory name of point `pct` (`aug-0`, `aug-6`, `aug-2.5`).
pub fn run_name(pct: f32) -> String {
    format!("aug-{pct}")
}

/// The config of point `pct`.
pub fn point_config(opts: &SweepOptions, pct: f32) -> TrainConfig {
    let mut cfg = opts.config.clone();
    if let Some(n) = opts.epochs {
        cfg.num_epochs = n;
    }
    cfg.augment_pct = pct;
    cfg.synthetic_pool = (pct > 0.0).then(|| opts.pool.to_string_lossy().into_owned());
    cfg
}

/// Run (or continue, or just re-evaluate) every point and write the table. Returns the rows.
pub fn run_sweep(opts: &SweepOptions) -> Result<Vec<SweepRow>> {
    if opts.pcts.is_empty() {
        bail!("no augmentation percentages given");
    }
    for (i, p) in opts.pcts.iter().enumerate() {
        if opts.pcts[..i].contains(p) {
            bail!("augmentation percentage {p} given twice");
        }
    }
    // Validate every point's config before spending time on any of them.
    for &p in &opts.pcts {
        point_config(opts, p)
            .validate()
            .with_context(|| format!("augment {p} %"))?;
    }
    std::fs::create_dir_all(&opts.out)
        .with_context(|| format!("cannot create {}", opts.out.display()))?;
    if opts.pcts.iter().any(|&p| p > 0.0) && !opts.pool.exists() {
        eprintln!(
            "generating the synthetic pool ({} trajectories, seed {}) into {} ...",
            opts.pool_n,
            opts.pool_seed,
            opts.pool.display()
        );
        if let Some(dir) = opts.pool.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir)?;
        }
        super::cli::run_synth(
            &opts.data_root,
            opts.pool_n,
            opts.pool_seed,
            3200,
            &opts.pool,
        )?;
    }
    let test = load_sdd(&opts.data_root, SddSplit::Test)?;
    let mut rows = Vec::new();
    for &pct in &opts.pcts {
        let row = run_point(opts, pct, &test)?;
        eprintln!(
            "augment {pct} %: {} + {} windows, best epoch {}, val minFDE {:.2} px; test minADE/minFDE {:.2}/{:.2} px, FDE K=1 {:.2} px",
            row.n_real, row.n_synthetic, row.best_epoch, row.val.min_fde, row.test.min_ade, row.test.min_fde, row.test.fde_k1
        );
        rows.push(row);
        write_tables(opts, &rows)?;
    }
    Ok(rows)
}

fn run_point(opts: &SweepOptions, pct: f32, test: &crate::data::Dataset) -> Result<SweepRow> {
    let cfg = point_config(opts, pct);
    let run_dir = opts.out.join(run_name(pct));
    let topts = TrainOptions {
        data_root: opts.data_root.clone(),
        run_dir: run_dir.clone(),
        epochs: None,
        quiet: opts.quiet,
        stop_after: None,
        // The sweep owns its aug-<K>/ folders: one without a checkpoint is restarted.
        force: true,
    };
    if run_dir.join(checkpoint::CHECKPOINT_FILE).exists() {
        let ckpt = checkpoint::load(&run_dir)?;
        let stored = ckpt.config()?;
        if stored != cfg {
            bail!(
                "{} holds a run with a different config; remove it or use another --out",
                run_dir.display()
            );
        }
        if ckpt.epochs_done < cfg.num_epochs {
            eprintln!(
                "augment {pct} %: resuming {} at epoch {}",
                run_dir.display(),
                ckpt.epochs_done
            );
            train_resume(&topts)?;
        } else {
            eprintln!(
                "augment {pct} %: {} is finished, evaluating",
                run_dir.display()
            );
        }
    } else {
        eprintln!("augment {pct} %: training into {}", run_dir.display());
        train_new(cfg.clone(), &topts)?;
    }
    let ckpt = checkpoint::load(&run_dir)?;
    let Some(best) = ckpt.best.as_ref() else {
        bail!("{}: no validated epoch", run_dir.display());
    };
    let data = prepare_data(&cfg, &opts.data_root)?;
    let name = format!("sweep-{}", run_name(pct));
    let (_, model, epoch) = crate::run_export::model_from_run(&run_dir, &name)?;
    let blob = blob_bytes(&model)?;
    let (metrics, _) = evaluate_core(&blob, SineKind::Libm, test, opts.k, opts.base_seed)?;
    Ok(SweepRow {
        pct,
        n_real: data.n_real,
        n_synthetic: data.n_synthetic,
        n_train: data.train.len(),
        epochs: ckpt.epochs_done,
        best_epoch: epoch,
        val: best.val,
        test: metrics,
        train_seconds: ckpt.history.iter().map(|m| m.seconds).sum(),
    })
}

/// The CSV of the rows.
pub fn sweep_csv(rows: &[SweepRow]) -> Result<String> {
    crate::csvfile::to_csv(
        &[
            "augment_pct",
            "n_real",
            "n_synthetic",
            "n_train_samples",
            "epochs",
            "best_epoch",
            "val_min_ade",
            "val_min_fde",
            "test_min_ade",
            "test_min_fde",
            "test_ade_k1",
            "test_fde_k1",
            "test_k",
            "train_seconds",
        ],
        rows.iter().map(|r| {
            [
                r.pct.to_string(),
                r.n_real.to_string(),
                r.n_synthetic.to_string(),
                r.n_train.to_string(),
                r.epochs.to_string(),
                r.best_epoch.to_string(),
                r.val.min_ade.to_string(),
                r.val.min_fde.to_string(),
                r.test.min_ade.to_string(),
                r.test.min_fde.to_string(),
                r.test.ade_k1.to_string(),
                r.test.fde_k1.to_string(),
                r.test.k.to_string(),
                format!("{:.1}", r.train_seconds),
            ]
        }),
    )
}

/// The markdown table of the rows.
pub fn sweep_md(opts: &SweepOptions, rows: &[SweepRow]) -> String {
    let k = opts.k;
    let mut s = format!(
        "Augmentation sweep: `{}`\n\npool {}; SDD test through gpecnet-core, K = {k}, latent seed of window i = {} + i, pixels\n\n",
        opts.command,
        opts.pool.display(),
        opts.base_seed
    );
    s.push_str(
        "| augment % | real + synthetic windows | training samples (×2 reversal) | best epoch | val minFDE | test minADE | test minFDE | test FDE K=1 |\n|---|---|---|---|---|---|---|---|\n",
    );
    for r in rows {
        let _ = writeln!(
            s,
            "| {} | {} + {} | {} | {} / {} | {:.2} | {:.2} | {:.2} | {:.2} |",
            r.pct,
            r.n_real,
            r.n_synthetic,
            r.n_train,
            r.best_epoch,
            r.epochs,
            r.val.min_fde,
            r.test.min_ade,
            r.test.min_fde,
            r.test.fde_k1
        );
    }
    s
}

fn write_tables(opts: &SweepOptions, rows: &[SweepRow]) -> Result<()> {
    write_atomic(&opts.out.join("sweep.csv"), sweep_csv(rows)?.as_bytes())?;
    write_atomic(&opts.out.join("sweep.md"), sweep_md(opts, rows).as_bytes())?;
    Ok(())
}

/// Parse `--pcts 0,1,3,5.5`.
pub fn parse_pcts(s: &str) -> Result<Vec<f32>> {
    s.split(',')
        .map(|x| {
            let v: f32 = x
                .trim()
                .parse()
                .with_context(|| format!("bad percentage {x:?}"))?;
            if !(v.is_finite() && (0.0..=100.0).contains(&v)) {
                bail!("percentage {v} is not in [0, 100]");
            }
            Ok(v)
        })
        .collect()
}
