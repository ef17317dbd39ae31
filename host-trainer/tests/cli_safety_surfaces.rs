//! Nothing lost on the newer surfaces (signing, scoring, proposals, own data): outputs never
//! written through planted links nor over inputs, one writer per output, numeric options
//! bounded before any work, keys in their role, unit and clock checks wherever a blob meets
//! data (docs/errors-and-safety.md).

use crate::common;

use std::path::{Path, PathBuf};
use std::process::Command;

use common::{copy_set, own_data_refusal, quantize, run, s, temp_dir, weights};

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
    let blob = weights("sdd-m-tiny-qe.gpec");
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
        s(&weights("sdd-m-lp-qe.gpec")),
        "--data",
        s(&empty),
        "--k",
        "21",
    ]);
    assert!(!ok, "{text}");
    assert!(text.contains("--k 21") && text.contains("1..=20"), "{text}");
    let src = copy_set(&dir, "sdd-m-lp");
    let out = dir.join("q.gpec");
    let (ok, text) = quantize(&src, &out, &["--data", s(&empty), "--k", "21"]);
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
    let (ok, text) = quantize(
        &weights("sdd-tiny.gpec"),
        &dir.join("q.gpec"),
        &["--sign-key", s(&pk), "--sign-version", "2"],
    );
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

/// Two `score` runs into one `--out`: the folder's lock is held from the start until
/// `score.json` is in place, so the second is refused at once and writes nothing.
#[test]
fn a_second_score_into_the_same_folder_is_refused_at_once() {
    let dir = temp_dir("score-lock");
    let out = dir.join("fit");
    std::fs::create_dir_all(&out).unwrap();
    // A running score (this process) holds the folder.
    let held = gpecnet_trainer::rundir::RunLock::acquire_file(&out.join(".score.lock"), |_, _| {
        String::from("busy")
    })
    .unwrap();
    let blob = weights("sdd-m-lp-host.gpec");
    let (ok, text) = run(&["score", "--blob", s(&blob), "--out", s(&out)]);
    assert!(!ok && text.contains("another gpecnet score"), "{text}");
    assert!(!out.join("score.json").exists());
    drop(held);
    let _ = std::fs::remove_dir_all(&dir);
}

/// `propose`'s numeric options are bounded before any work, each error naming the option
/// and its limit; nothing is created.
#[test]
fn propose_options_are_bounded_before_any_work() {
    let dir = temp_dir("propose-bounds");
    let out = dir.join("run");
    let blob = weights("sdd-m-tiny.gpec");
    for (args, want) in [
        (
            &["--k", "1000000"][..],
            "--k 1000000 is out of range: allowed 1..=64",
        ),
        (&["--k", "65"][..], "allowed 1..=64"),
        (&["--k", "0"][..], "allowed 1..=64"),
        (&["--hidden", "100000000"][..], "allowed widths 1..=4096"),
        (&["--hidden", "0"][..], "allowed widths 1..=4096"),
        (
            &["--threads", "100000"][..],
            "--threads 100000 is out of range: allowed 0..=1024",
        ),
        (&["--lr", "nan"][..], "--lr NaN is out of range"),
        (&["--lr=-1"][..], "--lr -1 is out of range"),
        (&["--lr", "inf"][..], "--lr inf is out of range"),
        (&["--batch", "0"][..], "--batch 0 is out of range"),
        (&["--epochs", "0"][..], "--epochs 0 is out of range"),
        (&["--bound", "nan"][..], "--bound NaN is out of range"),
        (
            &["--temperature", "0"][..],
            "--temperature 0 is out of range",
        ),
        (
            &["--prior-weight=-1"][..],
            "--prior-weight -1 is out of range",
        ),
        (
            &["--hidden", "4096,4096,4096"][..],
            "parameters, over the limit",
        ),
        (
            &["--batch", "1000000", "--k", "64"][..],
            "over the limit of",
        ),
    ] {
        let start = std::time::Instant::now();
        let (ok, text) =
            run(&[&["propose", "--blob", s(&blob), "--out", s(&out)][..], args].concat());
        assert!(!ok && text.contains(want), "{args:?}: {text}");
        assert!(start.elapsed().as_secs() < 20, "{args:?} took long");
        assert!(!out.exists(), "{args:?} created the run folder");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// A blob whose stated clock is not the data's 0.4 s is refused by every command that
/// pairs a blob with data, before anything is written; and a metre model is refused on
/// pixel data by `score` and `propose` as by `eval` and `quantize`.
#[test]
fn unit_and_clock_are_checked_wherever_a_blob_meets_data() {
    let dir = temp_dir("clock");
    let retimed = |name: &str, period: f32| {
        let bytes = std::fs::read(weights(&format!("{name}.gpec"))).unwrap();
        let mut m = gpecnet_trainer::export::read_blob(&bytes).unwrap();
        m.config.meta.as_mut().unwrap().period_s = period;
        let p = dir.join(format!("{name}-{period}.gpec"));
        std::fs::write(&p, gpecnet_trainer::export::blob_bytes(&m).unwrap()).unwrap();
        p
    };
    let tiny = retimed("sdd-m-tiny", 0.5);
    let lp = retimed("sdd-m-lp-host", 60.0);
    let out = dir.join("out");
    let q = dir.join("q.gpec");
    let commands: Vec<Vec<&str>> = vec![
        vec!["eval", "--blob", s(&tiny), "--dataset", "eth_ucy:zara1"],
        vec!["quantize", "--blob", s(&tiny), "--out", s(&q)],
        vec!["propose", "--blob", s(&tiny), "--out", s(&out)],
        vec!["score", "--blob", s(&lp), "--out", s(&out)],
    ];
    for args in &commands {
        let (ok, text) = run(args);
        assert!(
            !ok && text.contains("between positions") && text.contains("0.4 s"),
            "{args:?}: {text}"
        );
    }
    assert!(!q.exists() && !out.join("score.json").exists());
    assert!(!out.join("proposal.json").exists());
    // The shipped clock is accepted (a pixel model at 0.4 s on SDD pixels gets further).
    let metric = weights("sdd-m-tiny.gpec");
    let host = weights("sdd-m-lp-host.gpec");
    for args in [
        vec![
            "propose",
            "--blob",
            s(&metric),
            "--dataset",
            "sdd",
            "--out",
            s(&out),
        ],
        vec![
            "score",
            "--blob",
            s(&host),
            "--dataset",
            "sdd",
            "--out",
            s(&out),
        ],
    ] {
        let (ok, text) = run(&args);
        assert!(
            !ok && text.contains("takes and returns metres"),
            "{args:?}: {text}"
        );
    }
    assert!(!out.join("score.json").exists() && !out.join("proposal.json").exists());
    let _ = std::fs::remove_dir_all(&dir);
}

/// `train --out` and `score --out` (and `propose --out`) inside the data folders are
/// refused, also when the folder does not exist yet; nothing is created there.
#[test]
fn run_and_fit_folders_are_never_among_the_data() {
    let r = common::TinyRun::new("out-in-data");
    let inside = r.dir.join("sdd/train/run.txt");
    let (ok, text) = common::train(&r.dir, &inside, &["--config", s(&r.cfg)]);
    assert!(!ok && text.contains("inside the input folder"), "{text}");
    assert!(
        !inside.exists(),
        "the run folder was created among the data"
    );
    let fit = r.dir.join("sdd/fit");
    for (command, blob) in [
        ("score", "sdd-m-lp-host.gpec"),
        ("propose", "sdd-m-tiny.gpec"),
    ] {
        let blob = weights(blob);
        let (ok, text) = run(&[
            command,
            "--blob",
            s(&blob),
            "--data",
            s(&r.dir),
            "--out",
            s(&fit),
        ]);
        assert!(
            !ok && text.contains("inside the input folder"),
            "{command}: {text}"
        );
        assert!(!fit.exists(), "{command}");
    }
}

/// An own data folder's metres per pixel must survive the conversion to f32: 1e-300 (0 as
/// f32) and 1e300 (infinite) are refused, naming the key.
#[test]
fn own_data_scales_are_checked_as_f32() {
    for bad in ["1e-300", "1e-40", "1e300"] {
        let e = own_data_refusal(
            "scale-f32",
            &format!(
                "unit = \"px\"\nseconds_per_frame = 0.4\n[metres_per_pixel]\nflight_01 = {bad}\n"
            ),
        );
        assert!(
            e.contains("metres_per_pixel.flight_01") && e.contains("normal f32"),
            "{bad}: {e}"
        );
    }
}

/// A second fallback to `checkpoint.prev.bin` keeps the new unusable checkpoint beside the
/// first one (`checkpoint.corrupt.1.bin`), never over it.
#[test]
fn a_second_checkpoint_fallback_keeps_the_first_corrupt_file() {
    let r = common::TinyRun::trained("corrupt-twice", 2);
    let path = r.out.join("checkpoint.bin");
    let flip = || {
        let mut bytes = std::fs::read(&path).unwrap();
        let n = bytes.len();
        bytes[n / 2] ^= 0x10;
        std::fs::write(&path, &bytes).unwrap();
        bytes
    };
    let first = flip();
    let (ok, text) = r.resume(&["--epochs", "2"]);
    assert!(ok, "{text}");
    assert_eq!(
        std::fs::read(r.out.join("checkpoint.corrupt.bin")).unwrap(),
        first
    );
    let second = flip();
    let (ok, text) = r.resume(&["--epochs", "2"]);
    assert!(ok && text.contains("checkpoint.corrupt.1.bin"), "{text}");
    assert_eq!(
        std::fs::read(r.out.join("checkpoint.corrupt.bin")).unwrap(),
        first
    );
    assert_eq!(
        std::fs::read(r.out.join("checkpoint.corrupt.1.bin")).unwrap(),
        second
    );
}

/// An own data folder's licence longer than a blob holds is refused when the folder is
/// read, naming the key and the limit, not at export.
#[test]
fn an_own_data_licence_too_long_for_a_blob_is_refused_up_front() {
    let licence = "x".repeat(600);
    let e = own_data_refusal(
        "licence",
        &format!("unit = \"m\"\nseconds_per_frame = 0.4\nlicence = \"{licence}\"\n"),
    );
    assert!(
        e.contains("licence is 600 bytes") && e.contains("at most 512"),
        "{e}"
    );
}

/// A run killed before its first checkpoint was written (its folder holds the lock of a
/// dead process, config.toml and metrics.csv, no checkpoint): `--resume` says there is
/// nothing to resume and how to start again; the suggested `--force` start then trains.
#[test]
fn resume_before_the_first_checkpoint_says_nothing_to_resume() {
    let r = common::TinyRun::new("resume-no-ckpt");
    std::fs::create_dir_all(&r.out).unwrap();
    std::fs::write(
        r.out.join(gpecnet_trainer::rundir::LOCK_FILE),
        format!(
            "pid={}\nhost={}\nstarted=1\n",
            common::dead_pid(),
            gpecnet_trainer::rundir::host_name()
        ),
    )
    .unwrap();
    std::fs::copy(&r.cfg, r.out.join("config.toml")).unwrap();
    std::fs::write(r.out.join("metrics.csv"), "epoch\n").unwrap();
    let (ok, text) = r.resume(&[]);
    assert!(!ok, "{text}");
    assert!(
        text.contains("nothing to resume")
            && text.contains("holds no checkpoint")
            && text.contains("without --resume")
            && text.contains("--force"),
        "{text}"
    );
    assert!(!text.contains("panicked"), "{text}");
    let (ok, text) = r.train(&["--force", "--epochs", "1"]);
    assert!(ok, "{text}");
    assert!(r.out.join("checkpoint.bin").exists());
}

/// A metre data-set folder in `dir` with 25-step tracks of `peds` pedestrians in
/// `train/a.txt`, `val/v.txt` and `test/t.txt`, and a tiny config training on it.
fn own_folder(dir: &Path, peds: usize) -> PathBuf {
    let ds = dir.join("ds");
    std::fs::write(
        {
            std::fs::create_dir_all(&ds).unwrap();
            ds.join("dataset.toml")
        },
        "unit = \"m\"\nseconds_per_frame = 0.4\n",
    )
    .unwrap();
    for (split, file) in [("train", "a"), ("val", "v"), ("test", "t")] {
        std::fs::create_dir_all(ds.join(split)).unwrap();
        let rows: String = (0..peds)
            .flat_map(|p| {
                (0..25).map(move |t| {
                    format!(
                        "{t} {p} {:.1} {:.1}\n",
                        1.0 + 0.3 * t as f32 + p as f32,
                        2.0
                    )
                })
            })
            .collect();
        std::fs::write(ds.join(split).join(format!("{file}.txt")), rows).unwrap();
    }
    let cfg = dir.join("cfg.toml");
    std::fs::write(
        &cfg,
        format!(
            "enc_past_size = [8]\nenc_dest_size = [8]\nenc_latent_size = [8]\ndec_size = [8]\n\
             predictor_hidden_size = [8]\nfdim = 4\nzdim = 2\nnum_epochs = 1\nbatch_size = 16\n\
             learning_rate = 1e-3\nk = 3\nseed = 5\nthreads = 1\ndataset = \"{}/\"\n",
            ds.display()
        ),
    )
    .unwrap();
    cfg
}

/// A run on a data-set folder names that folder when its data changed, never the default
/// benchmark root it does not read.
#[test]
fn errors_on_a_folder_data_set_name_the_folder_not_the_data_root() {
    let dir = temp_dir("folder-errors");
    let cfg = own_folder(&dir, 5);
    let out = dir.join("run");
    let (ok, text) = common::train(&dir.join("nowhere"), &out, &["--config", s(&cfg)]);
    assert!(ok, "{text}");
    let rows = std::fs::read_to_string(dir.join("ds/train/a.txt")).unwrap();
    std::fs::write(dir.join("ds/train/a.txt"), rows.replace(" 2.0\n", " 2.5\n")).unwrap();
    let (ok, text) = common::train(&dir.join("nowhere"), &out, &["--resume"]);
    assert!(!ok, "{text}");
    assert!(
        text.contains(&format!("the folder {}/ds/", dir.display()))
            && !text.contains("nowhere")
            && !text.contains("--data"),
        "{text}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// An empty validation file is reported as empty, naming it, by `train` and `eval`, not
/// as a missing scene or as tracks too short.
#[test]
fn an_empty_validation_file_is_reported_as_empty() {
    let dir = temp_dir("empty-val");
    let cfg = own_folder(&dir, 5);
    let v = dir.join("ds/val/v.txt");
    std::fs::write(&v, "").unwrap();
    let (ok, text) = common::train(
        &dir.join("nowhere"),
        &dir.join("run"),
        &["--config", s(&cfg)],
    );
    assert!(!ok, "{text}");
    assert!(
        text.contains("empty") && text.contains(&v.display().to_string()),
        "{text}"
    );
    let (ok, text) = run(&[
        "eval",
        "--blob",
        s(&weights("sdd-m-tiny.gpec")),
        "--dataset",
        &format!("{}/", dir.join("ds").display()),
    ]);
    assert!(!ok, "{text}");
    assert!(
        text.contains("empty") && text.contains(&v.display().to_string()),
        "{text}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// `export` and `select` with `--tts` smaller than `--k` name both options and the rule.
#[test]
fn tts_below_k_names_both_options_and_the_rule() {
    let r = common::TinyRun::trained("tts-below-k", 1);
    let weights_out = r.dir.join("w");
    // Both commands end with the same data and the same refused pair.
    let refused = ["--data", s(&r.dir), "--tts", "5", "--k", "20"];
    for command in [
        &[
            "export",
            "--run",
            s(&r.out),
            "--name",
            "m",
            "--out",
            s(&weights_out),
        ][..],
        &["select", "--run", s(&r.out)],
    ] {
        let args = [command, &refused].concat();
        let (ok, text) = run(&args);
        assert!(!ok, "{args:?}: {text}");
        assert!(
            text.contains("--tts 5 with --k 20")
                && text.contains("draws --tts samples and reduces them to --k endpoints")
                && text.contains("between --k = 20 and"),
            "{args:?}: {text}"
        );
    }
    assert!(!weights_out.join("m.gpec").exists());
}

/// The numeric options of `synth`, `rl-train`, `abscore`, `sweep` and `train` that were
/// accepted out of range (an aborting pool size, NaN or negative rates, empty batches, a seed
/// config.toml cannot hold) are refused before any work, naming the option and its limit.
#[test]
fn numeric_options_are_bounded_before_any_work() {
    let r = common::TinyRun::new("numeric-bounds");
    let out = r.dir.join("o");
    let pool = r.dir.join("o/pool.csv");
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (
            vec!["synth", "--out", s(&pool), "--n", "100000000000"],
            "1..=1000000",
        ),
        (vec!["synth", "--out", s(&pool), "--n", "0"], "1..=1000000"),
        (
            vec!["synth", "--out", s(&pool), "--rl-episodes", "0"],
            "1..=1000000",
        ),
        (
            vec!["rl-train", "--out", s(&out), "--episodes", "0"],
            "1..=1000000",
        ),
        (
            vec!["rl-train", "--out", s(&out), "--batch", "0"],
            "1..=4096",
        ),
        (
            vec!["rl-train", "--out", s(&out), "--batch", "100000000000"],
            "1..=4096",
        ),
        (vec!["rl-train", "--out", s(&out), "--lr", "nan"], "(0, 1]"),
        (vec!["rl-train", "--out", s(&out), "--lr=-1"], "(0, 1]"),
        (
            vec!["abscore", "--out", s(&out), "--max-abscore", "nan"],
            "finite number >= 0",
        ),
        (
            vec!["sweep", "--config", s(&r.cfg), "--out", s(&out), "--k", "0"],
            "--k 0 is out of range: allowed 1..=64",
        ),
        (
            vec![
                "sweep",
                "--config",
                s(&r.cfg),
                "--out",
                s(&out),
                "--pool-n",
                "0",
            ],
            "1..=1000000",
        ),
    ];
    for (args, want) in cases {
        let (ok, text) = run(&args);
        assert!(!ok && text.contains(want), "{args:?}: {text}");
        assert!(
            !text.contains("panicked") && !out.exists(),
            "{args:?}: {text}"
        );
    }
    let (ok, text) = r.train(&["--seed", "18446744073709551615"]);
    assert!(
        !ok && text.contains("seed = 18446744073709551615")
            && text.contains("0..=9223372036854775807"),
        "{text}"
    );
    assert!(!r.out.join("config.toml").exists());
}
