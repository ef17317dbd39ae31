//! New and resumed runs and the epoch loop.

use std::io::IsTerminal;
use std::path::PathBuf;

use anyhow::{bail, Context, Result};
use indicatif::{MultiProgress, ProgressBar, ProgressDrawTarget, ProgressStyle};

use crate::checkpoint::{self, EpochMetrics};
use crate::config::TrainConfig;
use crate::data::Unit;
use crate::eval::Metrics;
use crate::rundir::{self, RunLock};

use super::*;

/// Options of one `gpecnet train` invocation.
#[derive(Clone, Debug)]
pub struct TrainOptions {
    /// Data root (`shared/data`).
    pub data_root: PathBuf,
    /// Run directory (checkpoint, metrics, curves).
    pub run_dir: PathBuf,
    /// Override `num_epochs` (total epochs of the run, also when resuming).
    pub epochs: Option<usize>,
    /// No progress bars / per-epoch lines.
    pub quiet: bool,
    /// Stop (as if killed) after this many epochs of this invocation; for tests.
    pub stop_after: Option<usize>,
    /// New runs: start even when the run directory already holds files (overwriting
    /// `config.toml`, `metrics.*`, `curves.svg`); never overrides a checkpoint or a lock.
    pub force: bool,
}

/// Result of a training invocation.
#[derive(Clone, Debug)]
pub struct TrainSummary {
    /// Finished epochs of the run (in total).
    pub epochs_done: usize,
    /// Validation metrics of the last validated epoch.
    pub last_val: Option<Metrics>,
    /// Best epoch and its validation metrics.
    pub best: Option<(usize, Metrics)>,
    /// The run directory.
    pub run_dir: PathBuf,
    /// Unit of the metrics.
    pub unit: Unit,
}

/// The folders the run reads data from (the data root's `sdd/` and `eth_ucy/`, and an own
/// data folder, as written and under the data root), where a run folder is refused: the
/// loaders would read its files (a folder named `*.txt` breaks every later load).
fn check_run_dir_outside_data(cfg: &TrainConfig, opts: &TrainOptions) -> Result<()> {
    fn folders(spec: &crate::data::DatasetSpec, root: &std::path::Path, out: &mut Vec<PathBuf>) {
        match spec {
            crate::data::DatasetSpec::Folder { dir, .. } => {
                out.push(PathBuf::from(dir));
                out.push(root.join(dir));
            }
            crate::data::DatasetSpec::Combined(parts) => {
                for p in parts {
                    folders(p, root, out);
                }
            }
            _ => {}
        }
    }
    let mut dirs: Vec<PathBuf> = crate::outpath::data_input_dirs(&opts.data_root).into();
    if let Ok(spec) = cfg.dataset_spec() {
        folders(&spec, &opts.data_root, &mut dirs);
    }
    let dirs: Vec<&std::path::Path> = dirs.iter().map(PathBuf::as_path).collect();
    crate::outpath::check_output("--out", &opts.run_dir.join("config.toml"), &[], &dirs)?;
    Ok(())
}

/// Start a new run in `opts.run_dir`: takes the run lock ([`crate::rundir`]), refuses a
/// folder with a checkpoint (continue it with `--resume`) and, unless `opts.force`, a folder
/// that holds any other file; writes `config.toml` and the data fingerprint, then trains.
pub fn train_new(cfg: TrainConfig, opts: &TrainOptions) -> Result<TrainSummary> {
    let mut cfg = cfg;
    if let Some(n) = opts.epochs {
        cfg.num_epochs = n;
    }
    cfg.validate()?;
    check_run_dir_outside_data(&cfg, opts)?;
    std::fs::create_dir_all(&opts.run_dir)
        .with_context(|| format!("cannot create {}", opts.run_dir.display()))?;
    let _lock = RunLock::acquire(&opts.run_dir)?;
    rundir::remove_stale_temp_files(&opts.run_dir);
    let ckpt_path = opts.run_dir.join(checkpoint::CHECKPOINT_FILE);
    if ckpt_path.exists() || opts.run_dir.join(checkpoint::PREV_FILE).exists() {
        bail!(
            "{} already exists: continue it with `gpecnet train --resume --out {}` or pick another --out",
            ckpt_path.display(),
            opts.run_dir.display()
        );
    }
    let existing = rundir::existing_entries(&opts.run_dir)?;
    if !existing.is_empty() && !opts.force {
        bail!(
            "{} is not empty ({}) and has no checkpoint: a new run would overwrite config.toml, \
             metrics.csv, metrics.jsonl and curves.svg there. Pick another --out, or pass --force \
             to overwrite",
            opts.run_dir.display(),
            existing.join(", ")
        );
    }
    set_num_threads(cfg.resolved_threads());
    // The training split is read once: for the data scale when the config leaves it to the
    // data, then for training.
    let train_split = load_train_split(&cfg, &opts.data_root)?;
    if cfg.data_scale == crate::config::AUTO_DATA_SCALE {
        let (scale, span, n) = data_scale_of(&cfg, &opts.data_root, &train_split.windows)?;
        eprintln!(
            "data_scale = {scale} (computed: 1.86 x 208.2 / {span:.3}, the RMS span of {n} \
             training windows; written to config.toml)"
        );
        cfg.data_scale = scale;
    }
    if let Some(init) = &cfg.init {
        eprintln!("starting from {init} (fine-tuning: fresh optimizer, epochs from 1)");
    }
    // Nothing is written before the data load: a run that fails there (wrong --data, a bad
    // file) leaves the folder as it was, so the corrected command needs no --force.
    let data = prepare_loaded(&cfg, &opts.data_root, train_split)?;
    rundir::write_atomic(
        &opts.run_dir.join("config.toml"),
        cfg.to_toml_string()?.as_bytes(),
    )?;
    data.fingerprint.save(&opts.run_dir)?;
    let trainer = Trainer::new(cfg, data)?;
    run_loop(trainer, opts)
}

/// Continue the run in `opts.run_dir` from its checkpoint.
pub fn train_resume(opts: &TrainOptions) -> Result<TrainSummary> {
    train_resume_checked(opts, None)
}

/// Continue the run in `opts.run_dir` from its checkpoint (falling back to the previous one,
/// with a warning, when the newest is unusable). Takes the run lock and removes stale temp
/// files first. Refuses when `expected` (a config given with `--resume`) or the folder's
/// `config.toml` differs from the checkpoint's config (`num_epochs` aside: `--epochs` may
/// extend a run), or when the data differ from the fingerprint stored at the start of the
/// run; the errors say what differs.
pub fn train_resume_checked(
    opts: &TrainOptions,
    expected: Option<&TrainConfig>,
) -> Result<TrainSummary> {
    if opts.epochs == Some(0) {
        bail!("--epochs = 0 is out of range: allowed 1 or more");
    }
    if !opts.run_dir.is_dir() {
        bail!(
            "{} does not exist: nothing to resume (start a run with --config)",
            opts.run_dir.display()
        );
    }
    let _lock = RunLock::acquire(&opts.run_dir)?;
    rundir::remove_stale_temp_files(&opts.run_dir);
    let ckpt = checkpoint::load_for_resume(&opts.run_dir)?;
    let cfg = ckpt.config()?;
    if let Some(e) = expected {
        // A config that leaves data_scale to the data matches the number the run computed.
        let mut e = e.clone();
        if e.data_scale == crate::config::AUTO_DATA_SCALE {
            e.data_scale = cfg.data_scale;
        }
        let d = config_diff(&cfg, &e)?;
        if !d.is_empty() {
            bail!(
                "--config differs from the config of the run in {} ({}); resume without --config or start a new run in another --out",
                opts.run_dir.display(),
                d.join("; ")
            );
        }
    }
    let toml_path = opts.run_dir.join("config.toml");
    if let Ok(text) = crate::inpath::read_text_limited(&toml_path, crate::inpath::FileKind::Text) {
        let folder = TrainConfig::from_toml_str(&text)
            .with_context(|| format!("in {}", toml_path.display()))?;
        let d = config_diff(&cfg, &folder)?;
        if !d.is_empty() {
            bail!(
                "{} does not match the checkpoint's config ({}): the folder mixes two runs; refusing to resume",
                toml_path.display(),
                d.join("; ")
            );
        }
    }
    set_num_threads(cfg.resolved_threads());
    let data = prepare_data(&cfg, &opts.data_root)?;
    match DataFingerprint::load(&opts.run_dir)? {
        Some(stored) => {
            let d = stored.diff(&data.fingerprint);
            if !d.is_empty() {
                // Name the files the run reads: a folder data set's own folder, never the
                // benchmark root it does not use.
                let spec = cfg.dataset_spec()?;
                let same = if matches!(spec, crate::data::DatasetSpec::Folder { .. }) {
                    "the same files in that folder"
                } else {
                    "the same data (--data)"
                };
                bail!(
                    "the data in {} differ from the data the run in {} started with: {}; \
                     resume with {same} or start a new run",
                    spec.location(&opts.data_root),
                    opts.run_dir.display(),
                    d.join("; ")
                );
            }
        }
        None => {
            eprintln!(
                "warning: {} has no {} (a run from an older gpecnet): the data cannot be checked; recording the current data",
                opts.run_dir.display(),
                DataFingerprint::FILE
            );
            data.fingerprint.save(&opts.run_dir)?;
        }
    }
    let mut trainer = Trainer::from_checkpoint(ckpt, data)?;
    if let Some(n) = opts.epochs {
        trainer.set_num_epochs(n);
    }
    run_loop(trainer, opts)
}

/// Keys whose values differ between two configs (`num_epochs` is ignored, and `init`: a
/// resumed run continues from its own checkpoint, whatever it started from), as
/// `key: a -> b`.
pub fn config_diff(a: &TrainConfig, b: &TrainConfig) -> Result<Vec<String>> {
    let ta: toml::Table = toml::from_str(&a.to_toml_string()?)?;
    let tb: toml::Table = toml::from_str(&b.to_toml_string()?)?;
    let mut keys: Vec<&String> = ta.keys().chain(tb.keys()).collect();
    keys.sort();
    keys.dedup();
    let show = |v: Option<&toml::Value>| v.map_or("(default)".to_string(), |v| v.to_string());
    Ok(keys
        .into_iter()
        // Compared as written: a float that is not a number equals itself here.
        .filter(|k| {
            k.as_str() != "num_epochs"
                && k.as_str() != "init"
                && show(ta.get(*k)) != show(tb.get(*k))
        })
        .map(|k| format!("{k}: {} -> {}", show(ta.get(k)), show(tb.get(k))))
        .collect())
}

fn bar_style(template: &str) -> ProgressStyle {
    ProgressStyle::with_template(template)
        .unwrap_or_else(|_| ProgressStyle::default_bar())
        .progress_chars("=> ")
}

fn run_loop(mut trainer: Trainer, opts: &TrainOptions) -> Result<TrainSummary> {
    let total = trainer.config().num_epochs;
    let show = !opts.quiet && std::io::stderr().is_terminal();
    let mp = MultiProgress::with_draw_target(if show {
        ProgressDrawTarget::stderr()
    } else {
        ProgressDrawTarget::hidden()
    });
    let ebar = mp.add(ProgressBar::new(total as u64));
    ebar.set_style(bar_style(
        "epochs  [{elapsed_precise}] {bar:30} {pos}/{len} ETA {eta_precise} {msg}",
    ));
    ebar.set_position(trainer.epochs_done() as u64);
    ebar.reset_eta();
    let bbar = mp.add(ProgressBar::new(trainer.batches_per_epoch() as u64));
    bbar.set_style(bar_style("batches {bar:30} {pos}/{len} ETA {eta}"));
    let unit = trainer.data().unit;
    let mut ran = 0usize;
    while trainer.epochs_done() < total {
        if opts.stop_after.is_some_and(|n| ran >= n) {
            break;
        }
        bbar.reset();
        let m = trainer.run_epoch(Some(&bbar))?;
        ran += 1;
        checkpoint::save(&opts.run_dir, &trainer.checkpoint()?)?;
        write_metrics(&opts.run_dir, trainer.history())?;
        if let Err(e) = plot_curves(&opts.run_dir.join("curves.svg"), trainer.history(), unit) {
            mp.suspend(|| eprintln!("warning: could not plot curves: {e}"));
        }
        let line = epoch_line(&m, unit);
        ebar.set_message(
            m.val
                .map(|v| format!("val minFDE {:.2} {unit}", v.min_fde))
                .unwrap_or_default(),
        );
        ebar.inc(1);
        if show {
            let _ = mp.println(line);
        } else if !opts.quiet {
            eprintln!("{line}");
        }
    }
    bbar.finish_and_clear();
    ebar.finish();
    Ok(TrainSummary {
        epochs_done: trainer.epochs_done(),
        last_val: trainer.history().iter().rev().find_map(|m| m.val),
        best: trainer.best().map(|b| (b.epoch, b.val)),
        run_dir: opts.run_dir.clone(),
        unit,
    })
}

fn epoch_line(m: &EpochMetrics, unit: Unit) -> String {
    let mut s = format!(
        "epoch {:4}  loss {:.4} (rcl {:.4} kld {:.4} adl {:.4})  {:.1}s",
        m.epoch, m.train_loss, m.train_rcl, m.train_kld, m.train_adl, m.seconds
    );
    if let Some(p) = m.val_point {
        s += &format!("  point ADE {:.2} FDE {:.2} {unit}", p.ade_k1, p.fde_k1);
    }
    if let Some(v) = m.val {
        s += &format!(
            "  val minADE {:.2} minFDE {:.2} {unit} (K={})",
            v.min_ade, v.min_fde, v.k
        );
    }
    s
}
