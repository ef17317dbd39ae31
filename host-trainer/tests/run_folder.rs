//! Run-folder safety of `gpecnet train`, on the real binary with tiny data:
//! the run lock, no silent overwrite, `--resume` config and data checks, stale temp files,
//! the previous-checkpoint fallback.

use crate::common;

use std::path::Path;
use std::time::{Duration, Instant};

use common::*;
use gpecnet_trainer::checkpoint;
use gpecnet_trainer::rundir::{self, LOCK_FILE};

fn write_lock(out: &Path, pid: u32) {
    std::fs::create_dir_all(out).unwrap();
    std::fs::write(
        out.join(LOCK_FILE),
        format!("pid={pid}\nhost={}\nstarted=1\n", rundir::host_name()),
    )
    .unwrap();
}

#[test]
fn a_locked_folder_is_refused_and_a_dead_lock_taken_over() {
    let r = TinyRun::new("lock");
    let out = &r.out;

    // A lock held by a live process (this test) on this host: refused, nothing written.
    write_lock(out, std::process::id());
    let (ok, text) = r.train(&[]);
    assert!(!ok, "{text}");
    assert!(text.contains("in use by another gpecnet run"), "{text}");
    assert!(
        text.contains(&format!("pid {}", std::process::id())),
        "{text}"
    );
    assert!(!out.join("config.toml").exists());
    assert!(
        out.join(LOCK_FILE).exists(),
        "someone else's lock was removed"
    );

    // A lock of a dead process on this host: taken over with a warning, removed at exit.
    write_lock(out, dead_pid());
    let (ok, text) = r.train(&[]);
    assert!(ok, "{text}");
    assert!(text.contains("taking over the stale run lock"), "{text}");
    assert!(out.join(checkpoint::CHECKPOINT_FILE).exists());
    assert!(!out.join(LOCK_FILE).exists(), "lock not removed at exit");
}

#[test]
fn two_concurrent_runs_into_one_folder() {
    let r = TinyRun::new("concurrent");
    let (dir, cfg, out) = (&r.dir, &r.cfg, &r.out);
    let mut first = gpecnet()
        .args(["train", "--quiet", "--data"])
        .arg(dir)
        .arg("--out")
        .arg(out)
        .arg("--config")
        .arg(cfg)
        .args(["--epochs", "100000"])
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let t0 = Instant::now();
    while !out.join(checkpoint::CHECKPOINT_FILE).exists() {
        assert!(
            t0.elapsed() < Duration::from_secs(60),
            "first run never wrote a checkpoint"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
    let (ok, text) = r.train(&["--force"]);
    assert!(!ok, "second run into a busy folder succeeded: {text}");
    assert!(text.contains("in use by another gpecnet run"), "{text}");
    let (ok, text) = r.resume(&[]);
    assert!(!ok, "resume into a busy folder succeeded: {text}");
    assert!(text.contains("in use"), "{text}");

    // Kill the first run: its lock is stale (dead pid) and --resume takes it over.
    first.kill().unwrap();
    first.wait().unwrap();
    let done = checkpoint::load(out).unwrap().epochs_done;
    let epochs = (done + 1).to_string();
    let (ok, text) = r.resume(&["--epochs", &epochs]);
    assert!(ok, "{text}");
    assert_eq!(checkpoint::load(out).unwrap().epochs_done, done + 1);
    assert!(!out.join(LOCK_FILE).exists());
}

#[test]
fn a_non_empty_folder_is_not_overwritten_without_force() {
    let r = TinyRun::new("nonempty");
    let (dir, cfg, out) = (&r.dir, &r.cfg, &r.out);
    std::fs::create_dir_all(out).unwrap();
    std::fs::write(out.join("config.toml"), "my notes").unwrap();
    std::fs::write(out.join("metrics.csv"), "precious").unwrap();

    let (ok, text) = r.train(&[]);
    assert!(!ok, "{text}");
    assert!(
        text.contains("is not empty") && text.contains("--force"),
        "{text}"
    );
    assert!(
        text.contains("config.toml") && text.contains("metrics.csv"),
        "{text}"
    );
    assert_eq!(
        std::fs::read_to_string(out.join("config.toml")).unwrap(),
        "my notes"
    );
    assert_eq!(
        std::fs::read_to_string(out.join("metrics.csv")).unwrap(),
        "precious"
    );
    assert!(!out.join(LOCK_FILE).exists());

    // A run that fails while loading the data writes nothing: the folder stays as it was.
    let fresh = dir.join("fresh");
    let (ok, text) = train(
        &dir.join("no-such-data"),
        &fresh,
        &["--config", cfg.to_str().unwrap()],
    );
    assert!(!ok, "{text}");
    assert_eq!(
        rundir::existing_entries(&fresh).unwrap(),
        Vec::<String>::new()
    );
    assert!(!fresh.join(LOCK_FILE).exists());
    let (ok, text) = train(dir, &fresh, &["--config", cfg.to_str().unwrap()]);
    assert!(ok, "{text}");

    let (ok, text) = r.train(&["--force"]);
    assert!(ok, "{text}");
    assert!(out.join(checkpoint::CHECKPOINT_FILE).exists());
    assert_ne!(
        std::fs::read_to_string(out.join("config.toml")).unwrap(),
        "my notes"
    );

    // A folder with a checkpoint is never restarted, --force or not.
    let (ok, text) = r.train(&["--force"]);
    assert!(!ok, "{text}");
    assert!(text.contains("--resume"), "{text}");
}

#[test]
fn resume_refuses_a_different_config() {
    let r = TinyRun::trained("resume-config", 1);
    let (dir, cfg, out) = (&r.dir, &r.cfg, &r.out);

    // --config equal to the run's (num_epochs aside) is accepted.
    let (ok, text) = r.resume(&["--config", cfg.to_str().unwrap(), "--epochs", "1"]);
    assert!(ok, "{text}");

    // A different --config: refused, naming the key.
    let other = dir.join("other.toml");
    std::fs::write(
        &other,
        tiny_config("").replace("learning_rate = 1e-3", "learning_rate = 2e-3"),
    )
    .unwrap();
    let (ok, text) = r.resume(&["--config", other.to_str().unwrap()]);
    assert!(!ok, "{text}");
    assert!(text.contains("learning_rate: 0.001 -> 0.002"), "{text}");

    // The folder's config.toml replaced by another run's: refused, naming the key.
    let mut toml = std::fs::read_to_string(out.join("config.toml")).unwrap();
    toml = toml.replace("seed = 5", "seed = 6");
    std::fs::write(out.join("config.toml"), toml).unwrap();
    let (ok, text) = r.resume(&[]);
    assert!(!ok, "{text}");
    assert!(
        text.contains("seed: 5 -> 6") && text.contains("config.toml"),
        "{text}"
    );
}

#[test]
fn resume_refuses_different_data() {
    let r = TinyRun::trained("resume-data", 1);
    let (dir, out) = (&r.dir, &r.out);
    assert!(out.join("data-fingerprint.json").exists());

    // A training scene goes missing.
    let c = dir.join("sdd/train/c.txt");
    let saved = std::fs::read(&c).unwrap();
    std::fs::remove_file(&c).unwrap();
    let (ok, text) = r.resume(&["--epochs", "2"]);
    assert!(!ok, "{text}");
    assert!(text.contains("training scenes missing now: c"), "{text}");

    // Same scenes and counts, one coordinate changed.
    let text0 = String::from_utf8(saved.clone()).unwrap();
    let (first, rest) = text0.split_once('\n').unwrap();
    let mut cols: Vec<String> = first.split(' ').map(String::from).collect();
    cols[2] = format!("{}", cols[2].parse::<f32>().unwrap() + 1.0);
    let changed = format!("{}\n{rest}", cols.join(" "));
    std::fs::write(&c, changed).unwrap();
    let (ok, text) = r.resume(&["--epochs", "2"]);
    assert!(!ok, "{text}");
    assert!(text.contains("different window contents"), "{text}");

    // The original data: resumes.
    std::fs::write(&c, saved).unwrap();
    let (ok, text) = r.resume(&["--epochs", "2"]);
    assert!(ok, "{text}");
    assert_eq!(checkpoint::load(out).unwrap().epochs_done, 2);
}

#[test]
fn stale_temp_files_are_removed_and_named_when_a_write_fails() {
    let r = TinyRun::trained("tmpfiles", 1);
    let out = &r.out;

    // Leftovers of a killed run (another pid).
    let stale = out.join(format!(".checkpoint.bin.tmp.{}", dead_pid()));
    std::fs::write(&stale, vec![0u8; 4096]).unwrap();
    let stale_csv = out.join(format!(".metrics.csv.tmp.{}", dead_pid()));
    std::fs::write(&stale_csv, "x").unwrap();
    let (ok, text) = r.resume(&["--epochs", "2"]);
    assert!(ok, "{text}");
    assert!(text.contains("removed stale temp file"), "{text}");
    assert!(!stale.exists() && !stale_csv.exists());

    // A failing checkpoint write (the destination is taken by a non-empty directory, so the
    // rename fails) names the temp files still in the folder and leaves none of its own. A
    // directory at this process's old temp name is no obstacle: temp names are fresh.
    let leftover = out.join(".checkpoint.bin.tmp.999999999");
    std::fs::write(&leftover, vec![0u8; 100]).unwrap();
    let planted = out.join(format!(".checkpoint.bin.tmp.{}", std::process::id()));
    std::fs::create_dir(&planted).unwrap();
    let ckpt = checkpoint::load(out).unwrap();
    let path = out.join(checkpoint::CHECKPOINT_FILE);
    let aside = out.join("aside.bin");
    std::fs::rename(&path, &aside).unwrap();
    std::fs::create_dir(&path).unwrap();
    std::fs::write(path.join("x"), b"x").unwrap();
    let e = checkpoint::save(out, &ckpt).unwrap_err().to_string();
    assert!(
        e.contains(".checkpoint.bin.tmp.999999999 (100 bytes)"),
        "{e}"
    );
    assert!(
        e.contains("interrupted writes") && e.contains("removed the partial"),
        "{e}"
    );
    let mine = format!(".checkpoint.bin.tmp.{}.", std::process::id());
    let left: Vec<String> = std::fs::read_dir(out)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with(&mine))
        .collect();
    assert!(left.is_empty(), "{left:?}");
    std::fs::remove_dir_all(&path).unwrap();
    std::fs::rename(&aside, &path).unwrap();
    std::fs::remove_dir(&planted).unwrap();
}

#[test]
fn a_corrupt_checkpoint_falls_back_to_the_previous_one() {
    let r = TinyRun::trained("fallback", 2);
    let out = &r.out;
    let prev = checkpoint::load(&out.join(checkpoint::PREV_FILE)).unwrap();
    assert_eq!(prev.epochs_done, 1);

    // Flip a byte of the newest checkpoint: --resume warns and continues from epoch 1.
    let path = out.join(checkpoint::CHECKPOINT_FILE);
    let mut bytes = std::fs::read(&path).unwrap();
    let n = bytes.len();
    bytes[n / 2] ^= 0x10;
    std::fs::write(&path, &bytes).unwrap();
    let (ok, text) = r.resume(&["--epochs", "2"]);
    assert!(ok, "{text}");
    assert!(
        text.contains("corrupt") && text.contains("checkpoint.prev.bin"),
        "{text}"
    );
    assert!(text.contains("(epoch 1)"), "{text}");
    assert_eq!(checkpoint::load(out).unwrap().epochs_done, 2);
    assert!(out.join(checkpoint::CORRUPT_FILE).exists());

    // Both unusable: an error naming both.
    std::fs::write(&path, b"junk").unwrap();
    std::fs::write(out.join(checkpoint::PREV_FILE), b"junk").unwrap();
    let (ok, text) = r.resume(&["--epochs", "3"]);
    assert!(!ok, "{text}");
    assert!(
        text.contains("no usable checkpoint") && text.contains("previous"),
        "{text}"
    );
}
