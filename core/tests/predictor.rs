//! The predictor against independent computations: by hand, in f64, and a
#![allow(clippy::needless_range_loop)]
//! naive f32 pass in the documented order (which must agree bit for bit).
use crate::common;

use common::*;
use gpecnet_core::blob::Activation;
use gpecnet_core::prng::Gaussian;
use gpecnet_core::{FastSine, LibmSine, Model, PredictError, Predictor, Sine};

const PAST: [[f32; 2]; 8] = [
    [100.0, 200.0],
    [102.0, 201.5],
    [104.5, 203.0],
    [106.0, 205.0],
    [108.5, 206.0],
    [110.0, 208.5],
    [112.5, 210.0],
    [114.0, 212.0],
];

/// Naive dense layer, f32, left-to-right (the documented order).
fn dense_f32<S: Sine>(l: &WireLayer, x: &[f32]) -> Vec<f32> {
    let (w, b) = (f32s(&l.weights), f32s(&l.bias));
    (0..l.out_dim)
        .map(|j| {
            let mut acc = b[j];
            for i in 0..l.in_dim {
                acc += w[j * l.in_dim + i] * x[i];
            }
            match l.activation {
                Activation::Linear => acc,
                Activation::Relu => {
                    if acc < 0.0 {
                        0.0
                    } else {
                        acc
                    }
                }
                Activation::Sine => S::sin(acc),
            }
        })
        .collect()
}

fn dense_f64(l: &WireLayer, x: &[f64]) -> Vec<f64> {
    let (w, b) = (f32s(&l.weights), f32s(&l.bias));
    (0..l.out_dim)
        .map(|j| {
            let acc: f64 = b[j] as f64
                + (0..l.in_dim)
                    .map(|i| w[j * l.in_dim + i] as f64 * x[i])
                    .sum::<f64>();
            match l.activation {
                Activation::Linear => acc,
                Activation::Relu => acc.max(0.0),
                Activation::Sine => acc.sin(),
            }
        })
        .collect()
}

fn net_f32<S: Sine>(net: &[WireLayer], x: &[f32]) -> Vec<f32> {
    net.iter().fold(x.to_vec(), |h, l| dense_f32::<S>(l, &h))
}

fn net_f64(net: &[WireLayer], x: &[f64]) -> Vec<f64> {
    net.iter().fold(x.to_vec(), |h, l| dense_f64(l, &h))
}

/// The whole documented computation, written out naively (full decoder pass,
/// no feature-column caching), returning endpoints and trajectories.
fn naive<S: Sine>(nets: &[Vec<WireLayer>; 4], seed: u64, k: usize) -> Vec<Vec<[f32; 2]>> {
    let c = config();
    let o = PAST[0];
    let x: Vec<f32> = PAST
        .iter()
        .flat_map(|p| [(p[0] - o[0]) * c.data_scale, (p[1] - o[1]) * c.data_scale])
        .collect();
    let f = net_f32::<S>(&nets[0], &x);
    let mut g = Gaussian::new(seed);
    (0..k)
        .map(|_| {
            let z: Vec<f32> = (0..c.zdim).map(|_| c.sigma * g.next()).collect();
            let d = net_f32::<S>(&nets[1], &[f.clone(), z].concat());
            let e = [d[0] / c.data_scale + o[0], d[1] / c.data_scale + o[1]];
            let gd = net_f32::<S>(&nets[2], &d);
            let last = PAST[7];
            let inp = [
                f.clone(),
                gd,
                vec![
                    last[0] / c.initial_pos_divisor,
                    last[1] / c.initial_pos_divisor,
                ],
            ]
            .concat();
            let q = net_f32::<S>(&nets[3], &inp);
            let mut t: Vec<[f32; 2]> = q
                .chunks(2)
                .map(|p| [p[0] / c.data_scale + o[0], p[1] / c.data_scale + o[1]])
                .collect();
            t.push(e);
            t
        })
        .collect()
}

#[test]
fn hand_computed_single_sine_layer() {
    // encoder: one Sine layer 16 -> 4 with W[j][i] = 0.01 (i+1)(j+1), b = -0.1 j;
    // decoder linear 7 -> 2 summing the features and ignoring z.
    let mut nets = small_nets(Activation::Sine);
    let (mut w, mut b) = (vec![0.0f32; 16 * 4], vec![0.0f32; 4]);
    for j in 0..4 {
        for i in 0..16 {
            w[j * 16 + i] = 0.01 * ((i + 1) * (j + 1)) as f32;
        }
        b[j] = -0.1 * j as f32;
    }
    nets[0] = vec![WireLayer::f32(16, 4, Activation::Sine, &w, &b)];
    let mut w = vec![0.0f32; 2 * 7];
    for i in 0..4 {
        w[i] = 1.0; // endpoint x = sum of features
        w[7 + i] = if i == 0 { 1.0 } else { 0.0 }; // endpoint y = feature 0
    }
    nets[1] = vec![WireLayer::f32(7, 2, Activation::Linear, &w, &[0.0; 2])];
    let blob = encode("hand", config(), &nets);
    let m = Model::from_blob(&blob).unwrap();
    let mut p = Predictor::<LibmSine, 32>::new(m).unwrap();
    let e = samples(&mut p, &PAST, 0, 1).unwrap()[0];
    // By hand: x = (p - p0) * 1.86 flattened; f_j = sin(sum_i 0.01 (i+1)(j+1) x_i - 0.1 j).
    let x: Vec<f64> = PAST
        .iter()
        .flat_map(|p| [(p[0] - 100.0) as f64 * 1.86, (p[1] - 200.0) as f64 * 1.86])
        .collect();
    let s: f64 = x
        .iter()
        .enumerate()
        .map(|(i, v)| 0.01 * (i + 1) as f64 * v)
        .sum();
    let f: Vec<f64> = (0..4)
        .map(|j| (s * (j + 1) as f64 - 0.1 * j as f64).sin())
        .collect();
    let want = [f.iter().sum::<f64>() / 1.86 + 100.0, f[0] / 1.86 + 200.0];
    assert!((e[0] as f64 - want[0]).abs() < 1e-4, "{e:?} vs {want:?}");
    assert!((e[1] as f64 - want[1]).abs() < 1e-4, "{e:?} vs {want:?}");
}

#[test]
fn relu_layer_and_nan_propagation() {
    let mut nets = small_nets(Activation::Relu);
    // All-negative bias, zero weights: ReLU gives exactly 0 features.
    for l in nets[0].iter_mut() {
        let (i, o) = (l.in_dim, l.out_dim);
        *l = WireLayer::f32(i, o, Activation::Relu, &vec![0.0; i * o], &vec![-1.0; o]);
    }
    let blob = encode("relu", config(), &nets);
    let m = Model::from_blob(&blob).unwrap();
    let mut p = Predictor::<LibmSine, 32>::new(m).unwrap();
    let got = samples(&mut p, &PAST, 3, 4).unwrap();
    let want = naive::<LibmSine>(&nets, 3, 4);
    for (g, w) in got.iter().zip(&want) {
        assert_eq!(g.map(f32::to_bits), w[11].map(f32::to_bits));
    }
}

fn check_bit_exact<S: Sine>(act: Activation) {
    let nets = small_nets(act);
    let blob = encode("exact", config(), &nets);
    let m = Model::from_blob(&blob).unwrap();
    let mut p = Predictor::<S, 32>::new(m).unwrap();
    for seed in [0u64, 1, 42, u64::MAX] {
        let want = naive::<S>(&nets, seed, 20);
        let ends = samples(&mut p, &PAST, seed, 20).unwrap();
        let trajs = trajectories(&mut p, &PAST, seed, 20).unwrap();
        assert_eq!(ends.len(), 20);
        for s in 0..20 {
            assert_eq!(
                ends[s].map(f32::to_bits),
                want[s][11].map(f32::to_bits),
                "seed {seed} sample {s}"
            );
            assert_eq!(trajs[s].len(), 12);
            for t in 0..12 {
                assert_eq!(trajs[s][t].map(f32::to_bits), want[s][t].map(f32::to_bits));
            }
        }
    }
}

#[test]
fn bit_exact_with_naive_pass_libm() {
    check_bit_exact::<LibmSine>(Activation::Sine);
    check_bit_exact::<LibmSine>(Activation::Relu);
}

#[test]
fn bit_exact_with_naive_pass_fast_sine() {
    check_bit_exact::<FastSine>(Activation::Sine);
}

#[test]
fn close_to_f64() {
    let nets = small_nets(Activation::Sine);
    let blob = encode("f64", config(), &nets);
    let m = Model::from_blob(&blob).unwrap();
    let mut p = Predictor::<LibmSine, 32>::new(m).unwrap();
    let ends = samples(&mut p, &PAST, 9, 5).unwrap();
    let c = config();
    let o = PAST[0];
    let x: Vec<f64> = PAST
        .iter()
        .flat_map(|q| {
            [
                (q[0] - o[0]) as f64 * c.data_scale as f64,
                (q[1] - o[1]) as f64 * c.data_scale as f64,
            ]
        })
        .collect();
    let f = net_f64(&nets[0], &x);
    let mut g = Gaussian::new(9);
    for e in &ends {
        let z: Vec<f64> = (0..3).map(|_| (c.sigma * g.next()) as f64).collect();
        let d = net_f64(&nets[1], &[f.clone(), z].concat());
        let want = [d[0] / 1.86 + o[0] as f64, d[1] / 1.86 + o[1] as f64];
        assert!(
            (e[0] as f64 - want[0]).abs() < 1e-3 && (e[1] as f64 - want[1]).abs() < 1e-3,
            "{e:?} vs {want:?}"
        );
    }
}

#[test]
fn seeds_and_determinism() {
    let blob = small_blob();
    let m = Model::from_blob(&blob).unwrap();
    let mut p = Predictor::<LibmSine, 32>::new(m).unwrap();
    let a = samples(&mut p, &PAST, 5, 20).unwrap();
    let b = samples(&mut p, &PAST, 5, 20).unwrap();
    let c = samples(&mut p, &PAST, 6, 20).unwrap();
    assert_eq!(a, b);
    assert_ne!(a, c);
    // The first k samples do not depend on how many are asked for.
    let d = samples(&mut p, &PAST, 5, 3).unwrap();
    assert_eq!(&a[..3], &d[..]);
    // Samples differ from each other.
    assert_ne!(a[0], a[1]);
}

#[test]
fn input_errors() {
    let blob = small_blob();
    let m = Model::from_blob(&blob).unwrap();
    assert_eq!(
        Predictor::<LibmSine, 8>::new(m).err(),
        Some(gpecnet_core::Error::Predict(
            PredictError::ScratchTooSmall {
                needed: 22,
                capacity: 8
            }
        ))
    );
    let mut p = Predictor::<LibmSine, 32>::new(m).unwrap();
    assert_eq!(
        samples(&mut p, &PAST[..7], 0, 4),
        Err(PredictError::WrongPastLength {
            expected: 8,
            got: 7
        })
    );
    assert_eq!(
        samples(&mut p, &PAST, 0, 0),
        Err(PredictError::BadSampleCount)
    );
    let mut bad = PAST;
    bad[3][1] = f32::NAN;
    assert_eq!(
        samples(&mut p, &bad, 0, 4),
        Err(PredictError::NonFiniteInput)
    );
    bad[3][1] = f32::INFINITY;
    assert_eq!(
        samples(&mut p, &bad, 0, 4),
        Err(PredictError::NonFiniteInput)
    );
    // Finite but absurd inputs are refused before any network runs.
    let mut huge = PAST;
    huge[7] = [3.0e38, -3.0e38];
    assert_eq!(
        samples(&mut p, &huge, 0, 4),
        Err(PredictError::InputOutOfRange)
    );
    // Endpoint-only model: trajectories are refused.
    let mut nets = small_nets(Activation::Sine);
    nets[2].clear();
    nets[3].clear();
    let blob = encode("ends", config(), &nets);
    let m = Model::from_blob(&blob).unwrap();
    let mut p = Predictor::<LibmSine, 32>::new(m).unwrap();
    assert!(samples(&mut p, &PAST, 0, 4).is_ok());
    assert_eq!(
        trajectories(&mut p, &PAST, 0, 4).err(),
        Some(PredictError::NoPredictor)
    );
}
