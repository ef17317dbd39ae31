//! `gpecnet-core` against the trainer's canonical reference path, bit for bit,
//! on real SDD test windows — independent of any shipped weights.

use gpecnet_core::Model;
use gpecnet_data::{load_sdd, SddSplit};
use gpecnet_metrics::core_eval::{evaluate_core, evaluate_reference};
use gpecnet_reference::export::{blob_bytes, read_blob};
use gpecnet_reference::reference::SineKind;
use gpecnet_tests::{data_root, mismatches, random_siren};

#[test]
fn export_roundtrip_is_lossless() {
    let m = random_siren("roundtrip", &[64, 32], &[128, 64], &[8, 16], &[128, 64], 1);
    let blob = blob_bytes(&m).unwrap();
    assert_eq!(read_blob(&blob).unwrap(), m);
    let core = Model::from_blob(&blob).unwrap();
    assert_eq!(core.parameter_count(), m.parameter_count());
}

#[test]
fn random_siren_matches_on_sdd_test_set() {
    let test = load_sdd(&data_root(), SddSplit::Test)
        .expect("SDD test set (see ../shared/data/README.md)");
    assert_eq!(test.windows.len(), 2829);
    for (sine, seed) in [(SineKind::Libm, 0u64), (SineKind::Fast, 1000)] {
        let m = random_siren("bitexact", &[64, 32], &[128, 64], &[8, 16], &[128, 64], 7);
        let blob = blob_bytes(&m).unwrap();
        let (mc, pc) = evaluate_core(&blob, sine, &test, 20, seed).unwrap();
        let (mr, pr) = evaluate_reference(&m, sine, &test, 20, seed).unwrap();
        let mismatches = mismatches(&pc, &pr);
        assert_eq!(mismatches, 0, "{sine:?}: {mismatches} points differ");
        assert_eq!(pc.len(), 2829);
        assert_eq!(mc.min_fde.to_bits(), mr.min_fde.to_bits());
        assert_eq!(mc.min_ade.to_bits(), mr.min_ade.to_bits());
        assert!(mc.min_fde.is_finite() && mc.min_fde > 0.0);
    }
}

#[test]
fn relu_model_matches() {
    let mut m = random_siren("relu", &[32], &[64], &[8, 16], &[64], 3);
    for net in [
        &mut m.nets.encoder_past,
        &mut m.nets.decoder,
        &mut m.nets.encoder_dest,
        &mut m.nets.predictor,
    ] {
        for l in net.iter_mut() {
            if l.act == gpecnet_reference::network::Act::Sine {
                l.act = gpecnet_reference::network::Act::Relu;
            }
        }
    }
    let test = load_sdd(&data_root(), SddSplit::Test).unwrap();
    let blob = blob_bytes(&m).unwrap();
    let (mc, _) = evaluate_core(&blob, SineKind::Libm, &test, 5, 0).unwrap();
    let (mr, _) = evaluate_reference(&m, SineKind::Libm, &test, 5, 0).unwrap();
    assert_eq!(mc, mr);
}
