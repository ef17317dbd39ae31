//! Every shipped blob in `weights/`: its golden vectors replay bit for bit
//! through `gpecnet-core` and through the trainer's reference path, and the
//! whole SDD test set through `gpecnet-core` reproduces its model card exactly.

use gpecnet_core::NumericKind;
use gpecnet_tests::{assert_sidecars, card_dataset, card_test_set, shipped_blobs_of, Shipped};
use gpecnet_trainer::core_eval::evaluate_core;
use gpecnet_trainer::eval::dist_metrics;
use gpecnet_trainer::export::read_blob;
use gpecnet_trainer::reference::SineKind;
use gpecnet_trainer::ship::ModelCard;

fn f32_blobs() -> Vec<std::path::PathBuf> {
    shipped_blobs_of(NumericKind::F32)
}

#[test]
fn weights_folder_ships_models() {
    let blobs = f32_blobs();
    assert!(
        blobs.iter().any(|p| p.ends_with("sdd-small.gpec")),
        "weights/sdd-small.gpec missing: {blobs:?}"
    );
    for b in &blobs {
        assert_sidecars(b);
        let card = std::fs::read_to_string(b.with_extension("md")).unwrap();
        assert!(
            card.contains("## Data licence"),
            "{}: model card must state the data's licence",
            b.display()
        );
        if card_dataset(b).is_sdd() {
            assert!(
                card.contains("CC BY-NC-SA 3.0"),
                "{}: model card must state the SDD licence",
                b.display()
            );
        }
        // A blob that states its unit (format 4) agrees with its card's data set, and its
        // card says the unit and the clock.
        let blob = std::fs::read(b).unwrap();
        let m = gpecnet_core::blob::Meta::of_blob(&blob).unwrap();
        if m.unit != gpecnet_core::blob::PositionUnit::Unknown {
            assert_eq!(m.unit.suffix(), card_dataset(b).unit().suffix());
            assert_eq!(m.period(), Some(0.4));
            assert!(card.contains("| unit and clock |"), "{}", b.display());
        }
    }
}

#[test]
fn golden_vectors_replay_bit_exact() {
    for path in f32_blobs() {
        let shipped = Shipped::read(&path);
        let golden = shipped.golden();
        // Every 10th test window (SDD: 283 cases), at most 283 on larger test sets.
        let n_test = card_test_set(&path).windows.len();
        let stride = gpecnet_trainer::ship::golden_stride(n_test);
        assert_eq!(golden.info().n_cases as usize, n_test.div_ceil(stride));
        shipped.assert_replays();

        // The trainer's reference path, reading the same blob, reproduces the golden file too.
        let r = read_blob(&shipped.blob).unwrap();
        let sine = if golden.info().sine == "libm" {
            SineKind::Libm
        } else {
            SineKind::Fast
        };
        for case in golden.cases() {
            let ends = r
                .predict_set(&case.past, case.seed, case.k(), sine)
                .unwrap();
            for (i, e) in ends.iter().enumerate() {
                assert_eq!(e.map(f32::to_bits), case.endpoint_bits(i));
            }
            if let Some(t) = r.predict_point(&case.past, sine) {
                for (j, pt) in t.iter().enumerate() {
                    assert_eq!(Some(pt.map(f32::to_bits)), case.point_bits(j));
                }
            }
        }
    }
}

#[test]
fn sdd_test_set_reproduces_model_cards() {
    for path in f32_blobs() {
        let test = card_test_set(&path);
        let blob = std::fs::read(&path).unwrap();
        let card: ModelCard =
            serde_json::from_slice(&std::fs::read(path.with_extension("json")).unwrap()).unwrap();
        let (m, preds) = evaluate_core(&blob, card.sine, &test, card.k, card.base_seed).unwrap();
        assert_eq!(
            m,
            card.test,
            "{}: SDD test metrics through gpecnet-core differ from the model card",
            path.display()
        );
        assert_eq!(
            dist_metrics(&test, &preds),
            Some(card.test_dist),
            "{}: KDE NLL / hit rates through gpecnet-core differ from the model card",
            path.display()
        );
        assert!(
            m.min_fde < card.test_constant_velocity.fde_k1,
            "{}: worse than constant velocity",
            path.display()
        );
    }
}
