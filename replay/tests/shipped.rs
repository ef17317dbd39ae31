//! The golden replay on a shipped blob: every case matches, and a blob with
//! one flipped byte or a golden file of another blob is an error line, never
//! a pass.
use gpecnet_replay::{verify_all, EmbeddedModel, Line};

use crate::common::read;

/// Runs `models` with scratch width 128; (summary, golden lines, error lines).
fn run(models: &[EmbeddedModel]) -> (gpecnet_replay::Summary, usize, Vec<String>) {
    let (mut golden, mut errors) = (0, Vec::new());
    let s = verify_all::<128, true>(models, true, &mut |l| match l {
        Line::Golden { ok, .. } => {
            assert!(ok, "a shipped golden case must match");
            golden += 1
        }
        Line::Error { what, .. } => errors.push(what.to_string()),
        Line::TooWide { needed, .. } => errors.push(format!("too wide: {needed}")),
        _ => {}
    });
    (s, golden, errors)
}

#[test]
fn shipped_fixed_and_f32_blobs_replay_bit_exact() {
    let models = [
        EmbeddedModel {
            name: "sdd-tiny-qe",
            blob: read("sdd-tiny-qe.gpec"),
            golden: read("sdd-tiny-qe.golden"),
        },
        EmbeddedModel {
            name: "sdd-tiny",
            blob: read("sdd-tiny.gpec"),
            golden: read("sdd-tiny.golden"),
        },
    ];
    let (s, golden, errors) = run(&models);
    assert!(errors.is_empty(), "{errors:?}");
    assert!(s.ok());
    assert_eq!(s.models, 2);
    assert_eq!(s.mismatches, 0);
    assert!(golden > 100, "only {golden} golden lines");
    assert_eq!(golden as u32, s.cases);
    // The f32 blob's other compiled-in sine(s) ran too.
    assert!(s.xchecks >= golden as u32 / 2);
}

#[test]
fn a_flipped_byte_or_a_foreign_golden_file_fails() {
    let blob = read("sdd-tiny-qe.gpec");
    let mut bad = blob.to_vec();
    let mid = bad.len() / 2;
    bad[mid] ^= 0x10;
    let models = [
        EmbeddedModel {
            name: "flipped",
            blob: Box::leak(bad.into_boxed_slice()),
            golden: read("sdd-tiny-qe.golden"),
        },
        EmbeddedModel {
            name: "foreign",
            blob,
            golden: read("sdd-tiny.golden"),
        },
    ];
    let (s, golden, errors) = run(&models);
    assert!(!s.ok());
    assert_eq!(golden, 0);
    assert_eq!(errors.len(), 2, "{errors:?}");
    assert!(errors[0].contains("blob rejected"), "{errors:?}");
    assert!(errors[1].contains("another blob"), "{errors:?}");
}
