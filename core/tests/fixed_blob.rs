//! Fixed-point (`Int16Q15`) blobs meet the same reader contract as f32 ones:
//! every truncation, every bit flip (with and without a valid CRC), random
//! bytes and each error path give a typed error, never a panic; and the
//! fixed predictor runs on what the reader accepts.
use gpecnet_core::blob::{
    Activation, LayerWireQ, ModelConfig, ModelInfo, NetworkId, NumericKind, Preamble, CRC32, MAGIC,
    MIN_FORMAT_VERSION,
};
mod common;

use common::{samples, trajectories};
use gpecnet_core::fixed::Q15;
use gpecnet_core::{BlobError, Engine, Error, LibmSine, Model, PredictError, Predictor};

#[derive(Clone)]
struct QLayer {
    in_dim: usize,
    out_dim: usize,
    act: Activation,
    in_exp: i8,
    out_exp: i8,
    w: Vec<i16>,
    b: Vec<i32>,
    s: Vec<i8>,
}

fn qlayer(in_dim: usize, out_dim: usize, act: Activation, e: (i8, i8), seed: u32) -> QLayer {
    let mut st = seed.wrapping_mul(2654435761).wrapping_add(1);
    let mut next = move || {
        st ^= st << 13;
        st ^= st >> 17;
        st ^= st << 5;
        st
    };
    let w = (0..in_dim * out_dim).map(|_| next() as i16 >> 2).collect();
    let b = (0..out_dim).map(|_| (next() as i32) >> 8).collect();
    // Sine: ew + in_exp - 32 with ew = 15; affine: ew + in_exp - out_exp.
    let s = (0..out_dim)
        .map(|_| match act {
            Activation::Sine => 15 + e.0 - 32,
            _ => 15 + e.0 - e.1,
        })
        .collect();
    QLayer {
        in_dim,
        out_dim,
        act,
        in_exp: e.0,
        out_exp: e.1,
        w,
        b,
        s,
    }
}

fn config() -> ModelConfig {
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

/// Exponents: input 6, features 10, decoder output 5.
fn nets() -> [Vec<QLayer>; 4] {
    use Activation::*;
    [
        vec![
            qlayer(16, 6, Sine, (6, 15), 1),
            qlayer(6, 4, Linear, (15, 10), 2),
        ],
        vec![
            qlayer(7, 5, Sine, (10, 15), 3),
            qlayer(5, 2, Linear, (15, 5), 4),
        ],
        vec![
            qlayer(2, 3, Sine, (5, 15), 5),
            qlayer(3, 3, Relu, (15, 10), 8),
        ],
        vec![
            qlayer(9, 6, Sine, (10, 15), 6),
            qlayer(6, 22, Linear, (15, 5), 7),
        ],
    ]
}

fn seal(mut body: Vec<u8>) -> Vec<u8> {
    let crc = CRC32.checksum(&body);
    body.extend(crc.to_le_bytes());
    body
}

fn encode(nets: &[Vec<QLayer>; 4], config: ModelConfig) -> Vec<u8> {
    let mut out = postcard::to_stdvec(&Preamble {
        magic: MAGIC,
        version: MIN_FORMAT_VERSION,
    })
    .unwrap();
    out.extend(
        postcard::to_stdvec(&ModelInfo {
            numeric: NumericKind::Int16Q15,
            name: "test-q",
            config,
        })
        .unwrap(),
    );
    for net in nets {
        out.extend(postcard::to_stdvec(&(net.len() as u8)).unwrap());
        for l in net {
            let w: Vec<u8> = l.w.iter().flat_map(|v| v.to_le_bytes()).collect();
            let b: Vec<u8> = l.b.iter().flat_map(|v| v.to_le_bytes()).collect();
            let s: Vec<u8> = l.s.iter().map(|&v| v as u8).collect();
            let wire = LayerWireQ {
                in_dim: l.in_dim as u16,
                out_dim: l.out_dim as u16,
                activation: l.act,
                in_exp: l.in_exp,
                out_exp: l.out_exp,
                weights: &w,
                bias: &b,
                shifts: &s,
            };
            out.extend(postcard::to_stdvec(&wire).unwrap());
        }
    }
    seal(out)
}

fn blob() -> Vec<u8> {
    encode(&nets(), config())
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
    assert_eq!(l.weight_q(0, 0), nets()[1][0].w[0]);
    assert_eq!(l.bias_q(4), nets()[1][0].b[4]);
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
fn every_truncation_is_rejected() {
    let b = blob();
    for n in 0..b.len() {
        let err = Model::from_blob(&b[..n]).unwrap_err();
        assert!(
            matches!(
                err,
                BlobError::Truncated | BlobError::ChecksumMismatch { .. }
            ),
            "len {n}: {err:?}"
        );
    }
    for n in 6..b.len() - 4 {
        let err = Model::from_blob(&seal(b[..n].to_vec())).unwrap_err();
        assert!(
            err == BlobError::Truncated || matches!(err, BlobError::ShapeMismatch(_)),
            "len {n}: {err:?}"
        );
    }
}

#[test]
fn every_single_bit_flip_is_rejected() {
    let b = blob();
    let mut crc_fails = 0;
    for byte in 0..b.len() {
        for bit in 0..8 {
            let mut c = b.clone();
            c[byte] ^= 1 << bit;
            let err = Model::from_blob(&c).unwrap_err();
            if byte < 4 {
                assert_eq!(err, BlobError::BadMagic);
            }
            crc_fails += usize::from(matches!(err, BlobError::ChecksumMismatch { .. }));
        }
    }
    assert!(crc_fails > b.len() * 7, "{crc_fails}");
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
    let mut s = 0x8765_4321u32;
    let mut next = move || {
        s ^= s << 13;
        s ^= s >> 17;
        s ^= s << 5;
        s
    };
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

fn with(edit: impl Fn(&mut [Vec<QLayer>; 4])) -> Result<(), BlobError> {
    let mut n = nets();
    edit(&mut n);
    Model::from_blob(&encode(&n, config())).map(|_| ())
}

#[test]
fn error_paths() {
    // Shapes: i16 weights (2 bytes), i32 biases, one shift per channel.
    assert_eq!(
        with(|n| {
            n[1][0].w.pop();
        }),
        Err(BlobError::ShapeMismatch(NetworkId::Decoder))
    );
    assert_eq!(
        with(|n| n[0][0].b.push(0)),
        Err(BlobError::ShapeMismatch(NetworkId::EncoderPast))
    );
    assert_eq!(
        with(|n| {
            n[3][1].s.pop();
        }),
        Err(BlobError::ShapeMismatch(NetworkId::Predictor))
    );
    // Scales.
    assert_eq!(
        with(|n| n[0][1].in_exp = 14),
        Err(BlobError::BadScale(NetworkId::EncoderPast))
    );
    assert_eq!(
        with(|n| n[0][0].out_exp = 14),
        Err(BlobError::BadScale(NetworkId::EncoderPast))
    );
    assert_eq!(
        with(|n| n[0][0].in_exp = 31),
        Err(BlobError::BadScale(NetworkId::EncoderPast))
    );
    assert_eq!(
        with(|n| n[1][1].s[0] = -1),
        Err(BlobError::BadScale(NetworkId::Decoder))
    );
    assert_eq!(
        with(|n| n[1][0].s[0] = -32),
        Err(BlobError::BadScale(NetworkId::Decoder))
    );
    assert_eq!(
        with(|n| n[1][0].s[0] = 63),
        Err(BlobError::BadScale(NetworkId::Decoder))
    );
    assert_eq!(with(|n| n[1][0].s[0] = -31), Ok(()));
    // Boundaries between networks.
    assert_eq!(
        with(|n| n[1][0].in_exp = 9),
        Err(BlobError::BadScale(NetworkId::Decoder))
    );
    assert_eq!(
        with(|n| n[2][0].in_exp = 6),
        Err(BlobError::BadScale(NetworkId::EncoderDest))
    );
    assert_eq!(
        with(|n| n[2][1].out_exp = 9),
        Err(BlobError::BadScale(NetworkId::EncoderDest))
    );
    assert_eq!(
        with(|n| n[3][0].in_exp = 9),
        Err(BlobError::BadScale(NetworkId::Predictor))
    );
    // Endpoint-only fixed models are valid.
    assert_eq!(
        with(|n| {
            n[2].clear();
            n[3].clear();
        }),
        Ok(())
    );
}

#[test]
fn f32_models_are_refused_by_the_fixed_engine_and_run_by_the_predictor() {
    // Same config, f32 layers: build via the f32 wire with zero weights.
    use gpecnet_core::blob::LayerWire;
    let mut out = postcard::to_stdvec(&Preamble {
        magic: MAGIC,
        version: MIN_FORMAT_VERSION,
    })
    .unwrap();
    out.extend(
        postcard::to_stdvec(&ModelInfo {
            numeric: NumericKind::F32,
            name: "f",
            config: config(),
        })
        .unwrap(),
    );
    for dims in [&[(16usize, 4usize)][..], &[(7, 2)], &[(2, 3)], &[(9, 22)]] {
        out.extend(postcard::to_stdvec(&(dims.len() as u8)).unwrap());
        for &(i, o) in dims {
            let (w, b) = (vec![0u8; i * o * 4], vec![0u8; o * 4]);
            let wire = LayerWire {
                in_dim: i as u16,
                out_dim: o as u16,
                activation: Activation::Linear,
                weights: &w,
                bias: &b,
            };
            out.extend(postcard::to_stdvec(&wire).unwrap());
        }
    }
    let b = seal(out);
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
    let mut ns = nets();
    let mut wide = qlayer(N, M, Activation::Linear, (15, 15), 9);
    // Rows: all −32768, all 32767, alternating signs, then mixed extremes.
    for j in 0..M {
        for i in 0..N {
            wide.w[j * N + i] = match j % 4 {
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
        wide.b[j] = if j % 2 == 0 { i32::MIN } else { i32::MAX };
        wide.s[j] = [0, 1, 31, 32, 62][j % 5];
    }
    ns[3] = vec![
        qlayer(9, N, Activation::Sine, (10, 15), 6),
        wide.clone(),
        qlayer(M, 22, Activation::Linear, (15, 5), 7),
    ];
    let b = encode(&ns, config());
    let m = Model::from_blob(&b).unwrap();
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
                    let want: i128 = i128::from(wide.b[j])
                        + (0..len)
                            .map(|i| i128::from(wide.w[j * N + i]) * i128::from(xs[i]))
                            .sum::<i128>();
                    assert_eq!(i128::from(part[j]), want, "row {j}, {len} inputs");
                    if len == N {
                        let acc = i64::try_from(want).unwrap();
                        assert_eq!(out[j], activate_q(Activation::Linear, acc, wide.s[j]));
                    }
                }
            }
        }
    }
}
