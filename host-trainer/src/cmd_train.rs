//! `gpecnet train` and `gpecnet select`: training runs and the choice among them.
// Doc comments here are the CLI --help text, where <name> placeholders are plain text.
#![allow(rustdoc::invalid_html_tags)]

use std::path::PathBuf;

use anyhow::Result;
use gpecnet_trainer::{config::TrainConfig, data, train};

#[derive(clap::Args, Debug)]
pub(crate) struct SelectArgs {
    /// Run directory written by `gpecnet train` (its best validation epoch is used).
    #[arg(long, value_name = "DIR")]
    run: PathBuf,
    /// Data root holding sdd/ and eth_ucy/ (see shared/data/README.md).
    #[arg(long, value_name = "DIR", default_value_os_t = data::default_data_root())]
    data: PathBuf,
    /// Latent standard deviations to try.
    #[arg(long, value_delimiter = ',', default_value = "0.8,1.0,1.3")]
    sigmas: Vec<f32>,
    /// Test-time samples N to try (0 = plain sampling; N >= K reduces N samples to K by k-means).
    #[arg(long, value_delimiter = ',', default_value = "0,60,80,100")]
    tts: Vec<usize>,
    /// Endpoints per window.
    #[arg(long, default_value_t = 20)]
    k: usize,
    /// Print one JSON object instead of the table.
    #[arg(long)]
    json: bool,
}

pub(crate) fn cmd_select(a: SelectArgs) -> Result<()> {
    let (rows, point) = gpecnet_trainer::select::select(
        &a.run,
        &a.data,
        &a.sigmas,
        &a.tts,
        a.k,
        gpecnet_trainer::reference::SineKind::Libm,
    )?;
    if a.json {
        let v = serde_json::json!({ "run": a.run, "rows": rows, "point": point });
        println!("{v}");
        return Ok(());
    }
    print!(
        "{}",
        gpecnet_trainer::select::table(a.k, &rows, point.as_ref())
    );
    Ok(())
}

#[derive(clap::Args, Debug)]
pub(crate) struct TrainArgs {
    /// Training config (TOML; see host-trainer/configs/). Required for a new run without
    /// --init; with
    /// --resume the config stored in the checkpoint is used, and a --config given as well
    /// must equal it (num_epochs aside) or the resume is refused, naming the keys that differ.
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
    /// New runs: train into an --out folder that already holds files (but no checkpoint),
    /// overwriting its config.toml, metrics.csv, metrics.jsonl and curves.svg. Never breaks
    /// another run's lock and never replaces a checkpoint.
    #[arg(long)]
    force: bool,
    /// Override the total number of epochs of the run (also extends a resumed run).
    #[arg(long, value_name = "N")]
    epochs: Option<usize>,
    /// No progress bars and no per-epoch lines (bars are also hidden when stderr is not a
    /// terminal; then one line per epoch is printed instead).
    #[arg(long)]
    quiet: bool,
    /// Augment with the first K % (of the real training windows) of the synthetic pool
    /// (overrides the config's augment_pct; new runs only).
    #[arg(long, value_name = "K")]
    augment: Option<f32>,
    /// The synthetic pool CSV written by `gpecnet synth` (overrides synthetic_pool).
    #[arg(long, value_name = "CSV")]
    pool: Option<PathBuf>,
    /// Override the config's seed (new runs only): one config, several seeds.
    #[arg(long, value_name = "N")]
    seed: Option<u64>,
    /// Override the config's heading_steps (new runs only; 0 = raw orientation).
    #[arg(long, value_name = "M")]
    heading_steps: Option<usize>,
    /// Override the config's dataset (new runs only): `sdd` (pixels), `sdd-m` (SDD in metres),
    /// `eth_ucy:<scene>` (one config for every leave-one-scene-out split), a data-set folder
    /// with a `/` in its path (`./mydrone`: dataset.toml + train/ val/ test/, see
    /// docs/own-data.md), or several joined by `+`.
    #[arg(long, value_name = "SPEC")]
    dataset: Option<String>,
    /// Turn on reflection augmentation (new runs only; see `mirror` in the config).
    #[arg(long)]
    mirror: bool,
    /// Cosine learning-rate decay over the run (new runs only; see `lr_schedule`).
    #[arg(long)]
    cosine: bool,
    /// Train on noisy pasts: i.i.d. Gaussian noise of standard deviation SIGMA (the data's
    /// unit: metres for sdd-m and ETH/UCY) on each coordinate of the 8 observed positions of
    /// every training window, drawn afresh every epoch; the future stays clean (new runs
    /// only; overrides the config's obs_noise; 0 = none, today's training bit for bit).
    #[arg(long, value_name = "SIGMA")]
    obs_noise: Option<f32>,
    /// Fine-tune: start from the weights of a run folder (its best validation epoch) or of an
    /// f32 blob such as weights/sdd-m-lp.gpec (new runs only). The run takes the source's
    /// config (for a blob, the training config in the <name>.json beside it), so its
    /// architecture and data scale; --config may change how to train but not what the weights
    /// depend on. A blob's latent encoder (training only, not in any blob) starts fresh and its
    /// proposal is dropped: refit it on the new data with `gpecnet propose` and `gpecnet score`.
    /// See docs/own-data.md, "Fine-tuning".
    #[arg(long, value_name = "RUN_OR_BLOB")]
    init: Option<PathBuf>,
    /// Train on a part of the training split: the windows of a fixed FRACTION of its tracks
    /// (the same tracks for every seed; validation is never reduced), in (0, 1] (new runs
    /// only; overrides the config's train_fraction).
    #[arg(long, value_name = "FRACTION")]
    train_fraction: Option<f32>,
    /// The data scale (multiplier from data units to model units; new runs only): a number,
    /// or `auto` to compute it from the training windows (1.86 x 208.2 / their RMS span from
    /// first observed point to endpoint, the rule of docs/ethucy.md). A config without
    /// data_scale is `auto`. The number a run uses is written to its config.toml and card.
    #[arg(long, value_name = "X|auto", value_parser = parse_data_scale)]
    data_scale: Option<f32>,
}

fn parse_data_scale(s: &str) -> Result<f32, String> {
    if s == "auto" {
        return Ok(gpecnet_trainer::config::AUTO_DATA_SCALE);
    }
    match s.parse::<f32>() {
        Ok(v) if v.is_finite() && v > 0.0 => Ok(v),
        _ => Err(format!("`{s}` is neither `auto` nor a finite number > 0")),
    }
}

pub(crate) fn cmd_train(a: TrainArgs) -> Result<()> {
    let opts = train::TrainOptions {
        data_root: a.data,
        run_dir: a.out,
        epochs: a.epochs,
        quiet: a.quiet,
        stop_after: None,
        force: a.force,
    };
    let summary = if a.resume {
        if a.force {
            anyhow::bail!("--force applies to new runs; --resume never overwrites anything");
        }
        if a.augment.is_some()
            || a.pool.is_some()
            || a.seed.is_some()
            || a.heading_steps.is_some()
            || a.dataset.is_some()
            || a.mirror
            || a.cosine
            || a.obs_noise.is_some()
            || a.init.is_some()
            || a.train_fraction.is_some()
            || a.data_scale.is_some()
        {
            anyhow::bail!(
                "--resume uses the config stored in the checkpoint; drop --augment/--pool/--seed/--heading-steps/--dataset/--mirror/--cosine/--obs-noise/--init/--train-fraction/--data-scale"
            );
        }
        let expected = a
            .config
            .as_deref()
            .map(TrainConfig::from_file)
            .transpose()?;
        train::train_resume_checked(&opts, expected.as_ref())?
    } else {
        let given = a
            .config
            .as_deref()
            .map(TrainConfig::from_file)
            .transpose()?;
        let mut cfg = match (&a.init, given) {
            (Some(init), given) => {
                let src = train::init::load_init(init)?;
                train::init::init_config(&src, given)?
            }
            (None, Some(cfg)) => cfg,
            (None, None) => anyhow::bail!(
                "a new run needs --config <TOML> or --init <RUN_OR_BLOB> (or --resume to continue one)"
            ),
        };
        if let Some(f) = a.train_fraction {
            cfg.train_fraction = f;
        }
        if let Some(x) = a.data_scale {
            if a.init.is_some() && x != cfg.data_scale {
                anyhow::bail!(
                    "--data-scale {x}: a fine-tuning run keeps the data scale of --init ({})",
                    cfg.data_scale
                );
            }
            cfg.data_scale = x;
        }
        if let Some(k) = a.augment {
            cfg.augment_pct = k;
        }
        if let Some(p) = a.pool {
            cfg.synthetic_pool = Some(p.to_string_lossy().into_owned());
        }
        if let Some(s) = a.seed {
            cfg.seed = s;
        }
        if let Some(m) = a.heading_steps {
            cfg.heading_steps = m;
        }
        if let Some(d) = a.dataset {
            cfg.dataset = d;
        }
        if a.mirror {
            cfg.mirror = true;
        }
        if a.cosine {
            cfg.lr_schedule = gpecnet_trainer::config::LrSchedule::Cosine;
        }
        if let Some(s) = a.obs_noise {
            cfg.obs_noise = s;
        }
        train::train_new(cfg, &opts)?
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
