//! Nothing lost: outputs never overwrite inputs or special files, artefact sets are written
//! as one, user-given files are read bounded and without blocking, nothing is skipped
//! silently (docs/errors-and-safety.md).

use crate::common;

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use common::{gpecnet, s, temp_dir, write_sdd, TinyRun};

/// The shipped blob the file-safety tests copy (small, f32).
const BLOB: &str = "sdd-tiny";

fn weights() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../weights")
}

/// A temp folder holding a copy of the shipped `sdd-tiny` set; returns (folder, blob path).
fn copy_of_set(name: &str) -> (PathBuf, PathBuf) {
    let dir = temp_dir(name);
    for ext in ["gpec", "golden", "json", "md"] {
        std::fs::copy(
            weights().join(format!("{BLOB}.{ext}")),
            dir.join(format!("{BLOB}.{ext}")),
        )
        .unwrap();
    }
    let blob = dir.join(format!("{BLOB}.gpec"));
    (dir, blob)
}

/// The bytes of every file of the set in `dir` named `name`.
fn set_bytes(dir: &Path, name: &str) -> Vec<Vec<u8>> {
    ["gpec", "golden", "json", "md"]
        .iter()
        .map(|e| std::fs::read(dir.join(format!("{name}.{e}"))).unwrap_or_default())
        .collect()
}

/// Runs `gpecnet args` with a deadline; (finished in time and succeeded, output). A command
/// still running at the deadline is killed and counted as a failure of the test.
fn run_deadline(args: &[&str], secs: u64) -> (bool, String) {
    let mut child = gpecnet()
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let start = Instant::now();
    loop {
        if child.try_wait().unwrap().is_some() {
            let o = child.wait_with_output().unwrap();
            let text = format!(
                "{}{}",
                String::from_utf8_lossy(&o.stdout),
                String::from_utf8_lossy(&o.stderr)
            );
            return (o.status.success(), text);
        }
        if start.elapsed() > Duration::from_secs(secs) {
            let _ = child.kill();
            let _ = child.wait();
            panic!("gpecnet {args:?} still running after {secs} s (blocked or unbounded)");
        }
        std::thread::sleep(Duration::from_millis(50));
    }
}

fn mkfifo(p: &Path) {
    let st = Command::new("mkfifo").arg(p).status().unwrap();
    assert!(st.success(), "mkfifo {}", p.display());
}

fn is_fifo(p: &Path) -> bool {
    use std::os::unix::fs::FileTypeExt;
    std::fs::symlink_metadata(p)
        .map(|m| m.file_type().is_fifo())
        .unwrap_or(false)
}

#[test]
fn onnx_never_writes_over_its_input_or_a_special_file() {
    let (dir, blob) = copy_of_set("onnx-out");
    let before = set_bytes(&dir, BLOB);
    for out in [blob.clone(), dir.join(format!("{BLOB}.json"))] {
        let (ok, text) = run_deadline(&["onnx", "--blob", s(&blob), "--out", s(&out)], 60);
        assert!(!ok, "{text}");
        assert!(text.contains("same file as the input"), "{text}");
    }
    // A hard link to the blob is the same file too.
    let link = dir.join("other-name.onnx");
    std::fs::hard_link(&blob, &link).unwrap();
    let (ok, text) = run_deadline(&["onnx", "--blob", s(&blob), "--out", s(&link)], 60);
    assert!(!ok && text.contains("same file"), "{text}");
    assert_eq!(set_bytes(&dir, BLOB), before, "an input changed");

    let (ok, text) = run_deadline(&["onnx", "--blob", s(&blob), "--out", "/dev/null"], 60);
    assert!(!ok, "{text}");
    assert!(text.contains("character device"), "{text}");
    let fifo = dir.join("pipe.onnx");
    mkfifo(&fifo);
    let (ok, text) = run_deadline(&["onnx", "--blob", s(&blob), "--out", s(&fifo)], 60);
    assert!(!ok && text.contains("a FIFO"), "{text}");
    assert!(is_fifo(&fifo), "the FIFO was replaced");
    let to_stdout = dir.join("stdout.onnx");
    std::os::unix::fs::symlink("/proc/self/fd/1", &to_stdout).unwrap();
    let (ok, text) = run_deadline(&["onnx", "--blob", s(&blob), "--out", s(&to_stdout)], 60);
    assert!(
        !ok && (text.contains("not a regular file") || text.contains("a FIFO")),
        "{text}"
    );
    assert!(std::fs::symlink_metadata(&to_stdout)
        .unwrap()
        .file_type()
        .is_symlink());
    // A good output still works.
    let good = dir.join("out.onnx");
    let (ok, text) = run_deadline(&["onnx", "--blob", s(&blob), "--out", s(&good)], 120);
    assert!(ok, "{text}");
    assert!(std::fs::metadata(&good).unwrap().len() > 1000);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn eval_draw_never_writes_over_the_blob_its_card_or_a_device() {
    let (dir, blob) = copy_of_set("eval-draw");
    let before = set_bytes(&dir, BLOB);
    for draw in ["gpec", "json", "golden", "md"] {
        let out = dir.join(format!("{BLOB}.{draw}"));
        let (ok, text) = run_deadline(&["eval", "--blob", s(&blob), "--draw", s(&out)], 60);
        assert!(!ok, "{text}");
        assert!(
            text.contains("--draw") && text.contains("same file"),
            "{text}"
        );
    }
    let (ok, text) = run_deadline(&["eval", "--blob", s(&blob), "--draw", "/dev/full"], 60);
    assert!(!ok && text.contains("character device"), "{text}");
    assert_eq!(set_bytes(&dir, BLOB), before, "an input changed");
    // Never inside the data root's data folders either.
    let data = temp_dir("eval-draw-data");
    std::fs::create_dir_all(data.join("sdd")).unwrap();
    let (ok, text) = run_deadline(
        &[
            "eval",
            "--blob",
            s(&blob),
            "--data",
            s(&data),
            "--draw",
            s(&data.join("sdd/p.svg")),
        ],
        60,
    );
    assert!(!ok && text.contains("inside the input folder"), "{text}");
    let _ = std::fs::remove_dir_all(&dir);
    let _ = std::fs::remove_dir_all(&data);
}

#[test]
fn quantize_never_writes_over_its_source_or_an_existing_set() {
    let (dir, blob) = copy_of_set("quantize-out");
    let before = set_bytes(&dir, BLOB);
    let (ok, text) = run_deadline(&["quantize", "--blob", s(&blob), "--out", s(&blob)], 60);
    assert!(!ok && text.contains("same file as the input"), "{text}");
    // Another name whose set exists already: refused without --force, before any work.
    std::fs::write(dir.join("q.json"), b"{}").unwrap();
    let out = dir.join("q.gpec");
    let (ok, text) = run_deadline(&["quantize", "--blob", s(&blob), "--out", s(&out)], 60);
    assert!(!ok && text.contains("use --force"), "{text}");
    assert_eq!(std::fs::read(dir.join("q.json")).unwrap(), b"{}");
    assert!(!out.exists());
    assert_eq!(set_bytes(&dir, BLOB), before, "an input changed");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn export_refuses_an_existing_set_and_a_second_writer() {
    let (dir, _) = copy_of_set("export-existing");
    let before = set_bytes(&dir, BLOB);
    let run = temp_dir("export-existing-run");
    let (ok, text) = run_deadline(
        &["export", "--run", s(&run), "--name", BLOB, "--out", s(&dir)],
        60,
    );
    assert!(!ok, "{text}");
    assert!(
        text.contains("already exist") && text.contains("use --force"),
        "{text}"
    );
    assert_eq!(set_bytes(&dir, BLOB), before);

    // A writer of name "tn" holds the lock: a second one is refused at once.
    let w = gpecnet_trainer::outpath::ArtefactWriter::begin("--out", &dir, "tn", false, &[], &[])
        .unwrap();
    let (ok, text) = run_deadline(
        &["export", "--run", s(&run), "--name", "tn", "--out", s(&dir)],
        60,
    );
    assert!(!ok, "{text}");
    assert!(
        text.contains("another gpecnet command is writing model"),
        "{text}"
    );
    drop(w);
    assert!(!dir.join(".tn.lock").exists());
    let _ = std::fs::remove_dir_all(&dir);
    let _ = std::fs::remove_dir_all(&run);
}

#[test]
fn export_writes_a_verified_set_and_replaces_it_only_with_force() {
    let run = TinyRun::trained("export-set", 1);
    write_sdd(&run.dir, "test", &[("t1", 8), ("t2", 6)]);
    // The constant-velocity baseline of the card picks its window on SDD's validation scenes.
    let val: Vec<(String, usize)> = gpecnet_trainer::data::default_sdd_val_scenes()
        .into_iter()
        .map(|n| (n, 6))
        .collect();
    let val: Vec<(&str, usize)> = val.iter().map(|(n, p)| (n.as_str(), *p)).collect();
    write_sdd(&run.dir, "train", &val);
    let out = run.dir.join("weights");
    let export = |extra: &[&str]| {
        run_deadline(
            &[
                &[
                    "export",
                    "--run",
                    s(&run.out),
                    "--name",
                    "tn",
                    "--out",
                    s(&out),
                    "--data",
                    s(&run.dir),
                    "--k",
                    "3",
                ],
                extra,
            ]
            .concat(),
            300,
        )
    };
    let (ok, text) = export(&[]);
    assert!(ok, "{text}");
    let first = set_bytes(&out, "tn");
    assert!(first.iter().all(|b| !b.is_empty()));
    let blob = gpecnet_core::Model::from_blob(&first[0]).unwrap();
    let golden = gpecnet_core::golden::GoldenSet::parse(&first[1]).unwrap();
    assert_eq!(golden.info().model_crc, blob.crc());
    let (ok, text) = export(&[]);
    assert!(!ok && text.contains("use --force"), "{text}");
    assert_eq!(set_bytes(&out, "tn"), first);
    let (ok, text) = export(&["--force"]);
    assert!(ok, "{text}");
    // Nothing but the set is left in the folder (no staging folder, no lock).
    let mut names: Vec<String> = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect();
    names.sort();
    assert_eq!(names, ["tn.golden", "tn.gpec", "tn.json", "tn.md"]);
}

#[test]
fn blobs_and_runs_that_are_devices_fifos_or_huge_are_refused_at_once() {
    let dir = temp_dir("bounded-read");
    let fifo = dir.join("blob.gpec");
    mkfifo(&fifo);
    let big = dir.join("big.gpec");
    std::fs::File::create(&big)
        .unwrap()
        .set_len(gpecnet_trainer::inpath::MAX_BLOB_BYTES + 1)
        .unwrap();
    let out = dir.join("o.onnx");
    for input in ["/dev/zero", "/dev/urandom", s(&fifo)] {
        let (ok, text) = run_deadline(&["onnx", "--blob", input, "--out", s(&out)], 30);
        assert!(
            !ok && text.contains("not a regular file"),
            "{input}: {text}"
        );
        let (ok, text) = run_deadline(&["eval", "--blob", input, "--draw", s(&out)], 30);
        assert!(
            !ok && text.contains("not a regular file"),
            "{input}: {text}"
        );
        let q = dir.join("q.gpec");
        let (ok, text) = run_deadline(&["quantize", "--blob", input, "--out", s(&q)], 30);
        assert!(
            !ok && text.contains("not a regular file"),
            "{input}: {text}"
        );
        let (ok, text) = run_deadline(&["select", "--run", input], 30);
        assert!(
            !ok && text.contains("not a regular file"),
            "{input}: {text}"
        );
        let (ok, text) = run_deadline(
            &["export", "--run", input, "--name", "x", "--out", s(&dir)],
            30,
        );
        assert!(
            !ok && text.contains("not a regular file"),
            "{input}: {text}"
        );
    }
    let (ok, text) = run_deadline(&["onnx", "--blob", s(&big), "--out", s(&out)], 30);
    assert!(!ok && text.contains("larger than 67108864 bytes"), "{text}");
    let cfg = dir.join("cfg.toml");
    mkfifo(&cfg);
    let (ok, text) = run_deadline(
        &["train", "--config", s(&cfg), "--out", s(&dir.join("run"))],
        30,
    );
    assert!(!ok && text.contains("not a regular file"), "{text}");
    assert!(!out.exists());
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn dangling_and_looping_scene_files_are_errors_naming_them() {
    for (name, make) in [
        ("dangling", 0), // link to a file that does not exist
        ("looping", 1),  // link to itself
    ] {
        let run = TinyRun::new(&format!("scene-{name}"));
        let link = run.dir.join("sdd/train/zz.txt");
        if make == 0 {
            std::os::unix::fs::symlink(run.dir.join("gone.txt"), &link).unwrap();
        } else {
            std::os::unix::fs::symlink(&link, &link).unwrap();
        }
        let (ok, text) = run.train(&["--epochs", "1"]);
        assert!(!ok, "{name}: {text}");
        assert!(text.contains("zz.txt"), "{name}: {text}");
        let e = gpecnet_trainer::data::load_sdd(&run.dir, gpecnet_trainer::data::SddSplit::Train)
            .unwrap_err();
        assert_eq!(e.path(), link, "{name}: {e}");
    }
}

#[test]
fn eth_ucy_duplicate_check_is_not_quadratic() {
    let dir = temp_dir("eth-one-frame");
    let scene = dir.join("eth_ucy/eth/test");
    std::fs::create_dir_all(&scene).unwrap();
    // 100 000 rows in one frame: the old per-row scan took minutes.
    let mut text = String::with_capacity(3_000_000);
    for i in 0..100_000 {
        text += &format!("10\t{i}\t1.5\t2.5\n");
    }
    std::fs::write(scene.join("big.txt"), &text).unwrap();
    let t = Instant::now();
    let d =
        gpecnet_trainer::data::load_eth_ucy(&dir, "eth", gpecnet_trainer::data::EthUcySplit::Test)
            .unwrap();
    assert!(d.windows.is_empty());
    assert!(t.elapsed() < Duration::from_secs(30), "{:?}", t.elapsed());
    // Duplicates are still found.
    text += "10\t77\t3.0\t4.0\n";
    std::fs::write(scene.join("big.txt"), &text).unwrap();
    let e =
        gpecnet_trainer::data::load_eth_ucy(&dir, "eth", gpecnet_trainer::data::EthUcySplit::Test)
            .unwrap_err();
    assert!(e.to_string().contains("ped_id 77 appears twice"), "{e}");
    assert_eq!(e.line(), Some(100_001));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn select_names_the_option_and_its_limit() {
    let dir = temp_dir("select-tts");
    let (ok, text) = run_deadline(&["select", "--run", s(&dir), "--tts", "1000000"], 30);
    assert!(!ok, "{text}");
    assert!(
        text.contains("--tts 1000000") && text.contains("1024"),
        "{text}"
    );
    assert!(!text.contains("integral type conversion"), "{text}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_checkpoint_with_wrong_shapes_falls_back_to_the_previous_one() {
    use gpecnet_trainer::checkpoint;
    let run = TinyRun::trained("ckpt-shapes", 2);
    let path = run.out.join(checkpoint::CHECKPOINT_FILE);
    let bytes = std::fs::read(&path).unwrap();
    let mut c = checkpoint::from_bytes(&bytes, &path).unwrap();
    c.weights[0].pop();
    std::fs::write(&path, checkpoint::to_bytes(&c).unwrap()).unwrap();
    let e = checkpoint::load(&path).unwrap_err();
    assert!(e.to_string().contains("tensor 0"), "{e}");
    let (ok, text) = run.resume(&["--epochs", "3"]);
    assert!(ok, "{text}");
    assert!(
        text.contains("resuming from the previous checkpoint"),
        "{text}"
    );
    assert!(run.out.join(checkpoint::CORRUPT_FILE).exists());
}

#[test]
fn lock_files_are_complete_or_absent() {
    use gpecnet_trainer::rundir::{RunLock, LOCK_FILE};
    let dir = temp_dir("lock-atomic");
    let lock = RunLock::acquire(&dir).unwrap();
    let text = std::fs::read_to_string(dir.join(LOCK_FILE)).unwrap();
    assert!(
        text.starts_with(&format!("pid={}\n", std::process::id())),
        "{text}"
    );
    // The lock's temp file is gone.
    let names: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect();
    assert_eq!(names, [LOCK_FILE]);
    drop(lock);
    assert!(!dir.join(LOCK_FILE).exists());
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn fixed_point_models_far_from_their_source_are_refused_without_force() {
    use gpecnet_trainer::data::Unit;
    use gpecnet_trainer::quantize_blob::check_fixed_tolerance;
    assert!(check_fixed_tolerance(18.77, 18.78, Unit::Pixels, false).is_ok());
    let e = check_fixed_tolerance(19.9, 48.3, Unit::Pixels, false).unwrap_err();
    assert!(
        e.to_string().contains("use --force") && e.to_string().contains("0.5 px"),
        "{e}"
    );
    assert!(check_fixed_tolerance(19.9, 48.3, Unit::Pixels, true).is_ok());
    assert!(check_fixed_tolerance(0.80, 0.85, Unit::Metres, false).is_err());
    assert!(check_fixed_tolerance(0.80, 0.81, Unit::Metres, false).is_ok());
}

#[test]
fn non_finite_and_oversized_config_values_are_refused_naming_the_key() {
    use gpecnet_trainer::config::TrainConfig;
    let wide = format!("[{}]", ["4096"; 7].join(", "));
    let five = format!(
        "enc_past_size = {wide}\nenc_dest_size = {wide}\nenc_latent_size = {wide}\n\
         dec_size = {wide}\npredictor_hidden_size = {wide}"
    );
    for (toml, want) in [
        (
            "dist_thresh = nan",
            "dist_thresh = NaN is not a finite number",
        ),
        (
            "sigma = inf",
            "sigma = inf is out of range: allowed a finite number",
        ),
        (
            "speed_scales = [1.0, nan]",
            "speed_scales: every factor must be a number in [0.25, 4], got NaN",
        ),
        (
            "non_local_dim = 1099511627776",
            "non_local_dim = 1099511627776 is out of range",
        ),
        (
            "nonlocal_pools = 1099511627776",
            "nonlocal_pools = 1099511627776 is out of range",
        ),
        (five.as_str(), "over the limit of 8388608"),
    ] {
        let e = TrainConfig::from_toml_str(toml).unwrap_err();
        let text = format!("{e:#}");
        assert!(text.contains(want), "{toml}: {text}");
    }
    // Every shipped-size config stays well inside the parameter cap.
    assert!(TrainConfig::default().total_param_count() < 4_000_000);
    // The same through the command line, before any work.
    let dir = temp_dir("cfg-nan");
    let cfg = common::write_config(&dir, "dist_thresh = nan");
    let (ok, text) = run_deadline(
        &["train", "--config", s(&cfg), "--out", s(&dir.join("run"))],
        30,
    );
    assert!(!ok && text.contains("dist_thresh"), "{text}");
    assert!(!dir.join("run").exists());
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn config_comparison_never_reports_nan_against_nan() {
    use gpecnet_trainer::config::TrainConfig;
    let a = TrainConfig {
        dist_thresh: f64::NAN,
        ..Default::default()
    };
    let d = gpecnet_trainer::train::config_diff(&a, &a.clone()).unwrap();
    assert!(d.is_empty(), "{d:?}");
    let b = TrainConfig {
        dist_thresh: 5.0,
        ..Default::default()
    };
    let d = gpecnet_trainer::train::config_diff(&a, &b).unwrap();
    assert_eq!(d.len(), 1, "{d:?}");
}

/// `gpecnet eval` on metre data: the metric MCU model prints metres; the pixel default (a
/// format-3 blob, no unit recorded) is refused with a unit error, exit non-zero and no metrics
/// on stdout, before anything is written.
#[test]
fn eval_checks_units_end_to_end() {
    let dir = temp_dir("units");
    let svg = dir.join("p.svg");
    let eval_on_zara1 = |blob: &str| {
        gpecnet()
            .args(["eval", "--blob", s(&weights().join(blob)), "--json"])
            .args(["--dataset", "eth_ucy:zara1", "--draw", s(&svg)])
            .output()
            .unwrap()
    };
    let o = eval_on_zara1("sdd-m-tiny-qe.gpec");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["unit"], "m");
    assert_eq!(v["dataset"], "eth_ucy:zara1");
    assert!(v["min_fde"].as_f64().unwrap() < 1.0, "{v}");
    let _ = std::fs::remove_file(&svg);
    let o = eval_on_zara1("sdd-tiny-v2-qe.gpec");
    assert!(!o.status.success());
    assert!(
        o.stdout.is_empty(),
        "{}",
        String::from_utf8_lossy(&o.stdout)
    );
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("does not state its unit"), "{err}");
    assert!(!svg.exists());
    let _ = std::fs::remove_dir_all(&dir);
}
