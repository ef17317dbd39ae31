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
//!   path (rotated into the heading frame first when the model has one,
//!   [`crate::frame`]), then [`quantize`]`(x, in_exp)` of `encoder_past`; the
//!   point-forecast head reads the same quantised vector.
//! - Latent: `z_i = sigma · Gaussian::next()` (f32, [`crate::prng`]), then
//!   `quantize(z_i, in_exp of decoder)`.
//! - The vectors passed between networks share exponents (checked by the
//!   blob reader): features `f`, the latent, `encoder_dest`'s output and the
//!   predictor input use `encoder_past`'s output exponent; `encoder_dest`
//!   reads the decoder output as is. `initial_pos = last / divisor` (f32) is
//!   quantised with the feature exponent.
//! - Output: `d_c = (y_c as f32) · 2^-out_exp`, endpoint `d_c / data_scale + p_0[c]`
//!   (as in the f32 path, through [`crate::frame`]); trajectory and point-forecast
//!   points likewise.
//!
//! The decoder's feature columns are summed once per call into an `i64`
//! partial sum and the latent columns added per sample; with integers this
//! equals one full pass exactly.
//!
//! # Memory
//!
//! [`crate::engine::Engine`]`<Q15, W>` holds four `i16` rows and one `i64`
//! row of `W` (`16·W` bytes). The sine table is 514 bytes of flash.
//!
//! # Speed (Cortex-M4/M7)
//!
//! Portable path (every target without the Arm DSP extension, and the
//! reference): weights are read as `[u8; 2]` pairs and activations are
//! packed `i16`, so that LLVM's ARM parallel-DSP pass turns each pair of
//! MACs into `ldr`/`ldr`/`smlald` where it can. On `thumbv7em` (Cortex-M4/M7,
//! `cfg(all(target_arch = "arm", target_feature = "dsp"))`) the rows go two
//! at a time through the private `kernels` module: one `LDRD` of four
//! activations shared by both rows, one unaligned `LDR` of two weights and
//! one `SMLALD` (two exact 16 × 16 MACs into the 64-bit accumulator) per
//! row and pair of inputs, 16 inputs per loop iteration; the rest of a row
//! (fewer than 4 columns, or an unaligned `x`) and an odd last row take the
//! portable loop. The sums are exact integers either way, so both paths
//! give the same bits (bound and measurements: `docs/kernels.md`). Each
//! layer's weights, biases and shifts are walked in one pass
//! ([`crate::blob::Layer::tensors_q`], no per-row bounds checks), and the
//! activation is chosen once per layer.
//!
//! # Files
//!
//! The backend is split by job: this file holds [`Q15`], the shift ranges,
//! the sine table and [`sin_q15`], and the [`crate::backend::Backend`]
//! implementation; `convert.rs` the f32 boundaries ([`quantize`],
//! [`dequantize`]), `activation.rs` one channel's rounding shift, `Sine`
//! phase and activation ([`activate_q`]), `dot.rs` the portable dot
//! products of one row, `rows.rs` the walk over a layer's rows (portable,
//! or the Cortex-M4/M7 row kernel), `dense.rs` whole layers and the
//! decoder's latent columns, and `dsp.rs` the Cortex-M4/M7 layer paths
//! (`Sine` layers, latent rows).

mod activation;
mod convert;
mod dense;
mod dot;
#[cfg(all(target_arch = "arm", target_feature = "dsp"))]
mod dsp;
mod rows;
#[cfg(test)]
mod tests;

use crate::backend::{Backend, Sealed};
use crate::blob::{Activation, Layer, NumericKind};
use crate::lanes::LaneArith;

#[doc(hidden)]
pub use activation::activate_q;
#[doc(hidden)]
pub use convert::{dequantize, quantize};
// The exponent scale and the shift ranges are rules of the blob format,
// which validates them: they live in `blob` and are re-exported here under
// the names the fixed-point code has always had.
#[doc(hidden)]
pub use crate::blob::{pow2, AFFINE_SHIFTS, SINE_SHIFTS};
use dense::{accumulate, dense_q, latent_with};
use dot::{dot1, w16};

/// The fixed-point backend ([`NumericKind::Int16Q15`] blobs; see the module docs).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Q15;

/// Name of this sine in golden files and model cards.
pub const SINE_NAME: &str = "q15-table";

#[doc(hidden)]
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

/// [`QUARTER_SINE`] as interpolation pairs: entry `i` holds `a_i` in its
/// low half and `a_(i+1) − a_i` (0..=201, the quarter wave rises) in its
/// high half; entry 256 holds `(32768, 0)`, which interpolates to the same
/// peak as the `(32768, 32768)` pair [`sin_q15`] specifies there (its
/// fraction is 0 and the difference is 0). One word load per activation
/// instead of two halfword loads and a subtraction; 1,028 bytes of flash.
const SINE_PAIRS: [u32; 257] = {
    let mut t = [0u32; 257];
    let mut i = 0;
    while i < 257 {
        let a = QUARTER_SINE[i] as u32;
        let d = if i < 256 {
            QUARTER_SINE[i + 1] as u32 - a
        } else {
            0
        };
        t[i] = a | (d << 16);
        i += 1;
    }
    t
};

/// `sin(2π · phase / 2^32)` in Q15, saturated to −32767..=32767 (so that
/// every activation fits an `i16`).
///
/// Quadrant = top 2 bits; within the quadrant the 30-bit offset `p` is
/// mirrored (`2^30 − p`) in quadrants 1 and 3; index `p >> 22` (0..=256)
/// into [`QUARTER_SINE`], 16-bit fraction `(p >> 6) & 0xffff`, linear
/// interpolation `v = a + (((b − a) · frac + 2^15) >> 16)` (at index 256,
/// `p = 2^30`: `a = b = 32768`), then `min(v, 32767)`, negated in quadrants
/// 2 and 3. Measured maximum error against f64 `sin` over all 2^26
/// distinct inputs (the low 6 bits are ignored): see [`SIN_Q15_MAX_ERROR`].
///
/// Computed from a private table of `(a, b − a)` words; since
/// `0 ≤ v ≤ 32768`, `min(v, 32767)` is `v − (v >> 15)`, one subtraction
/// with a shifted operand on a Cortex-M4 (`sin_q15_matches_table_form`
/// checks every distinct input against the two-table-load form).
#[inline]
pub fn sin_q15(phase: u32) -> i32 {
    let (neg, idx, frac) = quarter(phase);
    // idx ≤ 256 (p ≤ 2^30), so the fallback never runs.
    let e = SINE_PAIRS.get(idx).copied().unwrap_or(32768);
    let (a, d) = ((e & 0xffff) as i32, (e >> 16) as i32);
    // 0 ≤ v ≤ b ≤ 32768 (the rounded step is at most d), so v >> 15 is 1
    // only at 32768: `v − (v >> 15)` is `min(v, 32767)`.
    let v = a + ((d * frac + 0x8000) >> 16);
    let v = v - (v >> 15);
    (v ^ neg) - neg
}

/// A phase folded into the first quarter turn, as [`sin_q15`] and its test's
/// table form both read it: `(neg, idx, frac)`, `neg` −1 in quadrants 2 and
/// 3, else 0 (`(v ^ neg) − neg` negates there), then the quarter-sine table
/// entry `idx` (≤ 256) and the 16-bit fraction `frac` towards the next one.
#[inline(always)]
fn quarter(phase: u32) -> (i32, usize, i32) {
    let neg = (phase as i32) >> 31;
    let mut p = phase & 0x3fff_ffff;
    if phase & (1 << 30) != 0 {
        p = (1 << 30) - p;
    }
    (neg, (p >> 22) as usize, ((p >> 6) & 0xffff) as i32)
}

/// Measured maximum absolute error of [`sin_q15`]`/32768` against f64 sin,
/// over every distinct input (`core/tests/fixed_sine.rs`, `max_error_all_inputs`):
/// 3.102e-5, i.e. 1.016 Q15 LSB (table rounding ≤ 0.5 LSB, interpolation
/// ≤ 0.15 LSB, final rounding ≤ 0.5 LSB).
pub const SIN_Q15_MAX_ERROR: f64 = 3.2e-5;

impl LaneArith for Q15 {
    type Weight = i32;
    const WEIGHT_BYTES: usize = 2;

    #[inline(always)]
    fn weight(b: &[u8]) -> i32 {
        w16(b)
    }

    /// `a[l] += q · x[l]` (exact: `i32` product, `i64` sum).
    #[inline(always)]
    fn axpy<const L: usize>(a: &mut [i64; L], q: i32, x: &[i16; L]) {
        for (al, &xl) in a.iter_mut().zip(x) {
            *al += i64::from(q * i32::from(xl));
        }
    }

    #[inline(always)]
    fn bias(layer: &Layer<'_>, j: usize) -> i64 {
        i64::from(layer.bias_q(j))
    }

    /// [`activate_q`] with row `j`'s shift: the exact `i64` sums of
    /// [`dense_q`] give the same outputs.
    #[inline(always)]
    fn finish<const L: usize>(
        layer: &Layer<'_>,
        act: Activation,
        j: usize,
        acc: &[i64; L],
        used: usize,
        o: &mut [i16; L],
    ) {
        let shift = layer.shift(j);
        for (l, (o, &a)) in o.iter_mut().zip(acc).enumerate() {
            *o = if l < used {
                activate_q(act, a, shift)
            } else {
                0
            };
        }
    }
}

impl Sealed for Q15 {}

impl Backend for Q15 {
    type Act = i16;
    type Acc = i64;
    const KIND: NumericKind = NumericKind::Int16Q15;
    const SINE: &'static str = SINE_NAME;

    #[inline]
    fn from_f32(v: f32, exp: i8) -> i16 {
        quantize(v, exp) as i16
    }

    #[inline]
    fn to_f32(v: i16, exp: i8) -> f32 {
        dequantize(v.into(), exp)
    }

    #[inline]
    fn dense(layer: &Layer<'_>, x: &[i16], out: &mut [i16]) {
        dense_q(layer, x, out);
    }

    fn partial(layer: &Layer<'_>, x: &[i16], part: &mut [i64]) {
        accumulate(layer, 0, x, part, |p, acc, _| *p = acc, dot1);
    }

    fn dense_lanes<const L: usize>(
        layer: &Layer<'_>,
        x: &[[i16; L]],
        out: &mut [[i16; L]],
        used: usize,
    ) {
        crate::lanes::dense_lanes::<Self, L>(layer, x, out, used);
    }

    fn latent(layer: &Layer<'_>, skip: usize, z: &[i16], part: &[i64], out: &mut [i16]) {
        match layer.activation() {
            Activation::Linear => latent_with(layer, skip, z, part, out, |a, s| {
                activate_q(Activation::Linear, a, s)
            }),
            Activation::Relu => latent_with(layer, skip, z, part, out, |a, s| {
                activate_q(Activation::Relu, a, s)
            }),
            Activation::Sine => latent_with(layer, skip, z, part, out, |a, s| {
                activate_q(Activation::Sine, a, s)
            }),
        }
    }
}
