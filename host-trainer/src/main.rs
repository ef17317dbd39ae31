//! `gpecnet`: the G-PECNet host command line.
//!
//! One `Command` variant and one small `cmd_*` function per subcommand; the work lives in the
//! library modules so subcommands can be appended without touching each other.

use std::path::PathBuf;

use anyhow::Result;
use clap::{Parser, Subcommand};
use gpecnet_trainer::{config::TrainConfig, data, train};

/// G-PECNet (PECNet with SIREN sine MLPs) host tools: training, evaluation and export.
#[derive(Parser, Debug)]
#[command(name = "gpecnet", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Train a model (new run, or continue one with --resume).
    ///
    /// Writes checkpoint.bin (after every epoch, atomically), metrics.csv, metrics.jsonl,
    /// curves.svg and config.toml into the run directory. The best epoch is chosen on the
    /// validation scenes (never the test set).
    Train(TrainArgs),
}

#[derive(clap::Args, Debug)]
struct TrainArgs {
    /// Training config (TOML; see host-trainer/configs/). Required for a new run; with
    /// --resume the config stored in the checkpoint is used and this must be omitted.
    #[arg(long, value_name = "TOML")]
    config: Option<PathBuf>,
    /// Data root holding sdd/ and eth_ucy/ (see shared/data/README.md).
    #[arg(long, value_name = "DIR", default_value_os_t = data::default_data_root())]
    data: PathBuf,
    /// Run directory for checkpoint, metrics and plots (created if missing).
    #[arg(long, value_name = "DIR")]
    out: PathBuf,
    /// Continue the run in --out from its checkpoint.bin, bit-exactly.
    #[arg(long)]
    resume: bool,
    /// Override the total number of epochs of the run (also extends a resumed run).
    #[arg(long, value_name = "N")]
    epochs: Option<usize>,
    /// No progress bars and no per-epoch lines (bars are also hidden when stderr is not a
    /// terminal; then one line per epoch is printed instead).
    #[arg(long)]
    quiet: bool,
}

fn cmd_train(a: TrainArgs) -> Result<()> {
    let opts = train::TrainOptions {
        data_root: a.data,
        run_dir: a.out,
        epochs: a.epochs,
        quiet: a.quiet,
        stop_after: None,
    };
    let summary = if a.resume {
        if a.config.is_some() {
            anyhow::bail!("--resume uses the config stored in the checkpoint; drop --config");
        }
        train::train_resume(&opts)?
    } else {
        let Some(path) = a.config else {
            anyhow::bail!("a new run needs --config <TOML> (or --resume to continue one)");
        };
        train::train_new(TrainConfig::from_file(&path)?, &opts)?
    };
    let u = summary.unit;
    println!(
        "run: {} ({} epochs)",
        summary.run_dir.display(),
        summary.epochs_done
    );
    if let Some(v) = summary.last_val {
        println!(
            "final validation: minADE {:.3} {u}  minFDE {:.3} {u}  (K={}, n={})",
            v.min_ade, v.min_fde, v.k, v.n
        );
    }
    if let Some((epoch, v)) = summary.best {
        println!(
            "best epoch {epoch}: validation minADE {:.3} {u}  minFDE {:.3} {u}",
            v.min_ade, v.min_fde
        );
    }
    Ok(())
}

fn main() -> Result<()> {
    match Cli::parse().command {
        Command::Train(a) => cmd_train(a),
    }
}
