//! `cargo xtask build-core-thumb`: gpecnet-core alone for the Cortex-M4F
//! (no std, no alloc) in every feature combination, and the embassy example
//! built and linked for the MCU.
//!
//! The combinations are type-checked (`cargo check`: any use of std or alloc
//! fails there, as only `core` exists for the target); the machine code of
//! the library, inline assembly included, is generated and linked by the
//! example's build below, the C ABI's (`cargo xtask ffi-arm`) and every
//! firmware image: building each combination in full as well made six more
//! release builds of the library for no check the others do not make.

use crate::root;
use crate::toolchain::{require, status, thumb_cargo};

pub(crate) fn build_core_thumb() -> i32 {
    require(false);
    let combos: &[&[&str]] = &[
        &["--no-default-features"],
        &["--no-default-features", "--features", "defmt"],
        &["--no-default-features", "--features", "micromath"],
        &["--no-default-features", "--features", "defmt,micromath"],
        &["--no-default-features", "--features", "signed"],
        &["--no-default-features", "--features", "defmt,signed"],
    ];
    let target_dir = root().join("target/thumb-core");
    let mut failed = 0;
    for combo in combos {
        let mut c = thumb_cargo("check", "gpecnet-core", &["--lib"], &target_dir);
        c.args(*combo);
        let rc = status(c);
        println!(
            "build-core-thumb {:<40} {}",
            combo.join(" "),
            if rc == 0 { "ok" } else { "FAILED" }
        );
        failed += (rc != 0) as i32;
    }
    // The embassy task skeleton (core/examples/embassy_task.rs), linked with the
    // repository's memory.x through cortex-m-rt's link.x: the example an
    // integrator starts from must build for the MCU, not only on the host. The
    // link flags go to the example alone (`cargo rustc`), so the target's `core`
    // and the library above come from the same target directory.
    let mut c = thumb_cargo(
        "rustc",
        "gpecnet-core",
        &["--example", "embassy_task"],
        &target_dir,
    );
    c.arg("--")
        .args(["-C", "link-arg=-Tlink.x", "-L"])
        .arg(root());
    let rc = status(c);
    println!(
        "build-core-thumb {:<40} {}",
        "--example embassy_task",
        if rc == 0 { "ok" } else { "FAILED" }
    );
    failed += (rc != 0) as i32;
    (failed != 0) as i32
}
