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

/// The bytes of every file of `dir`'s set `name`.
fn set_bytes(dir: &Path, name: &str) -> Vec<Vec<u8>> {
    ["gpec", "golden", "json", "md"]
        .iter()
        .map(|e| std::fs::read(dir.join(format!("{name}.{e}"))).unwrap_or_default())
        .collect()
}

/// A fresh key pair in `dir/keys`: (private, public).
fn keygen(dir: &Path) -> (PathBuf, PathBuf) {
    let keys = dir.join("keys");
    let (ok, text) = run(&["keygen", "--out", s(&keys)]);
    assert!(ok, "{text}");
    (
        keys.join("gpecnet-signing.key"),
        keys.join("gpecnet-signing.pub"),
    )
}

fn sign(blob: &Path, key: &Path, out: &Path) -> (bool, String) {
    run(&[
        "sign",
        "--blob",
        s(blob),
        "--key",
        s(key),
        "--version",
        "3",
        "--out",
        s(out),
    ])
}

/// `sign --out` never names the blob's own golden file or cards (nor the blob or the key).
#[test]
fn sign_never_writes_over_the_blobs_golden_file_or_cards() {
    let dir = temp_dir("sign-sidecars");
    let blob = copy_set(&dir, "sdd-tiny-qe");
    let (sk, _) = keygen(&dir);
    let before = set_bytes(&dir, "sdd-tiny-qe");
    for ext in ["golden", "json", "md", "gpec"] {
        let (ok, text) = sign(&blob, &sk, &dir.join(format!("sdd-tiny-qe.{ext}")));
        assert!(
            !ok && text.contains("same file as the input"),
            "{ext}: {text}"
        );
    }
    let (ok, text) = sign(&blob, &sk, &sk);
    assert!(!ok && text.contains("same file as the input"), "{text}");
    assert_eq!(set_bytes(&dir, "sdd-tiny-qe"), before, "an input changed");
    let (ok, text) = sign(&blob, &sk, &dir.join("signed.gpec"));
    assert!(ok, "{text}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// A public key file is refused as the signing key (by `sign`, `export` and `quantize`),
/// a private key as the verifying key, and a private key others may read is not used;
/// an untagged private key (written before keys said what they are) still signs.
#[test]
fn key_files_are_refused_in_the_wrong_role() {
    use std::os::unix::fs::PermissionsExt;
    let dir = temp_dir("key-roles");
    let blob = copy_set(&dir, "sdd-tiny-qe");
    let (sk, pk) = keygen(&dir);
    let out = dir.join("signed.gpec");
    let (ok, text) = sign(&blob, &pk, &out);
    assert!(!ok && text.contains("public key file"), "{text}");
    // A copy of the public key under another name, beside it.
    let disguised = pk.with_file_name("release.key");
    std::fs::copy(&pk, &disguised).unwrap();
    std::fs::set_permissions(&disguised, std::fs::Permissions::from_mode(0o600)).unwrap();
    let (ok, text) = sign(&blob, &disguised, &out);
    assert!(!ok && text.contains("holds the public key"), "{text}");
    let (ok, text) = run(&[
        "quantize",
        "--blob",
        s(&weights().join("sdd-tiny.gpec")),
        "--out",
        s(&dir.join("q.gpec")),
        "--sign-key",
        s(&pk),
        "--sign-version",
        "2",
    ]);
    assert!(!ok && text.contains("public key file"), "{text}");
    assert!(!out.exists() && !dir.join("q.gpec").exists());
    // The private key is not a public key.
    let (ok, text) = sign(&blob, &sk, &out);
    assert!(ok, "{text}");
    let verify = |key: &Path| {
        run(&[
            "verify",
            "--blob",
            s(&out),
            "--pubkey",
            s(key),
            "--min-version",
            "3",
        ])
    };
    let (ok, text) = verify(&sk);
    assert!(!ok && text.contains("private key"), "{text}");
    let secret = std::fs::read_to_string(&sk).unwrap();
    let hex = secret.lines().last().unwrap();
    assert!(!text.contains(hex), "the private key was printed");
    assert!(verify(&pk).0);
    // Readable by others: refused, naming the fix.
    std::fs::set_permissions(&sk, std::fs::Permissions::from_mode(0o644)).unwrap();
    let (ok, text) = sign(&blob, &sk, &dir.join("other.gpec"));
    assert!(!ok && text.contains("chmod 600"), "{text}");
    std::fs::set_permissions(&sk, std::fs::Permissions::from_mode(0o600)).unwrap();
    // An untagged private key (64 hex digits alone) still signs, and still is no public key.
    let legacy = sk.with_file_name("gpecnet-signing-old.key");
    std::fs::write(&legacy, format!("{hex}\n")).unwrap();
    std::fs::set_permissions(&legacy, std::fs::Permissions::from_mode(0o600)).unwrap();
    let (ok, text) = sign(&blob, &legacy, &dir.join("legacy.gpec"));
    assert!(ok, "{text}");
    let (ok, text) = run(&[
        "verify",
        "--blob",
        s(&dir.join("legacy.gpec")),
        "--pubkey",
        s(&legacy),
    ]);
    assert!(!ok && text.contains("private key of"), "{text}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// A keygen that cannot write its files (here: a file-size limit of 0) leaves no key
/// behind, so the retry succeeds.
#[test]
fn a_failed_keygen_leaves_nothing_behind() {
    let dir = temp_dir("keygen-fail");
    let keys = dir.join("keys");
    let o = Command::new("sh")
        .arg("-c")
        .arg("trap '' XFSZ; ulimit -f 0; exec \"$0\" keygen --out \"$1\"")
        .arg(env!("CARGO_BIN_EXE_gpecnet"))
        .arg(&keys)
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success(), "{text}");
    let left: Vec<_> = std::fs::read_dir(&keys)
        .map(|r| r.map(|e| e.unwrap().file_name()).collect())
        .unwrap_or_default();
    assert!(left.is_empty(), "left behind: {left:?} ({text})");
    let (ok, text) = run(&["keygen", "--out", s(&keys)]);
    assert!(ok, "{text}");
    let _ = std::fs::remove_dir_all(&dir);
}
