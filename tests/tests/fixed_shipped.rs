//! Every shipped fixed-point blob (`weights/*-q.gpec`, `NumericKind::Int16Q15`):
//! its golden vectors replay bit for bit through `gpecnet_core::Predictor` (its fixed-point engine,
//! `Engine<Q15>`),
//! and re-evaluating the SDD test set through `gpecnet-core` reproduces its card.

use gpecnet_core::blob::NumericKind;
use gpecnet_core::Model;
use gpecnet_metrics::dist::dist_metrics;
use gpecnet_metrics::fixed_eval::evaluate_core_fixed;
use gpecnet_ship::quantize_blob::QuantCard;
use gpecnet_tests::{assert_sidecars, card_test_set, shipped_blobs_of, Shipped};

fn fixed_blobs() -> Vec<std::path::PathBuf> {
    shipped_blobs_of(NumericKind::Int16Q15)
}

#[test]
fn fixed_blobs_are_named_q_and_complete() {
    for b in fixed_blobs() {
        let stem = b.file_stem().unwrap().to_str().unwrap().to_string();
        assert!(
            stem.ends_with("-q") || stem.ends_with("-qe"),
            "{}: fixed-point blobs are named <name>-q (<name>-qe: endpoint-only)",
            b.display()
        );
        assert_sidecars(&b);
    }
}

#[test]
fn fixed_golden_vectors_replay_bit_exact() {
    for path in fixed_blobs() {
        let shipped = Shipped::read(&path);
        assert_eq!(shipped.golden().info().sine, "q15-table");
        shipped.assert_replays();
    }
}

#[test]
fn fixed_cards_are_reproduced() {
    let blobs = fixed_blobs();
    if blobs.is_empty() {
        return;
    }
    for path in blobs {
        let test = card_test_set(&path);
        let blob = std::fs::read(&path).unwrap();
        let card: QuantCard =
            serde_json::from_slice(&std::fs::read(path.with_extension("json")).unwrap()).unwrap();
        assert_eq!(card.blob_crc, Model::from_blob(&blob).unwrap().crc());
        let (m, preds) = evaluate_core_fixed(&blob, &test, card.k, card.base_seed).unwrap();
        assert_eq!(
            dist_metrics(&test, &preds),
            Some(card.test_fixed_dist),
            "{}: KDE NLL / hit rates through gpecnet-core differ from the card",
            path.display()
        );
        // The f32 source's distribution metrics are those of its own card (re-computed by
        // shipped_blobs.rs) when that card has the same K, seeds and sine.
        let src: serde_json::Value = serde_json::from_slice(
            &std::fs::read(path.with_file_name(&card.source).with_extension("json")).unwrap(),
        )
        .unwrap();
        let same_protocol = src["k"].as_u64() == Some(card.k as u64)
            && src["base_seed"].as_u64() == Some(card.base_seed)
            && serde_json::from_value::<gpecnet_reference::reference::SineKind>(
                src["sine"].clone(),
            )
            .is_ok_and(|s| s.core_name() == card.source_sine);
        if same_protocol {
            assert_eq!(
                serde_json::from_value(src["test_dist"].clone()).ok(),
                Some(card.test_f32_dist),
                "{}: test_f32_dist differs from {}'s card",
                path.display(),
                card.source
            );
        }
        // JSON keeps f64 to within an ulp or so (serde_json without `float_roundtrip`).
        let c = &card.test_fixed;
        assert_eq!((m.n, m.k), (c.n, c.k));
        for (a, b) in [
            (m.min_ade, c.min_ade),
            (m.min_fde, c.min_fde),
            (m.ade_k1, c.ade_k1),
            (m.fde_k1, c.fde_k1),
            (m.mean_ade, c.mean_ade),
            (m.mean_fde, c.mean_fde),
        ] {
            assert!(
                (a - b).abs() <= 1e-12 * a.abs().max(1.0),
                "{}: {m:?} vs card {c:?}",
                path.display()
            );
        }
        // Acceptance: at most 0.5 px (0.02 m) FDE (best of K) lost against the f32 source.
        let tolerance = if card.dataset.as_deref().is_some_and(|d| d != "sdd") {
            0.02
        } else {
            0.5
        };
        assert!(
            card.test_fixed.min_fde - card.test_f32.min_fde <= tolerance,
            "{}: {card:?}",
            path.display()
        );
    }
}

#[test]
fn scored_fixed_blobs_match_the_integer_reference() {
    for path in fixed_blobs() {
        let card: QuantCard =
            serde_json::from_slice(&std::fs::read(path.with_extension("json")).unwrap()).unwrap();
        let Some(want) = card.test_fixed_planner else {
            continue;
        };
        // Quantize the f32 source again, as the card says: `quantize_blob_with` compares every
        // test window's probabilities through gpecnet-core with the integer reference's, bit
        // for bit, and refuses to write otherwise.
        let dir = std::env::temp_dir().join(format!("gpecnet-scored-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let again = gpecnet_ship::quantize_blob::quantize_blob_with(
            &path.with_file_name(&card.source),
            &dir.join(path.file_name().unwrap()),
            &gpecnet_tests::data_root(),
            card.k,
            card.base_seed,
            4,
            8,
            true,
            None,
            true,
            None,
        );
        let _ = std::fs::remove_dir_all(&dir);
        let again = again.unwrap();
        assert_eq!(again.blob_crc, card.blob_crc, "{}", path.display());
        assert_eq!(again.test_fixed_planner, Some(want), "{}", path.display());
    }
}
