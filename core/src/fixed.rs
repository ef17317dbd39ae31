//! Fixed-point inference ([`NumericKind::Int16Q15`] blobs): int16 weights,
//! 16-bit activations, 64-bit accumulators and a table sine. Everything
//! inside the networks is integer arithmetic, so the result is exact and
//! identical on every target, and a Cortex-M4 never touches its FPU (or an
//! emulated f64) there. Only the boundaries use f32: the input normalisation
//! and the latent draw (the same f32 operations as [`crate::predictor`]),
//! each quantised once, and the final dequantisation of the outputs.
//!
//! # Number format
//!
//! An activation vector with exponent `e` holds `i16` integers `v` meaning
//! `v · 2^-e`. A layer ([`crate::blob::LayerWireQ`])
//! stores `in_exp`, `out_exp`, weights `q_ji` (i16), biases `B_j` (i32) and a
//! shift `s_j` (i8) per output channel. The quantiser picks a power-of-two
//! weight scale `2^ew_j` per output channel, so `q_ji ≈ W_ji · 2^ew_j`,
//! `B_j ≈ b_j · 2^(ew_j + in_exp)` and
//!
//! - `Linear`/`Relu`: `s_j = ew_j + in_exp − out_exp` (0..=62);
//! - `Sine`: the weights are `W / 2π` (the pre-activation is a phase in
//!   turns) and `s_j = ew_j + in_exp − 32` (−31..=62): the accumulator,
//!   shifted by `s_j`, is the phase with a full circle = 2^32.
//!
//! # One layer, exactly
//!
//! 1. `acc_j = B_j + Σ_i q_ji · x_i` in `i64` (order irrelevant: integer
//!    sums are exact; |acc| < 2^47 for any blob, so it cannot overflow).
//! 2. `Linear`: `y_j = sat16(rshr(acc_j, s_j))`; `Relu`: `max(that, 0)`;
//!    `Sine`: `phase = rshr(acc_j, s_j) mod 2^32` for `s_j ≥ 0`, else
//!    `(acc_j mod 2^32) · 2^(−s_j) mod 2^32` (wrap-around is the range
//!    reduction), then `y_j = `[`sin_q15`]`(phase)` in Q15, saturated to
//!    −32767..=32767 (so every activation is an `i16`).
//!
//! `rshr(a, s) = (a + 2^(s−1)) >> s` (arithmetic shift: round half up),
//! `rshr(a, 0) = a`; `sat16` clamps to −32768..=32767.
//!
//! # Boundaries
//!
//! - Input: `x[2t+c] = (p_t[c] − p_0[c]) · data_scale` in f32 as in the f32
//!   path, then [`quantize`]`(x, in_exp)` of `encoder_past`.
//! - Latent: `z_i = sigma · Gaussian::next()` (f32, [`crate::prng`]), then
//!   `quantize(z_i, in_exp of decoder)`.
//! - The vectors passed between networks share exponents (checked by the
//!   blob reader): features `f`, the latent, `encoder_dest`'s output and the
//!   predictor input use `encoder_past`'s output exponent; `encoder_dest`
//!   reads the decoder output as is. `initial_pos = last / divisor` (f32) is
//!   quantised with the feature exponent.
//! - Output: `d_c = (y_c as f32) · 2^-out_exp`, endpoint `d_c / data_scale + p_0[c]`
//!   (as in the f32 path); trajectory points likewise.
//!
//! The decoder's feature columns are summed once per call into an `i64`
//! partial sum and the latent columns added per sample; with integers this
//! equals one full pass exactly.
//!
//! # Memory
//!
//! `FixedPredictor<W>` holds four `i16` rows and one `i64` row of `W`
//! (`16·W` bytes). The sine table is 514 bytes of flash.
//!
//! # Speed (Cortex-M4)
//!
//! Weights are read as `[u8; 2]` pairs and activations are packed `i16`, so
//! that LLVM's ARM parallel-DSP pass turns each pair of MACs into one
//! unaligned `ldr` of two weights, one `ldr` of two activations and one
//! `smlald` (dual 16×16 multiply-accumulate into 64 bits: the exact sum
//! above). `cargo xtask profile` measures the result; see `firmware/README.md`.

use core::ops::RangeInclusive;

use crate::blob::{Activation, Layer, Model, Network, NumericKind, MAX_PAST};
use crate::predictor::{PredictError, Trajectory};
use crate::prng::Gaussian;
use crate::{BlobError, Error};

/// Allowed shifts of `Linear`/`Relu` channels.
pub const AFFINE_SHIFTS: RangeInclusive<i8> = 0..=62;
/// Allowed shifts of `Sine` channels.
pub const SINE_SHIFTS: RangeInclusive<i8> = -31..=62;
/// Name of this sine in golden files and model cards.
pub const SINE_NAME: &str = "q15-table";

/// `round(32768 · sin(π/2 · i / 256))`, `i = 0..=256`: a quarter wave.
pub const QUARTER_SINE: [u16; 257] = [
    0, 201, 402, 603, 804, 1005, 1206, 1407, 1608, 1809, 2009, 2210, 2411, 2611, 2811, 3012, 3212,
    3412, 3612, 3812, 4011, 4211, 4410, 4609, 4808, 5007, 5205, 5404, 5602, 5800, 5998, 6195, 6393,
    6590, 6787, 6983, 7180, 7376, 7571, 7767, 7962, 8157, 8351, 8546, 8740, 8933, 9127, 9319, 9512,
    9704, 9896, 10088, 10279, 10469, 10660, 10850, 11039, 11228, 11417, 11605, 11793, 11980, 12167,
    12354, 12540, 12725, 12910, 13095, 13279, 13463, 13646, 13828, 14010, 14192, 14373, 14553,
    14733, 14912, 15091, 15269, 15447, 15624, 15800, 15976, 16151, 16326, 16500, 16673, 16846,
    17018, 17190, 17361, 17531, 17700, 17869, 18037, 18205, 18372, 18538, 18703, 18868, 19032,
    19195, 19358, 19520, 19681, 19841, 20001, 20160, 20318, 20475, 20632, 20788, 20943, 21097,
    21251, 21403, 21555, 21706, 21856, 22006, 22154, 22302, 22449, 22595, 22740, 22884, 23028,
    23170, 23312, 23453, 23593, 23732, 23870, 24008, 24144, 24279, 24414, 24548, 24680, 24812,
    24943, 25073, 25202, 25330, 25457, 25583, 25708, 25833, 25956, 26078, 26199, 26320, 26439,
    26557, 26674, 26791, 26906, 27020, 27133, 27246, 27357, 27467, 27576, 27684, 27791, 27897,
    28002, 28106, 28209, 28311, 28411, 28511, 28610, 28707, 28803, 28899, 28993, 29086, 29178,
    29269, 29359, 29448, 29535, 29622, 29707, 29792, 29875, 29957, 30038, 30118, 30196, 30274,
    30350, 30425, 30499, 30572, 30644, 30715, 30784, 30853, 30920, 30986, 31050, 31114, 31177,
    31238, 31298, 31357, 31415, 31471, 31527, 31581, 31634, 31686, 31737, 31786, 31834, 31881,
    31927, 31972, 32015, 32058, 32099, 32138, 32177, 32214, 32251, 32286, 32319, 32352, 32383,
    32413, 32442, 32470, 32496, 32522, 32546, 32568, 32590, 32610, 32629, 32647, 32664, 32679,
    32693, 32706, 32718, 32729, 32738, 32746, 32753, 32758, 32762, 32766, 32767, 32768,
];

/// `sin(2π · phase / 2^32)` in Q15, saturated to −32767..=32767 (so that
/// every activation fits an `i16`).
///
/// Quadrant = top 2 bits; within the quadrant the 30-bit offset `p` is
/// mirrored (`2^30 − p`) in quadrants 1 and 3; index `p >> 22` (0..=256)
/// into [`QUARTER_SINE`], 16-bit fraction `(p >> 6) & 0xffff`, linear
/// interpolation `v = a + (((b − a) · frac + 2^15) >> 16)`, then
/// `min(v, 32767)`, negated in quadrants 2 and 3. Measured maximum error
/// against f64 `sin` over all 2^26 distinct inputs (the low 6 bits are
/// ignored): see [`SIN_Q15_MAX_ERROR`].
#[inline]
pub fn sin_q15(phase: u32) -> i32 {
    let quadrant = phase >> 30;
    let mut p = phase & 0x3fff_ffff;
    if quadrant & 1 == 1 {
        p = (1 << 30) - p;
    }
    let idx = (p >> 22) as usize;
    let frac = ((p >> 6) & 0xffff) as i32;
    let (a, b) = match QUARTER_SINE.get(idx..idx + 2) {
        Some(&[a, b]) => (a as i32, b as i32),
        // idx = 256 (p = 2^30): frac = 0, the peak.
        _ => (32768, 32768),
    };
    let v = (a + (((b - a) * frac + 0x8000) >> 16)).min(32767);
    if quadrant >= 2 {
        -v
    } else {
        v
    }
}

/// Measured maximum absolute error of [`sin_q15`]`/32768` against f64 sin,
/// over every distinct input (`core/tests/fixed_sine.rs`, `max_error_all_inputs`):
/// 3.102e-5, i.e. 1.016 Q15 LSB (table rounding ≤ 0.5 LSB, interpolation
/// ≤ 0.15 LSB, final rounding ≤ 0.5 LSB).
pub const SIN_Q15_MAX_ERROR: f64 = 3.2e-5;

/// `2^e` as f32 (exact for −126 ≤ e ≤ 127).
#[inline]
pub fn pow2(e: i32) -> f32 {
    let e = e.clamp(-126, 127);
    f32::from_bits(((127 + e) as u32) << 23)
}

/// f32 → fixed: `clamp(round_ties_even(x · 2^e), −32768, 32767)`; NaN → 0.
#[inline]
pub fn quantize(x: f32, e: i8) -> i32 {
    let r = crate::math::round_ties_even(x * pow2(e as i32));
    if r.is_nan() {
        0
    } else if r < -32768.0 {
        -32768
    } else if r > 32767.0 {
        32767
    } else {
        r as i32
    }
}

/// fixed → f32: `v · 2^-e` (exact).
#[inline]
pub fn dequantize(v: i32, e: i8) -> f32 {
    (v as f32) * pow2(-(e as i32))
}

/// `(a + 2^(s−1)) >> s`, or `a` for `s ≤ 0`.
#[inline]
fn rshr(a: i64, s: i8) -> i64 {
    if s <= 0 {
        a
    } else {
        let s = (s as u32).min(62);
        (a + (1i64 << (s - 1))) >> s
    }
}

/// The activation of one accumulated channel (see the module docs).
#[inline]
pub fn activate_q(act: Activation, acc: i64, shift: i8) -> i16 {
    match act {
        Activation::Linear | Activation::Relu => {
            let v = rshr(acc, shift).clamp(-32768, 32767) as i16;
            if act == Activation::Relu {
                v.max(0)
            } else {
                v
            }
        }
        Activation::Sine => {
            let phase = if shift >= 0 {
                rshr(acc, shift) as u32
            } else {
                (acc as u32).wrapping_shl((-(shift as i32)) as u32)
            };
            sin_q15(phase) as i16
        }
    }
}

/// One i16 LE weight from `w[0..2]` (0 if short).
#[inline(always)]
fn w16(w: &[u8]) -> i32 {
    w.first_chunk::<2>()
        .map_or(0, |b| i32::from(i16::from_le_bytes(*b)))
}

/// `acc + Σ_i q_i · x_i` for one row `w` (i16 LE, `2·x.len()` bytes): each
/// product is exact in `i32` (|q·x| ≤ 2^30), the sum is taken in `i64`.
///
/// Written so that LLVM's ARM parallel-DSP pass finds its pattern (two
/// adjacent i16 loads on each side, each read as one `[u8; 2]` →
/// `load i16`, sign-extended, multiplied, added to an i64): on a Cortex-M4
/// every pair of MACs becomes one unaligned `ldr` of two weights, one `ldr`
/// of two activations and one `smlald`, unrolled 4×. (Sharing the activation
/// loads between several rows exceeds the pass's 16-load limit per block
/// once the loop is unrolled, so it is one row per pass.)
#[inline(always)]
fn dot1(w: &[u8], x: &[i16], mut acc: i64) -> i64 {
    let c = w.chunks_exact(4);
    let t = c.remainder();
    let xs = x.chunks_exact(2);
    let xt = xs.remainder();
    for (xx, q) in xs.zip(c) {
        let (x0, x1) = match *xx {
            [a, b] => (i32::from(a), i32::from(b)),
            _ => (0, 0),
        };
        let (q0, q1) = match q.split_first_chunk::<2>() {
            Some((a, b)) => (i32::from(i16::from_le_bytes(*a)), w16(b)),
            None => (0, 0),
        };
        acc += i64::from(q0 * x0) + i64::from(q1 * x1);
    }
    if let [v] = *xt {
        acc += i64::from(w16(t) * i32::from(v));
    }
    acc
}

/// For each output channel `j < m` of `layer`, calls `f(j, acc_j)` with
/// `acc_j = init(j) + Σ_i q_j,skip+i · x_i` (exact, in `i64`).
#[inline(always)]
fn accumulate(
    layer: &Layer<'_>,
    skip: usize,
    x: &[i16],
    m: usize,
    init: impl Fn(usize) -> i64,
    mut f: impl FnMut(usize, i64),
) {
    let (lo, hi) = (2 * skip, 2 * (skip + x.len()));
    for j in 0..m {
        let row = layer.row_bytes_q(j).get(lo..hi).unwrap_or(&[]);
        f(j, dot1(row, x, init(j)));
    }
}

fn dense_q(layer: &Layer<'_>, x: &[i16], out: &mut [i16]) {
    let act = layer.activation();
    accumulate(
        layer,
        0,
        x,
        out.len(),
        |j| i64::from(layer.bias_q(j)),
        |j, acc| {
            if let Some(o) = out.get_mut(j) {
                *o = activate_q(act, acc, layer.shift(j));
            }
        },
    );
}

fn run_network_q<'s>(
    net: &Network<'_>,
    input: &[i16],
    a: &'s mut [i16],
    b: &'s mut [i16],
) -> &'s [i16] {
    let n = input.len().min(a.len());
    a[..n].copy_from_slice(&input[..n]);
    let (mut src, mut dst) = (a, b);
    let mut width = n;
    for layer in net.layers() {
        let out = layer.out_dim().min(dst.len());
        dense_q(layer, &src[..width], &mut dst[..out]);
        core::mem::swap(&mut src, &mut dst);
        width = out;
    }
    &src[..width]
}

fn in_exp(net: &Network<'_>) -> i8 {
    net.layer(0).map_or(0, |l| l.in_exp())
}

fn out_exp(net: &Network<'_>) -> i8 {
    net.layers().last().map_or(0, |l| l.out_exp())
}

/// Predicts endpoints (and trajectories) of a fixed-point model with scratch width `W`.
pub struct FixedPredictor<'m, 'a, const W: usize> {
    model: &'m Model<'a>,
    a: [i16; W],
    b: [i16; W],
    feat: [i16; W],
    z: [i16; W],
    part: [i64; W],
}

impl<'m, 'a, const W: usize> FixedPredictor<'m, 'a, W> {
    /// A predictor for `model`: fails with [`BlobError::UnsupportedNumeric`]
    /// for an f32 model and [`PredictError::ScratchTooSmall`] if it is wider than `W`.
    pub fn new(model: &'m Model<'a>) -> Result<Self, Error> {
        if model.numeric() != NumericKind::Int16Q15 {
            return Err(Error::Blob(BlobError::UnsupportedNumeric));
        }
        let c = model.config();
        let needed = model.max_width().max(c.fdim as usize + c.zdim as usize);
        if needed > W {
            return Err(Error::Predict(PredictError::ScratchTooSmall {
                needed,
                capacity: W,
            }));
        }
        Ok(Self {
            model,
            a: [0; W],
            b: [0; W],
            feat: [0; W],
            z: [0; W],
            part: [0; W],
        })
    }

    /// The model.
    pub fn model(&self) -> &'m Model<'a> {
        self.model
    }

    fn encode(&mut self, past: &[[f32; 2]]) -> Result<[f32; 2], PredictError> {
        let c = *self.model.config();
        let p = c.past_len as usize;
        if past.len() != p {
            return Err(PredictError::WrongPastLength {
                expected: p,
                got: past.len(),
            });
        }
        if past.iter().flatten().any(|v| !v.is_finite()) {
            return Err(PredictError::NonFiniteInput);
        }
        let origin = past[0];
        let e = in_exp(self.model.encoder_past());
        let mut x = [0i16; 2 * MAX_PAST];
        for (t, pt) in past.iter().enumerate() {
            x[2 * t] = quantize((pt[0] - origin[0]) * c.data_scale, e) as i16;
            x[2 * t + 1] = quantize((pt[1] - origin[1]) * c.data_scale, e) as i16;
        }
        let fdim = c.fdim as usize;
        let f = run_network_q(
            self.model.encoder_past(),
            &x[..2 * p],
            &mut self.a,
            &mut self.b,
        );
        self.feat[..fdim].copy_from_slice(&f[..fdim]);
        if let Some(l0) = self.model.decoder().layer(0) {
            let part = &mut self.part;
            accumulate(
                l0,
                0,
                &self.feat[..fdim],
                l0.out_dim().min(W),
                |j| i64::from(l0.bias_q(j)),
                |j, acc| {
                    if let Some(p) = part.get_mut(j) {
                        *p = acc;
                    }
                },
            );
        }
        Ok(origin)
    }

    fn decode(&mut self) -> [i16; 2] {
        let c = self.model.config();
        let (fdim, zdim) = (c.fdim as usize, c.zdim as usize);
        let dec = self.model.decoder();
        let Some(l0) = dec.layer(0) else {
            return [0; 2];
        };
        let out0 = l0.out_dim().min(W);
        let act = l0.activation();
        let (a, part) = (&mut self.a, &self.part);
        accumulate(
            l0,
            fdim,
            &self.z[..zdim],
            out0,
            |j| part.get(j).copied().unwrap_or(0),
            |j, acc| {
                if let Some(o) = a.get_mut(j) {
                    *o = activate_q(act, acc, l0.shift(j));
                }
            },
        );
        let (mut src, mut dst) = (&mut self.a, &mut self.b);
        let mut width = out0;
        for layer in dec.layers().skip(1) {
            let out = layer.out_dim();
            dense_q(layer, &src[..width], &mut dst[..out]);
            core::mem::swap(&mut src, &mut dst);
            width = out;
        }
        [src[0], src[1]]
    }

    /// Predicts `k` endpoints (`k <= K`) in the caller's units; same inputs,
    /// same bits, on every target.
    pub fn predict_endpoints<const K: usize>(
        &mut self,
        past: &[[f32; 2]],
        seed: u64,
        k: usize,
    ) -> Result<heapless::Vec<[f32; 2], K>, PredictError> {
        let mut out = heapless::Vec::new();
        self.run::<K>(past, seed, k, |e, _| out.push(e).is_ok())?;
        Ok(out)
    }

    /// Predicts `k` full trajectories (the last point of each is its endpoint).
    pub fn predict_trajectories<const K: usize>(
        &mut self,
        past: &[[f32; 2]],
        seed: u64,
        k: usize,
    ) -> Result<heapless::Vec<Trajectory, K>, PredictError> {
        if !self.model.has_predictor() {
            return Err(PredictError::NoPredictor);
        }
        let mut pending = heapless::Vec::<([f32; 2], [i16; 2]), K>::new();
        self.run::<K>(past, seed, k, |e, d| pending.push((e, d)).is_ok())?;
        let origin = past.first().copied().unwrap_or([0.0; 2]);
        let last = past.last().copied().unwrap_or([0.0; 2]);
        let mut out: heapless::Vec<Trajectory, K> = heapless::Vec::new();
        for (e, d) in pending {
            let t = self.trajectory(origin, last, e, d)?;
            if out.push(t).is_err() {
                return Err(PredictError::BadSampleCount);
            }
        }
        Ok(out)
    }

    fn run<const K: usize>(
        &mut self,
        past: &[[f32; 2]],
        seed: u64,
        k: usize,
        mut sink: impl FnMut([f32; 2], [i16; 2]) -> bool,
    ) -> Result<(), PredictError> {
        if k == 0 || k > K {
            return Err(PredictError::BadSampleCount);
        }
        let origin = self.encode(past)?;
        let c = *self.model.config();
        let zdim = c.zdim as usize;
        let ez = in_exp(self.model.decoder());
        let eo = out_exp(self.model.decoder());
        let mut g = Gaussian::new(seed);
        for _ in 0..k {
            for zi in self.z[..zdim].iter_mut() {
                *zi = quantize(c.sigma * g.next(), ez) as i16;
            }
            let d = self.decode();
            let e = [
                dequantize(d[0].into(), eo) / c.data_scale + origin[0],
                dequantize(d[1].into(), eo) / c.data_scale + origin[1],
            ];
            if !(e[0].is_finite() && e[1].is_finite()) {
                return Err(PredictError::NonFiniteOutput);
            }
            if !sink(e, d) {
                return Err(PredictError::BadSampleCount);
            }
        }
        Ok(())
    }

    fn trajectory(
        &mut self,
        origin: [f32; 2],
        last: [f32; 2],
        e: [f32; 2],
        d: [i16; 2],
    ) -> Result<Trajectory, PredictError> {
        let c = *self.model.config();
        let fdim = c.fdim as usize;
        let ef = out_exp(self.model.encoder_past());
        let g = run_network_q(self.model.encoder_dest(), &d, &mut self.a, &mut self.b);
        let ddim = g.len();
        self.z[..fdim].copy_from_slice(&self.feat[..fdim]);
        self.z[fdim..fdim + ddim].copy_from_slice(g);
        self.z[fdim + ddim] = quantize(last[0] / c.initial_pos_divisor, ef) as i16;
        self.z[fdim + ddim + 1] = quantize(last[1] / c.initial_pos_divisor, ef) as i16;
        let n_in = fdim + ddim + 2;
        let eq = out_exp(self.model.predictor());
        let q = run_network_q(
            self.model.predictor(),
            &self.z[..n_in],
            &mut self.a,
            &mut self.b,
        );
        let mut t = Trajectory::new();
        for pair in q.chunks_exact(2) {
            let pt = [
                dequantize(pair[0].into(), eq) / c.data_scale + origin[0],
                dequantize(pair[1].into(), eq) / c.data_scale + origin[1],
            ];
            if !(pt[0].is_finite() && pt[1].is_finite()) || t.push(pt).is_err() {
                return Err(PredictError::NonFiniteOutput);
            }
        }
        if t.push(e).is_err() {
            return Err(PredictError::NonFiniteOutput);
        }
        Ok(t)
    }
}
