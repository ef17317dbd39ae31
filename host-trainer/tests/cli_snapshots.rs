//! What the `gpecnet` command line prints, snapshotted: every command's `--help` and the
//! report of `gpecnet eval` on a shipped model, compared with the files in
//! `tests/snapshots/`. A change fails here until the snapshot is updated on purpose:
//!
//! ```sh
//! UPDATE_SNAPSHOTS=1 cargo test -p gpecnet-trainer --test it cli_snapshots::
//! ```
use std::path::{Path, PathBuf};

use crate::common::{run, s};

fn snapshot_path(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/snapshots")
        .join(name)
}

/// `text` with the repository's absolute path (in defaults such as `--data`'s, which the
/// build fixes) written as `<repo>`, so a snapshot holds for every checkout.
fn portable(text: &str) -> String {
    let repo = Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .map(|p| p.display().to_string())
        .unwrap_or_default();
    if repo.is_empty() {
        text.to_string()
    } else {
        text.replace(&repo, "<repo>")
    }
}

/// Compares `now` (its repository path made [`portable`]) with the snapshot `name` (or
/// rewrites it with `UPDATE_SNAPSHOTS=1`), naming the first line that differs.
fn assert_snapshot(name: &str, now: &str) {
    let now = portable(now);
    let path = snapshot_path(name);
    if std::env::var_os("UPDATE_SNAPSHOTS").is_some() {
        std::fs::write(&path, now).unwrap();
        return;
    }
    let snap = std::fs::read_to_string(&path).unwrap_or_default();
    if snap != now {
        let first = snap
            .lines()
            .zip(now.lines())
            .position(|(a, b)| a != b)
            .unwrap_or(snap.lines().count().min(now.lines().count()));
        panic!(
            "{} changed at line {} (rerun with UPDATE_SNAPSHOTS=1 if on purpose):\n  was: {:?}\n  now: {:?}",
            path.display(),
            first + 1,
            snap.lines().nth(first).unwrap_or(""),
            now.lines().nth(first).unwrap_or("")
        );
    }
}

/// The subcommand names listed under "Commands:" in `gpecnet --help`.
fn subcommands(help: &str) -> Vec<String> {
    help.lines()
        .skip_while(|l| !l.starts_with("Commands:"))
        .skip(1)
        .take_while(|l| l.starts_with("  "))
        .filter_map(|l| l.split_whitespace().next())
        .filter(|c| *c != "help")
        .map(str::to_string)
        .collect()
}

#[test]
fn every_commands_help_matches_the_snapshot() {
    let (ok, top) = run(&["--help"]);
    assert!(ok, "{top}");
    let commands = subcommands(&top);
    assert!(
        commands.len() >= 10 && commands.iter().any(|c| c == "train"),
        "the command list was not found in:\n{top}"
    );
    let mut all = format!("$ gpecnet --help\n{top}");
    for c in &commands {
        let (ok, text) = run(&[c, "--help"]);
        assert!(ok, "gpecnet {c} --help: {text}");
        all += &format!("\n$ gpecnet {c} --help\n{text}");
    }
    assert_snapshot("cli-help.txt", &all);
}

#[test]
fn the_eval_report_of_a_shipped_model_matches_the_snapshot() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let data = root.join("../shared/data");
    if !data.join("sdd").is_dir() {
        panic!("{} is missing (see shared/data/README.md)", data.display());
    }
    let blob = root.join("weights/sdd-m-lp-qe.gpec");
    let tmp = tempfile::tempdir().unwrap();
    let draw = tmp.path().join("predictions.svg");
    let (ok, text) = run(&[
        "eval",
        "--blob",
        s(&blob),
        "--dataset",
        "sdd-m",
        "--data",
        s(&data),
        "--draw",
        s(&draw),
    ]);
    assert!(ok, "{text}");
    assert!(draw.is_file(), "the drawing was not written");
    // The one line that names a temporary path.
    let report: String = text
        .lines()
        .filter(|l| !l.starts_with("drew predictions to "))
        .map(|l| format!("{l}\n"))
        .collect();
    assert_snapshot("eval-sdd-m-lp-qe.txt", &report);
}
