//! Test blobs for the core's integration tests, written through `gpecnet-blob-writer` (the one
//! writer of blobs, as the trainer and the firmware host tools use it). Networks are
//! [`WireLayer`]s; the helpers below read and edit their little-endian tensors, and the
//! reader-contract tests damage finished blobs ([`seal`], [`reseal`], [`with_version`]).
#![allow(dead_code)]

use gpecnet_blob_writer::{blob_bytes, BlobHead, Extensions, WriteError};
pub use gpecnet_blob_writer::{FixedScale, WireLayer};
use gpecnet_core::blob::{Activation, ModelConfig, NumericKind, Preamble, CRC32};
use gpecnet_core::{BlobError, Model};

/// A xorshift32 stream from `state` (non-zero): the tests' deterministic "random" numbers.
pub fn xorshift32(mut state: u32) -> impl FnMut() -> u32 {
    move || {
        state ^= state << 13;
        state ^= state >> 17;
        state ^= state << 5;
        state
    }
}

/// The xorshift stream of layer `seed` (spread so that small seeds differ).
fn layer_stream(seed: u32) -> impl FnMut() -> u32 {
    xorshift32(seed.wrapping_mul(2654435761).wrapping_add(1))
}

/// An f32 layer with deterministic pseudo-random weights in [-scale, scale).
pub fn layer(in_dim: usize, out_dim: usize, act: Activation, seed: u32, scale: f32) -> WireLayer {
    let mut s = layer_stream(seed);
    let mut next = move || ((s() >> 8) as f32 / 16_777_216.0 * 2.0 - 1.0) * scale;
    let w: Vec<f32> = (0..in_dim * out_dim).map(|_| next()).collect();
    let b: Vec<f32> = (0..out_dim).map(|_| next()).collect();
    WireLayer::f32(in_dim, out_dim, act, &w, &b)
}

/// A fixed-point layer with pseudo-random int16 weights and int32 biases, input and output
/// exponents `e`, and the shifts that make the scales consistent (sine: `15 + in_exp - 32`,
/// affine: `15 + in_exp - out_exp`).
pub fn qlayer(in_dim: usize, out_dim: usize, act: Activation, e: (i8, i8), seed: u32) -> WireLayer {
    let mut next = layer_stream(seed);
    let w: Vec<i16> = (0..in_dim * out_dim).map(|_| next() as i16 >> 2).collect();
    let b: Vec<i32> = (0..out_dim).map(|_| (next() as i32) >> 8).collect();
    let shift = match act {
        Activation::Sine => 15 + e.0 - 32,
        _ => 15 + e.0 - e.1,
    };
    let scale = FixedScale {
        in_exp: e.0,
        out_exp: e.1,
        shifts: vec![shift; out_dim],
    };
    WireLayer::q15(in_dim, out_dim, act, &w, &b, scale)
}

/// The values of a little-endian f32 tensor.
pub fn f32s(bytes: &[u8]) -> Vec<f32> {
    bytes
        .chunks_exact(4)
        .map(|c| f32::from_le_bytes(c.try_into().unwrap()))
        .collect()
}

/// The values of a little-endian int16 tensor.
pub fn i16s(bytes: &[u8]) -> Vec<i16> {
    bytes
        .chunks_exact(2)
        .map(|c| i16::from_le_bytes(c.try_into().unwrap()))
        .collect()
}

/// The values of a little-endian int32 tensor.
pub fn i32s(bytes: &[u8]) -> Vec<i32> {
    bytes
        .chunks_exact(4)
        .map(|c| i32::from_le_bytes(c.try_into().unwrap()))
        .collect()
}

/// Overwrites element `i` of a tensor of `N`-byte values with `v`.
pub fn set<const N: usize>(tensor: &mut [u8], i: usize, v: [u8; N]) {
    tensor[i * N..(i + 1) * N].copy_from_slice(&v);
}

/// The fixed-point scaling of a Q15 layer.
pub fn scale(l: &mut WireLayer) -> &mut FixedScale {
    l.fixed.as_mut().expect("a fixed-point layer")
}

/// The hyper-parameters of the small test models.
pub fn config() -> ModelConfig {
    ModelConfig {
        past_len: 8,
        future_len: 12,
        fdim: 4,
        zdim: 3,
        data_scale: 1.86,
        sigma: 1.3,
        initial_pos_divisor: 1000.0,
        w0: 30.0,
        hidden_activation: Activation::Sine,
    }
}

/// A small but complete model: encoder 16-6-4, decoder 7-5-2, dest 2-3, predictor 9-6-22.
pub fn small_nets(act: Activation) -> [Vec<WireLayer>; 4] {
    [
        vec![
            layer(16, 6, act, 1, 0.5),
            layer(6, 4, Activation::Linear, 2, 0.5),
        ],
        vec![
            layer(7, 5, act, 3, 0.8),
            layer(5, 2, Activation::Linear, 4, 0.8),
        ],
        vec![layer(2, 3, act, 5, 0.8)],
        vec![
            layer(9, 6, act, 6, 0.5),
            layer(6, 22, Activation::Linear, 7, 0.5),
        ],
    ]
}

/// Why the writer refused a model: the core reader's error, as text (the writer reads every
/// blob back through `Model::from_blob` and reports its `BlobError` with `Display`).
pub type Refused = String;

/// `Err(e)` as [`write`] reports a blob the reader refuses with `e`.
pub fn refused<T>(e: BlobError) -> Result<T, Refused> {
    Err(e.to_string())
}

/// Writes a blob of kind `numeric` (format 1 without `extensions`, else format 2 with
/// `point_head`) through `gpecnet-blob-writer`; `Err` carries the reader's refusal.
pub fn write(
    numeric: NumericKind,
    name: &str,
    config: ModelConfig,
    nets: &[Vec<WireLayer>; 4],
    extensions: Option<Extensions>,
    point_head: &[WireLayer],
) -> Result<Vec<u8>, Refused> {
    let head = BlobHead {
        numeric,
        name,
        config,
        extensions,
        meta: None,
    };
    let [a, b, c, d] = nets;
    blob_bytes(&head, [a, b, c, d, point_head]).map_err(refusal)
}

/// The reader's refusal a writer error carries (any other writer error fails the test:
/// the writer must not fail before the reader).
pub fn refusal(e: WriteError) -> Refused {
    match e {
        WriteError::Rejected { reason, .. } => reason,
        other => panic!("the writer failed before the reader: {other}"),
    }
}

/// A format-5 blob of `head` and `nets` with `proposal` and its latent bound.
pub fn write_with_proposal(
    head: &BlobHead<'_>,
    nets: [&[WireLayer]; 5],
    proposal: &[WireLayer],
    bound: f32,
) -> Result<Vec<u8>, Refused> {
    write_with_scores(head, nets, proposal, bound, [0.0; 2])
}

/// A blob of `head` and `nets` with `proposal`, its latent bound and radius multipliers
/// (format 6 when they are not both 0: the proposal's last layer then ends in K logit rows).
pub fn write_with_scores(
    head: &BlobHead<'_>,
    nets: [&[WireLayer]; 5],
    proposal: &[WireLayer],
    bound: f32,
    radius_scales: [f32; 2],
) -> Result<Vec<u8>, Refused> {
    let proposal = gpecnet_blob_writer::ProposalWire {
        layers: proposal,
        bound,
        radius_scales,
    };
    gpecnet_blob_writer::blob_bytes_with_proposal(head, nets, Some(proposal)).map_err(refusal)
}

/// The small fixed-point model: exponents input 6, features 10, decoder output 5.
pub fn q_nets() -> [Vec<WireLayer>; 4] {
    use Activation::*;
    // Per network, its two layers: (in, out, activation, exponents, seed).
    let nets = [
        [(16, 6, Sine, (6, 15), 1), (6, 4, Linear, (15, 10), 2)],
        [(7, 5, Sine, (10, 15), 3), (5, 2, Linear, (15, 5), 4)],
        [(2, 3, Sine, (5, 15), 5), (3, 3, Relu, (15, 10), 8)],
        [(9, 6, Sine, (10, 15), 6), (6, 22, Linear, (15, 5), 7)],
    ];
    nets.map(|layers| {
        layers
            .iter()
            .map(|&(i, o, act, e, seed)| qlayer(i, o, act, e, seed))
            .collect()
    })
}

/// A format-1 f32 blob (`Err`: the reader's refusal).
pub fn try_encode(
    name: &str,
    config: ModelConfig,
    nets: &[Vec<WireLayer>; 4],
) -> Result<Vec<u8>, Refused> {
    write(NumericKind::F32, name, config, nets, None, &[])
}

/// A valid format-1 f32 blob.
pub fn encode(name: &str, config: ModelConfig, nets: &[Vec<WireLayer>; 4]) -> Vec<u8> {
    try_encode(name, config, nets).unwrap()
}

/// A format-2 blob: `nets` plus a point head (16 → 8 → 24), heading frame over
/// `heading_steps`, `tts` test-time samples (3 Lloyd iterations, first-K init).
pub fn encode_v2(name: &str, nets: &[Vec<WireLayer>; 4], heading_steps: u8, tts: u16) -> Vec<u8> {
    let head = [
        layer(16, 8, Activation::Sine, 21, 0.5),
        layer(8, 24, Activation::Linear, 22, 0.5),
    ];
    let ext = Extensions {
        heading_steps,
        tts_samples: tts,
        tts_iters: 3,
        tts_init: 0,
    };
    write(NumericKind::F32, name, config(), nets, Some(ext), &head).unwrap()
}

/// Appends the CRC-32 of `body`.
pub fn seal(mut body: Vec<u8>) -> Vec<u8> {
    let crc = CRC32.checksum(&body);
    body.extend(crc.to_le_bytes());
    body
}

/// Replaces the trailing CRC with a correct one (after editing the body).
pub fn reseal(blob: &[u8]) -> Vec<u8> {
    seal(blob[..blob.len() - 4].to_vec())
}

/// `blob` relabelled as format `version` (same body after the preamble, CRC recomputed).
pub fn with_version(blob: &[u8], version: u16) -> Vec<u8> {
    let (old, rest) = postcard::take_from_bytes::<Preamble>(blob).unwrap();
    let mut out = postcard::to_stdvec(&Preamble {
        magic: old.magic,
        version,
    })
    .unwrap();
    out.extend(&rest[..rest.len() - 4]);
    seal(out)
}

/// The format version of a blob the writer produced.
pub fn version_of(blob: &[u8]) -> u16 {
    postcard::take_from_bytes::<Preamble>(blob)
        .unwrap()
        .0
        .version
}

/// The small f32 test model `test-small` (sine hidden layers), format 1.
pub fn small_blob() -> Vec<u8> {
    encode("test-small", config(), &small_nets(Activation::Sine))
}

/// The reader's contract on damaged copies of the valid `blob`:
/// - every truncation is refused: without the CRC as truncated (below 4 bytes) or by the
///   checksum, and, with a valid CRC over what is left (from byte 6 on), as truncated or by a
///   shape;
/// - every single bit flip is refused, a flip in the magic as `BadMagic`, and the CRC catches
///   more than 7 of every 8 flips.
///
/// Returns how many bit flips gave `BadMagic`, `UnsupportedVersion`, `ChecksumMismatch` and
/// anything else.
pub fn assert_damage_rejected(blob: &[u8]) -> [usize; 4] {
    for n in 0..blob.len() {
        let err = Model::from_blob(&blob[..n]).unwrap_err();
        if n < 4 {
            assert_eq!(err, BlobError::Truncated, "len {n}");
        }
        assert!(
            matches!(
                err,
                BlobError::Truncated | BlobError::ChecksumMismatch { .. }
            ),
            "len {n}: {err:?}"
        );
    }
    for n in 6..blob.len() - 4 {
        let err = Model::from_blob(&seal(blob[..n].to_vec())).unwrap_err();
        assert!(
            err == BlobError::Truncated || matches!(err, BlobError::ShapeMismatch(_)),
            "len {n}: {err:?}"
        );
    }
    let mut counts = [0usize; 4];
    for i in 0..blob.len() * 8 {
        let mut b = blob.to_vec();
        b[i / 8] ^= 1 << (i % 8);
        let err = Model::from_blob(&b).unwrap_err();
        if i < 32 {
            assert_eq!(err, BlobError::BadMagic, "bit {i}");
        }
        counts[match err {
            BlobError::BadMagic => 0,
            BlobError::UnsupportedVersion(_) => 1,
            BlobError::ChecksumMismatch { .. } => 2,
            _ => 3,
        }] += 1;
    }
    assert!(counts[2] > blob.len() * 7, "{counts:?}");
    counts
}

/// `k` plain latent samples through the caller-owned-output API (`Err` as the core returns it).
pub fn samples<S: gpecnet_core::Sine, const W: usize>(
    p: &mut gpecnet_core::Predictor<'_, S, W>,
    past: &[[f32; 2]],
    seed: u64,
    k: usize,
) -> Result<Vec<[f32; 2]>, gpecnet_core::PredictError> {
    let mut out = vec![[0.0f32; 2]; k];
    p.predict_samples(past, seed, &mut out)?;
    Ok(out)
}

/// `k` full trajectories of plain latent samples.
pub fn trajectories<S: gpecnet_core::Sine, const W: usize>(
    p: &mut gpecnet_core::Predictor<'_, S, W>,
    past: &[[f32; 2]],
    seed: u64,
    k: usize,
) -> Result<Vec<gpecnet_core::Trajectory>, gpecnet_core::PredictError> {
    let mut out = vec![gpecnet_core::Trajectory::new(); k];
    p.predict_trajectories(past, seed, &mut out)?;
    Ok(out)
}

/// [`small_blob`]'s networks as a format-4 blob describing itself with `meta`.
pub fn small_blob_with_meta(meta: gpecnet_core::blob::Meta<'_>) -> Vec<u8> {
    let head = BlobHead {
        numeric: NumericKind::F32,
        name: "test-small",
        config: config(),
        extensions: None,
        meta: Some(meta),
    };
    let [a, b, c, d] = &small_nets(Activation::Sine);
    blob_bytes(&head, [a, b, c, d, &[]]).unwrap()
}

/// The description of the small metric test models (format 4 on).
pub const META: gpecnet_core::blob::Meta<'static> = gpecnet_core::blob::Meta {
    unit: gpecnet_core::blob::PositionUnit::Metre,
    metres_per_pixel: 0.0,
    period_s: 0.4,
    data: "test",
    licence: "",
};

/// An observed track of 8 points, walking.
pub const PAST: [[f32; 2]; 8] = [
    [1.0, 2.0],
    [1.3, 2.1],
    [1.7, 2.3],
    [2.0, 2.4],
    [2.4, 2.6],
    [2.7, 2.7],
    [3.1, 2.9],
    [3.4, 3.0],
];
