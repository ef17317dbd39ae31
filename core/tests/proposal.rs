//! Format version 5: a learned latent proposal. The reader's rules (shape,
//! bound, protocol, fixed-point ranges), damage to a version-5 blob, and the
//! engine's stream: K latents from the past, the seed unused, the clamp applied,
//! the same bits on the scalar and the batched path.
use crate::common;

use common::*;
use gpecnet_blob_writer::{BlobHead, WireLayer};
use gpecnet_core::batch::BatchPredictor;
use gpecnet_core::blob::{Activation, Extensions, NetworkId, NumericKind, MAX_PROPOSAL_LATENTS};
use gpecnet_core::{BlobError, LibmSine, Model, PredictError, Predictor};

/// Writes the small f32 model with `proposal` (fdim 4, zdim 3) and `ext`.
fn write_f32(
    proposal: &[WireLayer],
    bound: f32,
    ext: Option<Extensions>,
) -> Result<Vec<u8>, Refused> {
    let head = BlobHead {
        numeric: NumericKind::F32,
        name: "v5",
        config: config(),
        extensions: ext,
        meta: Some(META),
    };
    let [a, b, c, d] = &small_nets(Activation::Sine);
    write_with_proposal(&head, [a, b, c, d, &[]], proposal, bound)
}

/// A proposal of `k` latents: 4 → 5 (ReLU) → 3k (linear).
fn proposal(k: usize) -> Vec<WireLayer> {
    vec![
        layer(4, 5, Activation::Relu, 11, 0.9),
        layer(5, 3 * k, Activation::Linear, 12, 0.9),
    ]
}

#[test]
fn a_proposal_blob_is_version_5_and_predicts_its_k_latents() {
    let blob = write_f32(&proposal(4), 2.0, None).unwrap();
    assert_eq!(version_of(&blob), 5);
    let m = Model::from_blob(&blob).unwrap();
    assert!(m.has_proposal());
    assert_eq!((m.proposal_latents(), m.latent_bound()), (4, 2.0));
    // The last layer counts as zdim wide in the scratch (12 outputs, 3 at a time).
    assert_eq!(m.max_width(), 22);
    assert_eq!(gpecnet_core::sampling::max_endpoints_of(&m, 100), 4);
    let mut p = Predictor::<LibmSine, 32>::new(m).unwrap();
    let mut a = [[0.0f32; 2]; 4];
    let mut b = [[0.0f32; 2]; 4];
    p.predict_endpoint_set::<8>(&PAST, 1, &mut a).unwrap();
    p.predict_endpoint_set::<8>(&PAST, 99, &mut b).unwrap();
    assert_eq!(a, b, "the seed is not used");
    assert!(a.iter().all(|e| e[0].is_finite() && e[1].is_finite()));
    assert!(a.windows(2).any(|w| w[0] != w[1]), "the latents differ");
    // The stream ends after K samples.
    let mut five = [[0.0f32; 2]; 5];
    assert_eq!(
        p.predict_endpoint_set::<8>(&PAST, 1, &mut five),
        Err(PredictError::BadSampleCount)
    );
    // The first k of K.
    let mut two = [[0.0f32; 2]; 2];
    p.predict_endpoint_set::<8>(&PAST, 1, &mut two).unwrap();
    assert_eq!(two, a[..2]);
    // Trajectories end in the same endpoints.
    let mut t = [
        gpecnet_core::Trajectory::new(),
        gpecnet_core::Trajectory::new(),
    ];
    p.predict_trajectories(&PAST, 5, &mut t).unwrap();
    assert_eq!([t[0][11], t[1][11]], two);
    // The batched path gives the same bits (it runs a proposal model track by track).
    let mut batch = Box::new(BatchPredictor::<LibmSine, 32, 8>::new(m).unwrap());
    let mut c = [[0.0f32; 2]; 4];
    batch.predict_endpoint_set::<8>(&PAST, 7, &mut c).unwrap();
    assert_eq!(a, c);
}

#[test]
fn the_bound_is_applied() {
    // With a bound far below any weight's effect every latent is ±1e-30: the K
    // endpoints collapse to the decoder at z ≈ 0; with a wide bound they differ.
    let tiny = write_f32(&proposal(4), 1e-30, None).unwrap();
    let mut p = Predictor::<LibmSine, 32>::new(Model::from_blob(&tiny).unwrap()).unwrap();
    let mut e = [[0.0f32; 2]; 4];
    p.predict_endpoint_set::<8>(&PAST, 0, &mut e).unwrap();
    assert!(e.windows(2).all(|w| w[0] == w[1]), "{e:?}");
}

#[test]
fn the_reader_checks_every_proposal_rule() {
    let ok = write_f32(&proposal(4), 2.0, None);
    assert!(ok.is_ok());
    // The bound: finite and > 0.
    for b in [0.0, -1.0, f32::NAN, f32::INFINITY] {
        assert_eq!(
            write_f32(&proposal(4), b, None),
            refused(BlobError::BadConfig),
            "{b}"
        );
    }
    // One protocol: no test-time sampling beside a proposal.
    let tts = Extensions {
        tts_samples: 8,
        ..Extensions::default()
    };
    assert_eq!(
        write_f32(&proposal(4), 2.0, Some(tts)),
        refused(BlobError::BadConfig)
    );
    let shape = refused(BlobError::ShapeMismatch(NetworkId::Proposal));
    // Outputs not whole latents, a non-linear last layer, a wrong input width, too many.
    let partial = vec![
        layer(4, 5, Activation::Relu, 11, 0.9),
        layer(5, 10, Activation::Linear, 12, 0.9),
    ];
    assert_eq!(write_f32(&partial, 2.0, None), shape);
    let sine_last = vec![layer(4, 12, Activation::Sine, 12, 0.9)];
    assert_eq!(write_f32(&sine_last, 2.0, None), shape);
    let wrong_in = vec![layer(5, 12, Activation::Linear, 12, 0.9)];
    assert_eq!(write_f32(&wrong_in, 2.0, None), shape);
    assert_eq!(
        write_f32(&proposal(MAX_PROPOSAL_LATENTS + 1), 2.0, None),
        shape
    );
    assert!(write_f32(&proposal(MAX_PROPOSAL_LATENTS), 2.0, None).is_ok());
    let nan = {
        let mut l = proposal(4);
        let w = f32s(&l[1].weights);
        let mut w = w.clone();
        w[3] = f32::NAN;
        l[1] = WireLayer::f32(5, 12, Activation::Linear, &w, &f32s(&l[1].bias));
        l
    };
    assert_eq!(
        write_f32(&nan, 2.0, None),
        refused(BlobError::NonFinite(NetworkId::Proposal))
    );
}

#[test]
fn damage_to_a_version_5_blob_is_refused() {
    let blob = write_f32(&proposal(4), 2.0, None).unwrap();
    let [magic, ..] = assert_damage_rejected(&blob);
    assert!(magic > 0);
}

/// Fixed point: exponents 6 (input), 10 (features, decoder input), 5 (decoder output).
fn write_q15(proposal: &[WireLayer], bound: f32) -> Result<Vec<u8>, Refused> {
    let nets = q_nets();
    let head = BlobHead {
        numeric: NumericKind::Int16Q15,
        name: "v5-q",
        config: config(),
        extensions: None,
        meta: Some(META),
    };
    write_with_proposal(&head, [&nets[0], &nets[1], &[], &[], &[]], proposal, bound)
}

#[test]
fn fixed_point_ranges_hold_the_bound() {
    use Activation::*;
    let good = vec![
        qlayer(4, 5, Relu, (10, 12), 9),
        qlayer(5, 6, Linear, (12, 10), 10),
    ];
    let blob = write_q15(&good, 4.0).unwrap();
    let m = Model::from_blob(&blob).unwrap();
    let mut p = Predictor::<LibmSine, 32>::new(m).unwrap();
    let mut e = [[0.0f32; 2]; 2];
    p.predict_endpoint_set::<4>(&PAST, 0, &mut e).unwrap();
    let scale = refused(BlobError::BadScale(NetworkId::Proposal));
    // The decoder's input exponent 10 holds ±31.99: a bound of 40 would saturate.
    assert_eq!(write_q15(&good, 40.0), scale);
    // The proposal's output exponent 12 holds ±7.99.
    let narrow = vec![
        qlayer(4, 5, Relu, (10, 12), 9),
        qlayer(5, 6, Linear, (12, 12), 10),
    ];
    assert!(write_q15(&narrow, 7.9).is_ok());
    assert_eq!(write_q15(&narrow, 8.5), scale);
    // Its input must be the features' exponent.
    let wrong_in = vec![
        qlayer(4, 5, Relu, (11, 12), 9),
        qlayer(5, 6, Linear, (12, 10), 10),
    ];
    assert_eq!(write_q15(&wrong_in, 4.0), scale);
}
