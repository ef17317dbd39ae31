//! `cargo xtask ffi-arm`: the C example of gpecnet-ffi on a Cortex-M4F.
//!
//! Builds the `thumbv7em-none-eabihf` staticlib of `ffi/` (Debian's
//! toolchain, `-Zbuild-std=core`, `--no-default-features`: no std, no
//! allocator), links `ffi/examples/arm/replay_arm.c` against it with Debian's
//! `arm-none-eabi-gcc` + newlib-nano (blob and golden file in flash via
//! `objcopy -I binary`), and runs it in QEMU `netduinoplus2` (STM32F405) with
//! semihosting: every golden case of each model must match bit for bit.
//! Installs `gcc-arm-none-eabi`, `libnewlib-arm-none-eabi` and
//! `qemu-system-arm` with apt when they are missing.
use std::path::{Path, PathBuf};
use std::process::Command;

use crate::root;
use crate::toolchain::{require, status, thumb_build, TARGET};

/// Fixed-point models (an f32 model through `libm::sinf` in f64 emulation takes minutes in QEMU).
const MODELS: &[&str] = &[
    "sdd-tiny-v2-qe",
    "sdd-m-tiny-qe",
    "sdd-m-lp-qe",
    "sdd-tiny-qe",
];
const APT: &[&str] = &[
    "gcc-arm-none-eabi",
    "libnewlib-arm-none-eabi",
    "qemu-system-arm",
];
const CFLAGS: &[&str] = &[
    "-mcpu=cortex-m4",
    "-mthumb",
    "-mfloat-abi=hard",
    "-mfpu=fpv4-sp-d16",
    "-std=c11",
    "-O2",
    "-Wall",
    "-Wextra",
    "-Werror",
    "-ffunction-sections",
    "-fdata-sections",
    "-nostartfiles",
    "-Wl,--gc-sections",
    "-Wl,--no-warn-execstack",
];

fn have_tools() -> bool {
    let newlib = Path::new("/usr/lib/arm-none-eabi/newlib/thumb/v7e-m+fp/hard/libc_nano.a");
    [
        "arm-none-eabi-gcc",
        "arm-none-eabi-objcopy",
        "qemu-system-arm",
    ]
    .iter()
    .all(|t| {
        Command::new(t)
            .arg("--version")
            .output()
            .is_ok_and(|o| o.status.success())
    }) && newlib.exists()
}

fn install_tools() -> i32 {
    if have_tools() {
        return 0;
    }
    let mut update = Command::new("apt-get");
    update.arg("update");
    let mut install = Command::new("apt-get");
    install
        .env("DEBIAN_FRONTEND", "noninteractive")
        .args(["install", "-y", "--no-install-recommends"])
        .args(APT);
    match status(update) {
        0 => status(install),
        rc => rc,
    }
}

/// Links the example for one model into `dir`; returns the ELF.
fn link(lib: &Path, model: &str, golden: &str, dir: &Path) -> Result<PathBuf, String> {
    std::fs::create_dir_all(dir).map_err(|e| e.to_string())?;
    let w = root().join("weights");
    for (src, name) in [(model, "blob"), (golden, "golden")] {
        std::fs::copy(w.join(src), dir.join(format!("{name}.bin")))
            .map_err(|e| format!("{src}: {e}"))?;
        let mut c = Command::new("arm-none-eabi-objcopy");
        c.current_dir(dir)
            .args(["-I", "binary", "-O", "elf32-littlearm", "-B", "arm"])
            .args([
                "--rename-section",
                ".data=.rodata,alloc,load,readonly,data,contents",
            ])
            .arg(format!("{name}.bin"))
            .arg(format!("{name}.o"));
        if status(c) != 0 {
            return Err(format!("objcopy {src} failed"));
        }
    }
    let ex = root().join("ffi/examples/arm");
    let elf = dir.join("replay_arm.elf");
    let mut c = Command::new("arm-none-eabi-gcc");
    c.args(CFLAGS)
        .arg("-I")
        .arg(root().join("ffi/include"))
        .arg("-T")
        .arg(ex.join("link.ld"))
        .arg("-o")
        .arg(&elf)
        .arg(ex.join("replay_arm.c"))
        .arg(dir.join("blob.o"))
        .arg(dir.join("golden.o"))
        .arg(lib)
        .args(["--specs=nano.specs", "--specs=nosys.specs"]);
    if status(c) != 0 {
        return Err("arm-none-eabi-gcc failed".into());
    }
    Ok(elf)
}

/// Runs `c` to its end: its exit code (1 when a signal ended it) and its
/// stdout followed by its stderr; `Err` when it could not start.
/// `toolchain::output` keeps the two streams apart and stops xtask when a
/// program cannot start; here the caller reports that as a failed check.
pub(crate) fn combined_output(c: &mut Command) -> std::io::Result<(i32, String)> {
    let o = c.output()?;
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    Ok((o.status.code().unwrap_or(1), text))
}

/// Runs `elf` in QEMU; returns (exit code, output).
fn run(elf: &Path) -> (i32, String) {
    let mut c = Command::new("timeout");
    c.arg("600")
        .arg("qemu-system-arm")
        .args([
            "-machine",
            "netduinoplus2",
            "-nographic",
            "-monitor",
            "none",
        ])
        .args([
            "-serial",
            "none",
            "-semihosting-config",
            "enable=on,target=native",
        ])
        .arg("-kernel")
        .arg(elf);
    eprintln!("xtask: $ {c:?}");
    combined_output(&mut c).unwrap_or_else(|e| (1, e.to_string()))
}

/// `cargo xtask ffi-arm`.
pub fn arm_example() -> i32 {
    require(false);
    if install_tools() != 0 || !have_tools() {
        eprintln!("xtask: error: cannot install {}", APT.join(" "));
        return 2;
    }
    // The target directory of `build-core-thumb`: the target's `core` and
    // gpecnet-core (no features, as here) are built once for both.
    let target_dir = root().join("target/thumb-core");
    let mut c = thumb_build("gpecnet-ffi", &["--lib"], &target_dir);
    c.arg("--no-default-features");
    if status(c) != 0 {
        return 1;
    }
    let lib = target_dir.join(TARGET).join("release/libgpecnet_ffi.a");
    let out = root().join("target/ffi-arm");
    let mut failed = 0;
    for m in MODELS {
        let result = link(
            &lib,
            &format!("{m}.gpec"),
            &format!("{m}.golden"),
            &out.join(m),
        )
        .map(|elf| run(&elf));
        let ok = match &result {
            Ok((0, text)) => text.contains(" 0 differ, 0 calls failed"),
            _ => false,
        };
        match &result {
            Ok((rc, text)) => println!("ffi-arm {m:<16} exit {rc}: {}", text.trim()),
            Err(e) => println!("ffi-arm {m:<16} {e}"),
        }
        failed += i32::from(!ok);
    }
    // The failure path: a golden file of other weights must make the firmware exit non-zero.
    let neg = link(
        &lib,
        "sdd-tiny-qe.gpec",
        "sdd-tiny-v2-qe.golden",
        &out.join("mismatch"),
    )
    .map(|elf| run(&elf));
    let neg_ok = matches!(neg, Ok((rc, _)) if rc != 0);
    println!(
        "ffi-arm mismatched golden file: {}",
        if neg_ok {
            "refused (exit 1), ok"
        } else {
            "NOT refused"
        }
    );
    failed += i32::from(!neg_ok);
    println!(
        "ffi-arm: {} of {} checks passed",
        MODELS.len() + 1 - failed as usize,
        MODELS.len() + 1
    );
    i32::from(failed != 0)
}
