//! `cargo xtask profile`: one image per model and numeric path on the
//! STM32F405 in QEMU, the instruction count of one K = 20 call from the TCG
//! plugin (firmware/tools/insn_window.c), the per-function split, flash,
//! RAM and stack; the table in target/fw-profile/profile.md.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

use gpecnet_mcu_models::blob_path;

use crate::elf::{read_elf, Elf};
use crate::firmware::{fw_cargo, require_models, weights_dir, Opts};
use crate::toolchain::{output, require, show, status, which};
use crate::{die, mcu, root};

/// Numeric paths profiled for F32 blobs (gpecnet_core::sine::*::NAME).
pub(crate) const SINES: &[&str] = &["libm", "fast-f32", "micromath"];
/// The numeric path of Int16Q15 blobs (gpecnet_core::fixed::SINE_NAME).
pub(crate) const FIXED_PATH: &str = "q15-table";
/// The first MCU budget (K = 20 endpoints in fixed point), for models without a point head.
pub(crate) const TARGET_INSNS: u64 = 300_000;
/// The MCU budget for one call of a model with a point head: the point forecast plus the
/// model's 20 endpoints (test-time sampling included), fixed point.
pub(crate) const TARGET_INSNS_POINT: u64 = 1_500_000;
pub(crate) const TARGET_CODE_WEIGHTS: u32 = 64 * 1024;

pub(crate) fn plugin() -> PathBuf {
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

/// The firmware's defmt stream as text (see [`crate::defmt`]); a decode
/// failure ends xtask with its message.
pub(crate) fn defmt_decode(elf: &Path, raw: &[u8]) -> String {
    crate::defmt::decode(elf, raw).unwrap_or_else(|e| die(&e))
}

pub(crate) fn field<'a>(line: &'a str, key: &str) -> Option<&'a str> {
    line.split_whitespace()
        .find_map(|w| w.strip_prefix(key).and_then(|r| r.strip_prefix('=')))
}

pub(crate) struct ProfRow {
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
pub(crate) fn blob_is_fixed(path: &Path) -> bool {
    std::fs::read(path)
        .ok()
        .is_some_and(|b| b.len() > 5 && &b[..4] == b"GPEC" && b[5] == 1)
}

/// Folds the plugin's per-PC counts ("0xPC n" lines) into functions:
/// (instructions per function, most first; bytes of the functions that ran).
pub(crate) fn fold_profile(prof: &Path, funcs: &[(u32, u32, String)]) -> (Vec<(String, u64)>, u32) {
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
pub(crate) fn blob_has_point_head(path: &std::path::Path) -> bool {
    std::fs::read(path)
        .ok()
        .and_then(|b| {
            gpecnet_core::Model::from_blob(&b)
                .ok()
                .map(|m| m.has_point_head())
        })
        .unwrap_or(false)
}

/// Builds the `profile` firmware for `mcu` with `models` (comma-separated) on the numeric path
/// `sine` (plus the firmware `features`), copies its ELF to `elf_copy` and reads it.
/// `extras`: what the image measures after the models' windows: [`Extras::Tables`], the
/// timed track table and the signature verification (`cargo xtask profile`'s one-model
/// images; the MCU x model table's multi-model images leave them out, so their windows are
/// the models' and the verifier is not linked into a Cortex-M0's flash);
/// [`Extras::Online`], one grid step of the online forecaster.
pub(crate) fn build_profile_image(
    o: &Opts,
    mcu: &mcu::Mcu,
    models: &str,
    sine: &str,
    features: &[&str],
    extras: Extras,
    elf_copy: &Path,
) -> Elf {
    let mut c = fw_cargo(o);
    c.env(gpecnet_mcu_models::ONLY_VAR, models)
        .env("GPECNET_SINE", sine)
        .env(
            "GPECNET_PROFILE_EXTRAS",
            match extras {
                Extras::None => "0",
                Extras::Tables => "1",
                Extras::Online => "online",
            },
        )
        .arg("build");
    mcu.firmware_args(&mut c, &root(), "profile", features);
    let (rc, _, err) = output(c);
    if rc != 0 {
        eprintln!("{err}");
        die(&format!(
            "{} profile build {models} ({sine}) failed",
            mcu.name
        ));
    }
    std::fs::copy(mcu.elf(&root(), "profile"), elf_copy)
        .unwrap_or_else(|e| die(&format!("{}: {e}", elf_copy.display())));
    read_elf(elf_copy)
}

/// The windows a profile image measures after the models' (`GPECNET_PROFILE_EXTRAS`).
#[derive(Clone, Copy, PartialEq, Eq)]
pub(crate) enum Extras {
    /// None: the MCU x model table's images.
    None,
    /// The timed track table and the signature verification.
    Tables,
    /// One grid step of one pedestrian through `online::Forecaster<1, 2>` (an image of its
    /// own: the forecaster's predictor links both engines, which would change how the
    /// compiler lays out the models' measured call).
    Online,
}

/// Whether the online loop forecasts for `model` at K = 20 (the firmware's
/// `online_step` measures it): a model of 8 past and 12 future steps on a
/// recorded period whose endpoint set fits 20 samples.
fn online_takes(model: &Path) -> bool {
    use gpecnet_core::online::{Config, Forecaster};
    std::fs::read(model).ok().is_some_and(|b| {
        gpecnet_core::Model::from_blob(&b).is_ok_and(|m| {
            Forecaster::<1, 2>::new(&m, Config::metres(), 1_000).is_ok()
                && gpecnet_core::sampling::max_endpoints_of(&m, 20) > 0
        })
    })
}

/// What one run of a profiling image under the instruction-window plugin left behind.
pub(crate) struct PluginRun {
    /// The firmware's defmt output, decoded.
    pub(crate) text: String,
    /// The plugin's log: one `window N insns M` line per measured window.
    pub(crate) plugin_log: String,
    /// QEMU's exit status.
    pub(crate) exit: Option<i32>,
}

impl PluginRun {
    /// The instruction count of every measured window, in order.
    pub(crate) fn windows(&self) -> Vec<u64> {
        self.plugin_log
            .lines()
            .filter_map(|l| {
                l.strip_prefix("window ")
                    .and_then(|r| r.split(" insns ").nth(1))
                    .and_then(|n| n.trim().parse().ok())
            })
            .collect()
    }

    /// The firmware's `profile ... sine=...` result lines.
    pub(crate) fn profile_lines(&self) -> Vec<&str> {
        self.text
            .lines()
            .filter(|l| l.contains("profile ") && l.contains("sine="))
            .collect()
    }
}

/// Runs the image `elf_path` (read as `elf`) on the QEMU `machine` with the TCG plugin `so`
/// (firmware/tools/insn_window.c) counting the instructions between the `bench_start` and
/// `bench_end` markers; `plugin_opts` are appended to the plugin's arguments (e.g.
/// `,profile=FILE,base=0x08000000` for the per-PC profile), the plugin logs to `log`.
pub(crate) fn run_with_plugin(
    machine: &str,
    so: &Path,
    elf_path: &Path,
    elf: &Elf,
    log: &Path,
    plugin_opts: &str,
) -> PluginRun {
    let (s, e) = match (elf.symbols.get("bench_start"), elf.symbols.get("bench_end")) {
        (Some(s), Some(e)) if s != e => (*s & !1, *e & !1),
        _ => die("bench_start/bench_end missing or merged in the profile ELF"),
    };
    let mut q = Command::new("qemu-system-arm");
    q.args(["-machine", machine, "-nographic", "-monitor", "none"])
        .args(["-serial", "null"])
        .args(["-semihosting-config", "enable=on,target=native"])
        .arg("-plugin")
        .arg(format!(
            "{},start={s:#x},end={e:#x}{plugin_opts}",
            so.display()
        ))
        .args(["-d", "plugin", "-D"])
        .arg(log)
        .arg("-kernel")
        .arg(elf_path);
    eprintln!("xtask: $ {}", show(&q));
    let qo = q
        .stdin(Stdio::null())
        .output()
        .unwrap_or_else(|e| die(&format!("qemu-system-arm: {e}")));
    PluginRun {
        text: defmt_decode(elf_path, &qo.stdout),
        plugin_log: std::fs::read_to_string(log).unwrap_or_default(),
        exit: qo.status.code(),
    }
}

/// `cargo xtask profile`: `only_fixed` `Some(true)` profiles the fixed-point blobs only
/// (`--path q15`), `Some(false)` the f32 ones (`--path f32`); `out` replaces target/fw-profile/.
pub(crate) fn profile(o: &Opts, only_fixed: Option<bool>, out: Option<&Path>) -> i32 {
    require(true);
    let dir = weights_dir(o);
    let models = require_models(&dir);
    let so = plugin();
    let out_dir = out.map_or_else(|| root().join("target/fw-profile"), Path::to_path_buf);
    std::fs::create_dir_all(&out_dir)
        .unwrap_or_else(|e| die(&format!("{}: {e}", out_dir.display())));
    let mut rows = Vec::new();
    let mut failed = false;
    // The timed track table's window (the second of every image; the same code in each).
    let mut table: Option<(u64, String)> = None;
    // The camera stage's window (the third of every image; the same code in each).
    let mut camera: Option<(u64, String)> = None;
    // The signature verification's window (the fourth, in images of signed blobs) and the
    // verifier's code: the functions of ed25519-dalek, curve25519-dalek, sha2 and the trailer.
    let mut verify: Option<(u64, String, u64)> = None;
    // The online forecaster's window (its own image, for a model the loop takes), per model.
    let mut online: Vec<(String, u64, String)> = Vec::new();
    for m in &models {
        let blob = blob_path(&dir, m);
        let blob_len = std::fs::metadata(&blob).map_or(0, |md| md.len() as u32);
        let fixed = blob_is_fixed(&blob);
        if only_fixed.is_some_and(|f| f != fixed) {
            continue;
        }
        let paths: &[&str] = if fixed { &[FIXED_PATH] } else { SINES };
        for &sine in paths {
            let elf_copy = out_dir.join(format!("{m}-{sine}.elf"));
            let elf = build_profile_image(
                o,
                &mcu::M4F,
                m,
                sine,
                &["micromath"],
                Extras::Tables,
                &elf_copy,
            );
            let log = out_dir.join(format!("{m}-{sine}.plugin.log"));
            let pcprof = out_dir.join(format!("{m}-{sine}.pcprof"));
            let _ = std::fs::remove_file(&pcprof);
            let run = run_with_plugin(
                mcu::M4F.machine,
                &so,
                &elf_copy,
                &elf,
                &log,
                &format!(",profile={},base=0x08000000", pcprof.display()),
            );
            let insns = run.windows().first().copied();
            let table_line = run.text.lines().find(|l| l.contains("tracktable tracks="));
            if sine == FIXED_PATH && online_takes(&blob) {
                // The online forecaster's window: the second of its own image.
                let elf_online = out_dir.join(format!("{m}-{sine}-online.elf"));
                let elf = build_profile_image(
                    o,
                    &mcu::M4F,
                    m,
                    sine,
                    &["micromath"],
                    Extras::Online,
                    &elf_online,
                );
                let log = out_dir.join(format!("{m}-{sine}-online.plugin.log"));
                let r = run_with_plugin(mcu::M4F.machine, &so, &elf_online, &elf, &log, "");
                match (
                    r.windows().get(1),
                    r.text.lines().find(|l| l.contains("online model=")),
                ) {
                    (Some(&n), Some(l)) if r.exit == Some(0) => {
                        online.push((format!("{m} / {sine}"), n, l.trim().to_string()));
                    }
                    _ => {
                        eprintln!("{}{}", r.text, r.plugin_log);
                        eprintln!(
                            "xtask: profile run {m}/{sine} (online) failed (exit {:?})",
                            r.exit
                        );
                        failed = true;
                    }
                }
            }
            match (
                run.windows().get(2),
                run.text.lines().find(|l| l.contains("camera tracks=")),
            ) {
                (Some(&n), Some(l)) => {
                    camera.get_or_insert((n, l.trim().to_string()));
                }
                _ => {
                    eprintln!("xtask: profile run {m}/{sine}: no camera-stage window");
                    failed = true;
                }
            }
            if let (Some(&n), Some(l)) = (
                run.windows().get(3),
                run.text.lines().find(|l| l.contains("verify model=")),
            ) {
                let code: u64 = elf
                    .functions
                    .iter()
                    .filter(|(_, _, f)| {
                        [
                            "curve25519_dalek",
                            "ed25519_dalek",
                            "sha2::",
                            "blob::signed",
                        ]
                        .iter()
                        .any(|c| f.contains(c))
                    })
                    .map(|(_, size, _)| u64::from(*size))
                    .sum();
                verify.get_or_insert((n, l.trim().to_string(), code));
            }
            match (run.windows().get(1), table_line) {
                (Some(&n), Some(l)) => {
                    table.get_or_insert((n, l.trim().to_string()));
                }
                _ => {
                    eprintln!("xtask: profile run {m}/{sine}: no track-table window");
                    failed = true;
                }
            }
            let pline = run.profile_lines().first().copied();
            let num = |key: &str| {
                pline
                    .and_then(|l| field(l, key))
                    .and_then(|v| v.parse::<u64>().ok())
            };
            let stack_total = run
                .text
                .lines()
                .find_map(|l| l.split("high-water ").nth(1))
                .and_then(|r| r.split_whitespace().next())
                .and_then(|n| n.parse().ok());
            if run.exit != Some(0) || pline.is_none() || insns.is_none() {
                eprintln!("{}{}", run.text, run.plugin_log);
                eprintln!("xtask: profile run {m}/{sine} failed (exit {:?})", run.exit);
                failed = true;
            }
            let (hot, exec_code) = fold_profile(&pcprof, &elf.functions);
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
                stack_predict: num("predict_stack").and_then(|v| u32::try_from(v).ok()),
                predictor: num("predictor_size").and_then(|v| u32::try_from(v).ok()),
                insns,
                macs: num("macs"),
                hash: pline
                    .and_then(|l| field(l, "hash"))
                    .unwrap_or("-")
                    .to_string(),
            });
        }
    }
    let columns: &[Column<ProfRow>] = &[
        ("model", |r| r.model.clone()),
        ("path", |r| r.sine.clone()),
        ("flash B (.text / .rodata)", |r| {
            format!("{} ({} / {})", r.flash, r.text, r.rodata)
        }),
        ("blob B", |r| r.blob.to_string()),
        ("predict code B", |r| opt(r.exec_code.map(u64::from))),
        ("code + weights B", |r| {
            opt(r.exec_code.map(|c| u64::from(c + r.blob)))
        }),
        ("static RAM B", |r| r.ram.to_string()),
        ("stack peak B (run / predict)", |r| {
            opt_pair(r.stack_total, r.stack_predict)
        }),
        ("Predictor B", |r| opt(r.predictor.map(u64::from))),
        ("instructions (K=20)", |r| opt(r.insns)),
        ("MACs (K=20)", |r| opt(r.macs)),
        ("insns/MAC", |r| per_mac(r.insns, r.macs)),
        ("output fnv32", |r| r.hash.clone()),
    ];
    let mut t = md_section(
        "Profile: release (opt-level 3, fat LTO), thumbv7em-none-eabihf, QEMU netduinoplus2 (STM32F405), one prediction K = 20\n",
        columns,
        &rows,
    );
    let _ = writeln!(
        t,
        "\nWhere the instructions go: the top functions in the window (full lists in {}/<model>-<path>.hot.txt); \
         dense = the dense-layer functions, which do all of the call's MACs:\n",
        out_dir.display()
    );
    md_table(
        &mut t,
        &[
            "model",
            "path",
            "function",
            "instructions",
            "share",
            "dense",
            "insns/MAC",
        ],
        rows.iter().flat_map(function_rows),
    );
    for r in rows.iter().filter(|r| r.sine == FIXED_PATH) {
        // A format-2 model with a point head is held to the point-head budget for the whole call.
        let with_point = blob_has_point_head(&blob_path(&dir, &r.model));
        let (target, what) = if with_point {
            (
                TARGET_INSNS_POINT,
                "budget: fixed point, point forecast + 20 endpoints",
            )
        } else {
            (TARGET_INSNS, "budget: fixed point, K = 20")
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
    if let Some((insns, line)) = &table {
        let num = |k: &str| {
            field(line, k)
                .and_then(|v| v.parse::<u64>().ok())
                .unwrap_or(0)
        };
        let frames = num("frames").max(1);
        let _ = writeln!(
            t,
            "\nTimed track table (`TimedTrackTable<{tracks}>`, {tracks} tracks in steady state, 30 Hz camera, \
             0.4 s period): {insns} instructions per period ({frames} frames, one completing a grid point for \
             every track) = {per_frame} per frame on average; RAM {size} B ({track} B per track).",
            tracks = num("tracks"),
            per_frame = insns / frames,
            size = num("table_size"),
            track = num("track_size"),
        );
    }
    if let Some((insns, line)) = &camera {
        let num = |k: &str| {
            field(line, k)
                .and_then(|v| v.parse::<u64>().ok())
                .unwrap_or(0)
        };
        let frames = num("frames").max(1);
        let per_frame = insns / frames;
        let _ = writeln!(
            t,
            "\nCamera stage (`camera::Pose::new`, then per pedestrian `image_to_ground` and \
             `ground_covariance`, then `TrackFilter<{tracks}>::update_with`), {tracks} pedestrians at 30 Hz in \
             steady state: {insns} instructions per 0.4 s ({frames} frames) = {per_frame} per frame = \
             {per_second} per second, {share:.1} % of a 168 MHz Cortex-M4F at one instruction per cycle; \
             the filter's RAM {size} B.",
            tracks = num("tracks"),
            per_second = per_frame * 30,
            share = 100.0 * (per_frame * 30) as f64 / 168e6,
            size = num("filter_size"),
        );
    }
    for (what, insns, line) in &online {
        let num = |k: &str| field(line, k).unwrap_or("-");
        let _ = writeln!(
            t,
            "\nOnline forecaster (`online::Forecaster<1, 2>`, loop on, {what}), one pedestrian, one grid step \
             in steady state (one camera frame completing a grid point: the track table's update, the new \
             point fed back to the pending forecasts, {feedback} update(s), then `online::forecast`: \
             endpoints, probabilities, point forecast, per-step radii): {insns} instructions; {stack} B of \
             stack on top of the forecaster and the predictor ({predictor} B); RAM: the forecaster {one} B \
             with one track, {per} B per track of which the loop's {looped} B (the table's the rest), \
             the calibration {cal} B.",
            feedback = num("feedback"),
            stack = num("online_stack"),
            predictor = num("predictor_size"),
            one = num("forecaster_1"),
            per = num("per_track"),
            looped = num("loop_per_track"),
            cal = num("calibration"),
        );
    }
    if let Some((insns, line, code)) = &verify {
        let stack = field(line, "verify_stack").unwrap_or("-");
        let model = field(line, "model").unwrap_or("-");
        let _ = writeln!(
            t,
            "\nSignature verification (`Model::from_signed_blob`, Ed25519 by ed25519-dalek, once per boot or \
             update) of {model}: {insns} instructions; {stack} B of stack on top of the caller; {code} B of code \
             (the functions of ed25519-dalek, curve25519-dalek, sha2 and the trailer reader; linked only where \
             it is called).",
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

/// Whether a profiled function is part of the dense layers (the portable loops, the DSP
/// kernels, the partial sums, the f32 row loop `float::accumulate`, the Q15 decoder's latent
/// columns `fixed::latent16`): the functions that do the MACs.
pub(crate) fn is_dense(function: &str) -> bool {
    let f = short_name(function);
    ["dense", "partial", "accumulate", "latent"]
        .iter()
        .any(|k| f.contains(k))
        || function.contains("kernels::")
}

/// The per-function rows of one profile: a summary row of the dense layers (their share of
/// the window's instructions, their instructions per MAC), then the top 8 functions.
fn function_rows(r: &ProfRow) -> Vec<Vec<String>> {
    let total: u64 = r.hot.iter().map(|h| h.1).sum();
    let share = |n: u64| format!("{:.1}%", 100.0 * n as f64 / total.max(1) as f64);
    let dense: u64 = r.hot.iter().filter(|h| is_dense(&h.0)).map(|h| h.1).sum();
    let mut out = vec![vec![
        r.model.clone(),
        r.sine.clone(),
        "**all dense layers**".into(),
        dense.to_string(),
        share(dense),
        "yes".into(),
        per_mac(Some(dense), r.macs),
    ]];
    out.extend(r.hot.iter().take(8).map(|(name, n)| {
        let d = is_dense(name);
        vec![
            r.model.clone(),
            r.sine.clone(),
            format!("`{}`", short_name(name)),
            n.to_string(),
            share(*n),
            if d { "yes" } else { "" }.into(),
            if d {
                per_mac(Some(*n), r.macs)
            } else {
                "-".into()
            },
        ]
    }));
    out
}

/// `a::b::<T>::f` -> `b::f`-ish: the last two path segments, generics dropped.
pub(crate) fn short_name(n: &str) -> String {
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

/// Appends a markdown table to `out`: the `header` row, the separator, one line per row of
/// `rows` (each as many cells as the header).
pub(crate) fn md_table(
    out: &mut String,
    header: &[&str],
    rows: impl IntoIterator<Item = Vec<String>>,
) {
    let _ = writeln!(out, "| {} |", header.join(" | "));
    let _ = writeln!(out, "|{}", "---|".repeat(header.len()));
    for row in rows {
        debug_assert_eq!(row.len(), header.len());
        let _ = writeln!(out, "| {} |", row.join(" | "));
    }
}

/// A column of a markdown table over rows of type `R`: its header and its
/// cell, side by side so the two cannot drift apart.
pub(crate) type Column<R> = (&'static str, fn(&R) -> String);

/// A markdown section: the line `intro`, then [`md_table`] over typed rows,
/// one cell per [`Column`].
pub(crate) fn md_section<R>(intro: &str, columns: &[Column<R>], rows: &[R]) -> String {
    let mut out = String::new();
    let _ = writeln!(out, "{intro}");
    let header: Vec<&str> = columns.iter().map(|c| c.0).collect();
    md_table(
        &mut out,
        &header,
        rows.iter()
            .map(|r| columns.iter().map(|c| (c.1)(r)).collect()),
    );
    out
}

/// A table cell: the number, or `-` when it was not measured.
pub(crate) fn opt(v: Option<u64>) -> String {
    v.map_or("-".to_string(), |v| v.to_string())
}

/// Two measurements in one cell, `a / b` (each `-` when not measured).
pub(crate) fn opt_pair(a: Option<u32>, b: Option<u32>) -> String {
    format!("{} / {}", opt(a.map(u64::from)), opt(b.map(u64::from)))
}

/// Instructions per MAC with two decimals, or `-`.
pub(crate) fn per_mac(insns: Option<u64>, macs: Option<u64>) -> String {
    match (insns, macs) {
        (Some(i), Some(m)) if m > 0 => format!("{:.2}", i as f64 / m as f64),
        _ => "-".into(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dense_functions_are_recognised() {
        assert!(is_dense("gpecnet_core::fixed::dense_q"));
        assert!(is_dense(
            "<gpecnet_core::float::Float<S> as gpecnet_core::backend::Backend>::partial"
        ));
        assert!(is_dense("gpecnet_core::kernels::smlald_rows"));
        assert!(is_dense("gpecnet_core::float::accumulate"));
        assert!(is_dense(
            "gpecnet_core::fixed::latent16::<&<gpecnet_core::fixed::Q15 as gpecnet_core::backend::Backend>::latent::{closure#2}>"
        ));
        assert!(!is_dense("gpecnet_core::sine::sin_q15"));
        assert!(!is_dense(
            "gpecnet_core::engine::Engine<B,_>::predict_point"
        ));
    }

    #[test]
    fn function_rows_give_dense_share_and_insns_per_mac() {
        let r = ProfRow {
            model: "m".into(),
            sine: "q15-table".into(),
            blob: 0,
            exec_code: None,
            hot: vec![
                ("gpecnet_core::fixed::dense_q".into(), 600),
                ("gpecnet_core::sine::sin_q15".into(), 300),
                (
                    "gpecnet_core::fixed::<impl Backend for Q15>::partial".into(),
                    100,
                ),
            ],
            flash: 0,
            text: 0,
            rodata: 0,
            ram: 0,
            stack_total: None,
            stack_predict: None,
            predictor: None,
            insns: Some(1000),
            macs: Some(350),
            hash: "-".into(),
        };
        let rows = function_rows(&r);
        assert_eq!(rows.len(), 4);
        assert_eq!(rows[0][3..], ["700", "70.0%", "yes", "2.00"]);
        assert_eq!(
            rows[1][2..],
            ["`fixed::dense_q`", "600", "60.0%", "yes", "1.71"]
        );
        assert_eq!(rows[2][5..], ["", "-"]);
    }

    #[test]
    fn md_section_puts_each_header_over_its_cells() {
        let rows = [(1u32, Some(2u32)), (3, None)];
        let columns: &[Column<(u32, Option<u32>)>] = &[
            ("a", |r| r.0.to_string()),
            ("a / b", |r| opt_pair(Some(r.0), r.1)),
        ];
        let t = md_section("intro", columns, &rows);
        assert_eq!(
            t,
            "intro\n| a | a / b |\n|---|---|\n| 1 | 1 / 2 |\n| 3 | 3 / - |\n"
        );
    }

    #[test]
    fn md_table_writes_header_separator_and_rows() {
        let mut t = String::new();
        md_table(
            &mut t,
            &["model", "insns/MAC"],
            [
                vec!["sdd-tiny".to_string(), per_mac(Some(1000), Some(400))],
                vec!["x".to_string(), opt(None)],
            ],
        );
        assert_eq!(
            t,
            "| model | insns/MAC |\n|---|---|\n| sdd-tiny | 2.50 |\n| x | - |\n"
        );
    }
}
