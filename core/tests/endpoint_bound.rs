//! `sampling::max_endpoints_of` is what every prediction path accepts: for every shipped
//! blob (formats 1 to 6, f32 and Q15) and for small format-5 and format-6 models, `k` up
//! to the bound is answered and one more is refused, on the endpoint-set call, the stream
//! (`start` + `next_endpoint`) and the batched path. A format-6 proposal's logit rows
//! follow its latent rows in the same layer: they are never decoded as a latent.
use crate::common;

use common::*;
use gpecnet_blob_writer::{BlobHead, WireLayer};
use gpecnet_core::batch::{HostBatchPredictor, Query};
use gpecnet_core::blob::{Activation, NumericKind};
use gpecnet_core::sampling::max_endpoints_of;
use gpecnet_core::{LibmSine, Model, PredictError, Predictor};

/// Samples the endpoint-set buffer holds in these tests.
const N: usize = 128;
/// Scratch width: enough for every shipped blob.
const W: usize = 1024;

/// Every shipped blob, by file name.
fn shipped() -> Vec<(String, Vec<u8>)> {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../weights");
    let mut out: Vec<(String, Vec<u8>)> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "gpec"))
        .map(|p| {
            let name = p.file_name().unwrap().to_string_lossy().into_owned();
            (name, std::fs::read(&p).unwrap())
        })
        .collect();
    out.sort();
    assert!(out.len() >= 10, "the shipped blobs are in weights/");
    out
}

/// A proposal of `k` latents (zdim 3) and `logits` logit rows: 4 → 5 (ReLU) → 3k + logits.
fn proposal(k: usize, logits: usize) -> Vec<WireLayer> {
    vec![
        layer(4, 5, Activation::Relu, 11, 0.9),
        layer(5, 3 * k + logits, Activation::Linear, 12, 0.9),
    ]
}

/// The small f32 model with a proposal of 4 latents: format 5 without logits, format 6
/// (4 logit rows after the 12 latent rows, and a point head) with.
fn small_proposal_blob(scored: bool) -> Vec<u8> {
    let head = BlobHead {
        numeric: NumericKind::F32,
        name: "bound",
        config: config(),
        extensions: None,
        meta: Some(META),
    };
    let [a, b, c, d] = &small_nets(Activation::Sine);
    let (logits, scales) = if scored {
        (4, [0.5, 1.5])
    } else {
        (0, [0.0; 2])
    };
    // Format 6 has a point head (its radii are about the point forecast).
    let point_head = if scored {
        vec![layer(16, 24, Activation::Linear, 13, 0.3)]
    } else {
        vec![]
    };
    write_with_scores(
        &head,
        [a, b, c, d, &point_head],
        &proposal(4, logits),
        2.0,
        scales,
    )
    .unwrap()
}

/// Checks every path of `blob` at its bound and one past it.
fn check_bound(name: &str, blob: &[u8]) {
    let model = Model::from_blob(blob).unwrap_or_else(|e| panic!("{name}: {e}"));
    let most = max_endpoints_of(&model, N);
    assert!(most >= 1, "{name}: no k accepted");
    let mut p = Box::new(Predictor::<LibmSine, W>::new(model).unwrap());
    let mut ends = vec![[0.0f32; 2]; most + 1];
    assert_eq!(
        p.predict_endpoint_set::<N>(&PAST, 3, &mut ends[..most]),
        Ok(()),
        "{name}: k = max_endpoints = {most}"
    );
    let over = p.predict_endpoint_set::<N>(&PAST, 3, &mut ends);
    if most == N {
        // Plain sampling: the caller's buffer is the bound.
        assert_eq!(over, Err(PredictError::CapacityExceeded), "{name}");
    } else {
        assert_eq!(
            over,
            Err(PredictError::BadSampleCount),
            "{name}: k = max_endpoints + 1 = {}",
            most + 1
        );
    }
    if model.has_proposal() {
        let k = model.proposal_latents();
        assert_eq!(most, k.min(N), "{name}: a proposal's bound is its K");
        // The stream ends after K latents.
        p.start(&PAST, 3).unwrap();
        for i in 0..k {
            assert!(p.next_endpoint().is_ok(), "{name}: latent {i}");
        }
        assert_eq!(
            p.next_endpoint(),
            Err(PredictError::BadSampleCount),
            "{name}: latent K = {k}"
        );
        // The batched path: K + 1 samples of one track are refused, K are not.
        let mut b = Box::new(HostBatchPredictor::<LibmSine, W>::new(model).unwrap());
        let q = [Query {
            past: &PAST,
            seed: 3,
        }];
        let mut out = vec![[0.0f32; 2]; k + 1];
        assert!(
            b.predict_samples_many(&q, k, &mut out[..k]).is_ok(),
            "{name}"
        );
        let e = b.predict_samples_many(&q, k + 1, &mut out).unwrap_err();
        assert_eq!(
            e.error,
            PredictError::BadSampleCount,
            "{name}: batched K + 1"
        );
        let e = b
            .predict_endpoint_sets::<N>(&q, k + 1, &mut out)
            .unwrap_err();
        assert_eq!(
            e.error,
            PredictError::BadSampleCount,
            "{name}: batched set K + 1"
        );
    }
}

#[test]
fn every_shipped_blob_answers_max_endpoints_and_refuses_one_more() {
    let blobs = shipped();
    let mut proposals = 0;
    for (name, blob) in &blobs {
        check_bound(name, blob);
        proposals += usize::from(Model::from_blob(blob).unwrap().has_proposal());
    }
    assert!(proposals >= 2, "the shipped proposal models are checked");
}

#[test]
fn a_format_5_proposal_refuses_k_plus_one() {
    let blob = small_proposal_blob(false);
    assert_eq!(version_of(&blob), 5);
    check_bound("format 5", &blob);
}

#[test]
fn a_format_6_proposal_never_decodes_its_logit_rows_as_a_latent() {
    let blob = small_proposal_blob(true);
    assert_eq!(version_of(&blob), 6);
    let m = Model::from_blob(&blob).unwrap();
    // 16 rows: 4 latents of 3, then 4 logits. A fifth latent would be rows 12..15.
    assert_eq!((m.proposal_latents(), max_endpoints_of(&m, N)), (4, 4));
    check_bound("format 6", &blob);
    let mut p = Predictor::<LibmSine, 32>::new(m).unwrap();
    let mut five = [[0.0f32; 2]; 5];
    assert_eq!(
        p.predict_endpoint_set::<8>(&PAST, 1, &mut five),
        Err(PredictError::BadSampleCount)
    );
    assert_eq!(five, [[0.0; 2]; 5], "nothing written on failure");
    let mut samples = [[0.0f32; 2]; 5];
    assert_eq!(
        p.predict_samples(&PAST, 1, &mut samples),
        Err(PredictError::BadSampleCount)
    );
}
