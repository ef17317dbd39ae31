//! The MCU × model table's snapshot: `xtask/snapshots/mcu-matrix.md` holds the
//! columns of `cargo xtask qemu --all-targets` that are exact on any run,
//! machine and checkout (instructions per call, the profiled call's stack,
//! static RAM, the verdicts; not the flash column, which holds the checkout's
//! path in panic locations, nor the golden run's stack peak, which moves with
//! where QEMU's host-timed SysTick lands), measured on purpose and committed. A run of every shipped model compares its table
//! with it and fails on any difference, naming each changed row; a change that
//! is meant is recorded with `UPDATE_SNAPSHOTS=1 cargo xtask qemu
//! --all-targets`.
//!
//! Instruction counts are a property of the code the compiler emitted: the
//! snapshot's first line names the firmware compiler (`/usr/bin/rustc -V`).
//! Under another compiler (a Debian update of `rustc-web`) the differences are
//! printed and the run does not fail on them: the snapshot is then re-recorded
//! on purpose, with the new compiler named.

use std::path::PathBuf;
use std::process::Command;

use crate::root;
use crate::toolchain::{output, DEB_RUSTC};

/// The snapshot file.
fn path() -> PathBuf {
    root().join("xtask/snapshots/mcu-matrix.md")
}

/// The firmware compiler's version line.
fn compiler() -> String {
    let (rc, out, err) = output({
        let mut c = Command::new(DEB_RUSTC);
        c.arg("-V");
        c
    });
    if rc == 0 {
        out.trim().to_string()
    } else {
        format!("{DEB_RUSTC} -V failed: {}", err.trim())
    }
}

/// Compares `table` (the exact columns, one markdown row per line) with the
/// snapshot, or records it with `UPDATE_SNAPSHOTS=1`; prints what differs.
/// `false` when CI must fail: a row differs under the snapshot's compiler, or
/// there is no snapshot.
pub(crate) fn check_mcu_table(table: &str) -> bool {
    let file = path();
    let now = format!("compiler: {}\n{table}", compiler());
    if std::env::var_os("UPDATE_SNAPSHOTS").is_some() {
        return match std::fs::write(&file, &now) {
            Ok(()) => {
                println!("snapshot: recorded {}", file.display());
                true
            }
            Err(e) => {
                println!("snapshot: {}: {e}", file.display());
                false
            }
        };
    }
    let Ok(was) = std::fs::read_to_string(&file) else {
        println!(
            "snapshot: {} missing: record it with UPDATE_SNAPSHOTS=1 cargo xtask qemu --all-targets",
            file.display()
        );
        return false;
    };
    if was == now {
        println!("snapshot: the MCU × model table equals {}", file.display());
        return true;
    }
    let first = |s: &str| s.lines().next().unwrap_or("").to_string();
    let same_compiler = first(&was) == first(&now);
    let (old, new): (Vec<&str>, Vec<&str>) = (was.lines().collect(), now.lines().collect());
    for i in 0..old.len().max(new.len()) {
        let (o, n) = (old.get(i).copied(), new.get(i).copied());
        if o != n {
            println!(
                "snapshot: line {}:\n  was: {}\n  now: {}",
                i + 1,
                o.unwrap_or("(none)"),
                n.unwrap_or("(none)")
            );
        }
    }
    if same_compiler {
        println!(
            "snapshot: the MCU × model table differs from {} (UPDATE_SNAPSHOTS=1 cargo xtask qemu --all-targets \
             records it when the change is meant)",
            file.display()
        );
        false
    } else {
        println!(
            "snapshot: recorded under another compiler ({}); the differences above are not checked: \
             record it with UPDATE_SNAPSHOTS=1 cargo xtask qemu --all-targets",
            first(&was)
        );
        true
    }
}
