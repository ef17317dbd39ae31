//! The firmware's cargo: which weights it embeds, building and running it
//! (`fw-build`, `fw-run`), the injected-failure proofs (`fw-faults`) and the
//! host side: the golden replay's tests and the host tools (`fw-test`).

use std::path::{Path, PathBuf};
use std::process::Command;

use crate::mcu;
use crate::toolchain::{deb_cargo, host_cargo, output, require, status};
use crate::{die, root};

/// What the firmware commands were asked for (from `FwArgs` in main.rs).
pub(crate) struct Opts {
    /// Weights directory (`--weights`, `--test-blob`); `None`: weights/.
    pub(crate) weights: Option<PathBuf>,
    /// `--mcu NAME`: the class for `qemu` (default: the M4F).
    pub(crate) mcu: Option<&'static mcu::Mcu>,
    /// `--all-targets`: `qemu` on every class, plus the MCU × model table.
    pub(crate) all_targets: bool,
    /// Passed on to the firmware's cargo.
    pub(crate) rest: Vec<String>,
}

pub(crate) fn make_test_blob() -> PathBuf {
    let dir = root().join("target/fw-test-weights");
    let mut c = host_cargo();
    c.args([
        "run",
        "-q",
        "--release",
        "--manifest-path",
        "firmware/host/Cargo.toml",
        "--bin",
        "make-test-blob",
        "--",
    ])
    .arg(&dir);
    if status(c) != 0 {
        die("make-test-blob failed");
    }
    dir
}

pub(crate) fn weights_dir(o: &Opts) -> PathBuf {
    o.weights.clone().unwrap_or_else(|| root().join("weights"))
}

/// Model names with both files, sorted (the firmware's build.rs does the same).
/// Largest blob linked into the firmware: the STM32F405 has 1 MiB of flash,
/// and code, golden files and the other models need room too. Bigger
/// (host-only, e.g. paper-size) models are skipped by firmware/build.rs too.
pub(crate) const MAX_MCU_BLOB: u64 = 512 * 1024;

pub(crate) fn models_in(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .map(|rd| {
            rd.filter_map(|e| e.ok())
                .map(|e| e.path())
                .filter(|p| p.extension().is_some_and(|x| x == "gpec"))
                .filter(|p| std::fs::metadata(p).is_ok_and(|m| m.len() <= MAX_MCU_BLOB))
                .filter_map(|p| p.file_stem().and_then(|s| s.to_str()).map(String::from))
                .filter(|n| dir.join(format!("{n}.golden")).is_file())
                .collect()
        })
        .unwrap_or_default();
    v.sort();
    v
}

pub(crate) fn require_models(dir: &Path) -> Vec<String> {
    let m = models_in(dir);
    if m.is_empty() {
        die(&format!(
            "no model in {}: need <name>.gpec (weight blob) + <name>.golden (golden-vector sidecar), \
             exported by the trainer.\n  To exercise the firmware pipeline without trained weights: cargo xtask <cmd> --test-blob",
            dir.display()
        ));
    }
    m
}

pub(crate) fn fw_cargo(o: &Opts) -> Command {
    let mut c = deb_cargo(&root().join("firmware"));
    if let Some(w) = &o.weights {
        c.env("GPECNET_WEIGHTS_DIR", w);
    }
    c
}

pub(crate) fn fw_build(o: &Opts, extra: &[&str]) -> i32 {
    require(false);
    let mut c = fw_cargo(o);
    c.arg("build");
    fw_class_args(o, &mut c);
    c.args(extra).args(&o.rest);
    status(c)
}

pub(crate) fn fw_run(o: &Opts) -> i32 {
    require(true);
    let mut c = fw_cargo(o);
    c.arg("run");
    fw_class_args(o, &mut c);
    c.args(&o.rest);
    status(c)
}

/// `--release`, and with `--mcu`: that class's chip, target, QEMU machine and
/// its golden image's modes (without: the firmware's defaults, the M4F).
pub(crate) fn fw_class_args(o: &Opts, c: &mut Command) {
    match o.mcu {
        Some(m) => {
            m.firmware_args(c, &root(), "golden", &m.golden_features());
        }
        None => {
            c.arg("--release");
        }
    }
}

pub(crate) fn fw_faults(o: &Opts) -> i32 {
    require(true);
    let mut bad = 0;
    let first = require_models(&weights_dir(o)).remove(0);
    // Each injected failure must end the run with exit 1 and its own log line
    // (no lockup, no silent corruption, no outer timeout).
    for (f, want) in [
        ("force-panic", "panic"),
        ("force-hardfault", "HardFault"),
        ("force-stack-overflow", "stack overflow"),
        ("force-hang", "a task hung"),
        ("force-corrupt-blob", "blob rejected"),
    ] {
        let mut c = fw_cargo(o);
        // The corrupted-blob proof runs the golden mode on one model (the first).
        c.env("GPECNET_MODELS", &first);
        c.arg("run");
        mcu::M4F.firmware_args(&mut c, &root(), "golden", &[f]);
        let (rc, out, _) = output(c);
        let last = out.lines().rev().find(|l| l.contains(want)).unwrap_or("");
        let ok = rc == 1 && !last.is_empty();
        println!(
            "fw-faults {f:<22} exit {rc} (want 1), log {:?} {}",
            last.trim(),
            if ok { "ok" } else { "FAILED" }
        );
        bad += (!ok) as i32;
    }
    (bad != 0) as i32
}

pub(crate) fn fw_test() -> i32 {
    // The golden replay the firmware runs (crate gpecnet-replay), tested on the
    // host, and the firmware's host tools (golden-host, make-test-blob) built.
    let mut c = host_cargo();
    c.args(["test", "-p", "gpecnet-replay"]);
    let rc = status(c);
    if rc != 0 {
        return rc;
    }
    let mut c = host_cargo();
    c.args([
        "build",
        "--release",
        "--manifest-path",
        "firmware/host/Cargo.toml",
    ]);
    status(c)
}
