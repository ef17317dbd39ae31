//! Exact resume and determinism of `gpecnet train` on the real SDD data (tiny model).
//!
//! * 3 epochs straight == 1 epoch, "kill" (drop all in-process state, reload from disk),
//!   resume for 2 more: bit-identical weights, optimizer state, RNG and history.
//! * Two identical runs give identical weights (candle CPU matmul with a pinned thread count).
//! * A truncated or corrupted checkpoint is a clear error, not a panic.
//!
//! All tests pin `threads = 2`, so the process-wide thread setting is the same for all of them.

use crate::common;

use std::path::{Path, PathBuf};

use common::tiny_train_config;
use gpecnet_trainer::checkpoint::{self, CheckpointError};
use gpecnet_trainer::config::TrainConfig;
use gpecnet_trainer::data;
use gpecnet_trainer::train::{train_new, train_resume, TrainOptions};

fn tiny_config() -> TrainConfig {
    tiny_train_config()
}

fn run_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!(
        "gpecnet-train-resume-{}-{name}",
        std::process::id()
    ));
    let _ = std::fs::remove_dir_all(&d);
    d
}

fn opts(dir: &Path, epochs: Option<usize>, stop_after: Option<usize>) -> TrainOptions {
    TrainOptions {
        data_root: data::default_data_root(),
        run_dir: dir.to_path_buf(),
        epochs,
        quiet: true,
        stop_after,
        force: false,
    }
}

/// Checkpoint with wall-clock times removed (they legitimately differ).
fn comparable(dir: &Path) -> checkpoint::Checkpoint {
    let mut c = checkpoint::load(dir).unwrap();
    for m in &mut c.history {
        m.seconds = 0.0;
    }
    c
}

#[test]
fn resume_is_bit_exact_and_runs_are_deterministic() {
    let straight = run_dir("straight");
    let s = train_new(tiny_config(), &opts(&straight, None, None)).unwrap();
    assert_eq!(s.epochs_done, 3);

    // 1 epoch, then the process "dies": nothing but the run directory survives.
    let killed = run_dir("killed");
    let s1 = train_new(tiny_config(), &opts(&killed, None, Some(1))).unwrap();
    assert_eq!(s1.epochs_done, 1);
    assert_eq!(checkpoint::load(&killed).unwrap().epochs_done, 1);
    let s2 = train_resume(&opts(&killed, None, None)).unwrap();
    assert_eq!(s2.epochs_done, 3);

    let a = comparable(&straight);
    let b = comparable(&killed);
    assert_eq!(a.weights, b.weights, "weights differ after resume");
    assert_eq!(a.adam, b.adam);
    assert_eq!(a.rng, b.rng);
    assert_eq!(a.best, b.best);
    assert_eq!(a.history, b.history);

    // A second identical run: identical weights (determinism of candle CPU with 2 threads).
    let again = run_dir("again");
    train_new(tiny_config(), &opts(&again, None, None)).unwrap();
    assert_eq!(
        comparable(&again).weights,
        a.weights,
        "two identical runs differ"
    );

    // The metrics files exist and have a header + one line per epoch.
    let csv = std::fs::read_to_string(killed.join("metrics.csv")).unwrap();
    assert_eq!(csv.lines().count(), 4);
    assert!(killed.join("curves.svg").exists());
    assert_eq!(
        std::fs::read_to_string(killed.join("metrics.jsonl"))
            .unwrap()
            .lines()
            .count(),
        3
    );

    // Starting a new run over an existing checkpoint is refused.
    let err = train_new(tiny_config(), &opts(&straight, None, None)).unwrap_err();
    assert!(err.to_string().contains("--resume"), "{err}");

    for d in [straight, killed, again] {
        let _ = std::fs::remove_dir_all(d);
    }
}

#[test]
fn corrupt_checkpoint_is_a_clear_error() {
    let dir = run_dir("corrupt");
    train_new(tiny_config(), &opts(&dir, Some(1), None)).unwrap();
    let path = dir.join(checkpoint::CHECKPOINT_FILE);
    let bytes = std::fs::read(&path).unwrap();

    // Truncated.
    std::fs::write(&path, &bytes[..bytes.len() / 2]).unwrap();
    let e = checkpoint::load(&dir).unwrap_err();
    assert!(matches!(e, CheckpointError::Truncated { .. }), "{e}");
    assert!(e.to_string().contains("truncated"), "{e}");
    let e = train_resume(&opts(&dir, None, None)).unwrap_err();
    assert!(format!("{e:#}").contains("truncated"), "{e:#}");

    // One flipped bit in the payload.
    let mut bad = bytes.clone();
    let n = bad.len();
    bad[n / 2] ^= 0x10;
    std::fs::write(&path, &bad).unwrap();
    let e = checkpoint::load(&dir).unwrap_err();
    assert!(matches!(e, CheckpointError::Checksum { .. }), "{e}");

    // Not a checkpoint at all / missing.
    std::fs::write(&path, b"garbage").unwrap();
    assert!(checkpoint::load(&dir).is_err());
    std::fs::remove_file(&path).unwrap();
    let e = train_resume(&opts(&dir, None, None)).unwrap_err();
    assert!(format!("{e:#}").contains("checkpoint.bin"), "{e:#}");

    let _ = std::fs::remove_dir_all(dir);
}
