//! The firmware's cargo: which weights it embeds, building and running it
//! (`fw-build`, `fw-run`) and the host side: the golden replay's tests and
//! the host tools (`fw-test`).

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::{Condvar, Mutex};
use std::thread::{Scope, ScopedJoinHandle};

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

/// The models the firmware embeds from `dir` (`<name>.gpec` + `<name>.golden`,
/// at most `MAX_MCU_BLOB` bytes), sorted: gpecnet-mcu-models, the rule of
/// firmware/build.rs and golden-host; the xtask names the set per build itself.
pub(crate) fn models_in(dir: &Path) -> Vec<String> {
    gpecnet_mcu_models::select(dir, None).names
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

/// The one build directory (cargo's `build.build-dir`: intermediate artefacts) of every
/// firmware build: all MCU classes, images and features. Each class keeps its own target
/// directory for its ELFs ([`mcu::Mcu::target_dir`]), so one class's build never replaces
/// another's; what their builds have in common is compiled once, not once per target
/// directory: the proc macros and build scripts (about 75 s of the ~170 s of CPU a firmware
/// build from empty takes) and, per target and flags, `core` and the crates below the
/// firmware.
/// Units differ by their hash (target, features, profile, RUSTFLAGS), so the M7's
/// `-C target-cpu=cortex-m7` units never replace the M4F's. Cargo locks the directory:
/// builds started side by side take turns. (The library's own thumb builds,
/// `target/thumb-core`, resolve their proc macros' features in the root workspace, so they
/// would share nothing here and keep their own directory.)
pub(crate) fn fw_build_dir() -> PathBuf {
    root().join("firmware/target/build")
}

pub(crate) fn fw_cargo(o: &Opts) -> Command {
    let mut c = deb_cargo(&root().join("firmware"));
    c.env("CARGO_BUILD_BUILD_DIR", fw_build_dir());
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

/// Builds the firmware binary `bin` for `mcu` with `features` (the command `c` from
/// [`fw_cargo`], its environment set) and copies the ELF to `copy`, out of the target
/// directory, so the next build may replace it while QEMU still runs this one.
/// `Err((exit, stderr))` when the build fails.
pub(crate) fn build_image(
    mut c: Command,
    mcu: &mcu::Mcu,
    bin: &str,
    features: &[&str],
    rest: &[String],
    copy: &Path,
) -> Result<(), (i32, String)> {
    c.arg("build");
    mcu.firmware_args(&mut c, &root(), bin, features);
    c.args(rest);
    let (rc, _, err) = output(c);
    if rc != 0 {
        return Err((rc, err));
    }
    if let Some(d) = copy.parent() {
        std::fs::create_dir_all(d).unwrap_or_else(|e| die(&format!("{}: {e}", d.display())));
    }
    std::fs::copy(mcu.elf(&root(), bin), copy)
        .map(|_| ())
        .map_err(|e| (1, format!("{}: {e}", copy.display())))
}

/// Runs the image `elf` on `mcu`'s QEMU machine through firmware/qemu-run.sh, the cargo
/// runner `cargo run` would start: (exit status, decoded defmt on stdout, stderr).
pub(crate) fn run_image(mcu: &mcu::Mcu, elf: &Path) -> (i32, String, String) {
    let _slot = QemuSlot::take();
    let fw = root().join("firmware");
    let mut c = Command::new(fw.join("qemu-run.sh"));
    c.arg(elf).current_dir(&fw).env("QEMU_MACHINE", mcu.machine);
    if let Ok(me) = std::env::current_exe() {
        c.env("GPECNET_XTASK", me);
    }
    output(c)
}

/// One of the QEMU runs that may go on at once: one per CPU. More would only share the
/// CPUs, and a run starved of CPU time could miss its watchdog (the supervisor counts
/// host time: QEMU runs without `-icount`).
struct QemuSlot;

static QEMU_RUNNING: (Mutex<usize>, Condvar) = (Mutex::new(0), Condvar::new());

impl QemuSlot {
    /// Waits until fewer runs than CPUs go on, then counts this one in.
    fn take() -> QemuSlot {
        let cpus = std::thread::available_parallelism().map_or(1, |n| n.get());
        let (count, freed) = &QEMU_RUNNING;
        let mut n = count.lock().unwrap_or_else(|e| e.into_inner());
        while *n >= cpus {
            n = freed.wait(n).unwrap_or_else(|e| e.into_inner());
        }
        *n += 1;
        QemuSlot
    }
}

impl Drop for QemuSlot {
    fn drop(&mut self) {
        let (count, freed) = &QEMU_RUNNING;
        *count.lock().unwrap_or_else(|e| e.into_inner()) -= 1;
        freed.notify_one();
    }
}

/// A firmware image's QEMU run: started as soon as the image is built, while the next
/// image builds (the fat-LTO link and QEMU are single-threaded each).
pub(crate) type Run<'s> = ScopedJoinHandle<'s, (i32, String, String)>;

/// [`build_image`], then [`run_image`] on a thread of `scope`; a failed build yields its
/// exit status and stderr without a run.
pub(crate) fn build_and_start<'s>(
    scope: &'s Scope<'s, '_>,
    c: Command,
    mcu: &'static mcu::Mcu,
    bin: &str,
    features: &[&str],
    rest: &[String],
    copy: PathBuf,
) -> Run<'s> {
    let built = build_image(c, mcu, bin, features, rest, &copy);
    scope.spawn(move || match built {
        Ok(()) => run_image(mcu, &copy),
        Err((rc, err)) => (rc, String::new(), err),
    })
}

/// The result of a run started by [`build_and_start`].
pub(crate) fn finish(run: Run<'_>) -> (i32, String, String) {
    run.join()
        .unwrap_or_else(|_| die("a QEMU run's thread panicked"))
}

/// The model the firmware demo runs (signed, metric).
pub(crate) const DEMO_MODEL: &str = "sdd-m-lp-qe";

pub(crate) fn fw_run(o: &Opts) -> i32 {
    require(true);
    let mut c = fw_cargo(o);
    // The demo embeds its signed model only, unless told otherwise (all the
    // models and the signature verifier do not fit one flash).
    let demo = o.rest.windows(2).any(|w| w[0] == "--bin" && w[1] == "demo");
    if demo && std::env::var_os(gpecnet_mcu_models::ONLY_VAR).is_none() {
        c.env(gpecnet_mcu_models::ONLY_VAR, DEMO_MODEL);
    }
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

pub(crate) fn fw_test(tests: bool) -> i32 {
    // The golden replay the firmware runs (crate gpecnet-replay) and the model
    // selection of its build script (gpecnet-mcu-models), tested on the host,
    // and the firmware's host tools (golden-host, make-test-blob) built.
    if tests {
        let mut c = host_cargo();
        c.args(["test", "-p", "gpecnet-replay", "-p", "gpecnet-mcu-models"]);
        let rc = status(c);
        if rc != 0 {
            return rc;
        }
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
