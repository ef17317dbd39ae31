//! The synthetic-data commands: `gpecnet abscore`, `classify`, `synth`, `rl-train` and `sweep`.
// Doc comments here are the CLI --help text, where <name> placeholders are plain text.
#![allow(rustdoc::invalid_html_tags)]

use std::path::PathBuf;

use crate::cmd_blob::TestSampling;
use anyhow::Result;
use gpecnet_trainer::{config::TrainConfig, data};

/// Largest synthetic pool (`synth --n`, `sweep --pool-n`): 55 times the default 18,000,
/// about 160 MB of trajectories in memory (a pool of 10^11 aborted on allocation).
const MAX_POOL: u64 = 1_000_000;
/// Most policy-gradient episodes (`synth --rl-episodes`, `rl-train --episodes`).
const MAX_EPISODES: u64 = 1_000_000;
/// Most episodes per REINFORCE update (`rl-train --batch`).
const MAX_RL_BATCH: u64 = 4096;

/// A count option in `lo..=hi`, refused by clap before any work with the range named.
fn count_in(lo: u64, hi: u64) -> clap::builder::RangedU64ValueParser<usize> {
    clap::builder::RangedU64ValueParser::<usize>::new().range(lo..=hi)
}

/// `rl-train --lr`: a finite learning rate in (0, 1], like the training config's.
fn parse_rl_lr(s: &str) -> std::result::Result<f64, String> {
    let v: f64 = s.parse().map_err(|e| format!("{e}"))?;
    if v.is_finite() && v > 0.0 && v <= 1.0 {
        Ok(v)
    } else {
        Err(format!(
            "{v} is out of range: allowed a finite number in (0, 1]"
        ))
    }
}

/// `abscore --max-abscore`: a finite AbScore >= 0 (NaN would filter nothing, silently).
fn parse_max_abscore(s: &str) -> std::result::Result<f64, String> {
    let v: f64 = s.parse().map_err(|e| format!("{e}"))?;
    if v.is_finite() && v >= 0.0 {
        Ok(v)
    } else {
        Err(format!("{v} is out of range: allowed a finite number >= 0"))
    }
}

#[derive(clap::Args, Debug)]
pub(crate) struct AbscoreArgs {
    /// Data root holding sdd/ (see shared/data/README.md).
    #[arg(long, value_name = "DIR", default_value_os_t = data::default_data_root())]
    data: PathBuf,
    /// Output directory (abscore.md, abscore.csv, abscore_hist.svg, abscore_scaled_hist.svg).
    #[arg(long, value_name = "DIR")]
    out: PathBuf,
    /// Outlier filter: report how many trajectories have AbScore above this value.
    #[arg(long, value_name = "X", value_parser = parse_max_abscore)]
    max_abscore: Option<f64>,
    /// Filter on the areal-scaled AbScore instead of the unscaled one.
    #[arg(long)]
    scaled: bool,
}

pub(crate) fn cmd_abscore(a: AbscoreArgs) -> Result<()> {
    use gpecnet_trainer::synth::abscore::Which;
    let which = if a.scaled {
        Which::Scaled
    } else {
        Which::Unscaled
    };
    print!(
        "{}",
        gpecnet_trainer::synth::cli::run_abscore(&a.data, &a.out, a.max_abscore, which)?
    );
    Ok(())
}

#[derive(clap::Args, Debug)]
pub(crate) struct ClassifyArgs {
    /// Data root holding sdd/.
    #[arg(long, value_name = "DIR", default_value_os_t = data::default_data_root())]
    data: PathBuf,
    /// Output directory (classify.md, types.svg, unique_points.svg, type_examples.svg).
    #[arg(long, value_name = "DIR")]
    out: PathBuf,
}

pub(crate) fn cmd_classify(a: ClassifyArgs) -> Result<()> {
    print!(
        "{}",
        gpecnet_trainer::synth::cli::run_classify(&a.data, &a.out)?
    );
    Ok(())
}

#[derive(clap::Args, Debug)]
pub(crate) struct SynthArgs {
    /// Data root holding sdd/ (SDD train's type shares are matched).
    #[arg(long, value_name = "DIR", default_value_os_t = data::default_data_root())]
    data: PathBuf,
    /// Pool size.
    #[arg(long, default_value_t = 18000, value_parser = count_in(1, MAX_POOL))]
    n: usize,
    /// Seed (policy training and pool order).
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Episodes for the policy-gradient agents used in the pool.
    #[arg(long, default_value_t = 3200, value_parser = count_in(1, MAX_EPISODES))]
    rl_episodes: usize,
    /// Output CSV (index,type,source,x0,y0,...); pictures and tables go next to it.
    #[arg(long, value_name = "CSV")]
    out: PathBuf,
}

pub(crate) fn cmd_synth(a: SynthArgs) -> Result<()> {
    print!(
        "{}",
        gpecnet_trainer::synth::cli::run_synth(&a.data, a.n, a.seed, a.rl_episodes, &a.out)?
    );
    Ok(())
}

#[derive(clap::Args, Debug)]
pub(crate) struct RlTrainArgs {
    /// Number of training episodes.
    #[arg(long, default_value_t = 3200, value_parser = count_in(1, MAX_EPISODES))]
    episodes: usize,
    /// Episodes per REINFORCE update.
    #[arg(long, default_value_t = 16, value_parser = count_in(1, MAX_RL_BATCH))]
    batch: usize,
    /// Adam learning rate.
    #[arg(long, default_value_t = 3e-3, value_parser = parse_rl_lr)]
    lr: f64,
    /// Seed.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Output directory (rl_train.md, rl_curve.csv, rl_curve_*.svg, rl_episodes.svg, policy.json).
    #[arg(long, value_name = "DIR")]
    out: PathBuf,
}

pub(crate) fn cmd_rl_train(a: RlTrainArgs) -> Result<()> {
    print!(
        "{}",
        gpecnet_trainer::synth::cli::run_rl_train(a.episodes, a.batch, a.lr, a.seed, &a.out)?.0
    );
    Ok(())
}

#[derive(clap::Args, Debug)]
pub(crate) struct SweepArgs {
    /// Training config of every point (its augment_pct / synthetic_pool are overridden).
    #[arg(
        long,
        value_name = "TOML",
        default_value = "host-trainer/configs/sdd-small.toml"
    )]
    config: PathBuf,
    /// Augmentation percentages, comma-separated (0 = no augmentation).
    #[arg(long, default_value = "0,1,3,5,6,8,10,13,15,18")]
    pcts: String,
    /// Epochs of every run (default: the config's num_epochs).
    #[arg(long, value_name = "N")]
    epochs: Option<usize>,
    /// Output directory: aug-<K>/ runs, sweep.md, sweep.csv.
    #[arg(long, value_name = "DIR", default_value = "runs/sweep")]
    out: PathBuf,
    /// The synthetic pool CSV; generated there (--pool-n, --pool-seed) if it does not exist.
    #[arg(long, value_name = "CSV", default_value = "runs/pool/pool.csv")]
    pool: PathBuf,
    /// Seed of a generated pool.
    #[arg(long, default_value_t = 1)]
    pool_seed: u64,
    /// Size of a generated pool.
    #[arg(long, default_value_t = 18000, value_parser = count_in(1, MAX_POOL))]
    pool_n: usize,
    /// Data root holding sdd/.
    #[arg(long, value_name = "DIR", default_value_os_t = data::default_data_root())]
    data: PathBuf,
    #[command(flatten)]
    sampling: TestSampling,
    /// No per-epoch lines.
    #[arg(long)]
    quiet: bool,
}

pub(crate) fn cmd_sweep(a: SweepArgs) -> Result<()> {
    use gpecnet_trainer::synth::sweep;
    // Every run is evaluated at --k after its training: refuse a K no blob gives first.
    let most = gpecnet_trainer::core_eval::HOST_MAX_K;
    if a.sampling.k == 0 || a.sampling.k > most {
        anyhow::bail!(
            "--k {} is out of range: allowed 1..={most} endpoints per window",
            a.sampling.k
        );
    }
    let command = format!(
        "gpecnet sweep --config {} --pcts {} --epochs {} --out {} --pool {}",
        a.config.display(),
        a.pcts,
        a.epochs.map_or("<config>".into(), |n| n.to_string()),
        a.out.display(),
        a.pool.display()
    );
    let opts = sweep::SweepOptions {
        config: TrainConfig::from_file(&a.config)?,
        epochs: a.epochs,
        pcts: sweep::parse_pcts(&a.pcts)?,
        data_root: a.data,
        pool: a.pool,
        pool_seed: a.pool_seed,
        pool_n: a.pool_n,
        out: a.out,
        k: a.sampling.k,
        base_seed: a.sampling.seed,
        quiet: a.quiet,
        command,
    };
    let rows = sweep::run_sweep(&opts)?;
    print!("{}", sweep::sweep_md(&opts, &rows));
    Ok(())
}
