//! `cargo xtask demo`: the main job on a fresh machine, in one command: the toolchain, the
//! shipped metric MCU model evaluated through `gpecnet-core` on the real SDD test set (in
//! metres and pixels, the point forecast against constant velocity, the distribution metrics,
//! `out/predictions.svg`), then the two models a drone flashes replayed on an emulated
//! STM32F405 against their golden files.
//!
//! The evaluation runs in this process through `gpecnet-ship` (`gpecnet eval`'s library and
//! report), so the demo compiles no training stack (candle, gemm, tokenizers, prost): the
//! `gpecnet` binary would cost a fresh machine minutes of compiling it never runs.

use std::path::{Path, PathBuf};

use gpecnet_ship::blob_eval::{eval_blob, EvalTarget};
use gpecnet_ship::eval_report;

use crate::firmware::Opts;
use crate::{replay, root, toolchain};

/// The model the demo evaluates, and its data set.
const BLOB: &str = "weights/sdd-m-lp-qe.gpec";
/// `gpecnet eval`'s data-set name for SDD in metres.
const DATASET: &str = "sdd-m";
/// Where the demo draws the predictions.
const DRAW: &str = "out/predictions.svg";
/// The models `cargo xtask demo` replays on the emulated STM32F405.
const MODELS: [&str; 2] = ["sdd-tiny-v2-qe", "sdd-m-lp-qe"];

/// Runs the demo (module docs); the exit code.
pub(crate) fn demo(o: &Opts) -> i32 {
    let rc = toolchain::setup();
    if rc != 0 {
        return rc;
    }
    if let Err(e) = evaluate(&root()) {
        eprintln!("xtask demo: {e:#}");
        return 1;
    }
    // The two models a drone flashes (pixel and metric MCU defaults); CI's
    // `qemu --all-targets` replays every shipped model on three MCU classes.
    replay::qemu_models(o, Some(&MODELS))
}

/// `gpecnet eval --blob BLOB --dataset sdd-m --draw out/predictions.svg`, in process; an error
/// when the model card's numbers are not reproduced.
fn evaluate(root: &Path) -> anyhow::Result<()> {
    let data = data_root(root);
    let target = EvalTarget {
        dataset: gpecnet_data::DatasetSpec::parse(DATASET).map_err(anyhow::Error::msg)?,
        assume_unit: None,
    };
    let blob = root.join(BLOB);
    let draw = root.join(DRAW);
    if let Some(dir) = draw.parent() {
        std::fs::create_dir_all(dir)?;
    }
    eprintln!(
        "xtask: evaluating {BLOB} on the {DATASET} test set through gpecnet-core (data: {})",
        data.display()
    );
    let r = eval_blob(&blob, &data, &target, None, 20, 0, Some(&draw), 16, None)?;
    print!("{}", eval_report::table(&r));
    if r.matches_card == Some(false) {
        anyhow::bail!("{BLOB}: the model card's numbers were not reproduced");
    }
    Ok(())
}

/// The benchmark data beside the checkout (`../shared/data`), else the data crate's default.
fn data_root(root: &Path) -> PathBuf {
    let beside = root.join("../shared/data");
    if beside.is_dir() {
        beside
    } else {
        gpecnet_data::default_data_root()
    }
}
