//! `gpecnet_core`'s fixed-point engine (`Engine<Q15>`) against the trainer's independent integer
//! reference (`gpecnet_reference::quantize`), bit for bit, on the whole SDD test set.

use gpecnet_core::Model;
use gpecnet_data::{load_sdd, SddSplit};
use gpecnet_metrics::core_eval::evaluate_core;
use gpecnet_metrics::fixed_eval::{evaluate_core_fixed, evaluate_reference_fixed};
use gpecnet_reference::export::blob_bytes;
use gpecnet_reference::quantize::quantize_with_data;
use gpecnet_reference::quantize::{qgolden_bytes, sin_q15_ref};
use gpecnet_reference::reference::SineKind;
use gpecnet_tests::{data_root, golden_inputs, mismatches, random_siren};

#[test]
fn trainer_sine_equals_core_sine() {
    for p in (0..=u32::MAX).step_by(4099).chain([
        0,
        63,
        1 << 30,
        (1 << 30) + 63,
        1 << 31,
        3 << 30,
        u32::MAX,
    ]) {
        assert_eq!(
            sin_q15_ref(p),
            gpecnet_core::fixed::sin_q15(p) as i64,
            "phase {p:#x}"
        );
    }
}

#[test]
fn random_siren_fixed_matches_on_sdd_test_set() {
    let train = load_sdd(&data_root(), SddSplit::Train)
        .expect("SDD train set (see ../shared/data/README.md)");
    let test = load_sdd(&data_root(), SddSplit::Test).expect("SDD test set");
    let m = random_siren("bitexact-q", &[64, 32], &[128, 64], &[8, 16], &[128, 64], 7);
    let q = quantize_with_data(&m, &train, 50, 4, "bitexact-q").unwrap();
    let blob = blob_bytes(&q).unwrap();
    let core = Model::from_blob(&blob).unwrap();
    assert_eq!(core.parameter_count(), m.parameter_count());
    let (mc, pc) = evaluate_core_fixed(&blob, &test, 20, 0).unwrap();
    let (mr, pr) = evaluate_reference_fixed(&q, &test, 20, 0).unwrap();
    assert_eq!(pc.len(), 2829);
    let mismatches = mismatches(&pc, &pr);
    assert_eq!(mismatches, 0, "{mismatches} points differ");
    assert_eq!(mc, mr);
    // The fixed path tracks the f32 model it came from.
    let (mf, _) = evaluate_core(&blob_bytes(&m).unwrap(), SineKind::Libm, &test, 20, 0).unwrap();
    eprintln!(
        "random SIREN, SDD test, K=20: f32 minFDE {:.3} px, fixed {:.3} px",
        mf.min_fde, mc.min_fde
    );
    assert!(
        (mf.min_fde - mc.min_fde).abs() < 0.5,
        "f32 {mf:?}\nfixed {mc:?}"
    );

    // Golden replay through core.
    let golden = qgolden_bytes(&q, core.crc(), 20, &golden_inputs(&test, 97)).unwrap();
    let set = gpecnet_core::golden::GoldenSet::parse(&golden).unwrap();
    assert_eq!(set.info().sine, "q15-table");
    let mut p = Box::new(gpecnet_core::Engine::<gpecnet_core::fixed::Q15, 256>::new(core).unwrap());
    for c in set.cases() {
        let mut e = [[0.0f32; 2]; 20];
        p.predict_samples(&c.past, c.seed, &mut e).unwrap();
        for (i, e) in e.iter().enumerate() {
            assert_eq!([e[0].to_bits(), e[1].to_bits()], c.endpoint_bits(i));
        }
        let mut t = [gpecnet_core::Trajectory::new()];
        p.predict_trajectories(&c.past, c.seed, &mut t).unwrap();
        for (i, pt) in t[0].iter().enumerate() {
            assert_eq!(
                Some([pt[0].to_bits(), pt[1].to_bits()]),
                c.trajectory0_bits(i)
            );
        }
    }
}
