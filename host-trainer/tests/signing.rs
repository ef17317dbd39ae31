//! `gpecnet keygen`, `sign` and `verify` end to end: key files (mode 0600,
//! never overwritten), a signed blob that verifies and predicts as before,
//! and every refusal named: wrong key, tampered byte, truncated file, an
//! unsigned blob, a rolled-back version, an output over an input.

use crate::common;

use std::os::unix::fs::PermissionsExt;
use std::path::Path;

use common::{copy_set, quantize, run, s, temp_dir, weights};

#[test]
fn keygen_sign_verify_and_every_refusal() {
    let dir = temp_dir("signing");
    let (keys, other) = (dir.join("keys"), dir.join("other"));
    let (ok, text) = run(&["keygen", "--out", s(&keys)]);
    assert!(ok, "{text}");
    let sk = keys.join("gpecnet-signing.key");
    let pk = keys.join("gpecnet-signing.pub");
    let mode = std::fs::metadata(&sk).unwrap().permissions().mode() & 0o777;
    assert_eq!(mode, 0o600);
    let secret = std::fs::read_to_string(&sk).unwrap();
    assert!(
        !text.contains(secret.trim()),
        "keygen printed the private key"
    );
    // Never overwritten.
    let (ok, text) = run(&["keygen", "--out", s(&keys)]);
    assert!(!ok && text.contains("never overwrites"), "{text}");
    assert_eq!(std::fs::read_to_string(&sk).unwrap(), secret);
    assert!(run(&["keygen", "--out", s(&other)]).0);

    let blob = dir.join("m.gpec");
    std::fs::copy(weights("sdd-tiny-qe.gpec"), &blob).unwrap();
    let signed = dir.join("m.signed.gpec");
    let sign = |out: &Path, version: &str| {
        run(&[
            "sign",
            "--blob",
            s(&blob),
            "--key",
            s(&sk),
            "--version",
            version,
            "--out",
            s(out),
        ])
    };
    // Never over the input.
    let (ok, text) = sign(&blob, "3");
    assert!(!ok && text.contains("same file as the input"), "{text}");
    let (ok, text) = sign(&signed, "3");
    assert!(ok, "{text}");
    let verify = |b: &Path, key: &Path, min: &str| {
        run(&[
            "verify",
            "--blob",
            s(b),
            "--pubkey",
            s(key),
            "--min-version",
            min,
        ])
    };
    let (ok, text) = verify(&signed, &pk, "3");
    assert!(
        ok && text.contains("signature ok") && text.contains("version 3"),
        "{text}"
    );
    // Signing changes no prediction: the shipped card is reproduced from the signed blob.
    let (ok, text) = run(&["eval", "--blob", s(&signed)]);
    assert!(ok, "{text}");

    let refused = |b: &Path, key: &Path, min: &str, why: &str| {
        let (ok, text) = verify(b, key, min);
        assert!(
            !ok && text.contains(why),
            "{}: want {why:?}: {text}",
            b.display()
        );
    };
    refused(
        &signed,
        &other.join("gpecnet-signing.pub"),
        "0",
        "not trusted",
    );
    refused(&signed, &pk, "4", "older than the minimum 4");
    refused(&blob, &pk, "0", "not signed");
    let bytes = std::fs::read(&signed).unwrap();
    for (i, name) in [
        (100, "body"),
        (bytes.len() - 67, "version"),
        (bytes.len() - 5, "signature"),
    ] {
        let mut t = bytes.clone();
        t[i] ^= 0x10;
        let p = dir.join(format!("tampered-{name}.gpec"));
        std::fs::write(&p, &t).unwrap();
        refused(&p, &pk, "0", "does not verify");
    }
    let cut = dir.join("cut.gpec");
    std::fs::write(&cut, &bytes[..bytes.len() - 1]).unwrap();
    refused(&cut, &pk, "0", "not signed");
    // A signed blob is not signed twice.
    let (ok, text) = run(&[
        "sign",
        "--blob",
        s(&signed),
        "--key",
        s(&sk),
        "--version",
        "4",
        "--out",
        s(&dir.join("twice.gpec")),
    ]);
    assert!(!ok && text.contains("signed already"), "{text}");
    // A key file that is not one.
    let (ok, text) = verify(&signed, &blob, "0");
    assert!(!ok, "{text}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// The shipped metric MCU blob verifies under the test key committed beside it.
#[test]
fn shipped_mcu_blob_verifies_with_the_test_key() {
    let (ok, text) = run(&[
        "verify",
        "--blob",
        s(&weights("sdd-m-tiny-qe.gpec")),
        "--pubkey",
        s(&weights("test-signing-key.pub")),
        "--min-version",
        "1",
    ]);
    assert!(ok && text.contains("model sdd-m-tiny-qe"), "{text}");
}

/// `quantize --sign-key K --sign-version V` writes the fixed-point blob signed, its golden
/// file naming the blob inside; half the signing options are refused by the parser.
#[test]
fn quantize_signs_as_it_writes() {
    let dir = temp_dir("sign-quantize");
    let keys = dir.join("keys");
    assert!(run(&["keygen", "--out", s(&keys)]).0);
    let src = copy_set(&dir, "sdd-tiny");
    let out = dir.join("q.gpec");
    let key = keys.join("gpecnet-signing.key");
    let (ok, text) = quantize(&src, &out, &["--sign-key", s(&key)]);
    assert!(!ok && text.contains("--sign-version"), "{text}");
    let (ok, text) = quantize(&src, &out, &["--sign-key", s(&key), "--sign-version", "4"]);
    assert!(ok, "{text}");
    let (ok, text) = run(&[
        "verify",
        "--blob",
        s(&out),
        "--pubkey",
        s(&keys.join("gpecnet-signing.pub")),
        "--min-version",
        "4",
    ]);
    assert!(ok && text.contains("version 4"), "{text}");
    // The golden file belongs to the blob inside: eval replays and reproduces the card.
    let (ok, text) = run(&["eval", "--blob", s(&out)]);
    assert!(ok && text.contains("reproduced exactly"), "{text}");
    let _ = std::fs::remove_dir_all(&dir);
}
