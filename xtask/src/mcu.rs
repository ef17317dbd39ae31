//! The MCU classes the firmware runs on in QEMU: one [`Mcu`] per class, and
//! how a firmware build, a QEMU run and the host's matching golden run are
//! set up for it. Keep in step with `CHIPS` in firmware/build.rs.

use std::path::{Path, PathBuf};
use std::process::Command;

/// One MCU class: a chip feature of the firmware, its target and QEMU machine.
pub struct Mcu {
    /// Short name for `--mcu` (`m0`, `m4f`, `m7`).
    pub name: &'static str,
    /// Core and chip, for reports.
    pub describe: &'static str,
    /// The firmware's chip feature.
    pub feature: &'static str,
    /// Rust target.
    pub target: &'static str,
    /// `qemu-system-arm -machine`.
    pub machine: &'static str,
    /// Flash left for blobs and golden files in one golden-verification image
    /// (the chip's flash minus room for the code and the vector table).
    pub image_data_budget: u64,
    /// The firmware's `golden::SCRATCH` on this chip: wider models are not embedded.
    pub max_width: usize,
    /// Whether the golden image compiles in the micromath sine (xcheck lines;
    /// the host run enables it to match).
    pub micromath: bool,
    /// Whether `qemu` also runs the tracker demo binary (RAM permitting).
    pub demo: bool,
    /// Extra rustc flags (the core's own tuning, e.g. `-C target-cpu=cortex-m7`).
    pub rustflags: Option<&'static str>,
    /// Whether the golden image plays the online loop's streamed scene
    /// (`gpecnet_replay::online_scene`; `ONLINE_SCENE` in firmware/src/lib.rs);
    /// `false`: the scene runs in an image of its own (firmware/src/bin/online.rs).
    pub online: bool,
    /// The golden image's opt-level when not the release profile's 3 (the
    /// profile images keep 3: their instruction counts are the table's).
    pub golden_opt_level: Option<&'static str>,
}

/// The Cortex-M4F of today's CI: STM32F405 on `netduinoplus2`; builds into
/// firmware/target/ (the default of `cargo build` in firmware/).
pub const M4F: Mcu = Mcu {
    name: "m4f",
    describe: "Cortex-M4F (STM32F405, QEMU netduinoplus2)",
    feature: "chip-stm32f405",
    target: "thumbv7em-none-eabihf",
    machine: "netduinoplus2",
    // 192 KiB kept for the golden image's code and constants (about 154 KiB: both
    // engines, the planner, the online loop's scene, defmt).
    image_data_budget: (1024 - 192) * 1024,
    max_width: 128,
    micromath: true,
    demo: true,
    rustflags: None,
    online: true,
    golden_opt_level: None,
};

/// Cortex-M0 without FPU or MPU: nRF51822 (BBC micro:bit v1) on `microbit`,
/// 256 KiB flash, 16 KiB RAM. f32 runs in software floating point.
pub const M0: Mcu = Mcu {
    name: "m0",
    describe: "Cortex-M0 (nRF51822, QEMU microbit)",
    feature: "chip-nrf51",
    target: "thumbv6m-none-eabi",
    machine: "microbit",
    // The M0's golden image holds both engines in soft float, the planner and defmt, and
    // a model-pack area of this size: 95 KiB (97,280 B) are kept for the code and
    // constants. At opt-level 3 the code had grown to 98,976 B, so the golden image is
    // built at opt-level 2 (about 95 KiB; the same bits; its profile images stay at 3).
    // Opt-level `s` is smaller still but overflows the 16 KiB stack in the f32 cases.
    image_data_budget: (256 - 95) * 1024,
    max_width: 64,
    micromath: false,
    demo: false,
    rustflags: None,
    online: false,
    golden_opt_level: Some("2"),
};

/// Cortex-M7 with FPU and MPU: ARM MPS2 AN500 on `mps2-an500`.
pub const M7: Mcu = Mcu {
    name: "m7",
    describe: "Cortex-M7 (MPS2 AN500, QEMU mps2-an500)",
    feature: "chip-mps2-an500",
    target: "thumbv7em-none-eabihf",
    machine: "mps2-an500",
    // As the M4F: 192 KiB for the golden image's code and constants.
    image_data_budget: (4096 - 192) * 1024,
    max_width: 128,
    micromath: true,
    demo: true,
    rustflags: Some("-C target-cpu=cortex-m7"),
    online: true,
    golden_opt_level: None,
};

/// Every class, in the order `--all-targets` runs them.
pub const ALL: [&Mcu; 3] = [&M0, &M4F, &M7];

/// The class named `name` (`m0`, `m4f`, `m7`).
pub fn by_name(name: &str) -> Option<&'static Mcu> {
    ALL.into_iter().find(|m| m.name == name)
}

impl Mcu {
    /// The firmware's cargo target directory for this class: firmware/target
    /// for the M4F (the firmware's default), `firmware/target/mcu-<name>` for
    /// the others, so one class's build never replaces another's ELF. The
    /// intermediate artefacts of all of them live in one build directory
    /// ([`crate::firmware::fw_build_dir`]).
    pub fn target_dir(&self, root: &Path) -> PathBuf {
        if self.name == M4F.name {
            root.join("firmware/target")
        } else {
            root.join("firmware/target")
                .join(format!("mcu-{}", self.name))
        }
    }

    /// The ELF a release build of the firmware binary `bin` leaves.
    pub fn elf(&self, root: &Path, bin: &str) -> PathBuf {
        self.target_dir(root)
            .join(self.target)
            .join("release")
            .join(bin)
    }

    /// Features of this class's golden image: its chip, and micromath where compiled in.
    pub fn golden_features(&self) -> Vec<&'static str> {
        if self.micromath {
            vec!["micromath"]
        } else {
            vec![]
        }
    }

    /// Adds to a firmware cargo command (`build`/`run`, after the verb): release,
    /// the binary `bin` (`golden`, `demo`, `profile`), this chip's feature plus
    /// `features`, target and target dir; and the runner's QEMU machine and the
    /// rustc flags in the environment.
    pub fn firmware_args(&self, c: &mut Command, root: &Path, bin: &str, features: &[&str]) {
        let mut all = vec![self.feature];
        all.extend_from_slice(features);
        c.args([
            "--release",
            "--bin",
            bin,
            "--no-default-features",
            "--features",
        ])
        .arg(all.join(","))
        .args(["--target", self.target, "--target-dir"])
        .arg(self.target_dir(root))
        .env("QEMU_MACHINE", self.machine);
        if let Some(f) = self.rustflags {
            c.env("RUSTFLAGS", f);
        }
    }

    /// Whether a blob of `width` ([`gpecnet_core::Model::scratch_width`]) and
    /// `bytes` (blob + golden file) can be embedded on this class.
    pub fn fits(&self, width: usize, bytes: u64) -> bool {
        width <= self.max_width && bytes <= self.image_data_budget
    }
}
