//! `cargo xtask fuzz-smoke [--seconds N] [--target NAME]`: every cargo-fuzz
//! target of `core/fuzz` built and run for N seconds (default 60) each, as
//! `cargo fuzz run <target> -- -max_total_time=N` would, without installing
//! cargo-fuzz: the stable cargo that runs xtask with `RUSTC_BOOTSTRAP=1` and
//! cargo-fuzz's flags (SanitizerCoverage for libFuzzer, `--cfg fuzzing`,
//! AddressSanitizer, debug assertions and overflow checks in a release build).
//!
//! Each run starts from its own corpus in `target/fuzz-smoke/corpus/<target>`,
//! seeded with the shipped files the target reads (`weights/*.gpec` for the
//! blob targets, `weights/*.golden` for `golden`; files over 128 KiB are left
//! out, they would only slow every run down) and kept between smoke runs. A
//! crash leaves its input in `target/fuzz-smoke/artifacts/<target>/` and fails
//! the command; `cd core/fuzz && RUSTC_BOOTSTRAP=1 cargo fuzz run <target>
//! <file>` reproduces it (core/fuzz/README.md).

use std::path::{Path, PathBuf};
use std::process::Command;

use crate::ffi::combined_output;
use crate::root;
use crate::toolchain::{host_cargo, status};

/// The targets of core/fuzz/Cargo.toml, and the shipped files that seed each.
const TARGETS: &[(&str, &str)] = &[
    ("blob", "gpec"),
    ("blob_resealed", "gpec"),
    ("blob_structured", ""),
    ("golden", "golden"),
];

/// Seeds larger than this are not copied into a corpus.
const MAX_SEED: u64 = 128 * 1024;

/// cargo-fuzz's flags for `cargo fuzz build` (sanitizer `address`, the default).
const RUSTFLAGS: &str = "-Cpasses=sancov-module \
    -Cllvm-args=-sanitizer-coverage-level=4 \
    -Cllvm-args=-sanitizer-coverage-inline-8bit-counters \
    -Cllvm-args=-sanitizer-coverage-pc-table \
    -Cllvm-args=-sanitizer-coverage-trace-compares \
    --cfg fuzzing \
    -Zsanitizer=address \
    -Cdebug-assertions \
    -Coverflow-checks";

/// The host triple: with an explicit `--target`, RUSTFLAGS reach only the
/// target's crates, not build scripts and proc macros (as with cargo-fuzz).
const HOST: &str = "x86_64-unknown-linux-gnu";

/// Builds every fuzz target; returns the directory holding the binaries.
fn build(target_dir: &Path) -> Result<PathBuf, i32> {
    let mut c = host_cargo();
    c.args(["build", "--release", "--bins", "--manifest-path"])
        .arg(root().join("core/fuzz/Cargo.toml"))
        .args(["--target", HOST, "--target-dir"])
        .arg(target_dir)
        .env("RUSTC_BOOTSTRAP", "1")
        .env("RUSTFLAGS", RUSTFLAGS)
        // The sanitizer runtime comes with the rustup toolchain; no incremental cache to keep.
        .env("CARGO_INCREMENTAL", "0");
    match status(c) {
        0 => Ok(target_dir.join(HOST).join("release")),
        rc => Err(rc),
    }
}

/// Copies the shipped `*.<ext>` files of weights/ (at most [`MAX_SEED`] bytes each) into `corpus`.
fn seed(corpus: &Path, ext: &str) -> std::io::Result<usize> {
    std::fs::create_dir_all(corpus)?;
    if ext.is_empty() {
        return Ok(0);
    }
    let mut n = 0;
    let mut files: Vec<PathBuf> = std::fs::read_dir(root().join("weights"))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == ext))
        .collect();
    files.sort();
    for f in files {
        if std::fs::metadata(&f)?.len() <= MAX_SEED {
            let name = f.file_name().unwrap_or_default();
            std::fs::copy(&f, corpus.join(name))?;
            n += 1;
        }
    }
    Ok(n)
}

/// libFuzzer's closing lines: `Done N runs in S second(s)` and the last status line.
fn summary(log: &str) -> String {
    let done = log
        .lines()
        .rev()
        .find(|l| l.starts_with("Done "))
        .unwrap_or("no 'Done' line");
    let cov = log
        .lines()
        .rev()
        .find(|l| l.starts_with('#') && l.contains(" cov: "))
        .and_then(|l| l.split_once(" cov: "))
        .map(|(_, rest)| format!("cov: {rest}"))
        .unwrap_or_default();
    format!("{done}; {cov}")
}

/// `cargo xtask fuzz-smoke`.
pub(crate) fn fuzz_smoke(seconds: u32, only: Option<&str>) -> i32 {
    let out = root().join("target/fuzz-smoke");
    let bins = match build(&out.join("build")) {
        Ok(b) => b,
        Err(rc) => {
            eprintln!("xtask: error: building the fuzz targets failed");
            return rc;
        }
    };
    let mut failed = 0;
    let targets: Vec<&(&str, &str)> = TARGETS
        .iter()
        .filter(|(t, _)| only.is_none_or(|o| o == *t))
        .collect();
    if targets.is_empty() {
        eprintln!(
            "xtask: error: no fuzz target {only:?}; there are {}",
            TARGETS.iter().map(|t| t.0).collect::<Vec<_>>().join(", ")
        );
        return 2;
    }
    for (target, ext) in targets {
        let corpus = out.join("corpus").join(target);
        let artifacts = out.join("artifacts").join(target);
        let seeds = match seed(&corpus, ext).and_then(|n| {
            std::fs::create_dir_all(&artifacts)?;
            Ok(n)
        }) {
            Ok(n) => n,
            Err(e) => {
                eprintln!("xtask: error: corpus {}: {e}", corpus.display());
                return 2;
            }
        };
        let mut c = Command::new(bins.join(target));
        c.arg(format!("-max_total_time={seconds}"))
            .arg(format!("-artifact_prefix={}/", artifacts.display()))
            // One status line per power of two runs, not one per new feature.
            .arg("-print_final_stats=1")
            .arg(&corpus);
        eprintln!("xtask: $ {c:?}");
        let (rc, log) = combined_output(&mut c).unwrap_or_else(|e| {
            (
                1,
                format!("cannot start {}: {e}", bins.join(target).display()),
            )
        });
        let log_file = out.join(format!("{target}.log"));
        let _ = std::fs::write(&log_file, &log);
        let ok = rc == 0;
        if !ok {
            // The crash report (panic message, stack, the input's file name).
            let tail: Vec<&str> = log.lines().rev().take(40).collect();
            for l in tail.iter().rev() {
                eprintln!("  {l}");
            }
        }
        println!(
            "fuzz-smoke {target:<16} {seconds} s, {seeds} seeds: exit {rc} {}: {} (log: {})",
            if ok { "ok" } else { "FAILED" },
            summary(&log),
            log_file.display()
        );
        failed += i32::from(!ok);
    }
    i32::from(failed != 0)
}
