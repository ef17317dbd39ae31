//! Format version 6: endpoint probabilities and radii. The reader's rules (radius
//! multipliers, point head, logit rows), damage to a version-6 blob, and what
//! `gpecnet_core::planner` returns: probabilities that sum to one over the endpoints asked
//! for, radii by the specified formula, and `1/k` without a head.
use crate::common;

use common::*;
use gpecnet_blob_writer::{BlobHead, WireLayer};
use gpecnet_core::blob::{Activation, NetworkId, NumericKind};
use gpecnet_core::planner::{most_probable, radii, softmax, Forecast};
use gpecnet_core::{BlobError, LibmSine, Model, PredictError, Predictor};

/// A proposal of `k` latents (zdim 3) and `logits` logit rows: 4 → 5 (ReLU) → 3k + logits.
fn proposal(k: usize, logits: usize) -> Vec<WireLayer> {
    vec![
        layer(4, 5, Activation::Relu, 11, 0.9),
        layer(5, 3 * k + logits, Activation::Linear, 12, 0.9),
    ]
}

/// The small f32 model (fdim 4, zdim 3), with a point head when `point`, `proposal` and the
/// radius multipliers `scales`.
fn write_scored(proposal: &[WireLayer], scales: [f32; 2], point: bool) -> Result<Vec<u8>, Refused> {
    let head = BlobHead {
        numeric: NumericKind::F32,
        name: "v6",
        config: config(),
        extensions: None,
        meta: Some(META),
    };
    let [a, b, c, d] = &small_nets(Activation::Sine);
    let point_head = if point {
        vec![layer(16, 24, Activation::Linear, 13, 0.3)]
    } else {
        vec![]
    };
    write_with_scores(&head, [a, b, c, d, &point_head], proposal, 2.0, scales)
}

fn predictor(blob: &[u8]) -> Predictor<'_, LibmSine, 32> {
    Predictor::new(Model::from_blob(blob).unwrap()).unwrap()
}

#[test]
fn a_scored_blob_is_version_6_and_returns_probabilities_and_radii() {
    let blob = write_scored(&proposal(4, 4), [0.5, 1.5], true).unwrap();
    assert_eq!(version_of(&blob), 6);
    let m = Model::from_blob(&blob).unwrap();
    assert!(m.has_probabilities());
    assert_eq!((m.proposal_latents(), m.radius_scales()), (4, [0.5, 1.5]));
    let mut p = predictor(&blob);
    let f: Forecast<8> = p.predict_forecast(&PAST, 3).unwrap();
    assert!(f.learned);
    assert_eq!(f.endpoints.len(), 4, "as many endpoints as the model gives");
    let total: f32 = f.probabilities.iter().sum();
    assert!((total - 1.0).abs() < 1e-6, "{total}");
    assert!(f.probabilities.iter().all(|&q| q > 0.0 && q < 1.0));
    assert!(
        f.probabilities.windows(2).any(|w| w[0] != w[1]),
        "learned, not uniform"
    );
    // The endpoints are the model's endpoint set, unchanged by the logit rows.
    let mut set = [[0.0f32; 2]; 4];
    p.predict_endpoint_set::<8>(&PAST, 3, &mut set).unwrap();
    assert_eq!(f.endpoints.as_slice(), &set);
    // The point is the point forecast's endpoint, the radii the specified formula.
    let point = p.predict_point(&PAST).unwrap();
    assert_eq!(f.point, point.last().copied());
    let pt = f.point.unwrap();
    let mut s2 = 0.0f32;
    for (e, &q) in f.endpoints.iter().zip(&f.probabilities) {
        let (dx, dy) = (e[0] - pt[0], e[1] - pt[1]);
        s2 += q * (dx * dx + dy * dy);
    }
    let s = libm::sqrtf(s2);
    let r = f.radii.unwrap();
    assert_eq!(
        (r.r50.to_bits(), r.r90.to_bits()),
        ((0.5 * s).to_bits(), (1.5 * s).to_bits())
    );
    assert!(f.most_probable().is_some_and(|i| i < 4));
}

#[test]
fn the_slice_form_gives_the_forecast_bit_for_bit() {
    let blob = write_scored(&proposal(4, 4), [0.5, 1.5], true).unwrap();
    let mut p = predictor(&blob);
    let f: Forecast<8> = p.predict_forecast(&PAST, 5).unwrap();
    let (mut ends, mut probs) = ([[0.0f32; 2]; 4], [0.0f32; 4]);
    let out = p
        .predict_planner::<8>(&PAST, 5, &mut ends, &mut probs)
        .unwrap();
    assert_eq!(f.endpoints.as_slice(), &ends);
    let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    assert_eq!(bits(&f.probabilities), bits(&probs));
    assert_eq!(out.point, Some(p.predict_point(&PAST).unwrap()));
    assert_eq!((out.learned, out.radii), (f.learned, f.radii));
    assert_eq!(most_probable(&probs), f.most_probable());
    assert_eq!(most_probable(&[]), None);
    assert_eq!(
        most_probable(&[0.25, 0.5, 0.5]),
        Some(1),
        "the first of equals"
    );
    // Buffers of different lengths are refused before anything runs.
    let mut short = [0.0f32; 3];
    assert_eq!(
        p.predict_planner::<8>(&PAST, 5, &mut ends, &mut short),
        Err(PredictError::BadSampleCount)
    );
}

#[test]
fn fewer_endpoints_renormalise_and_more_are_refused() {
    let blob = write_scored(&proposal(4, 4), [0.5, 1.5], true).unwrap();
    let mut p = predictor(&blob);
    let mut all = [0.0f32; 4];
    let mut two = [0.0f32; 2];
    assert_eq!(p.probabilities(&mut all), Err(PredictError::NotStarted));
    p.start(&PAST, 0).unwrap();
    assert_eq!(p.probabilities(&mut all), Ok(true));
    assert_eq!(p.probabilities(&mut two), Ok(true));
    // The first two logits alone: the same ratio, renormalised.
    let ratio = |a: f32, b: f32| a / b;
    assert!((ratio(two[0], two[1]) - ratio(all[0], all[1])).abs() < 1e-5);
    assert!((two[0] + two[1] - 1.0).abs() < 1e-6);
    let mut five = [0.0f32; 5];
    assert_eq!(
        p.probabilities(&mut five),
        Err(PredictError::BadSampleCount)
    );
    assert_eq!(p.probabilities(&mut []), Err(PredictError::BadSampleCount));
}

#[test]
fn a_model_without_probabilities_says_so() {
    let head = BlobHead {
        numeric: NumericKind::F32,
        name: "v5",
        config: config(),
        extensions: None,
        meta: Some(META),
    };
    let [a, b, c, d] = &small_nets(Activation::Sine);
    let blob = write_with_proposal(&head, [a, b, c, d, &[]], &proposal(4, 0), 2.0).unwrap();
    assert_eq!(version_of(&blob), 5);
    let mut p = predictor(&blob);
    let f: Forecast<8> = p.predict_forecast(&PAST, 0).unwrap();
    assert!(!f.learned);
    assert_eq!(f.probabilities.as_slice(), &[0.25; 4]);
    assert_eq!((f.point, f.radii), (None, None));
    // A plain-sampling model: K = the capacity, 1/K each.
    let small = small_blob();
    let mut q = predictor(&small);
    let g: Forecast<5> = q.predict_forecast(&PAST, 0).unwrap();
    assert_eq!(
        (g.learned, g.probabilities.as_slice()),
        (false, &[0.2; 5][..])
    );
}

#[test]
fn the_reader_checks_every_radius_rule() {
    let bad_config = refused::<Vec<u8>>(BlobError::BadConfig);
    for scales in [
        [1.5, 0.5],
        [0.0, 1.0],
        [-0.5, 1.0],
        [0.5, f32::INFINITY],
        [f32::NAN, 1.0],
        [0.5, -0.0],
    ] {
        let got = write_scored(&proposal(4, 4), scales, true).map(|_| ());
        assert!(got.is_err(), "{scales:?} accepted");
    }
    // Radii are around the point forecast: a model without a point head may not have them.
    assert_eq!(write_scored(&proposal(4, 4), [0.5, 1.5], false), bad_config);
    // K·(zdim + 1) rows: 4 latents of 3 and 3 logits do not divide.
    assert_eq!(
        write_scored(&proposal(4, 3), [0.5, 1.5], true),
        refused(BlobError::ShapeMismatch(NetworkId::Proposal))
    );
    // Equal multipliers are allowed.
    assert!(write_scored(&proposal(4, 4), [1.0, 1.0], true).is_ok());
}

#[test]
fn damage_to_a_version_6_blob_is_refused() {
    let blob = write_scored(&proposal(4, 4), [0.5, 1.5], true).unwrap();
    assert_damage_rejected(&blob);
}

#[test]
fn softmax_and_radii_refuse_what_is_not_finite() {
    let mut l = [1e30f32, -1e30, 0.0];
    softmax(&mut l).unwrap();
    assert_eq!(l, [1.0, 0.0, 0.0]);
    let mut bad = [0.0f32, f32::NAN];
    assert_eq!(softmax(&mut bad), Err(PredictError::NonFiniteOutput));
    assert_eq!(softmax(&mut []), Err(PredictError::BadSampleCount));
    let e = [[1e30f32, 0.0], [-1e30, 0.0]];
    assert_eq!(
        radii([0.0, 0.0], &e, &[0.5, 0.5], [1.0, 2.0]),
        Err(PredictError::NonFiniteOutput)
    );
    let r = radii([0.0, 0.0], &[[3.0, 4.0]], &[1.0], [0.5, 2.0]).unwrap();
    assert_eq!((r.r50, r.r90), (2.5, 10.0));
}
