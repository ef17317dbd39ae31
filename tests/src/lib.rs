//! Shared helpers for the workspace tests: finding the data and the shipped blobs.

use std::path::PathBuf;

use gpecnet_core::golden::GoldenSet;
use gpecnet_core::{Model, Predictor, Sine};

use gpecnet_trainer::network::{Act, Layer, Networks};
use gpecnet_trainer::reference::{RefConfig, RefModel};

/// The workspace root.
pub fn workspace_root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .map(PathBuf::from)
        .unwrap_or_default()
}

/// `../shared/data` next to the checkout (or `GPECNET_DATA`).
pub fn data_root() -> PathBuf {
    std::env::var_os("GPECNET_DATA")
        .map(PathBuf::from)
        .unwrap_or_else(|| workspace_root().join("../shared/data"))
}

/// Every `weights/*.gpec` blob, sorted.
pub fn shipped_blobs() -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(workspace_root().join("weights"))
        .map(|d| {
            d.filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|p| p.extension().is_some_and(|x| x == "gpec"))
                .collect()
        })
        .unwrap_or_default();
    v.sort();
    v
}

/// A SIREN model with SIREN-initialised random weights (w0 folded), of the
/// given widths, for tests that need a model before training.
pub fn random_siren(
    name: &str,
    enc: &[usize],
    dec: &[usize],
    dest: &[usize],
    pred: &[usize],
    seed: u32,
) -> RefModel {
    let (fdim, zdim, w0) = (16usize, 16usize, 30.0f32);
    let mut s = seed.wrapping_mul(0x9E37_79B9) | 1;
    let mut uni = move || {
        s ^= s << 13;
        s ^= s >> 17;
        s ^= s << 5;
        (s >> 8) as f32 / 16_777_216.0 * 2.0 - 1.0
    };
    let mut net = |dims: Vec<usize>| -> Vec<Layer> {
        let n = dims.len() - 1;
        (0..n)
            .map(|l| {
                let (i, o) = (dims[l], dims[l + 1]);
                let last = l + 1 == n;
                let bound = if l == 0 {
                    1.0 / i as f32
                } else {
                    (6.0 / i as f32).sqrt() / w0
                };
                let fold = if last { 1.0 } else { w0 };
                let w = (0..i * o).map(|_| uni() * bound * fold).collect();
                let b = (0..o).map(|_| uni() / (i as f32).sqrt() * fold).collect();
                Layer::new(i, o, if last { Act::Linear } else { Act::Sine }, w, b)
            })
            .collect()
    };
    let ddim = *dest.last().unwrap_or(&16);
    let with = |a: usize, mid: &[usize], b: usize| [&[a][..], mid, &[b][..]].concat();
    RefModel {
        name: name.to_string(),
        config: RefConfig {
            past_len: 8,
            future_len: 12,
            fdim,
            zdim,
            data_scale: 1.86,
            sigma: 1.3,
            initial_pos_divisor: 1000.0,
            w0,
            hidden_act: Act::Sine,
            heading_steps: 0,
            tts_samples: 0,
            tts_iters: 0,
            tts_init: 0,
        },
        nets: Networks {
            encoder_past: net(with(16, enc, fdim)),
            decoder: net(with(fdim + zdim, dec, 2)),
            encoder_dest: net(with(2, &dest[..dest.len() - 1], ddim)),
            predictor: net(with(fdim + ddim + 2, pred, 22)),
            point_head: Vec::new(),
        },
    }
}

/// `m` with the format-2 features: the heading frame over `heading_steps`, a random point
/// head of hidden widths `head`, and test-time sampling of `tts` samples (3 Lloyd
/// iterations, first-K init; 0 = off).
pub fn with_v2_features(
    mut m: RefModel,
    heading_steps: usize,
    head: &[usize],
    tts: usize,
    seed: u32,
) -> RefModel {
    let donor = random_siren("donor", head, &[8], &[8, 16], &[8], seed);
    // The donor's past encoder has the point head's input width; re-draw its output layer
    // at the head's output width (2 · future_len) with the same bounds.
    let mut layers = donor.nets.encoder_past;
    if let Some(last) = layers.last_mut() {
        let out = 2 * m.config.future_len;
        let i = last.in_dim;
        last.out_dim = out;
        last.w = (0..out * i)
            .map(|j| last.w[j % last.w.len()] * if j % 3 == 0 { -1.0 } else { 1.0 })
            .collect();
        last.b = (0..out).map(|j| last.b[j % last.b.len()]).collect();
    }
    m.nets.point_head = layers;
    m.config.heading_steps = heading_steps;
    m.config.tts_samples = tts;
    m.config.tts_iters = if tts > 0 { 3 } else { 0 };
    m.config.tts_init = 0;
    m
}

/// Replays every case of `golden` through `gpecnet_core::Predictor` with sine `S` (the engine
/// of the blob's numeric kind): the endpoint set, the point forecast and sample 0's trajectory
/// where recorded. Returns how many values differ from the recorded bits.
pub fn replay_golden<S: Sine>(model: &Model<'_>, golden: &GoldenSet<'_>) -> usize {
    let mut p = Box::new(Predictor::<S, 1024>::new(*model).unwrap());
    let mut bad = 0;
    for case in golden.cases() {
        // The model's endpoint set (test-time sampling when the blob asks for it).
        let mut ends = vec![[0.0f32; 2]; case.k()];
        p.predict_endpoint_set::<{ gpecnet_core::blob::MAX_TTS_SAMPLES }>(
            &case.past, case.seed, &mut ends,
        )
        .unwrap();
        for (i, e) in ends.iter().enumerate() {
            bad += usize::from(e.map(f32::to_bits) != case.endpoint_bits(i));
        }
        // The point forecast, recorded for models with a point head (golden version 2).
        assert_eq!(model.has_point_head(), case.point_len() > 0);
        if model.has_point_head() {
            let t = p.predict_point(&case.past).unwrap();
            for (j, pt) in t.iter().enumerate() {
                bad += usize::from(Some(pt.map(f32::to_bits)) != case.point_bits(j));
            }
        }
        if case.trajectory0_len() > 0 {
            let mut t = [gpecnet_core::Trajectory::new()];
            p.predict_trajectories(&case.past, case.seed, &mut t)
                .unwrap();
            for (j, pt) in t[0].iter().enumerate() {
                bad += usize::from(Some(pt.map(f32::to_bits)) != case.trajectory0_bits(j));
            }
        }
    }
    bad
}
