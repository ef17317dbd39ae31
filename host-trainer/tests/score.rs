//! `gpecnet score` on the real SDD-in-metres data: it fits the probabilities and radii of
//! the shipped proposal on training windows, calibrates them on validation, refuses what it
//! cannot score and never writes over a fit; `export --score` joins a fit only to the
//! model and proposal it was fitted for.

use crate::common;

use std::path::{Path, PathBuf};

use common::{run, s, temp_dir};
use gpecnet_trainer::score_file::{scored_fingerprint, ScoreFile};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn score(blob: &Path, out: &Path, extra: &[&str]) -> (bool, String) {
    let args = [
        &["score", "--blob", s(blob), "--out", s(out), "--iters", "60"][..],
        extra,
    ]
    .concat();
    run(&args)
}

#[test]
fn a_fit_calibrates_on_validation_and_is_never_overwritten() {
    let dir = temp_dir("score");
    let out = dir.join("fit");
    let blob = root().join("weights/sdd-m-tiny.gpec");
    let proposal = root().join("weights/sdd-m-lp.gpec");
    // The shipped f32 model carries its probabilities already: refused.
    let (ok, text) = score(&proposal, &out, &[]);
    assert!(
        !ok && text.contains("already has endpoint probabilities"),
        "{text}"
    );
    // A model without a proposal cannot be scored.
    let (ok, text) = score(&blob, &out, &[]);
    assert!(!ok && text.contains("learned proposal"), "{text}");
    // The unscored proposal model of sdd-m-lp-host (64-wide).
    let host = root().join("weights/sdd-m-lp-host.gpec");
    let (ok, text) = score(&host, &out, &["--l2", "0.001"]);
    assert!(ok, "{text}");
    let f = ScoreFile::read(&out.join("score.json")).unwrap();
    assert_eq!((f.k, f.width, f.w.len()), (20, 64, 20 * 64));
    // The radii are calibrated on validation: coverage 50 % and 90 % there by construction.
    assert!((f.val.r50_coverage - 0.5).abs() < 0.01, "{:?}", f.val);
    assert!((f.val.r90_coverage - 0.9).abs() < 0.01, "{:?}", f.val);
    assert!(0.0 < f.radius_scales[0] && f.radius_scales[0] < f.radius_scales[1]);
    // Learned probabilities beat equal weights and chance on validation, calibrated.
    assert!(f.val.mixture_nll < f.val.uniform_nll - 0.1, "{:?}", f.val);
    assert!(
        f.val.top_is_closest > 0.1 && f.val.ece < 0.02,
        "{:?}",
        f.val
    );
    let model = gpecnet_trainer::export::read_blob(&std::fs::read(&host).unwrap()).unwrap();
    assert_eq!(f.fingerprint, scored_fingerprint(&model));
    // A second fit into the same folder is refused and leaves the first one alone.
    let before = std::fs::read(out.join("score.json")).unwrap();
    let (ok, text) = score(&host, &out, &[]);
    assert!(!ok && text.contains("exists"), "{text}");
    assert_eq!(std::fs::read(out.join("score.json")).unwrap(), before);
    // Joined to other weights: refused.
    let mut other = model.clone();
    other.nets.proposal[0].b[0] += 1.0;
    let err = gpecnet_trainer::score::attach(&mut other, &out.join("score.json")).unwrap_err();
    assert!(
        err.to_string().contains("fitted for other weights"),
        "{err}"
    );
    // Joined to its own model: a format-6 blob that the core reads with probabilities.
    let mut m = model;
    gpecnet_trainer::score::attach(&mut m, &out.join("score.json")).unwrap();
    let bytes = gpecnet_trainer::export::blob_bytes(&m).unwrap();
    let core = gpecnet_core::Model::from_blob(&bytes).unwrap();
    assert!(core.has_probabilities());
    assert_eq!(core.radius_scales(), f.radius_scales);
    let _ = std::fs::remove_dir_all(&dir);
}
