//! Fixed-point (`Int16Q15`) blobs meet the same reader contract as f32 ones:
//! every truncation, every bit flip (with and without a valid CRC), random
//! bytes and each error path give a typed error, never a panic; and the
//! fixed predictor runs on what the reader accepts.
use crate::common;
use gpecnet_core::blob::{Activation, NetworkId, NumericKind};

use common::*;
use gpecnet_core::fixed::Q15;
use gpecnet_core::{BlobError, Engine, Error, LibmSine, Model, PredictError, Predictor};

/// A fixed-point format-1 blob of `nets` (`Err`: the reader's refusal).
fn encode(nets: &[Vec<WireLayer>; 4]) -> Result<Vec<u8>, Refused> {
    write(NumericKind::Int16Q15, "test-q", config(), nets, None, &[])
}

fn blob() -> Vec<u8> {
    encode(&q_nets()).unwrap()
}

const PAST: [[f32; 2]; 8] = [
    [10.0, 20.0],
    [11.0, 21.5],
    [12.5, 22.0],
    [13.0, 23.5],
    [14.5, 24.0],
    [15.0, 26.0],
    [16.5, 27.0],
    [17.0, 28.5],
];

#[test]
fn valid_fixed_blob_parses_and_predicts() {
    let b = blob();
    assert_eq!(b[5], 1, "NumericKind::Int16Q15 is variant 1");
    let m = Model::from_blob(&b).unwrap();
    assert_eq!(m.numeric(), NumericKind::Int16Q15);
    assert_eq!(m.max_width(), 22);
    let l = m.decoder().layer(0).unwrap();
    assert_eq!((l.in_exp(), l.out_exp()), (10, 15));
    assert_eq!(l.weight_q(0, 0), i16s(&q_nets()[1][0].weights)[0]);
    assert_eq!(l.bias_q(4), i32s(&q_nets()[1][0].bias)[4]);
    let mut p = Predictor::<LibmSine, 32>::new(m).unwrap();
    let e1 = samples(&mut p, &PAST, 3, 8).unwrap();
    let e2 = samples(&mut p, &PAST, 3, 8).unwrap();
    assert_eq!(e1, e2);
    assert!(e1.iter().flatten().all(|v| v.is_finite()));
    let t = trajectories(&mut p, &PAST, 3, 8).unwrap();
    assert_eq!(t.len(), 8);
    for (tr, e) in t.iter().zip(&e1) {
        assert_eq!(tr.len(), 12);
        assert_eq!(tr[11], *e);
    }
    assert!(matches!(
        Predictor::<LibmSine, 8>::new(m),
        Err(Error::Predict(PredictError::ScratchTooSmall { .. }))
    ));
    assert_eq!(
        samples(&mut p, &PAST[..7], 3, 8).unwrap_err(),
        PredictError::WrongPastLength {
            expected: 8,
            got: 7
        }
    );
    assert_eq!(
        samples(&mut p, &PAST, 3, 0).unwrap_err(),
        PredictError::BadSampleCount
    );
    let mut bad = PAST;
    bad[3][1] = f32::NAN;
    assert_eq!(
        samples(&mut p, &bad, 3, 1).unwrap_err(),
        PredictError::NonFiniteInput
    );
}

#[test]
fn every_truncation_and_bit_flip_is_rejected() {
    assert_damage_rejected(&blob());
}

#[test]
fn every_bit_flip_with_valid_checksum_never_panics() {
    let b = blob();
    let body = b.len() - 4;
    let mut accepted = 0;
    for byte in 6..body {
        for bit in 0..8 {
            let mut c = b[..body].to_vec();
            c[byte] ^= 1 << bit;
            if let Ok(m) = Model::from_blob(&seal(c)) {
                accepted += 1;
                // Whatever the reader accepts, the predictor runs without panicking.
                if let Ok(mut p) = Predictor::<LibmSine, 64>::new(m) {
                    let _ = samples(&mut p, &PAST, 1, 4);
                    let _ = trajectories(&mut p, &PAST, 1, 2);
                }
            }
        }
    }
    assert!(accepted > 0);
}

#[test]
fn random_bytes_never_panic() {
    let mut next = xorshift32(0x8765_4321);
    for len in 0..2_000usize {
        let mut b: Vec<u8> = (0..len % 300).map(|_| next() as u8).collect();
        if b.len() >= 6 {
            b[..4].copy_from_slice(b"GPEC");
            b[4] = 1;
            b[5] = 1;
            b = seal(b);
        }
        let _ = Model::from_blob(&b);
    }
}

fn with(edit: impl Fn(&mut [Vec<WireLayer>; 4])) -> Result<(), Refused> {
    let mut n = q_nets();
    edit(&mut n);
    encode(&n).map(|_| ())
}

#[test]
fn error_paths() {
    use NetworkId::*;
    type Edit = fn(&mut [Vec<WireLayer>; 4]);
    let cases: [(&str, Edit, Result<(), BlobError>); 15] = [
        // Shapes: i16 weights (2 bytes), i32 biases, one shift per channel.
        (
            "weight missing",
            |n| {
                n[1][0].weights.drain(..2);
            },
            Err(BlobError::ShapeMismatch(Decoder)),
        ),
        (
            "extra bias",
            |n| n[0][0].bias.extend(0i32.to_le_bytes()),
            Err(BlobError::ShapeMismatch(EncoderPast)),
        ),
        (
            "shift missing",
            |n| {
                scale(&mut n[3][1]).shifts.pop();
            },
            Err(BlobError::ShapeMismatch(Predictor)),
        ),
        // Scales.
        (
            "in_exp",
            |n| scale(&mut n[0][1]).in_exp = 14,
            Err(BlobError::BadScale(EncoderPast)),
        ),
        (
            "out_exp",
            |n| scale(&mut n[0][0]).out_exp = 14,
            Err(BlobError::BadScale(EncoderPast)),
        ),
        (
            "in_exp 31",
            |n| scale(&mut n[0][0]).in_exp = 31,
            Err(BlobError::BadScale(EncoderPast)),
        ),
        (
            "shift -1",
            |n| scale(&mut n[1][1]).shifts[0] = -1,
            Err(BlobError::BadScale(Decoder)),
        ),
        (
            "shift -32",
            |n| scale(&mut n[1][0]).shifts[0] = -32,
            Err(BlobError::BadScale(Decoder)),
        ),
        (
            "shift 63",
            |n| scale(&mut n[1][0]).shifts[0] = 63,
            Err(BlobError::BadScale(Decoder)),
        ),
        ("shift -31", |n| scale(&mut n[1][0]).shifts[0] = -31, Ok(())),
        // Boundaries between networks.
        (
            "decoder in",
            |n| scale(&mut n[1][0]).in_exp = 9,
            Err(BlobError::BadScale(Decoder)),
        ),
        (
            "dest in",
            |n| scale(&mut n[2][0]).in_exp = 6,
            Err(BlobError::BadScale(EncoderDest)),
        ),
        (
            "dest out",
            |n| scale(&mut n[2][1]).out_exp = 9,
            Err(BlobError::BadScale(EncoderDest)),
        ),
        (
            "predictor in",
            |n| scale(&mut n[3][0]).in_exp = 9,
            Err(BlobError::BadScale(Predictor)),
        ),
        // Endpoint-only fixed models are valid.
        (
            "endpoint-only",
            |n| {
                n[2].clear();
                n[3].clear();
            },
            Ok(()),
        ),
    ];
    for (what, edit, want) in cases {
        assert_eq!(with(edit), want.map_err(|e| e.to_string()), "{what}");
    }
}

#[test]
fn f32_models_are_refused_by_the_fixed_engine_and_run_by_the_predictor() {
    // Same config, f32 layers with zero weights.
    let zeros = |i: usize, o: usize| {
        vec![WireLayer::f32(
            i,
            o,
            Activation::Linear,
            &vec![0.0; i * o],
            &vec![0.0; o],
        )]
    };
    let nets = [zeros(16, 4), zeros(7, 2), zeros(2, 3), zeros(9, 22)];
    let b = try_encode("f", config(), &nets).unwrap();
    let m = Model::from_blob(&b).unwrap();
    assert!(matches!(
        Engine::<Q15, 32>::new(m),
        Err(Error::Blob(BlobError::UnsupportedNumeric))
    ));
    // The run-time dispatching predictor takes it (the f32 engine).
    let mut p = Predictor::<LibmSine, 32>::new(m).unwrap();
    assert_eq!(p.sine_name(), "libm");
    assert_eq!(samples(&mut p, &PAST, 1, 2).unwrap().len(), 2);
}

/// The integer accumulation at the extremes: every weight and every input
/// at ±32768/32767 and the biases at the ends of `i32`, on a layer whose
/// shape exercises every path of the dense kernels (131 inputs: the
/// 16-column blocks, the 4-column blocks and an odd tail; 23 rows: the
/// row pairs and an odd last row), against a plain `i128` sum. The sums
/// reach ±131 · 2^30 + 2^31 ≈ 2^37.0, far inside `i64` (the bound for any
/// blob is 65,535 · 2^30 + 2^31 < 2^47, `docs/kernels.md`); the same
/// function runs on the Cortex-M4 with the `SMLALD` kernel, whose results
/// the QEMU golden replay checks against the host.
#[test]
fn accumulators_exact_at_extremes() {
    use gpecnet_core::engine::Backend;
    use gpecnet_core::fixed::activate_q;
    const N: usize = 131;
    const M: usize = 23;
    let mut ns = q_nets();
    // Rows: all −32768, all 32767, alternating signs, then mixed extremes.
    let (mut w, mut b, mut s) = (vec![0i16; N * M], vec![0i32; M], vec![0i8; M]);
    for j in 0..M {
        for i in 0..N {
            w[j * N + i] = match j % 4 {
                0 => i16::MIN,
                1 => i16::MAX,
                2 => {
                    if i % 2 == 0 {
                        i16::MIN
                    } else {
                        i16::MAX
                    }
                }
                _ => {
                    if (i * 7 + j) % 3 == 0 {
                        i16::MAX
                    } else {
                        i16::MIN
                    }
                }
            };
        }
        b[j] = if j % 2 == 0 { i32::MIN } else { i32::MAX };
        s[j] = [0, 1, 31, 32, 62][j % 5];
    }
    let scale = FixedScale {
        in_exp: 15,
        out_exp: 15,
        shifts: s.clone(),
    };
    let wide = WireLayer::q15(N, M, Activation::Linear, &w, &b, scale);
    ns[3] = vec![
        qlayer(9, N, Activation::Sine, (10, 15), 6),
        wide.clone(),
        qlayer(M, 22, Activation::Linear, (15, 5), 7),
    ];
    let blob = encode(&ns).unwrap();
    let m = Model::from_blob(&blob).unwrap();
    let l = m.predictor().layer(1).unwrap();
    assert_eq!((l.in_dim(), l.out_dim()), (N, M));
    let inputs: [[i16; N]; 4] = [
        [i16::MIN; N],
        [i16::MAX; N],
        core::array::from_fn(|i| if i % 2 == 0 { i16::MAX } else { i16::MIN }),
        core::array::from_fn(|i| if i % 5 == 0 { i16::MIN } else { i16::MAX }),
    ];
    for x in &inputs {
        // Aligned and shifted by one element (the kernels' other path).
        let mut buf = [0i16; N + 1];
        buf[1..].copy_from_slice(x);
        for xs in [&x[..], &buf[1..]] {
            for len in [N, N - 1, 16, 4, 3, 0] {
                let xs = &xs[..len];
                let mut part = [0i64; M];
                Q15::partial(l, xs, &mut part);
                let mut out = [0i16; M];
                if len == N {
                    Q15::dense(l, xs, &mut out);
                    // A longer output slice: the layer's rows only, the
                    // rest untouched; a shorter one: its prefix.
                    let mut longer = [7i16; M + 3];
                    Q15::dense(l, xs, &mut longer);
                    assert_eq!(longer[..M], out);
                    assert_eq!(longer[M..], [7; 3]);
                    let mut shorter = [0i16; M - 4];
                    Q15::dense(l, xs, &mut shorter);
                    assert_eq!(shorter, out[..M - 4]);
                }
                for j in 0..M {
                    let want: i128 = i128::from(b[j])
                        + (0..len)
                            .map(|i| i128::from(w[j * N + i]) * i128::from(xs[i]))
                            .sum::<i128>();
                    assert_eq!(i128::from(part[j]), want, "row {j}, {len} inputs");
                    if len == N {
                        let acc = i64::try_from(want).unwrap();
                        assert_eq!(out[j], activate_q(Activation::Linear, acc, s[j]));
                    }
                }
            }
        }
    }
}

/// `Layer::short_shifts` (every shift in −31..=32, which lets the
/// Cortex-M4/M7 sine loop skip its per-row range check) is found per layer
/// when the blob is read: a valid shift of 33..=62 or of −31 in one layer
/// turns it off or leaves it on there and nowhere else.
#[test]
fn short_shifts_flag_per_layer() {
    let short = |n: &[Vec<WireLayer>; 4]| -> Vec<bool> {
        let b = encode(n).unwrap();
        let m = Model::from_blob(&b).unwrap();
        (0..2)
            .map(|i| m.decoder().layer(i).unwrap().short_shifts())
            .collect()
    };
    let mut n = q_nets();
    let base = short(&n);
    assert_eq!(base, [true, true], "the test nets' shifts are all short");
    for (s, want) in [(32, true), (33, false), (62, false), (-31, true), (0, true)] {
        n = q_nets();
        scale(&mut n[1][0]).shifts[1] = s;
        assert_eq!(short(&n), [want, true], "decoder layer 0, shift {s}");
    }
}
