//! The toolchains xtask drives: Debian's cargo/rustc for the MCU targets
//! (`-Zbuild-std=core`, `RUSTC_BOOTSTRAP=1`), the stable cargo that runs
//! xtask for host crates, the apt/cargo prerequisites (`cargo xtask setup`),
//! and running commands with their command line echoed.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

use crate::{die, root};

pub(crate) const DEB_CARGO: &str = "/usr/bin/cargo";
pub(crate) const DEB_RUSTC: &str = "/usr/bin/rustc";
pub(crate) const TARGET: &str = "thumbv7em-none-eabihf";
pub(crate) const APT_PKGS: &[&str] = &[
    "rustc-web",
    "cargo-web",
    "rust-web-src",
    "rust-web-llvm",
    "lld-22",
    "qemu-system-arm",
];
/// Variables the outer (rustup/stable) cargo puts in our environment that
/// must not reach another toolchain's cargo.
pub(crate) const LEAKY: &[&str] = &[
    "RUSTUP_TOOLCHAIN",
    "RUSTC",
    "RUSTC_WRAPPER",
    "RUSTC_WORKSPACE_WRAPPER",
    "RUSTDOC",
    "RUSTFLAGS",
    "CARGO_ENCODED_RUSTFLAGS",
    "CARGO_BUILD_TARGET",
    "CARGO_BUILD_RUSTFLAGS",
    "CARGO_TARGET_DIR",
    "CARGO_BUILD_TARGET_DIR",
    "CARGO",
    "CARGO_MANIFEST_DIR",
    "CARGO_MANIFEST_PATH",
    "CARGO_PKG_NAME",
    "CARGO_PRIMARY_PACKAGE",
    "RUSTC_BOOTSTRAP",
];

/// Debian cargo in `dir` (so dir/.cargo/config.toml applies), env cleaned.
pub(crate) fn deb_cargo(dir: &Path) -> Command {
    let mut c = Command::new(DEB_CARGO);
    c.current_dir(dir);
    // The QEMU runner (firmware/qemu-run.sh) decodes defmt with this binary.
    if let Ok(me) = std::env::current_exe() {
        c.env("GPECNET_XTASK", me);
    }
    for v in LEAKY {
        c.env_remove(v);
    }
    c.env("RUSTC_BOOTSTRAP", "1").env("RUSTC", DEB_RUSTC);
    c
}

/// `cargo build --locked --release -p <package> <what> --target thumbv7em-none-eabihf
/// -Zbuild-std=core --target-dir <target_dir>` with Debian's cargo, from the repository root:
/// only the root workspace's config applies there (no `[unstable]`), so build-std is passed
/// explicitly, and `--locked` never lets Debian's cargo rewrite the shared root `Cargo.lock`.
/// Only `core` is built for the target: any use of std or alloc fails to compile. `what`
/// selects the artefact (`["--lib"]`, `["--example", NAME]`); append more arguments to the
/// returned command.
pub(crate) fn thumb_build(package: &str, what: &[&str], target_dir: &Path) -> Command {
    thumb_cargo("build", package, what, target_dir)
}

/// [`thumb_build`] with another cargo command: `rustc` takes flags for the final crate
/// alone after `--`, so every crate below it is shared with the `build`s of the same
/// target directory (flags in RUSTFLAGS would rebuild them all, `core` included).
pub(crate) fn thumb_cargo(verb: &str, package: &str, what: &[&str], target_dir: &Path) -> Command {
    let mut c = deb_cargo(&root());
    c.args([verb, "--locked", "--release", "-p", package])
        .args(what)
        .args(["--target", TARGET, "-Zbuild-std=core", "--target-dir"])
        .arg(target_dir);
    c
}

/// The stable cargo that runs us (for firmware/host), from the repo root so
/// no firmware/.cargo/config.toml applies.
pub(crate) fn host_cargo() -> Command {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let mut c = Command::new(cargo);
    c.current_dir(root());
    for v in [
        "RUSTFLAGS",
        "CARGO_ENCODED_RUSTFLAGS",
        "CARGO_BUILD_TARGET",
        "CARGO_TARGET_DIR",
    ] {
        c.env_remove(v);
    }
    c
}

pub(crate) fn show(c: &Command) -> String {
    let mut s = String::new();
    for (k, v) in c.get_envs() {
        if let Some(v) = v {
            let _ = write!(s, "{}={} ", k.to_string_lossy(), v.to_string_lossy());
        }
    }
    s += &c.get_program().to_string_lossy();
    for a in c.get_args() {
        s.push(' ');
        s += &a.to_string_lossy();
    }
    s
}

pub(crate) fn status(mut c: Command) -> i32 {
    eprintln!("xtask: $ {}", show(&c));
    match c.status() {
        Ok(s) => s.code().unwrap_or(1),
        Err(e) => die(&format!("cannot start {:?}: {e}", c.get_program())),
    }
}

/// Runs, returns (exit code, stdout, stderr).
pub(crate) fn output(mut c: Command) -> (i32, String, String) {
    eprintln!("xtask: $ {}", show(&c));
    match c.stdin(Stdio::null()).output() {
        Ok(o) => (
            o.status.code().unwrap_or(1),
            String::from_utf8_lossy(&o.stdout).into_owned(),
            String::from_utf8_lossy(&o.stderr).into_owned(),
        ),
        Err(e) => die(&format!("cannot start {:?}: {e}", c.get_program())),
    }
}

pub(crate) fn which(tool: &str) -> Option<PathBuf> {
    let path = std::env::var_os("PATH")?;
    let mut dirs: Vec<PathBuf> = std::env::split_paths(&path).collect();
    if let Some(h) = std::env::var_os("CARGO_HOME") {
        dirs.push(PathBuf::from(h).join("bin"));
    }
    if let Some(h) = std::env::var_os("HOME") {
        dirs.push(PathBuf::from(h).join(".cargo/bin"));
    }
    dirs.into_iter().map(|d| d.join(tool)).find(|p| p.is_file())
}

// ---------------------------------------------------------------- prerequisites

pub(crate) struct Missing {
    apt: Vec<&'static str>,
    gcc: bool,
}

pub(crate) fn rust_src_present() -> bool {
    let (rc, out, _) = {
        let mut c = Command::new(DEB_RUSTC);
        c.args(["--print", "sysroot"]);
        match c.output() {
            Ok(o) => (0, String::from_utf8_lossy(&o.stdout).trim().to_string(), ()),
            Err(_) => (1, String::new(), ()),
        }
    };
    rc == 0
        && Path::new(&out)
            .join("lib/rustlib/src/rust/library/core")
            .is_dir()
}

pub(crate) fn missing() -> Missing {
    let mut apt = Vec::new();
    if !Path::new(DEB_RUSTC).is_file() {
        apt.push("rustc-web");
    }
    if !Path::new(DEB_CARGO).is_file() {
        apt.push("cargo-web");
    }
    if Path::new(DEB_RUSTC).is_file() && !rust_src_present() {
        apt.push("rust-web-src");
    }
    // /usr/bin/rust-lld (rust-web-llvm) is a symlink to lld-22, which nothing depends on.
    if std::fs::symlink_metadata("/usr/bin/rust-lld").is_err() {
        apt.push("rust-web-llvm");
    }
    if !Path::new("/usr/bin/rust-lld").exists() {
        apt.push("lld-22");
    }
    if which("qemu-system-arm").is_none() {
        apt.push("qemu-system-arm");
    }
    Missing {
        apt,
        gcc: which("gcc").is_none(),
    }
}

/// Fails with the install commands if the firmware toolchain is incomplete.
pub(crate) fn require(qemu: bool) {
    let m = missing();
    let apt: Vec<&str> = m
        .apt
        .iter()
        .copied()
        .filter(|p| qemu || *p != "qemu-system-arm")
        .collect();
    let mut msgs = Vec::new();
    if !apt.is_empty() {
        msgs.push(format!(
            "missing Debian packages: {}\n  fix: apt-get update && apt-get install -y --no-install-recommends {}\n  (or: cargo xtask setup)",
            apt.join(" "),
            APT_PKGS.join(" ")
        ));
    }
    if !msgs.is_empty() {
        die(&msgs.join("\n"));
    }
}

pub(crate) fn setup() -> i32 {
    let m = missing();
    if !m.apt.is_empty() {
        eprintln!("xtask: installing {}", m.apt.join(" "));
        let sudo = std::env::var("USER").map_or(true, |u| u != "root") && which("sudo").is_some();
        let apt = |args: &[&str]| {
            let mut c = if sudo {
                Command::new("sudo")
            } else {
                Command::new("apt-get")
            };
            if sudo {
                c.arg("apt-get");
            }
            c.args(args);
            c
        };
        if status(apt(&["update"])) != 0 {
            die("apt-get update failed");
        }
        let mut args = vec!["install", "-y", "--no-install-recommends"];
        args.extend(APT_PKGS);
        if status(apt(&args)) != 0 {
            die("apt-get install failed");
        }
    } else {
        eprintln!("xtask: Debian toolchain, rust-src, rust-lld (lld-22), qemu-system-arm: present");
    }
    if m.gcc {
        eprintln!(
            "xtask: note: gcc missing (only `cargo xtask profile` needs it): apt-get install gcc"
        );
    }
    let m = missing();
    if m.apt.is_empty() {
        eprintln!("xtask: setup complete");
        0
    } else {
        1
    }
}
