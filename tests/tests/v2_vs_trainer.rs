//! Format-2 models (heading-canonical frame, point-forecast head, test-time sampling) through
//! `gpecnet-core` against the trainer's independent reference paths, bit for bit, on real SDD
//! test windows, in f32 (both sines) and fixed point; and format-1 exports keep their bytes.

use gpecnet_core::Model;
use gpecnet_data::{load_sdd, Dataset, SddSplit};
use gpecnet_metrics::core_eval::{evaluate_core, evaluate_point_core, evaluate_reference};
use gpecnet_metrics::eval::Prediction;
use gpecnet_metrics::fixed_eval::{evaluate_core_fixed, evaluate_reference_fixed};
use gpecnet_reference::export::{blob_bytes, read_blob};
use gpecnet_reference::quantize::qgolden_bytes;
use gpecnet_reference::quantize::quantize_with_data;
use gpecnet_reference::reference::SineKind;
use gpecnet_tests::{data_root, golden_inputs, mismatches, random_siren, with_v2_features};

fn test_subset(step: usize) -> Dataset {
    let mut test = load_sdd(&data_root(), SddSplit::Test)
        .expect("SDD test set (see ../shared/data/README.md)");
    test.windows = test.windows.into_iter().step_by(step).collect();
    test
}

fn base() -> gpecnet_reference::reference::RefModel {
    random_siren("v2", &[32, 32], &[48, 32], &[8, 16], &[64, 32], 11)
}

#[test]
fn format1_exports_are_unchanged_and_v2_round_trips() {
    let m = base();
    let v1 = blob_bytes(&m).unwrap();
    // Every blob is written in the newest format (3: aligned tensors); older ones are read.
    assert_eq!(v1[4], 3, "the writer emits format version 3");
    let m2 = with_v2_features(m, 3, &[64, 64], 60, 5);
    let v2 = blob_bytes(&m2).unwrap();
    assert_eq!(v2[4], 3);
    assert_eq!(read_blob(&v2).unwrap(), m2);
    let core = Model::from_blob(&v2).unwrap();
    assert!(core.has_point_head());
    assert_eq!(core.extensions().heading_steps, 3);
    assert_eq!(core.extensions().tts_samples, 60);
}

#[test]
fn heading_frame_point_head_and_tts_match_in_f32() {
    let test = test_subset(3);
    for (heading, tts) in [(3, 0), (1, 60), (0, 40)] {
        let m = with_v2_features(base(), heading, &[64, 64], tts, 5);
        let blob = blob_bytes(&m).unwrap();
        for (sine, seed) in [(SineKind::Libm, 0u64), (SineKind::Fast, 77)] {
            let (mc, pc) = evaluate_core(&blob, sine, &test, 20, seed).unwrap();
            let (mr, pr) = evaluate_reference(&m, sine, &test, 20, seed).unwrap();
            assert_eq!(mismatches(&pc, &pr), 0, "h{heading} tts{tts} {sine:?}");
            assert_eq!(mc, mr);
            let (pm, pp) = evaluate_point_core(&blob, sine, &test).unwrap().unwrap();
            let pr: Vec<Prediction> = test
                .windows
                .iter()
                .map(|w| {
                    let t = m.predict_point(&w.obs(), sine).unwrap();
                    Prediction::single(t.try_into().unwrap())
                })
                .collect();
            assert_eq!(mismatches(&pp, &pr), 0, "point h{heading} {sine:?}");
            assert!(pm.fde_k1.is_finite());
        }
    }
}

#[test]
fn heading_frame_point_head_and_tts_match_in_fixed_point() {
    let train = load_sdd(&data_root(), SddSplit::Train).expect("SDD train set");
    let test = test_subset(3);
    let m = with_v2_features(base(), 3, &[64, 64], 60, 9);
    let q = quantize_with_data(&m, &train, 20, 8, "v2-q").unwrap();
    let blob = blob_bytes(&q).unwrap();
    assert_eq!(blob[4], 3);
    let core = Model::from_blob(&blob).unwrap();
    assert!(core.has_point_head());
    let (mc, pc) = evaluate_core_fixed(&blob, &test, 20, 0).unwrap();
    let (mr, pr) = evaluate_reference_fixed(&q, &test, 20, 0).unwrap();
    assert_eq!(mismatches(&pc, &pr), 0);
    assert_eq!(mc, mr);
    let (_, pp) = evaluate_point_core(&blob, SineKind::Libm, &test)
        .unwrap()
        .unwrap();
    let pr: Vec<Prediction> = test
        .windows
        .iter()
        .map(|w| Prediction::single(q.predict_point(&w.obs()).unwrap().try_into().unwrap()))
        .collect();
    assert_eq!(mismatches(&pp, &pr), 0);
    // The golden file records the point forecast (format 2) and replays through core.
    let golden = qgolden_bytes(&q, core.crc(), 20, &golden_inputs(&test, 50)).unwrap();
    let set = gpecnet_core::golden::GoldenSet::parse(&golden).unwrap();
    let mut p = Box::new(gpecnet_core::Engine::<gpecnet_core::fixed::Q15, 128>::new(core).unwrap());
    for case in set.cases() {
        assert_eq!(case.point_len(), 12);
        let t = p.predict_point(&case.past).unwrap();
        for (i, pt) in t.iter().enumerate() {
            assert_eq!(Some([pt[0].to_bits(), pt[1].to_bits()]), case.point_bits(i));
        }
        let mut ends = [[0.0f32; 2]; 20];
        p.predict_endpoint_set::<64>(&case.past, case.seed, &mut ends)
            .unwrap();
        for (i, e) in ends.iter().enumerate() {
            assert_eq!([e[0].to_bits(), e[1].to_bits()], case.endpoint_bits(i));
        }
    }
}
