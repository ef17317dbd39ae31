//! Nothing lost on the newer surfaces (signing, scoring, proposals, own data): outputs never
//! written through planted links nor over inputs, one writer per output, numeric options
//! bounded before any work, keys in their role, unit and clock checks wherever a blob meets
//! data (docs/errors-and-safety.md).

use crate::common;

use std::path::{Path, PathBuf};
use std::process::Command;

use common::{run, s, temp_dir};

fn weights() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../weights")
}

/// Copies the shipped set `name` (blob, golden file, cards) into `dir`; returns the blob.
fn copy_set(dir: &Path, name: &str) -> PathBuf {
    for ext in ["gpec", "golden", "json", "md"] {
        std::fs::copy(
            weights().join(format!("{name}.{ext}")),
            dir.join(format!("{name}.{ext}")),
        )
        .unwrap();
    }
    dir.join(format!("{name}.gpec"))
}

/// A link planted at the temp name earlier versions used for `target` in its folder
/// (`.<name>.tmp.<pid>` of the process about to start: the shell's pid, which `exec`
/// keeps), and at many names around it; then `gpecnet args` is exec'd.
fn exec_with_planted_links(target: &Path, victim: &Path, args: &[&str]) -> (bool, String) {
    let dir = target.parent().unwrap();
    let name = target.file_name().unwrap().to_str().unwrap();
    let script = format!(
        "cd \"$1\" && for i in '' 1 2 3 4 5 6 7 8 9; do ln -s \"$2\" \".{name}.tmp.$$$i\"; done \
         && shift 2 && exec \"$@\""
    );
    let o = Command::new("sh")
        .arg("-c")
        .arg(script)
        .arg("sh")
        .arg(dir)
        .arg(victim)
        .arg(env!("CARGO_BIN_EXE_gpecnet"))
        .args(args)
        .output()
        .unwrap();
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    (o.status.success(), text)
}

/// The atomic write never follows a link planted at its temp name: `eval --draw` writes its
/// drawing and leaves the link's target as it was.
#[test]
fn a_link_planted_at_the_temp_name_is_never_written_through() {
    let dir = temp_dir("planted-temp");
    let victim = dir.join("victim");
    std::fs::write(&victim, b"precious").unwrap();
    let svg = dir.join("d.svg");
    let blob = weights().join("sdd-m-tiny-qe.gpec");
    let (ok, text) = exec_with_planted_links(
        &svg,
        &victim,
        &[
            "eval",
            "--blob",
            s(&blob),
            "--dataset",
            "eth_ucy:zara1",
            "--draw",
            s(&svg),
        ],
    );
    assert!(ok, "{text}");
    assert_eq!(std::fs::read(&victim).unwrap(), b"precious", "{text}");
    assert!(std::fs::read_to_string(&svg).unwrap().contains("<svg"));
    let _ = std::fs::remove_dir_all(&dir);
}

/// A proposal model gives K endpoints: `eval --k K+1` and `quantize --k K+1` are refused
/// before any work, naming the option and the limit, and write nothing.
#[test]
fn k_above_a_proposal_models_latents_is_refused_up_front() {
    let dir = temp_dir("k-over");
    let empty = temp_dir("k-over-data");
    let (ok, text) = run(&[
        "eval",
        "--blob",
        s(&weights().join("sdd-m-lp-qe.gpec")),
        "--data",
        s(&empty),
        "--k",
        "21",
    ]);
    assert!(!ok, "{text}");
    assert!(text.contains("--k 21") && text.contains("1..=20"), "{text}");
    let src = copy_set(&dir, "sdd-m-lp");
    let out = dir.join("q.gpec");
    let (ok, text) = run(&[
        "quantize",
        "--blob",
        s(&src),
        "--out",
        s(&out),
        "--data",
        s(&empty),
        "--k",
        "21",
    ]);
    assert!(!ok, "{text}");
    assert!(text.contains("--k 21") && text.contains("1..=20"), "{text}");
    assert!(!out.exists() && !dir.join("q.golden").exists());
    let _ = std::fs::remove_dir_all(&dir);
    let _ = std::fs::remove_dir_all(&empty);
}
