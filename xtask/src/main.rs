//! `cargo xtask <command>`: drives the parts of the build the stable
//! workspace cannot do itself. std only, no dependencies.
//!
//! The firmware (firmware/, its own workspace) needs Debian's toolchain
//! (`/usr/bin/cargo` + `/usr/bin/rustc` 1.96 + rust-src) with
//! `RUSTC_BOOTSTRAP=1` and `-Zbuild-std=core`, QEMU and defmt-print; the
//! firmware's host side (firmware/host: unit tests of tracks.rs, the host
//! golden run) builds with the stable toolchain that runs this xtask.
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::{exit, Command, Stdio};

mod ffi;
mod mcu;
mod replay;

const DEB_CARGO: &str = "/usr/bin/cargo";
const DEB_RUSTC: &str = "/usr/bin/rustc";
const TARGET: &str = "thumbv7em-none-eabihf";
const APT_PKGS: &[&str] = &[
    "rustc-web",
    "cargo-web",
    "rust-web-src",
    "rust-web-llvm",
    "lld-22",
    "qemu-system-arm",
];
/// Numeric paths profiled for F32 blobs (gpecnet_core::sine::*::NAME).
const SINES: &[&str] = &["libm", "fast-f32", "micromath"];
/// The numeric path of Int16Q15 blobs (gpecnet_core::fixed::SINE_NAME).
const FIXED_PATH: &str = "q15-table";
/// Issue 6 targets for the small model in fixed point.
const TARGET_INSNS: u64 = 300_000;
/// Issue 10's budget for one call of a model with a point head: the point forecast plus the
/// model's 20 endpoints (test-time sampling included), fixed point.
const TARGET_INSNS_POINT: u64 = 1_500_000;
const TARGET_CODE_WEIGHTS: u32 = 64 * 1024;

const USAGE: &str = "usage: cargo xtask <command>
  demo               the main job from scratch: setup, then the shipped embedded model (weights/sdd-tiny-v2-qe)
                     on the SDD test set through gpecnet-core (ADE/FDE + out/predictions.svg), then the
                     same model on the STM32F405 in QEMU, bit-exact with the host
  setup              install missing prerequisites (apt: Debian rust toolchain, lld-22, qemu; cargo: defmt-print)
  build-core-thumb   build gpecnet-core alone for thumbv7em-none-eabihf (-Zbuild-std=core), all feature combos
  fw-build [ARGS]    build the firmware (release; ARGS go to cargo, e.g. --features force-panic)
  fw-run [ARGS]      build + run the firmware in QEMU netduinoplus2 (decoded defmt on stdout)
  qemu               golden verification: firmware in QEMU + the same cases on the host, hashes compared
                     (--mcu m0|m4f|m7: Cortex-M0 nRF51 / M4F STM32F405 (default) / M7 MPS2-AN500;
                     --all-targets: all three, plus the MCU x model table in target/fw-qemu/matrix.md)
  fw-faults          prove the failure paths: an injected panic, HardFault and stack overflow must each log and exit 1
  fw-test            host unit tests of the firmware's target-independent modules (golden.rs; the track table is tested in core)
  profile            flash/RAM/stack/instruction count per model and numeric path (TCG plugin)
  ffi-arm            gpecnet-ffi on a Cortex-M4F: the C golden replay (arm-none-eabi-gcc, newlib) in QEMU netduinoplus2
options for qemu/profile/fw-build/fw-run (--mcu also for fw-build/fw-run):
  --weights DIR      use DIR instead of weights/ (needs <name>.gpec + <name>.golden)
  --test-blob        generate a synthetic blob + golden (firmware/host make-test-blob) and use it";

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .unwrap()
        .to_path_buf()
}

fn die(msg: &str) -> ! {
    eprintln!("xtask: error: {msg}");
    exit(2)
}

/// Variables the outer (rustup/stable) cargo puts in our environment that
/// must not reach another toolchain's cargo.
const LEAKY: &[&str] = &[
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
fn deb_cargo(dir: &Path) -> Command {
    let mut c = Command::new(DEB_CARGO);
    c.current_dir(dir);
    for v in LEAKY {
        c.env_remove(v);
    }
    c.env("RUSTC_BOOTSTRAP", "1").env("RUSTC", DEB_RUSTC);
    c
}

/// The stable cargo that runs us (for firmware/host), from the repo root so
/// no firmware/.cargo/config.toml applies.
fn host_cargo() -> Command {
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

fn show(c: &Command) -> String {
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

fn status(mut c: Command) -> i32 {
    eprintln!("xtask: $ {}", show(&c));
    match c.status() {
        Ok(s) => s.code().unwrap_or(1),
        Err(e) => die(&format!("cannot start {:?}: {e}", c.get_program())),
    }
}

/// Runs, returns (exit code, stdout, stderr).
fn output(mut c: Command) -> (i32, String, String) {
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

fn which(tool: &str) -> Option<PathBuf> {
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

struct Missing {
    apt: Vec<&'static str>,
    defmt_print: bool,
    gcc: bool,
}

fn rust_src_present() -> bool {
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

fn missing() -> Missing {
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
        defmt_print: which("defmt-print").is_none(),
        gcc: which("gcc").is_none(),
    }
}

/// Fails with the install commands if the firmware toolchain is incomplete.
fn require(qemu: bool) {
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
    if qemu && m.defmt_print {
        msgs.push("defmt-print not found\n  fix: cargo install defmt-print --locked".into());
    }
    if !msgs.is_empty() {
        die(&msgs.join("\n"));
    }
}

fn setup() -> i32 {
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
    if m.defmt_print {
        let mut c = host_cargo();
        c.args(["install", "defmt-print", "--locked"]);
        if status(c) != 0 {
            die("cargo install defmt-print --locked failed");
        }
    } else {
        eprintln!("xtask: defmt-print: present");
    }
    if m.gcc {
        eprintln!(
            "xtask: note: gcc missing (only `cargo xtask profile` needs it): apt-get install gcc"
        );
    }
    let m = missing();
    if m.apt.is_empty() && !m.defmt_print {
        eprintln!("xtask: setup complete");
        0
    } else {
        1
    }
}

// ---------------------------------------------------------------- core for thumb

fn build_core_thumb() -> i32 {
    require(false);
    let combos: &[&[&str]] = &[
        &["--no-default-features"],
        &["--no-default-features", "--features", "defmt"],
        &["--no-default-features", "--features", "micromath"],
        &["--no-default-features", "--features", "defmt,micromath"],
    ];
    let target_dir = root().join("target/thumb-core");
    let mut failed = 0;
    for combo in combos {
        // From the repo root: only the root workspace's config applies (no
        // [unstable] there), so build-std is passed explicitly. Only `core`
        // is built for the target: any use of std or alloc fails to compile.
        let mut c = deb_cargo(&root());
        // --locked: never rewrite the shared root Cargo.lock with Debian's cargo.
        c.args([
            "build",
            "--locked",
            "--release",
            "-p",
            "gpecnet-core",
            "--lib",
            "--target",
            TARGET,
        ])
        .args(["-Zbuild-std=core", "--target-dir"])
        .arg(&target_dir)
        .args(*combo);
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
    // integrator starts from must build for the MCU, not only on the host.
    let mut c = deb_cargo(&root());
    c.env(
        "RUSTFLAGS",
        format!("-C link-arg=-Tlink.x -L {}", root().display()),
    )
    .args([
        "build",
        "--locked",
        "--release",
        "-p",
        "gpecnet-core",
        "--example",
        "embassy_task",
        "--target",
        TARGET,
        "-Zbuild-std=core",
        "--target-dir",
    ])
    .arg(root().join("target/thumb-examples"));
    let rc = status(c);
    println!(
        "build-core-thumb {:<40} {}",
        "--example embassy_task",
        if rc == 0 { "ok" } else { "FAILED" }
    );
    failed += (rc != 0) as i32;
    (failed != 0) as i32
}

// ---------------------------------------------------------------- firmware

struct Opts {
    weights: Option<PathBuf>,
    /// `--mcu NAME`: the class for `qemu` (default: the M4F).
    mcu: Option<&'static mcu::Mcu>,
    /// `--all-targets`: `qemu` on every class, plus the MCU × model table.
    all_targets: bool,
    rest: Vec<String>,
}

fn parse_opts(args: &[String]) -> Opts {
    let mut o = Opts {
        weights: None,
        mcu: None,
        all_targets: false,
        rest: Vec::new(),
    };
    let mut it = args.iter();
    while let Some(a) = it.next() {
        match a.as_str() {
            "--weights" => {
                let d = it
                    .next()
                    .unwrap_or_else(|| die("--weights needs a directory"));
                o.weights = Some(
                    std::fs::canonicalize(d)
                        .unwrap_or_else(|e| die(&format!("--weights {d}: {e}"))),
                );
            }
            "--test-blob" => o.weights = Some(make_test_blob()),
            "--mcu" => {
                let n = it
                    .next()
                    .unwrap_or_else(|| die("--mcu needs a name: m0, m4f or m7"));
                o.mcu = Some(mcu::by_name(n).unwrap_or_else(|| {
                    die(&format!("--mcu {n}: unknown MCU class (m0, m4f or m7)"))
                }));
            }
            "--all-targets" => o.all_targets = true,
            _ => o.rest.push(a.clone()),
        }
    }
    o
}

fn make_test_blob() -> PathBuf {
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

fn weights_dir(o: &Opts) -> PathBuf {
    o.weights.clone().unwrap_or_else(|| root().join("weights"))
}

/// Model names with both files, sorted (the firmware's build.rs does the same).
/// Largest blob linked into the firmware: the STM32F405 has 1 MiB of flash,
/// and code, golden files and the other models need room too. Bigger
/// (host-only, e.g. paper-size) models are skipped by firmware/build.rs too.
const MAX_MCU_BLOB: u64 = 512 * 1024;

fn models_in(dir: &Path) -> Vec<String> {
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

fn require_models(dir: &Path) -> Vec<String> {
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

fn fw_cargo(o: &Opts) -> Command {
    let mut c = deb_cargo(&root().join("firmware"));
    if let Some(w) = &o.weights {
        c.env("GPECNET_WEIGHTS_DIR", w);
    }
    c
}

fn fw_build(o: &Opts, extra: &[&str]) -> i32 {
    require(false);
    let mut c = fw_cargo(o);
    c.arg("build");
    fw_class_args(o, &mut c);
    c.args(extra).args(&o.rest);
    status(c)
}

fn fw_run(o: &Opts) -> i32 {
    require(true);
    let mut c = fw_cargo(o);
    c.arg("run");
    fw_class_args(o, &mut c);
    c.args(&o.rest);
    status(c)
}

/// `--release`, and with `--mcu`: that class's chip, target, QEMU machine and
/// its golden image's modes (without: the firmware's defaults, the M4F).
fn fw_class_args(o: &Opts, c: &mut Command) {
    match o.mcu {
        Some(m) => {
            let mut modes = vec!["golden"];
            modes.extend_from_slice(m.golden_features);
            m.firmware_args(c, &root(), &modes);
        }
        None => {
            c.arg("--release");
        }
    }
}

fn fw_faults(o: &Opts) -> i32 {
    require(true);
    let mut bad = 0;
    // Each injected failure must end the run with exit 1 and its own log line
    // (no lockup, no silent corruption, no outer timeout).
    for (f, want) in [
        ("force-panic", "panic"),
        ("force-hardfault", "HardFault"),
        ("force-stack-overflow", "stack overflow"),
    ] {
        let mut c = fw_cargo(o);
        c.arg("run");
        mcu::M4F.firmware_args(&mut c, &root(), &[f]);
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

fn fw_test() -> i32 {
    let mut c = host_cargo();
    c.args(["test", "--manifest-path", "firmware/host/Cargo.toml"]);
    status(c)
}

// ---------------------------------------------------------------- ELF

struct Section {
    name: String,
    kind: u32,
    flags: u32,
    addr: u32,
    size: u32,
}

struct Elf {
    sections: Vec<Section>,
    symbols: BTreeMap<String, u32>,
}

fn rd16(b: &[u8], o: usize) -> u16 {
    u16::from_le_bytes([b[o], b[o + 1]])
}
fn rd32(b: &[u8], o: usize) -> u32 {
    u32::from_le_bytes([b[o], b[o + 1], b[o + 2], b[o + 3]])
}
fn cstr(b: &[u8], o: usize) -> String {
    let end = b[o..]
        .iter()
        .position(|&c| c == 0)
        .map_or(b.len(), |p| o + p);
    String::from_utf8_lossy(&b[o..end]).into_owned()
}

/// Minimal ELF32 little-endian reader: section headers and the symbol table.
fn read_elf(path: &Path) -> Elf {
    let b = std::fs::read(path).unwrap_or_else(|e| die(&format!("{}: {e}", path.display())));
    if b.len() < 52 || &b[..4] != b"\x7fELF" || b[4] != 1 || b[5] != 1 {
        die(&format!("{}: not an ELF32 LE file", path.display()));
    }
    let (shoff, shentsize, shnum, shstrndx) = (
        rd32(&b, 0x20) as usize,
        rd16(&b, 0x2e) as usize,
        rd16(&b, 0x30) as usize,
        rd16(&b, 0x32) as usize,
    );
    let sh = |i: usize| shoff + i * shentsize;
    let stroff = rd32(&b, sh(shstrndx) + 16) as usize;
    let mut sections = Vec::new();
    let mut symbols = BTreeMap::new();
    for i in 0..shnum {
        let o = sh(i);
        let s = Section {
            name: cstr(&b, stroff + rd32(&b, o) as usize),
            kind: rd32(&b, o + 4),
            flags: rd32(&b, o + 8),
            addr: rd32(&b, o + 12),
            size: rd32(&b, o + 20),
        };
        if s.kind == 2 {
            // SHT_SYMTAB: entries of 16 bytes; names in the linked string table
            let (off, size, link) = (
                rd32(&b, o + 16) as usize,
                s.size as usize,
                rd32(&b, o + 24) as usize,
            );
            let names = rd32(&b, sh(link) + 16) as usize;
            for e in (off..off + size).step_by(16) {
                let name = cstr(&b, names + rd32(&b, e) as usize);
                if !name.is_empty() {
                    symbols.insert(name, rd32(&b, e + 4));
                }
            }
        }
        sections.push(s);
    }
    Elf { sections, symbols }
}

impl Elf {
    /// Flash: allocated sections with file contents (code, rodata, .data's load image).
    fn flash(&self) -> u32 {
        const SHF_ALLOC: u32 = 2;
        self.sections
            .iter()
            .filter(|s| s.flags & SHF_ALLOC != 0 && s.kind != 8 && s.size > 0)
            .map(|s| s.size)
            .sum()
    }
    /// Static RAM: allocated sections placed in SRAM or CCM (.data, .bss, .uninit).
    fn ram(&self) -> u32 {
        const SHF_ALLOC: u32 = 2;
        self.sections
            .iter()
            .filter(|s| s.flags & SHF_ALLOC != 0 && (s.addr >> 28 == 2 || s.addr >> 28 == 1))
            .map(|s| s.size)
            .sum()
    }
    fn section(&self, name: &str) -> u32 {
        self.sections
            .iter()
            .filter(|s| s.name == name)
            .map(|s| s.size)
            .sum()
    }
}

// ---------------------------------------------------------------- profile

fn plugin() -> PathBuf {
    let src = root().join("firmware/tools/insn_window.c");
    let so = root().join("firmware/tools/libinsn_window.so");
    let stale = |p: &Path| p.metadata().and_then(|m| m.modified()).ok();
    if stale(&so).is_none() || stale(&so) < stale(&src) {
        if which("gcc").is_none() {
            die("gcc is needed to build the QEMU plugin firmware/tools/insn_window.c: apt-get install gcc");
        }
        let mut c = Command::new("gcc");
        c.args(["-O2", "-Wall", "-shared", "-fPIC", "-o"])
            .arg(&so)
            .arg(&src);
        if status(c) != 0 {
            die("building the QEMU plugin failed");
        }
    }
    so
}

fn defmt_decode(elf: &Path, raw: &[u8]) -> String {
    let dp = which("defmt-print")
        .unwrap_or_else(|| die("defmt-print missing: cargo install defmt-print --locked"));
    let mut c = Command::new(dp);
    c.arg("-e")
        .arg(elf)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    let mut child = c
        .spawn()
        .unwrap_or_else(|e| die(&format!("defmt-print: {e}")));
    {
        use std::io::Write;
        let _ = child.stdin.take().unwrap().write_all(raw);
    }
    let o = child.wait_with_output().unwrap();
    String::from_utf8_lossy(&o.stdout).into_owned()
}

fn field<'a>(line: &'a str, key: &str) -> Option<&'a str> {
    line.split_whitespace()
        .find_map(|w| w.strip_prefix(key).and_then(|r| r.strip_prefix('=')))
}

struct ProfRow {
    model: String,
    sine: String,
    blob: u32,
    /// Bytes of the functions that executed inside the measured window.
    exec_code: Option<u32>,
    /// (function, instructions in the window), most first.
    hot: Vec<(String, u64)>,
    flash: u32,
    text: u32,
    rodata: u32,
    ram: u32,
    stack_total: Option<u32>,
    stack_predict: Option<u32>,
    predictor: Option<u32>,
    insns: Option<u64>,
    macs: Option<u64>,
    hash: String,
}

/// Whether a blob is fixed point: the `numeric` byte after "GPEC" + version 1 (one varint byte).
fn blob_is_fixed(path: &Path) -> bool {
    std::fs::read(path)
        .ok()
        .is_some_and(|b| b.len() > 5 && &b[..4] == b"GPEC" && b[5] == 1)
}

/// Defined functions (start, size, demangled name) from llvm-nm, sorted by address.
fn functions(elf: &Path) -> Vec<(u32, u32, String)> {
    let nm = ["llvm-nm-22", "llvm-nm"]
        .iter()
        .find_map(|t| which(t))
        .unwrap_or_else(|| {
            die("llvm-nm is needed for the per-function profile (apt-get install llvm)")
        });
    let o = Command::new(nm)
        .args(["-C", "-S", "--defined-only"])
        .arg(elf)
        .output()
        .unwrap_or_else(|e| die(&format!("llvm-nm: {e}")));
    let mut v: Vec<(u32, u32, String)> = String::from_utf8_lossy(&o.stdout)
        .lines()
        .filter_map(|l| {
            let mut it = l.splitn(4, ' ');
            let (a, sz, ty, name) = (it.next()?, it.next()?, it.next()?, it.next()?);
            if !matches!(ty, "t" | "T" | "w" | "W") {
                return None;
            }
            Some((
                u32::from_str_radix(a, 16).ok()? & !1,
                u32::from_str_radix(sz, 16).ok()?,
                name.to_string(),
            ))
        })
        .collect();
    v.sort();
    v
}

/// Folds the plugin's per-PC counts ("0xPC n" lines) into functions:
/// (instructions per function, most first; bytes of the functions that ran).
fn fold_profile(prof: &Path, funcs: &[(u32, u32, String)]) -> (Vec<(String, u64)>, u32) {
    let text = std::fs::read_to_string(prof).unwrap_or_default();
    let mut per: BTreeMap<usize, u64> = BTreeMap::new();
    let mut unknown = 0u64;
    for l in text.lines() {
        let mut it = l.split_whitespace();
        let (Some(pc), Some(n)) = (it.next(), it.next()) else {
            continue;
        };
        let (Some(pc), Ok(n)) = (
            u32::from_str_radix(pc.trim_start_matches("0x"), 16).ok(),
            n.parse::<u64>(),
        ) else {
            continue;
        };
        if n == 0 {
            continue;
        }
        let i = funcs.partition_point(|f| f.0 <= pc);
        match i.checked_sub(1).map(|i| (i, &funcs[i])) {
            Some((i, f)) if pc < f.0 + f.1.max(2) => *per.entry(i).or_default() += n,
            _ => unknown += n,
        }
    }
    let code = per.keys().map(|&i| funcs[i].1).sum();
    let mut hot: Vec<(String, u64)> = per
        .into_iter()
        .map(|(i, n)| (funcs[i].2.clone(), n))
        .collect();
    if unknown > 0 {
        hot.push(("?".into(), unknown));
    }
    hot.sort_by_key(|b| std::cmp::Reverse(b.1));
    (hot, code)
}

/// Whether the blob at `path` has a point-forecast head (format 2).
fn blob_has_point_head(path: &std::path::Path) -> bool {
    std::fs::read(path)
        .ok()
        .and_then(|b| {
            gpecnet_core::Model::from_blob(&b)
                .ok()
                .map(|m| m.has_point_head())
        })
        .unwrap_or(false)
}

fn profile(o: &Opts) -> i32 {
    require(true);
    let dir = weights_dir(o);
    let models = require_models(&dir);
    let so = plugin();
    let out_dir = root().join("target/fw-profile");
    std::fs::create_dir_all(&out_dir).unwrap();
    let mut rows = Vec::new();
    let mut failed = false;
    for m in &models {
        let blob_path = dir.join(format!("{m}.gpec"));
        let blob_len = std::fs::metadata(&blob_path).map_or(0, |md| md.len() as u32);
        let paths: &[&str] = if blob_is_fixed(&blob_path) {
            &[FIXED_PATH]
        } else {
            SINES
        };
        for &sine in paths {
            let mut c = fw_cargo(o);
            c.env("GPECNET_MODELS", m).env("GPECNET_SINE", sine);
            c.arg("build");
            mcu::M4F.firmware_args(&mut c, &root(), &["profile", "micromath"]);
            let (rc, _, err) = output(c);
            if rc != 0 {
                eprintln!("{err}");
                die(&format!("profile build {m}/{sine} failed"));
            }
            let elf_copy = out_dir.join(format!("{m}-{sine}.elf"));
            std::fs::copy(mcu::M4F.elf(&root()), &elf_copy).unwrap();
            let elf = read_elf(&elf_copy);
            let (s, e) = match (elf.symbols.get("bench_start"), elf.symbols.get("bench_end")) {
                (Some(s), Some(e)) if s != e => (*s & !1, *e & !1),
                _ => die("bench_start/bench_end missing or merged in the profile ELF"),
            };
            let log = out_dir.join(format!("{m}-{sine}.plugin.log"));
            let pcprof = out_dir.join(format!("{m}-{sine}.pcprof"));
            let _ = std::fs::remove_file(&pcprof);
            let mut q = Command::new("qemu-system-arm");
            q.args([
                "-machine",
                "netduinoplus2",
                "-nographic",
                "-monitor",
                "none",
                "-serial",
                "null",
            ])
            .args(["-semihosting-config", "enable=on,target=native"])
            .arg("-plugin")
            .arg(format!(
                "{},start={s:#x},end={e:#x},profile={},base=0x08000000",
                so.display(),
                pcprof.display()
            ))
            .args(["-d", "plugin", "-D"])
            .arg(&log)
            .arg("-kernel")
            .arg(&elf_copy);
            eprintln!("xtask: $ {}", show(&q));
            let qo = q
                .stdin(Stdio::null())
                .output()
                .unwrap_or_else(|e| die(&format!("qemu-system-arm: {e}")));
            let text = defmt_decode(&elf_copy, &qo.stdout);
            let plog = std::fs::read_to_string(&log).unwrap_or_default();
            let insns = plog.lines().find_map(|l| {
                l.strip_prefix("window 0 insns ")
                    .and_then(|n| n.trim().parse::<u64>().ok())
            });
            let pline = text
                .lines()
                .find(|l| l.contains("profile ") && l.contains("sine="));
            let stack_total = text
                .lines()
                .find_map(|l| l.split("high-water ").nth(1))
                .and_then(|r| r.split_whitespace().next())
                .and_then(|n| n.parse().ok());
            if qo.status.code() != Some(0) || pline.is_none() || insns.is_none() {
                eprintln!("{text}{plog}");
                eprintln!(
                    "xtask: profile run {m}/{sine} failed (exit {:?})",
                    qo.status.code()
                );
                failed = true;
            }
            let (hot, exec_code) = fold_profile(&pcprof, &functions(&elf_copy));
            let mut hot_txt = String::new();
            let total: u64 = hot.iter().map(|h| h.1).sum();
            for (name, n) in &hot {
                let _ = writeln!(
                    hot_txt,
                    "{n:>10} {:5.1}%  {name}",
                    100.0 * *n as f64 / total.max(1) as f64
                );
            }
            let _ = std::fs::write(out_dir.join(format!("{m}-{sine}.hot.txt")), hot_txt);
            rows.push(ProfRow {
                model: m.clone(),
                sine: sine.to_string(),
                blob: blob_len,
                exec_code: (exec_code > 0).then_some(exec_code),
                hot,
                flash: elf.flash(),
                text: elf.section(".text"),
                rodata: elf.section(".rodata"),
                ram: elf.ram(),
                stack_total,
                stack_predict: pline
                    .and_then(|l| field(l, "predict_stack"))
                    .and_then(|v| v.parse().ok()),
                predictor: pline
                    .and_then(|l| field(l, "predictor_size"))
                    .and_then(|v| v.parse().ok()),
                insns,
                macs: pline
                    .and_then(|l| field(l, "macs"))
                    .and_then(|v| v.parse().ok()),
                hash: pline
                    .and_then(|l| field(l, "hash"))
                    .unwrap_or("-")
                    .to_string(),
            });
        }
    }
    let opt = |v: Option<u64>| v.map_or("-".to_string(), |v| v.to_string());
    let mut t = String::new();
    let _ = writeln!(
        t,
        "Profile: release (opt-level 3, fat LTO), thumbv7em-none-eabihf, QEMU netduinoplus2 (STM32F405), one prediction K = 20\n"
    );
    let _ = writeln!(
        t,
        "| model | path | flash B (.text / .rodata) | blob B | predict code B | code + weights B | static RAM B | stack peak B (run / predict) | Predictor B | instructions (K=20) | MACs (K=20) | insns/MAC | output fnv32 |"
    );
    let _ = writeln!(t, "|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    for r in &rows {
        let per = match (r.insns, r.macs) {
            (Some(i), Some(m)) if m > 0 => format!("{:.2}", i as f64 / m as f64),
            _ => "-".into(),
        };
        let _ = writeln!(
            t,
            "| {} | {} | {} ({} / {}) | {} | {} | {} | {} | {} / {} | {} | {} | {} | {} | {} |",
            r.model,
            r.sine,
            r.flash,
            r.text,
            r.rodata,
            r.blob,
            opt(r.exec_code.map(u64::from)),
            opt(r.exec_code.map(|c| u64::from(c + r.blob))),
            r.ram,
            opt(r.stack_total.map(|v: u32| v as u64)),
            opt(r.stack_predict.map(|v: u32| v as u64)),
            opt(r.predictor.map(|v: u32| v as u64)),
            opt(r.insns),
            opt(r.macs),
            per,
            r.hash
        );
    }
    let _ = writeln!(t, "\nWhere the instructions go (top functions in the window; full lists in target/fw-profile/<model>-<path>.hot.txt):\n");
    for r in &rows {
        let total: u64 = r.hot.iter().map(|h| h.1).sum();
        let top: Vec<String> = r
            .hot
            .iter()
            .take(5)
            .map(|(n, c)| {
                format!(
                    "{:.1}% `{}`",
                    100.0 * *c as f64 / total.max(1) as f64,
                    short_name(n)
                )
            })
            .collect();
        let _ = writeln!(t, "- {} / {}: {}", r.model, r.sine, top.join(", "));
    }
    for r in rows.iter().filter(|r| r.sine == FIXED_PATH) {
        // A format-2 model with a point head is held to issue 10's budget for the whole call.
        let with_point = blob_has_point_head(&dir.join(format!("{}.gpec", r.model)));
        let (target, what) = if with_point {
            (
                TARGET_INSNS_POINT,
                "issue 10, fixed point, point forecast + 20 endpoints",
            )
        } else {
            (TARGET_INSNS, "issue 6, fixed point, K = 20")
        };
        let insns_ok = r.insns.is_some_and(|i| i < target);
        let size_ok = r
            .exec_code
            .is_some_and(|c| c + r.blob < TARGET_CODE_WEIGHTS);
        let _ = writeln!(
            t,
            "\nTarget of {} ({what}): < {target} instructions: {} ({}); \
             code + weights < {TARGET_CODE_WEIGHTS} B: {} ({} B = {} B blob + {} B predict code; whole image {} B incl. runtime, defmt, vector table).",
            r.model,
            if insns_ok { "MET" } else { "NOT MET" },
            opt(r.insns),
            if size_ok { "MET" } else { "NOT MET" },
            opt(r.exec_code.map(|c| u64::from(c + r.blob))),
            r.blob,
            opt(r.exec_code.map(u64::from)),
            r.flash
        );
    }
    let _ = writeln!(
        t,
        "\nInstructions are QEMU guest instructions between bench_start and bench_end (TCG plugin \
         firmware/tools/insn_window.c), not Cortex-M4 cycles; see firmware/README.md to convert. \
         Stack: whole-run peak (painted at boot) / extra depth of the measured call (point forecast + endpoint set) on top of the \
         Predictor, whose scratch (Predictor B) lives in the caller's frame. MACs from the blob's layer dims \
         (Model::endpoint_macs). Predict code: bytes of the functions that executed between the markers \
         (per-PC plugin profile folded with llvm-nm; constant tables such as the 514 B sine table are in \
         .rodata, not counted)."
    );
    print!("{t}");
    let md = out_dir.join("profile.md");
    std::fs::write(&md, &t).unwrap();
    eprintln!("xtask: wrote {}", md.display());
    failed as i32
}

/// `a::b::<T>::f` -> `b::f`-ish: the last two path segments, generics dropped.
fn short_name(n: &str) -> String {
    let mut depth = 0;
    let mut plain = String::new();
    for ch in n.chars() {
        match ch {
            '<' => depth += 1,
            '>' => depth -= 1,
            _ if depth == 0 => plain.push(ch),
            _ => {}
        }
    }
    let parts: Vec<&str> = plain.split("::").filter(|p| !p.is_empty()).collect();
    parts[parts.len().saturating_sub(2)..].join("::")
}

/// The README's one command: set up, evaluate on the host through gpecnet-core, verify on target.
fn demo(o: &Opts) -> i32 {
    let rc = setup();
    if rc != 0 {
        return rc;
    }
    let mut c = host_cargo();
    c.args([
        "run",
        "--release",
        "-q",
        "-p",
        "gpecnet-trainer",
        "--",
        "eval",
    ]);
    c.args([
        "--blob",
        "weights/sdd-tiny-v2-qe.gpec",
        "--draw",
        "out/predictions.svg",
    ]);
    let rc = status(c);
    if rc != 0 {
        return rc;
    }
    replay::qemu(o)
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some(cmd) = args.first() else {
        eprintln!("{USAGE}");
        exit(2)
    };
    let o = parse_opts(&args[1..]);
    let code = match cmd.as_str() {
        "setup" => setup(),
        "demo" => demo(&o),
        "build-core-thumb" => build_core_thumb(),
        "fw-build" => fw_build(&o, &[]),
        "fw-run" => fw_run(&o),
        "qemu" => replay::qemu(&o),
        "fw-faults" => fw_faults(&o),
        "fw-test" => fw_test(),
        "profile" => profile(&o),
        "ffi-arm" => ffi::arm_example(),
        "-h" | "--help" | "help" => {
            println!("{USAGE}");
            0
        }
        other => {
            eprintln!("xtask: unknown command {other:?}\n{USAGE}");
            2
        }
    };
    exit(code)
}
