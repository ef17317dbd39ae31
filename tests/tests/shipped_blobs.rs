//! Every shipped blob in `weights/`: its golden vectors replay bit for bit
//! through `gpecnet-core` and through the trainer's reference path, and the
//! whole SDD test set through `gpecnet-core` reproduces its model card exactly.

use gpecnet_core::NumericKind;
use gpecnet_metrics::card::{test_planner, ModelCard};
use gpecnet_metrics::core_eval::evaluate_core;
use gpecnet_metrics::dist::dist_metrics;
use gpecnet_metrics::planner_metrics::PlannerMetrics;
use gpecnet_reference::export::read_blob;
use gpecnet_reference::reference::SineKind;
use gpecnet_tests::{
    assert_sidecars, card_dataset, card_test_set, data_root, shipped_blobs_of, Shipped,
};

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
        let stride = gpecnet_metrics::card::golden_stride(n_test);
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

/// `a` and `b` equal to within JSON's f64 round trip.
fn planner_close(a: &PlannerMetrics, b: &PlannerMetrics) -> bool {
    let v = |m: &PlannerMetrics| serde_json::to_value(m).unwrap();
    let (va, vb) = (v(a), v(b));
    let close = |x: f64, y: f64| (x - y).abs() <= 1e-12 * x.abs().max(1.0);
    va.as_object()
        .unwrap()
        .iter()
        .all(|(k, x)| match (x, &vb[k]) {
            (serde_json::Value::Array(p), serde_json::Value::Array(q)) => p
                .iter()
                .zip(q)
                .all(|(p, q)| close(p.as_f64().unwrap(), q.as_f64().unwrap())),
            (x, y) => close(x.as_f64().unwrap(), y.as_f64().unwrap()),
        })
}

#[test]
fn planner_metrics_reproduce_and_match_the_reference() {
    for path in f32_blobs() {
        let card: ModelCard =
            serde_json::from_slice(&std::fs::read(path.with_extension("json")).unwrap()).unwrap();
        let blob = std::fs::read(&path).unwrap();
        let reference = read_blob(&blob).unwrap();
        assert_eq!(card.test_planner.is_some(), reference.is_scored());
        let Some(want) = card.test_planner else {
            continue;
        };
        let test = card_test_set(&path);
        // test_planner compares every window's probabilities with the reference path's, bit
        // for bit, before it computes the metrics.
        let (own, px) = test_planner(
            &data_root(),
            &card_dataset(&path),
            &blob,
            card.sine,
            &test,
            card.base_seed,
            &reference,
        )
        .unwrap()
        .expect("a scored blob has planner metrics");
        assert!(
            planner_close(&own, &want),
            "{}: {own:?} vs {want:?}",
            path.display()
        );
        assert_eq!(px.is_some(), card.test_planner_px.is_some());
        if let (Some(a), Some(b)) = (px, card.test_planner_px) {
            assert!(planner_close(&a, &b), "{}: pixels", path.display());
        }
        // What the radii promise: coverage near 50 % and 90 % on test (calibrated on
        // validation only), and probabilities better than equal weights.
        assert!((0.40..=0.60).contains(&own.r50_coverage), "{own:?}");
        assert!((0.85..=0.95).contains(&own.r90_coverage), "{own:?}");
        assert!(own.mixture_nll < own.uniform_nll, "{own:?}");
        assert!(own.top_is_closest > 1.5 / card.k as f64, "{own:?}");
    }
}
