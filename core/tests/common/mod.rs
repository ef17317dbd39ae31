//! A small blob writer for tests (the trainer has the production exporter).
#![allow(dead_code)]

use gpecnet_core::blob::{
    Activation, LayerWire, ModelConfig, ModelInfo, NumericKind, Preamble, CRC32, MAGIC,
    MIN_FORMAT_VERSION,
};

pub struct TestLayer {
    pub in_dim: usize,
    pub out_dim: usize,
    pub act: Activation,
    pub w: Vec<f32>,
    pub b: Vec<f32>,
}

/// Deterministic pseudo-random weights in [-scale, scale).
pub fn layer(in_dim: usize, out_dim: usize, act: Activation, seed: u32, scale: f32) -> TestLayer {
    let mut s = seed.wrapping_mul(2654435761).wrapping_add(1);
    let mut next = move || {
        s ^= s << 13;
        s ^= s >> 17;
        s ^= s << 5;
        ((s >> 8) as f32 / 16_777_216.0 * 2.0 - 1.0) * scale
    };
    let w = (0..in_dim * out_dim).map(|_| next()).collect();
    let b = (0..out_dim).map(|_| next()).collect();
    TestLayer {
        in_dim,
        out_dim,
        act,
        w,
        b,
    }
}

pub fn bytes(v: &[f32]) -> Vec<u8> {
    v.iter().flat_map(|x| x.to_le_bytes()).collect()
}

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
pub fn small_nets(act: Activation) -> [Vec<TestLayer>; 4] {
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

/// Serialises a blob exactly as weights/FORMAT.md describes.
pub fn encode(
    name: &str,
    config: ModelConfig,
    nets: &[Vec<TestLayer>; 4],
    version: u16,
) -> Vec<u8> {
    let mut out = postcard::to_stdvec(&Preamble {
        magic: MAGIC,
        version,
    })
    .unwrap();
    out.extend(
        postcard::to_stdvec(&ModelInfo {
            numeric: NumericKind::F32,
            name,
            config,
        })
        .unwrap(),
    );
    for net in nets {
        out.extend(postcard::to_stdvec(&(net.len() as u8)).unwrap());
        for l in net {
            let (w, b) = (bytes(&l.w), bytes(&l.b));
            let wire = LayerWire {
                in_dim: l.in_dim as u16,
                out_dim: l.out_dim as u16,
                activation: l.act,
                weights: &w,
                bias: &b,
            };
            out.extend(postcard::to_stdvec(&wire).unwrap());
        }
    }
    seal(out)
}

/// A format-2 blob: `nets` plus a point head (16 → 8 → 24), heading frame over
/// `heading_steps`, `tts` test-time samples (3 Lloyd iterations, first-K init).
pub fn encode_v2(name: &str, nets: &[Vec<TestLayer>; 4], heading_steps: u8, tts: u16) -> Vec<u8> {
    let v1 = encode(name, config(), nets, MIN_FORMAT_VERSION);
    // Re-assemble: preamble (version 2), model info, extensions, 4 networks, point head.
    let mut out = postcard::to_stdvec(&Preamble {
        magic: MAGIC,
        version: 2,
    })
    .unwrap();
    let head_len = postcard::to_stdvec(&Preamble {
        magic: MAGIC,
        version: MIN_FORMAT_VERSION,
    })
    .unwrap()
    .len();
    let info = postcard::to_stdvec(&ModelInfo {
        numeric: NumericKind::F32,
        name,
        config: config(),
    })
    .unwrap();
    out.extend(&info);
    out.extend(
        postcard::to_stdvec(&gpecnet_core::blob::Extensions {
            heading_steps,
            tts_samples: tts,
            tts_iters: 3,
            tts_init: 0,
        })
        .unwrap(),
    );
    out.extend(&v1[head_len + info.len()..v1.len() - 4]);
    let head = [
        layer(16, 8, Activation::Sine, 21, 0.5),
        layer(8, 24, Activation::Linear, 22, 0.5),
    ];
    out.extend(postcard::to_stdvec(&(head.len() as u8)).unwrap());
    for l in &head {
        let (w, b) = (bytes(&l.w), bytes(&l.b));
        out.extend(
            postcard::to_stdvec(&LayerWire {
                in_dim: l.in_dim as u16,
                out_dim: l.out_dim as u16,
                activation: l.act,
                weights: &w,
                bias: &b,
            })
            .unwrap(),
        );
    }
    seal(out)
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

pub fn small_blob() -> Vec<u8> {
    encode(
        "test-small",
        config(),
        &small_nets(Activation::Sine),
        MIN_FORMAT_VERSION,
    )
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
