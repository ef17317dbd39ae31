//! `cargo xtask qemu`: the golden replay. Every embedded model's golden cases
//! run in QEMU on one MCU class (`--mcu m0|m4f|m7`, default `m4f`) or on all
//! of them (`--all-targets`), the same cases run on the host, and the two
//! runs' lines are compared one by one. With `--all-targets` each class is
//! also profiled (one image per numeric path, the QEMU instruction-window
//! plugin around one call per model) and the MCU × model table is written to
//! `target/fw-qemu/matrix.md`.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

use gpecnet_mcu_models::{blob_path, golden_path};

use gpecnet_replay::pack;

use crate::elf::fill_symbol;
use crate::firmware::{
    build_and_start, build_image, finish, fw_cargo, require_models, run_image, weights_dir, Opts,
};
use crate::mcu::{self, Mcu};
use crate::profile::{
    blob_is_fixed, build_profile_image, field, md_section, opt, opt_pair, per_mac, plugin,
    run_with_plugin, Column, FIXED_PATH,
};
use crate::toolchain::{host_cargo, output, require};
use crate::{die, root};

/// `println!` into a class's report: the classes run side by side, and each report is
/// printed whole when its class is done.
macro_rules! outln {
    ($log:expr, $($arg:tt)*) => {
        let _ = writeln!($log, $($arg)*);
    };
}

/// One golden-host run at a time: the runs of the classes share firmware/host's target
/// directory and differ in features, so one run must not relink the binary another runs.
static HOST_RUN: std::sync::Mutex<()> = std::sync::Mutex::new(());

/// What one class's golden replay found, per model.
struct Replay {
    /// Firmware == sidecar == host for every embedded model, and both runs exited 0.
    ok: bool,
    /// Per model: verified (all cases bit-exact) and the stack high-water mark
    /// of the image that ran it.
    models: BTreeMap<String, (bool, Option<u32>)>,
}

/// How an image holds a model's blob and golden file.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Stored {
    /// In the model pack the golden image reads at run time: the pack's header, the
    /// model's entry, its name and the padding before its blob take room too.
    Pack,
    /// Linked into the image as statics (the profile images).
    Linked,
}

/// A model of `dir` on `mcu`, held as `stored` says: `Ok(width)` when it can be
/// embedded, else why not.
fn fit(dir: &Path, m: &str, mcu: &Mcu, stored: Stored) -> Result<usize, String> {
    let blob = std::fs::read(blob_path(dir, m)).unwrap_or_default();
    let golden = std::fs::metadata(golden_path(dir, m)).map_or(0, |md| md.len());
    let width = gpecnet_core::Model::from_blob(&blob).map_or(0, |m| m.scratch_width());
    let (bytes, what) = match stored {
        Stored::Linked => (blob.len() as u64 + golden, "blob + golden"),
        Stored::Pack => (
            (pack::HEADER_LEN + pack::max_entry_len(m.len(), blob.len(), golden as usize)) as u64,
            "its model pack",
        ),
    };
    if mcu.fits(width, bytes) {
        Ok(width)
    } else if width > mcu.max_width {
        Err(format!(
            "not embedded: scratch width {width} > {} (RAM)",
            mcu.max_width
        ))
    } else {
        Err(format!(
            "not embedded: {what} {bytes} B > {} B of image data (flash)",
            mcu.image_data_budget
        ))
    }
}

/// `models` (sorted) split into runs of consecutive models that fit `budget` bytes
/// together, each model taking `size(name)` bytes (a larger model alone gets its own).
fn batches_by(
    models: &[String],
    size: impl Fn(&String) -> u64,
    first: u64,
    budget: u64,
) -> Vec<Vec<String>> {
    let mut batches: Vec<Vec<String>> = Vec::new();
    let mut used = first;
    for m in models {
        let n = size(m);
        match batches.last_mut() {
            Some(b) if used + n <= budget => b.push(m.clone()),
            _ => {
                batches.push(vec![m.clone()]);
                used = first;
            }
        }
        used += n;
    }
    batches
}

/// `models` (sorted) split into runs of consecutive models whose files (the
/// extensions `exts`) fit `budget` bytes together (a larger model alone gets its own).
fn image_batches(dir: &Path, models: &[String], exts: &[&str], budget: u64) -> Vec<Vec<String>> {
    let size = |m: &String| -> u64 {
        exts.iter()
            .map(|e| std::fs::metadata(dir.join(format!("{m}.{e}"))).map_or(0, |md| md.len()))
            .sum()
    };
    batches_by(models, size, 0, budget)
}

/// `models` (sorted) split into model packs of at most `budget` bytes each.
fn pack_batches(dir: &Path, models: &[String], budget: u64) -> Vec<Vec<String>> {
    let len = |p: std::path::PathBuf| std::fs::metadata(p).map_or(0, |md| md.len() as usize);
    let size = |m: &String| -> u64 {
        pack::max_entry_len(m.len(), len(blob_path(dir, m)), len(golden_path(dir, m))) as u64
    };
    batches_by(models, size, pack::HEADER_LEN as u64, budget)
}

/// The model pack of `batch` (gpecnet_replay::pack), read from `dir`, each blob
/// passed through `edit` first (the fault proofs corrupt one; the replay changes nothing).
pub(crate) fn model_pack_with(
    dir: &Path,
    batch: &[String],
    budget: u64,
    edit: impl Fn(&mut Vec<u8>),
) -> Result<Vec<u8>, String> {
    let read =
        |p: std::path::PathBuf| std::fs::read(&p).map_err(|e| format!("{}: {e}", p.display()));
    let files = batch
        .iter()
        .map(|m| {
            let mut blob = read(blob_path(dir, m))?;
            edit(&mut blob);
            Ok((m.as_str(), blob, read(golden_path(dir, m))?))
        })
        .collect::<Result<Vec<_>, String>>()?;
    let models: Vec<(&str, &[u8], &[u8])> =
        files.iter().map(|(n, b, g)| (*n, &b[..], &g[..])).collect();
    let mut out = vec![0; budget as usize];
    let used = pack::write(&models, &mut out).map_err(|e| e.what().to_string())?;
    out.truncate(used);
    Ok(out)
}

fn lines_with<'a>(text: &'a str, prefixes: &[&str]) -> Vec<&'a str> {
    text.lines()
        .map(str::trim_end)
        .filter(|l| prefixes.iter().any(|p| l.starts_with(p)))
        // Totals differ by construction when the firmware runs several images.
        .filter(|l| !l.starts_with("golden summary"))
        .collect()
}

/// The firmware's stack report: `stack: high-water N B of M B`.
fn high_water(text: &str) -> Option<u32> {
    text.lines()
        .find_map(|l| l.split("high-water ").nth(1))
        .and_then(|r| r.split_whitespace().next())
        .and_then(|n| n.parse().ok())
}

/// `cargo xtask qemu [--mcu NAME | --all-targets]`.
pub fn qemu(o: &Opts) -> i32 {
    qemu_models(o, None)
}

/// [`qemu`] restricted to the models named in `only` (those of them that are shipped); every
/// model when `None`.
pub fn qemu_models(o: &Opts, only: Option<&[&str]>) -> i32 {
    require(true);
    let dir = weights_dir(o);
    let mut models = require_models(&dir);
    if let Some(only) = only {
        models.retain(|m| only.contains(&m.as_str()));
        if models.is_empty() {
            die(&format!("none of {only:?} is in {}", dir.display()));
        }
    }
    let classes: Vec<&'static Mcu> = if o.all_targets {
        mcu::ALL.to_vec()
    } else {
        vec![o.mcu.unwrap_or(&mcu::M4F)]
    };
    if o.all_targets {
        // The instruction-window plugin, built here once (when stale) for every class.
        plugin();
    }
    // The classes build into their own target directories: they run side by side (each
    // class's images one after the other), their reports are printed in class order.
    let reports: Vec<(String, bool, Vec<Row>)> = std::thread::scope(|s| {
        let jobs: Vec<_> = classes
            .iter()
            .map(|&m| {
                let (dir, models) = (&dir, &models);
                s.spawn(move || class_report(o, m, dir, models))
            })
            .collect();
        jobs.into_iter()
            .map(|j| {
                j.join()
                    .unwrap_or_else(|_| die("a class's thread panicked"))
            })
            .collect()
    });
    let mut ok = true;
    let mut rows = Vec::new();
    for (log, class_ok, mut class_rows) in reports {
        print!("{log}");
        ok &= class_ok;
        rows.append(&mut class_rows);
    }
    if o.all_targets {
        let t = matrix_table(&rows, false);
        print!("{t}");
        let md = root().join("target/fw-qemu/matrix.md");
        std::fs::write(&md, &t).unwrap_or_else(|e| die(&format!("{}: {e}", md.display())));
        eprintln!("xtask: wrote {}", md.display());
        // Every shipped model: the exact columns against the committed snapshot.
        if o.weights.is_none() && only.is_none() {
            ok &= crate::snapshot::check_mcu_table(&matrix_table(&rows, true));
        }
    }
    println!(
        "qemu: {}",
        if ok {
            if o.all_targets {
                "PASS on every MCU class (bit-exact: firmware == sidecar == host, every model that fits)"
            } else {
                "PASS (bit-exact: firmware == sidecar == host, every model)"
            }
        } else {
            "FAIL"
        }
    );
    (!ok) as i32
}

/// One class: its golden replay and, with `--all-targets`, its profile images (built and
/// run beside the replay's QEMU runs). Returns the class's report, whether all passed,
/// and its rows of the MCU × model table.
fn class_report(
    o: &Opts,
    m: &'static Mcu,
    dir: &Path,
    models: &[String],
) -> (String, bool, Vec<Row>) {
    let mut log = String::new();
    outln!(log, "qemu: == {} ==", m.describe);
    let (r, profiled) = std::thread::scope(|s| {
        let profiled = o.all_targets.then(|| {
            s.spawn(|| {
                let mut report = String::new();
                let (ok, rows) = profile_class(o, m, dir, models, &mut report);
                (report, ok, rows)
            })
        });
        let r = replay(o, m, dir, models, &mut log);
        let profiled = profiled.map(|p| {
            p.join()
                .unwrap_or_else(|_| die("a profile thread panicked"))
        });
        (r, profiled)
    });
    let (mut ok, mut rows) = (r.ok, Vec::new());
    if let Some((report, prof_ok, mut class_rows)) = profiled {
        log.push_str(&report);
        ok &= prof_ok;
        // The golden replay's verdict and stack high-water mark per profiled model.
        for row in class_rows.iter_mut().filter(|r| r.bit_exact.is_some()) {
            let (verified, stack) = r.models.get(&row.model).copied().unwrap_or((false, None));
            row.bit_exact = Some(verified);
            row.stack_run = stack;
        }
        rows = class_rows;
    }
    (log, ok, rows)
}

/// Golden verification of every model that fits `mcu`, in QEMU and on the
/// host, compared line by line. Logs: `target/fw-qemu/<mcu>/{firmware,host}.log`.
fn replay(o: &Opts, mcu: &'static Mcu, dir: &Path, all: &[String], log: &mut String) -> Replay {
    let mut models = Vec::new();
    for m in all {
        match fit(dir, m, mcu, Stored::Pack) {
            Ok(_) => models.push(m.clone()),
            Err(why) => {
                outln!(log, "qemu: {m:<16} {why}");
            }
        }
    }
    let log_dir = root().join("target/fw-qemu").join(mcu.name);
    std::fs::create_dir_all(&log_dir)
        .unwrap_or_else(|e| die(&format!("{}: {e}", log_dir.display())));
    let mut per: BTreeMap<String, (bool, Option<u32>)> = BTreeMap::new();
    if models.is_empty() {
        outln!(log, "qemu: no model fits {}", mcu.describe);
        return Replay {
            ok: false,
            models: per,
        };
    }
    // Not every model fits one image: one QEMU run per batch of consecutive models, so
    // the firmware's lines, concatenated, come in the host's order. The golden image is
    // linked once, with an empty model-pack area of the class's image-data budget; each
    // batch's pack is written into a copy of it.
    let batches = pack_batches(dir, &models, mcu.image_data_budget);
    let (mut fw_rc, mut fw_out) = (0, String::new());
    // Each image runs in QEMU while the next one builds. The longest runs go first (f32
    // models, in software floating point on the Cortex-M0, then the most golden cases);
    // the outputs are taken in the batches' order.
    let long = |batch: &Vec<String>| {
        let f32_models = batch.iter().any(|m| !blob_is_fixed(&blob_path(dir, m)));
        let golden: u64 = batch
            .iter()
            .map(|m| std::fs::metadata(golden_path(dir, m)).map_or(0, |md| md.len()))
            .sum();
        std::cmp::Reverse((f32_models, golden))
    };
    let mut order: Vec<usize> = (0..batches.len()).collect();
    order.sort_by_key(|&i| long(&batches[i]));
    let linked = log_dir.join("golden.elf");
    let mut c = fw_cargo(o);
    c.env("GPECNET_MODEL_PACK", mcu.image_data_budget.to_string());
    if let Some(level) = mcu.golden_opt_level {
        c.env("CARGO_PROFILE_RELEASE_OPT_LEVEL", level);
    }
    let built =
        build_image(c, mcu, "golden", &mcu.golden_features(), &o.rest, &linked).and_then(|()| {
            std::fs::read(&linked).map_err(|e| (1, format!("{}: {e}", linked.display())))
        });
    std::thread::scope(|s| {
        let mut started: BTreeMap<usize, _> = BTreeMap::new();
        for i in order {
            let batch = &batches[i];
            eprintln!("xtask: {} image with {}", mcu.name, batch.join(", "));
            let copy = log_dir.join(format!("golden-{i}.elf"));
            let image = built.clone().and_then(|mut image| {
                model_pack_with(dir, batch, mcu.image_data_budget, |_| {})
                    .and_then(|p| fill_symbol(&mut image, "GPECNET_MODEL_PACK", &p))
                    .and_then(|()| {
                        std::fs::write(&copy, &image)
                            .map_err(|e| format!("{}: {e}", copy.display()))
                    })
                    .map_err(|e| {
                        (
                            1,
                            format!(
                                "xtask: {} golden image for {}: {e}",
                                mcu.name,
                                batch.join(", ")
                            ),
                        )
                    })
            });
            let run = s.spawn(move || match image {
                Ok(()) => run_image(mcu, &copy),
                Err((rc, err)) => (rc, String::new(), err),
            });
            started.insert(i, (Some(batch), run));
        }
        let mut runs: Vec<_> = started.into_values().collect();
        // A class whose golden image has no room for the online loop's scene plays it in
        // an image of its own (the `online` binary), with the scene's model alone.
        let online_model = gpecnet_replay::ONLINE_MODEL;
        if !mcu.online && models.iter().any(|m| m == online_model) {
            eprintln!("xtask: {} online loop scene", mcu.name);
            let mut c = fw_cargo(o);
            c.env(gpecnet_mcu_models::ONLY_VAR, online_model);
            if let Some(level) = mcu.golden_opt_level {
                c.env("CARGO_PROFILE_RELEASE_OPT_LEVEL", level);
            }
            let copy = log_dir.join("online.elf");
            let features = mcu.golden_features();
            runs.push((
                None,
                build_and_start(s, c, mcu, "online", &features, &[], copy),
            ));
        }
        // The tracker demo, its own binary, with the signed metric MCU model only (the
        // demo verifies its signature at boot; more models would not fit the flash beside
        // the verifier).
        if mcu.demo && models.iter().any(|m| m == crate::firmware::DEMO_MODEL) {
            eprintln!("xtask: {} demo", mcu.name);
            let mut c = fw_cargo(o);
            c.env(gpecnet_mcu_models::ONLY_VAR, crate::firmware::DEMO_MODEL);
            let copy = log_dir.join("demo.elf");
            runs.push((None, build_and_start(s, c, mcu, "demo", &[], &[], copy)));
        }
        for (batch, run) in runs {
            let (rc, out, err) = finish(run);
            let stack = high_water(&out);
            for m in batch.into_iter().flatten() {
                per.insert(m.clone(), (false, stack));
            }
            fw_out.push_str(&out);
            if rc != 0 {
                fw_rc = rc;
                // build errors / QEMU stderr
                outln!(
                    log,
                    "{}",
                    err.lines()
                        .filter(|l| !l.starts_with("warning"))
                        .collect::<Vec<_>>()
                        .join("\n")
                );
            }
        }
    });
    let _ = std::fs::write(log_dir.join("firmware.log"), &fw_out);
    // The host runs the same code (firmware/src/golden.rs) with the same
    // compiled-in sines, on the same models.
    let mut h = host_cargo();
    h.args([
        "run",
        "-q",
        "--release",
        "--manifest-path",
        "firmware/host/Cargo.toml",
    ]);
    if mcu.micromath {
        h.args(["--features", "micromath"]);
    }
    h.env(gpecnet_mcu_models::ONLY_VAR, models.join(","))
        .args(["--bin", "golden-host", "--"])
        .arg(dir);
    let (host_rc, host_out, host_err) = {
        let _one = HOST_RUN.lock().unwrap_or_else(|e| e.into_inner());
        output(h)
    };
    let _ = std::fs::write(log_dir.join("host.log"), format!("{host_out}{host_err}"));
    if !host_err.trim().is_empty() {
        outln!(log, "{}", host_err.trim_end());
    }
    // The firmware's summary lines and everything it reports as an error.
    for l in fw_out.lines().map(str::trim_end).filter(|l| {
        [
            "boot:",
            "golden summary",
            "demo:",
            "stack:",
            "result:",
            "ERROR",
            "WARN",
        ]
        .iter()
        .any(|p| l.starts_with(p))
            || l.contains("panicked")
            || l.contains("HardFault")
    }) {
        outln!(log, "firmware| {l}");
    }
    // The golden cases in the host's order, then the online loop's scene: in the golden
    // image after its model's cases, or (a class with `online: false`) from its own image,
    // which runs beside the golden images, so its lines are compared on their own.
    let cases = ["model ", "golden ", "xcheck "];
    let fl: Vec<&str> = lines_with(&fw_out, &cases)
        .into_iter()
        .chain(lines_with(&fw_out, &["online "]))
        .collect();
    let hl: Vec<&str> = lines_with(&host_out, &cases)
        .into_iter()
        .chain(lines_with(&host_out, &["online "]))
        .collect();
    let differ: Vec<(usize, &str, &str)> = (0..fl.len().max(hl.len()))
        .filter_map(|i| {
            let (a, b) = (
                fl.get(i).copied().unwrap_or("<missing>"),
                hl.get(i).copied().unwrap_or("<missing>"),
            );
            (a != b).then_some((i, a, b))
        })
        .collect();
    let count = |prefix: &str| {
        fl.iter()
            .filter(|l| l.starts_with(prefix) && l.len() > prefix.len())
            .count()
    };
    // The timed track table's scene: once per firmware image, once on the host; every
    // image's line must be the host's.
    let fw_resample = lines_with(&fw_out, &["resample "]);
    let host_resample = lines_with(&host_out, &["resample "]);
    let resampled = !fw_resample.is_empty()
        && host_resample.len() == 1
        && fw_resample.iter().all(|l| Some(l) == host_resample.first());
    outln!(
        log,
        "qemu: timed track table scene: {} firmware image(s) {:?}, host {:?}{}",
        fw_resample.len(),
        fw_resample.first().copied().unwrap_or("<none>"),
        host_resample.first().copied().unwrap_or("<none>"),
        if resampled { "" } else { "  <- NOT VERIFIED" }
    );
    // The synthetic flight's camera stage: once per golden image of a class with room for it,
    // else once in the online loop's own image (when that runs), and once on the host.
    let fw_flight = lines_with(&fw_out, &["flight "]);
    let host_flight = lines_with(&host_out, &["flight "]);
    let flight_expected = mcu.online || models.iter().any(|m| m == gpecnet_replay::ONLINE_MODEL);
    let flown = if flight_expected {
        !fw_flight.is_empty()
            && host_flight.len() == 1
            && fw_flight.iter().all(|l| Some(l) == host_flight.first())
    } else {
        fw_flight.is_empty()
    };
    outln!(
        log,
        "qemu: synthetic flight scene (camera, measurement model, filter, table): {} firmware image(s) {:?}, host {:?}{}",
        fw_flight.len(),
        fw_flight.first().copied().unwrap_or("<none>"),
        host_flight.first().copied().unwrap_or("<none>"),
        if flown { "" } else { "  <- NOT VERIFIED" }
    );
    // The streamed scene through the online loop: one line per frame after the cases of
    // its model (compared line by line above), on every class that embeds that model.
    let online_model = gpecnet_replay::ONLINE_MODEL;
    let online = count(&format!("online {online_model} "));
    let online_ok = !models.iter().any(|m| m == online_model)
        || online == gpecnet_replay::ONLINE_FRAMES as usize;
    outln!(
        log,
        "qemu: online loop scene ({online_model}, Forecaster<{}, {}>): {online} of {} frames in the firmware's lines{}",
        gpecnet_replay::ONLINE_TRACKS,
        gpecnet_replay::ONLINE_PENDING,
        gpecnet_replay::ONLINE_FRAMES,
        if online_ok && !mcu.online {
            "  (its own image: firmware/src/bin/online.rs)"
        } else if online_ok {
            ""
        } else {
            "  <- NOT VERIFIED"
        }
    );
    let run_ok = fw_rc == 0 && host_rc == 0 && differ.is_empty() && resampled && flown && online_ok;
    // Every embedded model must have been verified, each with all its cases.
    let mut missing_models = 0;
    for m in &models {
        let head = fl
            .iter()
            .find(|l| l.split_whitespace().nth(1) == Some(m.as_str()) && l.starts_with("model "));
        let golden = count(&format!("golden {m} "));
        let xcheck = count(&format!("xcheck {m} "));
        let (numeric, sine, n) = head
            .map(|l| {
                let w: Vec<&str> = l.split_whitespace().collect();
                (
                    w.get(2).copied().unwrap_or("?"),
                    w.get(3).copied().unwrap_or("?"),
                    w.get(4).and_then(|v| v.parse::<usize>().ok()).unwrap_or(0),
                )
            })
            .unwrap_or(("?", "?", 0));
        let verified = head.is_some() && n > 0 && golden == n;
        missing_models += (!verified) as usize;
        if let Some(e) = per.get_mut(m) {
            e.0 = verified && run_ok;
        }
        outln!(
            log,
            "qemu: {m:<16} {numeric:<8} sine {sine:<10} {golden}/{n} golden cases, {xcheck} xcheck lines{}",
            if verified { "" } else { "  <- NOT VERIFIED" }
        );
    }
    outln!(
        log,
        "qemu: {}: firmware exit {fw_rc}, host exit {host_rc}; {} firmware lines, {} host lines, {} differ (logs: target/fw-qemu/{}/)",
        mcu.name,
        fl.len(),
        hl.len(),
        differ.len(),
        mcu.name
    );
    for (i, a, b) in differ.iter().take(20) {
        outln!(log, "  line {i}: firmware {a:?} != host {b:?}");
    }
    Replay {
        ok: run_ok && missing_models == 0,
        models: per,
    }
}

/// One row of the MCU × model table.
struct Row {
    mcu: &'static str,
    model: String,
    /// Numeric path of the profiled call, or why the model is not on this class.
    path: String,
    flash: Option<u32>,
    ram: Option<u32>,
    /// Golden run's whole-image high-water mark.
    stack_run: Option<u32>,
    /// Predictor + the extra depth of one call.
    stack_call: Option<u32>,
    insns: Option<u64>,
    macs: Option<u64>,
    bit_exact: Option<bool>,
}

/// Profiles every model that fits `mcu`: one image per numeric path (f32
/// models through `fast-f32`, fixed-point ones through `q15-table`), one K = 20
/// call (point forecast + endpoint set) per model between the bench markers,
/// counted by the QEMU plugin. Flash per model = the image's flash minus the
/// other models' blobs.
fn profile_class(
    o: &Opts,
    mcu: &Mcu,
    dir: &Path,
    all: &[String],
    report: &mut String,
) -> (bool, Vec<Row>) {
    let so = plugin();
    let out_dir = root().join("target/fw-qemu").join(mcu.name);
    let mut rows = Vec::new();
    let mut ok = true;
    let mut by_path: BTreeMap<&str, Vec<String>> = BTreeMap::new();
    for m in all {
        match fit(dir, m, mcu, Stored::Linked) {
            Ok(_) => {
                let path = if blob_is_fixed(&blob_path(dir, m)) {
                    FIXED_PATH
                } else {
                    "fast-f32"
                };
                by_path.entry(path).or_default().push(m.clone());
            }
            Err(why) => rows.push(Row {
                mcu: mcu.name,
                model: m.clone(),
                path: why,
                flash: None,
                ram: None,
                stack_run: None,
                stack_call: None,
                insns: None,
                macs: None,
                bit_exact: None,
            }),
        }
    }
    let blob_len = |m: &str| std::fs::metadata(blob_path(dir, m)).map_or(0, |md| md.len() as u32);
    for (path, models) in by_path {
        for (i, batch) in image_batches(dir, &models, &["gpec"], mcu.image_data_budget)
            .iter()
            .enumerate()
        {
            let elf_copy = out_dir.join(format!("profile-{path}-{i}.elf"));
            let elf = build_profile_image(
                o,
                mcu,
                &batch.join(","),
                path,
                &[],
                crate::profile::Extras::None,
                &elf_copy,
            );
            let log = out_dir.join(format!("profile-{path}-{i}.plugin.log"));
            let run = run_with_plugin(mcu.machine, &so, &elf_copy, &elf, &log, "");
            let _ = std::fs::write(out_dir.join(format!("profile-{path}-{i}.log")), &run.text);
            let windows = run.windows();
            let lines = run.profile_lines();
            if run.exit != Some(0) || lines.len() != batch.len() || windows.len() != batch.len() {
                outln!(report, "{}{}", run.text, run.plugin_log);
                outln!(
                    report,
                    "xtask: {} profile run ({path}) failed (exit {:?})",
                    mcu.name,
                    run.exit
                );
                ok = false;
            }
            let blobs: u32 = batch.iter().map(|m| blob_len(m)).sum();
            for (j, m) in batch.iter().enumerate() {
                let line = lines
                    .iter()
                    .find(|l| l.split_whitespace().nth(1) == Some(m.as_str()));
                let num = |key: &str| {
                    line.and_then(|l| field(l, key))
                        .and_then(|v| v.parse::<u64>().ok())
                };
                rows.push(Row {
                    mcu: mcu.name,
                    model: m.clone(),
                    path: path.to_string(),
                    flash: Some(elf.flash() - blobs + blob_len(m)),
                    ram: Some(elf.ram()),
                    stack_run: None,
                    stack_call: num("predict_stack")
                        .zip(num("predictor_size"))
                        .map(|(a, b)| (a + b) as u32),
                    insns: windows.get(j).copied(),
                    macs: num("macs"),
                    // From the golden replay (class_report): a profiled model is embedded.
                    bit_exact: Some(false),
                });
            }
        }
    }
    rows.sort_by(|a, b| a.model.cmp(&b.model));
    (ok, rows)
}

/// The MCU × model table (markdown); `exact`: only the columns that are the same
/// on every run, machine and checkout (the snapshot's), without the flash column
/// (panic locations hold the checkout's path) and the golden run's stack
/// high-water mark (QEMU's SysTick, which the golden image runs, fires at host-time
/// intervals: where it lands varies the peak); the profiled call's stack stays.
fn matrix_table(rows: &[Row], exact: bool) -> String {
    let stack: Column<Row> = if exact {
        ("stack B (predictor + one call)", |r| {
            opt(r.stack_call.map(u64::from))
        })
    } else {
        ("stack B (golden run / predictor + one call)", |r| {
            opt_pair(r.stack_run, r.stack_call)
        })
    };
    let mut columns: Vec<Column<Row>> = vec![
        ("MCU", |r| r.mcu.to_string()),
        ("model", |r| r.model.clone()),
        ("path", |r| r.path.clone()),
        ("flash B (code + blob)", |r| opt(r.flash.map(u64::from))),
        ("static RAM B", |r| opt(r.ram.map(u64::from))),
        stack,
        ("instructions per call", |r| opt(r.insns)),
        ("insns/MAC", |r| per_mac(r.insns, r.macs)),
        ("bit-exact with host", |r| {
            match r.bit_exact {
                Some(true) => "pass",
                Some(false) => "FAIL",
                None => "-",
            }
            .to_string()
        }),
    ];
    if exact {
        columns.retain(|c| !c.0.starts_with("flash"));
    }
    let mut t = md_section(
        "\nGolden replay and profile per MCU class (`cargo xtask qemu --all-targets`; release, opt-level 3, fat LTO; one call = point forecast + 20 endpoints):\n",
        &columns,
        rows,
    );
    let _ = writeln!(
        t,
        "\nm0 = {}, m4f = {}, m7 = {}. Instructions are QEMU guest instructions between the bench markers \
         (TCG plugin firmware/tools/insn_window.c), not cycles. f32 on the M0 is software floating point.",
        mcu::M0.describe,
        mcu::M4F.describe,
        mcu::M7.describe
    );
    t
}

#[cfg(test)]
mod tests {
    use super::{fit, Stored};
    use crate::mcu;

    /// A model whose blob and golden file fit the M0's image data exactly fits an image
    /// that links them, but not the golden image's model pack, whose header, entry, name
    /// and blob padding take room too: the replay must say so instead of failing to
    /// write the pack.
    #[test]
    fn the_model_pack_counts_its_own_bytes() {
        let dir = std::env::temp_dir().join(format!("gpecnet-xtask-fit-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let budget = mcu::M0.image_data_budget as usize;
        // Not a blob the core reads (scratch width 0): only the bytes count here.
        std::fs::write(dir.join("m.gpec"), vec![0u8; budget - 100]).unwrap();
        std::fs::write(dir.join("m.golden"), vec![0u8; 100]).unwrap();
        let linked = fit(&dir, "m", &mcu::M0, Stored::Linked);
        let packed = fit(&dir, "m", &mcu::M0, Stored::Pack);
        std::fs::write(dir.join("m.golden"), vec![0u8; 10]).unwrap();
        let small = fit(&dir, "m", &mcu::M0, Stored::Pack);
        std::fs::remove_dir_all(&dir).unwrap();
        assert_eq!(linked, Ok(0));
        let why = packed.unwrap_err();
        assert!(why.contains("its model pack"), "{why}");
        assert_eq!(small, Ok(0));
    }
}
