//! `cargo xtask <command>`: drives the parts of the build the stable
//! workspace cannot do itself: the Debian cross toolchain, the firmware in
//! QEMU on three MCU classes, the golden replay, profiling, the C ABI on the
//! MCU. One module per concern:
//!
//! | module | what it holds |
//! |---|---|
//! | [`toolchain`] | Debian vs. stable cargo, prerequisites (`setup`), running commands |
//! | [`thumb`] | `build-core-thumb`: the core alone for the MCU, every feature combination |
//! | [`firmware`] | the firmware's cargo, weights selection, `fw-build`/`fw-run`/`fw-faults`/`fw-test` |
//! | [`mcu`] | the MCU classes (M0, M4F, M7): chip feature, target, QEMU machine |
//! | [`replay`] | `qemu`: golden replay firmware vs. host, the MCU × model table |
//! | [`profile`] | `profile`: instruction counts, per-function split, flash/RAM/stack |
//! | [`elf`] | sections, symbols and functions of an ELF (`object`) |
//! | [`defmt`] | the defmt stream decoded in-process (`defmt-decoder`) |
//! | [`ffi`] | `ffi-arm`: the C golden replay on the Cortex-M4F |
//! | [`fuzz`] | `fuzz-smoke`: every fuzz target of core/fuzz for a minute, without cargo-fuzz |
//! | [`modules`] | `check-modules`: no import cycle between a crate's folders and modules, every test file compiled |
use std::path::PathBuf;
use std::process::exit;

use clap::{Args, Parser, Subcommand};

mod defmt;
mod demo;
mod elf;
mod faults;
mod ffi;
mod firmware;
mod fuzz;
mod mcu;
mod modules;
mod profile;
mod replay;
mod snapshot;
mod thumb;
mod toolchain;

use firmware::Opts;

/// cargo xtask: cross builds, the firmware in QEMU, golden replay, profiling.
#[derive(Parser)]
#[command(name = "cargo xtask", bin_name = "cargo xtask", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    cmd: Cmd,
}

#[derive(Subcommand)]
enum Cmd {
    /// The main job from scratch: setup, then the shipped embedded model (weights/sdd-m-lp-qe,
    /// metres) on the SDD test set through gpecnet-core (ADE/FDE in metres and pixels +
    /// out/predictions.svg), then the two MCU models (metric and pixel) on the STM32F405 in
    /// QEMU, bit-exact with the host.
    Demo(FwArgs),
    /// Install missing prerequisites (apt: Debian rust toolchain, lld-22, qemu-system-arm).
    Setup,
    /// Check gpecnet-core alone for thumbv7em-none-eabihf (-Zbuild-std=core) in all feature
    /// combinations, and build and link its embassy example.
    BuildCoreThumb,
    /// Build the firmware (release; trailing ARGS go to cargo, e.g. --features micromath).
    FwBuild(FwArgs),
    /// Build and run the firmware in QEMU (decoded defmt on stdout).
    FwRun(FwArgs),
    /// Golden verification: the firmware in QEMU and the same cases on the host, compared
    /// line by line (--mcu one class, --all-targets all three plus the MCU x model table).
    Qemu(FwArgs),
    /// Prove the failure paths: an injected panic, HardFault, stack overflow, hung task and
    /// corrupted embedded blob must each log their cause and end the run with exit 1.
    FwFaults(FwArgs),
    /// Host side of the firmware: the golden replay's and the model selection's tests (gpecnet-replay, gpecnet-mcu-models) and the host tools built.
    FwTest {
        /// Only build the host tools: the tests are the workspace's too, and CI has just run
        /// `cargo test --workspace` (this command's own run would build them a second time,
        /// with the two crates' features instead of the workspace's).
        #[arg(long)]
        no_tests: bool,
    },
    /// Flash/RAM/stack/instruction count per model and numeric path on the STM32F405 (TCG plugin),
    /// and where the instructions go per function (the dense layers' share, instructions per MAC).
    Profile(ProfileArgs),
    /// gpecnet-ffi on a Cortex-M4F: the C golden replay (arm-none-eabi-gcc, newlib) in QEMU.
    FfiArm,
    /// Build every fuzz target of core/fuzz (cargo-fuzz's flags, no cargo-fuzz install) and run
    /// each for N seconds; fails on a crash (its input in target/fuzz-smoke/artifacts/).
    FuzzSmoke {
        /// Seconds per target.
        #[arg(long, default_value_t = 60)]
        seconds: u32,
        /// Only this target (blob, blob_resealed, blob_structured, golden).
        #[arg(long)]
        target: Option<String>,
    },
    /// No chain of imports in a crate's src/ leads back to where it started: a folder or
    /// top-level module is one node, and so is each child of a folder among its siblings
    /// (strongly connected components; known cycles: xtask/known-module-cycles.txt, empty),
    /// and every file of a tests/ folder with a tests/it.rs is compiled into that binary.
    CheckModules,
    /// Decode a raw defmt stream (stdin) with ELF's table; used by firmware/qemu-run.sh.
    DefmtDecode {
        /// The firmware ELF that produced the stream.
        elf: PathBuf,
    },
}

/// Options of the firmware commands.
#[derive(Args)]
struct FwArgs {
    /// Use DIR instead of weights/ (needs `<name>.gpec` + `<name>.golden` pairs).
    #[arg(long, value_name = "DIR")]
    weights: Option<PathBuf>,
    /// Generate a synthetic blob + golden file (firmware/host make-test-blob) and use it.
    #[arg(long, conflicts_with = "weights")]
    test_blob: bool,
    /// MCU class: m0 (Cortex-M0, nRF51), m4f (Cortex-M4F, STM32F405; the default), m7 (Cortex-M7, MPS2 AN500).
    #[arg(long, value_parser = ["m0", "m4f", "m7"])]
    mcu: Option<String>,
    /// `qemu`: every MCU class, then the MCU x model table (target/fw-qemu/matrix.md).
    #[arg(long, conflicts_with = "mcu")]
    all_targets: bool,
    /// Passed on to the firmware's cargo.
    #[arg(
        trailing_var_arg = true,
        allow_hyphen_values = true,
        value_name = "CARGO ARGS"
    )]
    rest: Vec<String>,
}

/// Options of `profile`.
#[derive(Args)]
struct ProfileArgs {
    /// Only one numeric path: `q15` (fixed-point blobs, q15-table) or `f32` (f32 blobs: libm,
    /// fast-f32, micromath); both by default.
    #[arg(long, value_parser = ["q15", "f32"])]
    path: Option<String>,
    /// Write the images, logs and profile.md to DIR instead of target/fw-profile/.
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
    #[command(flatten)]
    fw: FwArgs,
}

impl FwArgs {
    fn opts(self) -> Opts {
        let weights = if self.test_blob {
            Some(firmware::make_test_blob())
        } else {
            self.weights.map(|d| {
                std::fs::canonicalize(&d)
                    .unwrap_or_else(|e| die(&format!("--weights {}: {e}", d.display())))
            })
        };
        Opts {
            weights,
            mcu: self.mcu.as_deref().and_then(mcu::by_name),
            all_targets: self.all_targets,
            rest: self.rest,
        }
    }
}

/// The repository root.
pub(crate) fn root() -> PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("xtask lives one level below the repository root")
        .to_path_buf()
}

/// Ends xtask with a message (exit status 2).
fn die(msg: &str) -> ! {
    eprintln!("xtask: error: {msg}");
    exit(2)
}

fn main() {
    let code = match Cli::parse().cmd {
        Cmd::Setup => toolchain::setup(),
        Cmd::Demo(a) => demo::demo(&a.opts()),
        Cmd::BuildCoreThumb => thumb::build_core_thumb(),
        Cmd::FwBuild(a) => firmware::fw_build(&a.opts(), &[]),
        Cmd::FwRun(a) => firmware::fw_run(&a.opts()),
        Cmd::Qemu(a) => replay::qemu(&a.opts()),
        Cmd::FwFaults(a) => faults::fw_faults(&a.opts()),
        Cmd::FwTest { no_tests } => firmware::fw_test(!no_tests),
        Cmd::Profile(a) => {
            let only_fixed = a.path.as_deref().map(|p| p == "q15");
            profile::profile(&a.fw.opts(), only_fixed, a.out.as_deref())
        }
        Cmd::FfiArm => ffi::arm_example(),
        Cmd::FuzzSmoke { seconds, target } => fuzz::fuzz_smoke(seconds, target.as_deref()),
        Cmd::CheckModules => modules::check_modules(),
        Cmd::DefmtDecode { elf } => defmt::decode_stdin(&elf),
    };
    exit(code)
}
