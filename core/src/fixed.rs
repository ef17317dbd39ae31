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

use core::ops::RangeInclusive;

use crate::blob::{Activation, Layer, NumericKind};
use crate::engine::{Backend, Sealed};
use crate::lanes::LaneArith;

/// The fixed-point backend ([`NumericKind::Int16Q15`] blobs; see the module docs).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Q15;

#[doc(hidden)]
/// Allowed shifts of `Linear`/`Relu` channels.
pub const AFFINE_SHIFTS: RangeInclusive<i8> = 0..=62;
#[doc(hidden)]
/// Allowed shifts of `Sine` channels.
pub const SINE_SHIFTS: RangeInclusive<i8> = -31..=62;
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
    // −1 in quadrants 2 and 3, else 0: `(v ^ neg) − neg` negates there.
    let neg = (phase as i32) >> 31;
    let mut p = phase & 0x3fff_ffff;
    if phase & (1 << 30) != 0 {
        p = (1 << 30) - p;
    }
    let idx = (p >> 22) as usize;
    let frac = ((p >> 6) & 0xffff) as i32;
    // idx ≤ 256 (p ≤ 2^30), so the fallback never runs.
    let e = SINE_PAIRS.get(idx).copied().unwrap_or(32768);
    let (a, d) = ((e & 0xffff) as i32, (e >> 16) as i32);
    // 0 ≤ v ≤ b ≤ 32768 (the rounded step is at most d), so v >> 15 is 1
    // only at 32768: `v − (v >> 15)` is `min(v, 32767)`.
    let v = a + ((d * frac + 0x8000) >> 16);
    let v = v - (v >> 15);
    (v ^ neg) - neg
}

/// Measured maximum absolute error of [`sin_q15`]`/32768` against f64 sin,
/// over every distinct input (`core/tests/fixed_sine.rs`, `max_error_all_inputs`):
/// 3.102e-5, i.e. 1.016 Q15 LSB (table rounding ≤ 0.5 LSB, interpolation
/// ≤ 0.15 LSB, final rounding ≤ 0.5 LSB).
pub const SIN_Q15_MAX_ERROR: f64 = 3.2e-5;

#[doc(hidden)]
/// `2^e` as f32 (exact for −126 ≤ e ≤ 127).
#[inline]
pub fn pow2(e: i32) -> f32 {
    let e = e.clamp(-126, 127);
    f32::from_bits(((127 + e) as u32) << 23)
}

#[doc(hidden)]
/// f32 → fixed: `clamp(round_ties_even(x · 2^e), −32768, 32767)`; NaN → 0.
///
/// Computed without branches as `clamp(((y + M) − M) as i32)` with
/// `y = x · 2^e` and `M = 1.5 · 2^23`, which is the same integer for every
/// `y`: for |y| < 2^22 `(y + M) − M` is [`crate::math::round_ties_even`]'s
/// own expression; for `y ≥ 2^22` (or +∞) rounding is monotonic, so
/// `(y + M) − M ≥ (2^22 + M) − M = 2^22` (both steps exact) and the clamp
/// gives 32767 as before, and symmetrically −32768 for `y ≤ −2^22`; NaN
/// stays NaN and `as i32` maps it to 0. On a Cortex-M4F this is `VMLA`,
/// `VSUB`, `VCVT`, `SSAT` instead of three compare-and-branch steps
/// (`fixed_blob.rs`, `quantize_matches_reference`, checks it against the
/// branching form over a stride of all f32 bit patterns).
#[inline]
pub fn quantize(x: f32, e: i8) -> i32 {
    const MAGIC: f32 = 12_582_912.0;
    ((x * pow2(e as i32) + MAGIC - MAGIC) as i32).clamp(-32768, 32767)
}

#[doc(hidden)]
/// fixed → f32: `v · 2^-e` (exact).
#[inline]
pub fn dequantize(v: i32, e: i8) -> f32 {
    (v as f32) * pow2(-(e as i32))
}

/// `(a + 2^(s−1)) >> s`, or `a` for `s ≤ 0`.
///
/// Computed as `((a >> (s−1)) + 1) >> 1`, which is the same integer
/// (`⌊(a/2^(s−1) + 1)/2⌋ = ⌊(⌊a/2^(s−1)⌋ + 1)/2⌋`) but needs one variable
/// 64-bit shift instead of a variable 64-bit constant, an add and a shift.
#[inline]
fn rshr(a: i64, s: i8) -> i64 {
    if s <= 0 {
        a
    } else {
        let t = a >> ((s as u32).min(62) - 1);
        (t + 1) >> 1
    }
}

/// The phase of a `Sine` channel: `rshr(acc, s) mod 2^32` for `s ≥ 0`, else
/// `(acc mod 2^32) · 2^(−s) mod 2^32` (module docs, step 2).
///
/// For `1 ≤ s ≤ 31`: `rshr(acc, s) = ⌊(acc + 2^(s−1)) / 2^s⌋`, which is
/// `⌊acc / 2^s⌋` plus bit `s − 1` of `acc` (adding `2^(s−1)` carries into
/// bit `s` exactly when that bit is set), and only the low 32 bits of
/// `⌊acc / 2^s⌋ = acc >> s` are needed: bits `s .. s + 31` of `acc`, i.e.
/// `(lo >> s) | (hi << (32 − s))` of its two words. Four shifts, an `and`
/// and an add instead of a variable 64-bit shift; `s ≥ 32` takes [`rshr`].
#[inline(always)]
fn sine_phase(acc: i64, shift: i8) -> u32 {
    if shift <= 0 {
        (acc as u32).wrapping_shl((-(shift as i32)) as u32)
    } else if shift < 32 {
        let s = shift as u32;
        let (lo, hi) = (acc as u32, (acc >> 32) as u32);
        // Bits s .. s + 31 of acc, plus bit s − 1 (the rounding).
        ((lo >> s) | hi.wrapping_shl(32 - s)).wrapping_add((lo >> (s - 1)) & 1)
    } else {
        rshr(acc, shift) as u32
    }
}

#[doc(hidden)]
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
        Activation::Sine => sin_q15(sine_phase(acc, shift)) as i16,
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
/// loads between several rows, or fixed 8-MAC blocks, exceeds the pass's
/// 16-load limit per block once the loop is unrolled, so it is one row per
/// pass, two MACs per step.)
#[inline(always)]
fn dot1(w: &[u8], x: &[i16], mut acc: i64) -> i64 {
    let c = w.chunks_exact(4);
    let t = c.remainder();
    let xs = x.chunks_exact(2);
    let xt = xs.remainder();
    for (xx, q) in xs.zip(c) {
        acc = pair_step(xx, q, acc);
    }
    if let [v] = *xt {
        acc += i64::from(w16(t) * i32::from(v));
    }
    acc
}

/// One step of [`dot1`]/[`dot_even`]: `acc + q0·x0 + q1·x1` for two
/// activations `xx` and two i16 LE weights `q` (4 bytes), each product
/// exact in `i32`, both added to the `i64` as `acc + (p0 + p1)` (exact, so
/// the grouping does not matter).
#[inline(always)]
fn pair_step(xx: &[i16], q: &[u8], acc: i64) -> i64 {
    let (x0, x1) = match *xx {
        [a, b] => (i32::from(a), i32::from(b)),
        _ => (0, 0),
    };
    let (q0, q1) = match q.split_first_chunk::<2>() {
        Some((a, b)) => (i32::from(i16::from_le_bytes(*a)), w16(b)),
        None => (0, 0),
    };
    acc + (i64::from(q0 * x0) + i64::from(q1 * x1))
}

/// [`dot1`] for an even `x.len()` (no odd tail, so a shorter loop
/// prologue/epilogue per row; used for `Sine` layers whose width is a
/// multiple of 8, i.e. the hidden layers).
#[inline(always)]
fn dot_even(w: &[u8], x: &[i16], mut acc: i64) -> i64 {
    for (xx, q) in x.chunks_exact(2).zip(w.chunks_exact(4)) {
        acc = pair_step(xx, q, acc);
    }
    acc
}

/// `(acc0 + Σ_i q0_i · x_i, acc1 + Σ_i q1_i · x_i)` for the two rows of `g`
/// (stride `n` bytes), columns from byte `lo`: the portable
/// [`dot1`]/[`dot_even`] twice (a Cortex-M4/M7 takes its own
/// [`rows_with`] and never comes here). Integer sums are exact.
#[cfg(not(all(target_arch = "arm", target_feature = "dsp")))]
#[inline(always)]
fn dot2(
    g: &[u8],
    n: usize,
    lo: usize,
    x: &[i16],
    a0: i64,
    a1: i64,
    dot: &impl Fn(&[u8], &[i16], i64) -> i64,
) -> (i64, i64) {
    let (r0, r1) = pair_rows(g, n, lo, 2 * x.len());
    (dot(r0, x, a0), dot(r1, x, a1))
}

/// Bytes `lo..lo + len` of the two rows of `g` (stride `n`), each empty
/// when it would run past its row (as the one-row walk has it).
#[cfg(not(all(target_arch = "arm", target_feature = "dsp")))]
#[inline(always)]
fn pair_rows(g: &[u8], n: usize, lo: usize, len: usize) -> (&[u8], &[u8]) {
    if lo.saturating_add(len) > n {
        return (&[], &[]);
    }
    (
        g.get(lo..lo + len).unwrap_or(&[]),
        g.get(n + lo..n + lo + len).unwrap_or(&[]),
    )
}

/// [`rows_with`] on a Cortex-M4/M7: up to `kernels::ROW_CHUNK` (32) rows at a time,
/// their dot products by one call of the `SMLALD` row kernel
/// (`kernels::dot_rows_q15`, which loops over the row pairs in assembly)
/// into a stack array, the columns it leaves by [`dot_rows_rest`] (and an
/// odd last row by [`dot_row`]), then `f(o_j, init_j + dot_j, s_j)` row by
/// row. The
/// same exact `i64` sums as the portable walk, so the same outputs.
#[cfg(all(target_arch = "arm", target_feature = "dsp"))]
#[inline(always)]
fn rows_with<T>(
    w: &[u8],
    (n, lo): (usize, usize),
    x: &[i16],
    mut inits: impl Iterator<Item = (i64, i8)>,
    out: &mut [T],
    mut f: impl FnMut(&mut T, i64, i8),
    dot: impl Fn(&[u8], &[i16], i64) -> i64,
) {
    let _ = dot;
    let nrows = out.len().min(w.len().checked_div(n).unwrap_or(0));
    let out = out.get_mut(..nrows).unwrap_or(&mut []);
    if lo.saturating_add(2 * x.len()) > n {
        // Columns past the row: every dot product is empty (as in the
        // portable walk, whose row slices are then empty).
        for o in out {
            let Some((i, s)) = inits.next() else {
                return;
            };
            f(o, i, s);
        }
        return;
    }
    let chunk = crate::kernels::ROW_CHUNK;
    for (oc, wc) in out.chunks_mut(chunk).zip(w.chunks(chunk.saturating_mul(n))) {
        let mut buf = [core::mem::MaybeUninit::uninit(); crate::kernels::ROW_CHUNK];
        let (acc, k) = crate::kernels::dot_rows_q15(wc, n, lo, x, oc.len(), &mut buf, false);
        if k < x.len() && !acc.is_empty() {
            dot_rows_rest(wc, (n, lo), x, k, acc);
        }
        let done = acc.len();
        // `zip` pulls from `inits` only while a row is left: one init per row.
        for ((o, &a), (i, s)) in oc.iter_mut().zip(acc.iter()).zip(&mut inits) {
            f(o, i + a, s);
        }
        // An odd last row, or every row when the kernel did nothing.
        for (j, o) in oc.iter_mut().enumerate().skip(done) {
            let Some((i, s)) = inits.next() else {
                return;
            };
            f(o, dot_row(wc, (n, lo), x, j, i), s);
        }
    }
}

/// What `kernels::dot_rows_q15` left of [`rows_with`]'s chunk: adds
/// `Σ_i q_j,i · x_i` over the columns `k..` (fewer than 4) to `acc[j]` for
/// each row it did, with the portable [`dot1`]; out of line so that it is
/// compiled once. `lo + 2·x.len() ≤ n` (checked by the caller).
#[cfg(all(target_arch = "arm", target_feature = "dsp"))]
#[inline(never)]
fn dot_rows_rest(w: &[u8], (n, lo): (usize, usize), x: &[i16], k: usize, acc: &mut [i64]) {
    let hi = lo + 2 * x.len();
    let xs = x.get(k..).unwrap_or(&[]);
    for (a, row) in acc.iter_mut().zip(w.chunks_exact(n.max(1))) {
        let r = row.get(lo + 2 * k..hi).unwrap_or(&[]);
        *a = dot1(r, xs, *a);
    }
}

/// `init + Σ_i q_j,i · x_i` for row `j` of [`rows_with`]'s chunk `w`, all
/// columns, with the portable [`dot1`] (a row the kernel did not take);
/// out of line. `lo + 2·x.len() ≤ n` (checked by the caller).
#[cfg(all(target_arch = "arm", target_feature = "dsp"))]
#[inline(never)]
fn dot_row(w: &[u8], (n, lo): (usize, usize), x: &[i16], j: usize, init: i64) -> i64 {
    let start = j.saturating_mul(n).saturating_add(lo);
    let r = w
        .get(start..start.saturating_add(2 * x.len()))
        .unwrap_or(&[]);
    dot1(r, x, init)
}

/// For each output `o_j` of `out` zipped with `inits` (`(init_j, s_j)`),
/// calls `f(o_j, init_j + Σ_i q_j,i · x_i, s_j)` (exact, in `i64`), where
/// row `j` of `w` has `n` bytes and its columns start at byte `lo`
/// (`(n, lo)`, the second argument): two
/// rows at a time ([`dot2`]; an odd last row with `dot`).
#[cfg(not(all(target_arch = "arm", target_feature = "dsp")))]
#[inline(always)]
fn rows_with<T>(
    w: &[u8],
    (n, lo): (usize, usize),
    x: &[i16],
    mut inits: impl Iterator<Item = (i64, i8)>,
    out: &mut [T],
    mut f: impl FnMut(&mut T, i64, i8),
    dot: impl Fn(&[u8], &[i16], i64) -> i64,
) {
    let mut done = 0;
    for (o, g) in out.chunks_exact_mut(2).zip(w.chunks_exact(2 * n.max(1))) {
        let (Some((i0, s0)), Some((i1, s1))) = (inits.next(), inits.next()) else {
            return;
        };
        let (a0, a1) = dot2(g, n, lo, x, i0, i1, &dot);
        if let [o0, o1] = o {
            f(o0, a0, s0);
            f(o1, a1, s1);
        }
        done += 2;
    }
    // One row left over (odd `out_dim`, or fewer rows than `out`).
    if let (Some(o), Some(row), Some((i0, s0))) = (
        out.get_mut(done),
        w.chunks_exact(n.max(1)).nth(done),
        inits.next(),
    ) {
        let row = row.get(lo..lo.saturating_add(2 * x.len())).unwrap_or(&[]);
        f(o, dot(row, x, i0), s0);
    }
}

/// For each output channel `j` (zipped with `out`, at most `out_dim`), calls
/// `f(o_j, acc_j, s_j)` with `acc_j = B_j + Σ_i q_j,skip+i · x_i` (exact,
/// in `i64`): one pass over the layer's whole weight slice, two rows at a
/// time.
#[inline(always)]
fn accumulate<T>(
    layer: &Layer<'_>,
    skip: usize,
    x: &[i16],
    out: &mut [T],
    f: impl FnMut(&mut T, i64, i8),
    dot: impl Fn(&[u8], &[i16], i64) -> i64,
) {
    let (w, bias, shifts) = layer.tensors_q();
    let inits = bias.chunks_exact(4).zip(shifts).map(|(b, &s)| {
        let b = match *b {
            [b0, b1, b2, b3] => i32::from_le_bytes([b0, b1, b2, b3]),
            _ => 0,
        };
        (i64::from(b), s as i8)
    });
    rows_with(w, (2 * layer.in_dim(), 2 * skip), x, inits, out, f, dot);
}

/// `dense_q` with the activation chosen once per layer.
#[inline(always)]
fn dense_with(
    layer: &Layer<'_>,
    x: &[i16],
    out: &mut [i16],
    g: impl Fn(i64, i8) -> i16,
    dot: impl Fn(&[u8], &[i16], i64) -> i64,
) {
    accumulate(layer, 0, x, out, |o, acc, s| *o = g(acc, s), dot);
}

/// One fixed-point dense layer (see the module docs).
fn dense_q(layer: &Layer<'_>, x: &[i16], out: &mut [i16]) {
    #[cfg(all(target_arch = "arm", target_feature = "dsp"))]
    if layer.activation() == Activation::Sine {
        let (w, bias, shifts) = layer.tensors_q();
        let short = layer.short_shifts();
        if dense_sine(w, 2 * layer.in_dim(), x, (bias, shifts, short), out) {
            return;
        }
    }
    if cfg!(not(all(target_arch = "arm", target_feature = "dsp")))
        && x.len() & 7 == 0
        && layer.activation() == Activation::Sine
    {
        return dense_with(
            layer,
            x,
            out,
            |a, s| activate_q(Activation::Sine, a, s),
            dot_even,
        );
    }
    match layer.activation() {
        Activation::Linear => dense_with(
            layer,
            x,
            out,
            |a, s| activate_q(Activation::Linear, a, s),
            dot1,
        ),
        Activation::Relu => dense_with(
            layer,
            x,
            out,
            |a, s| activate_q(Activation::Relu, a, s),
            dot1,
        ),
        Activation::Sine => dense_with(
            layer,
            x,
            out,
            |a, s| activate_q(Activation::Sine, a, s),
            dot1,
        ),
    }
}

/// `acc + Σ_{i<16} q_i · z_i` with `z` packed in pairs (`zp[k]` holds
/// `z_2k` in its low and `z_2k+1` in its high half), prepared once per
/// sample. A fixed 16-column product is fully unrolled, which the
/// parallel-DSP pass refuses (more than 16 loads); written this way LLVM
/// hoists the 16 sign-extended `z_i` out of the row loop, so each column
/// costs one `ldrsh` of the weight, one reload of `z_i` and one `smlalbb`
/// (85 instead of 104 instructions per row with the generic loop).
#[cfg_attr(all(target_arch = "arm", target_feature = "dsp"), allow(dead_code))]
#[inline(always)]
fn dot16_packed(q: &[u8; 32], zp: &[i32; 8], mut acc: i64) -> i64 {
    for (w, &z) in q.chunks_exact(4).zip(zp) {
        if let Some((a, b)) = w.split_first_chunk::<2>() {
            acc += i64::from(i32::from(i16::from_le_bytes(*a)) * i32::from(z as i16));
            acc += i64::from(w16(b) * (z >> 16));
        }
    }
    acc
}

/// The decoder's first layer, latent columns `skip..skip + z.len()` only:
/// `out_j = g(part_j + Σ_i q_j,skip+i · z_i, s_j)`, where `part_j` already
/// holds the bias and the feature columns. With 16 latent columns at the
/// end of each row (the shipped models) the dot product has a fixed length.
#[inline(always)]
fn latent_with(
    layer: &Layer<'_>,
    skip: usize,
    z: &[i16],
    part: &[i64],
    out: &mut [i16],
    g: impl Fn(i64, i8) -> i16,
) {
    let (w, _, shifts) = layer.tensors_q();
    let n = 2 * layer.in_dim();
    #[cfg(all(target_arch = "arm", target_feature = "dsp"))]
    {
        // 16 latent columns (the shipped models): the unrolled kernel that
        // starts from the partial sums.
        if let Ok(z16) = <&[i16; 16]>::try_from(z) {
            let mode = (layer.activation(), layer.short_shifts());
            if latent16(w, (n, 2 * skip), z16, part, shifts, out, mode) {
                return;
            }
        }
        // Otherwise two rows per pass with the `SMLALD` row kernel (the
        // packed 16-column product below is the faster portable form).
        let inits = part.iter().zip(shifts).map(|(&p, &s)| (p, s as i8));
        rows_with(
            w,
            (n, 2 * skip),
            z,
            inits,
            out,
            |o, acc, s| *o = g(acc, s),
            dot1,
        );
    }
    #[cfg(not(all(target_arch = "arm", target_feature = "dsp")))]
    {
        let rows = w.chunks_exact(n.max(1)).zip(part).zip(shifts);
        match <&[i16; 16]>::try_from(z) {
            Ok(z16) if n == 2 * (skip + 16) => {
                // z packed in pairs once (kept in registers across the rows).
                let mut zp = [0i32; 8];
                for (d, v) in zp.iter_mut().zip(z16.chunks_exact(2)) {
                    if let [a, b] = *v {
                        *d = i32::from(a as u16) | (i32::from(b) << 16);
                    }
                }
                for (o, ((row, &p), &s)) in out.iter_mut().zip(rows) {
                    let acc = match row.last_chunk::<32>() {
                        Some(q) => dot16_packed(q, &zp, p),
                        None => p,
                    };
                    *o = g(acc, s as i8);
                }
            }
            _ => {
                let (lo, hi) = (2 * skip, 2 * (skip + z.len()));
                for (o, ((row, &p), &s)) in out.iter_mut().zip(rows) {
                    let row = row.get(lo..hi).unwrap_or(&[]);
                    *o = g(dot1(row, z, p), s as i8);
                }
            }
        }
    }
}

/// `out_j = activate_q(Sine, sums_j + B_j, s_j)` for `j < out.len()`
/// (`B_j`: the i32 LE bias at `bias[4j..]`, or 0 for `None` when the sums
/// hold it, as the decoder's latent rows do; `s_j = shifts[j] as i8`) on a
/// Cortex-M4/M7: runs of rows by the asm loop `kernels::sine_rows_q15`
/// (the same integer steps as [`sine_phase`] and [`sin_q15`], see there);
/// a row it stops before (a shift outside −31..=32, which it does not
/// take) by [`activate_q`]. `short`: every shift is in −31..=32 (the
/// layer's `short_shifts`), so the loop skips its range check. Rows past
/// the end of `sums`, `bias` or `shifts` are left as they are.
#[cfg(all(target_arch = "arm", target_feature = "dsp"))]
#[inline(always)]
fn sine_rows(sums: &[i64], bias: Option<&[u8]>, shifts: &[u8], out: &mut [i16], short: bool) {
    if short {
        // The loop takes every row (no shift makes it stop).
        crate::kernels::sine_rows_q15(sums, bias, shifts, out, &SINE_PAIRS, true);
        return;
    }
    let mut j = 0;
    while j < out.len() {
        let bi = match bias {
            Some(b) => match b.get(4 * j..) {
                Some(b) => Some(b),
                None => return,
            },
            None => None,
        };
        let (Some(sm), Some(sh), Some(o)) = (sums.get(j..), shifts.get(j..), out.get_mut(j..))
        else {
            return;
        };
        j += crate::kernels::sine_rows_q15(sm, bi, sh, o, &SINE_PAIRS, false);
        let b = match bias {
            Some(b) => match b.get(4 * j..4 * j + 4) {
                Some(&[b0, b1, b2, b3]) => i32::from_le_bytes([b0, b1, b2, b3]),
                _ => return,
            },
            None => 0,
        };
        let (Some(o), Some(&a), Some(&s)) = (out.get_mut(j), sums.get(j), shifts.get(j)) else {
            return;
        };
        *o = activate_q(Activation::Sine, a + i64::from(b), s as i8);
        j += 1;
    }
}

/// A `Sine` layer of [`dense_q`] on a Cortex-M4/M7 (its weights `w`, row
/// stride `n` bytes, then its i32 LE `bias`, `shifts` and whether all of
/// them are in −31..=32, `short`): for at most
/// `kernels::ROW_CHUNK` rows the row kernel's sums (as in [`rows_with`]:
/// `kernels::dot_rows_q15`, [`dot_rows_rest`] for the columns it leaves,
/// [`dot_row`] for an odd last row), then the activation of the kernel's
/// rows by [`sine_rows`] (bias added there); more rows are taken in chunks
/// of `ROW_CHUNK`, each by a call of this function (one level deep, so one
/// copy of the code). Out of line. Returns `false`, having written
/// nothing, unless the layer holds a weight row, a bias and a shift for
/// every output and `x` fits a row; the caller then takes the generic
/// path. The same exact `i64` sums and the same activation steps, so the
/// same outputs.
#[cfg(all(target_arch = "arm", target_feature = "dsp"))]
#[inline(never)]
fn dense_sine(
    w: &[u8],
    n: usize,
    x: &[i16],
    (bias, shifts, short): (&[u8], &[u8], bool),
    out: &mut [i16],
) -> bool {
    let rows = out.len();
    if n == 0
        || 2 * x.len() > n
        || rows.saturating_mul(n) > w.len()
        || bias.len() / 4 < rows
        || shifts.len() < rows
    {
        return false;
    }
    let chunk = crate::kernels::ROW_CHUNK;
    if rows > chunk {
        // Chunks of ROW_CHUNK rows, each by a call of this function (which
        // then takes the path below): one copy of the row loops.
        let mut start = 0;
        while start < rows {
            let end = rows.min(start + chunk);
            if let (Some(wc), Some(bc), Some(sc), Some(oc)) = (
                w.get(start * n..),
                bias.get(4 * start..),
                shifts.get(start..end),
                out.get_mut(start..end),
            ) {
                dense_sine(wc, n, x, (bc, sc, short), oc);
            }
            start = end;
        }
        return true;
    }
    // At most ROW_CHUNK rows (the tiny models' layers): the row kernel's
    // sums, the columns it leaves, [`sine_rows`] for its rows, then an odd
    // last row (or every row, when the kernel did nothing) by [`dot_row`]
    // and [`activate_q`].
    let mut buf = [core::mem::MaybeUninit::uninit(); crate::kernels::ROW_CHUNK];
    let (acc, k) = crate::kernels::dot_rows_q15(w, n, 0, x, out.len(), &mut buf, true);
    if k < x.len() && !acc.is_empty() {
        dot_rows_rest(w, (n, 0), x, k, acc);
    }
    let done = acc.len();
    sine_rows(
        acc,
        Some(bias),
        shifts,
        out.get_mut(..done).unwrap_or(&mut []),
        short,
    );
    for (j, o) in out.iter_mut().enumerate().skip(done) {
        let (Some(&[b0, b1, b2, b3]), Some(&s)) = (bias.get(4 * j..4 * j + 4), shifts.get(j))
        else {
            return true;
        };
        let b = i64::from(i32::from_le_bytes([b0, b1, b2, b3]));
        *o = activate_q(Activation::Sine, dot_row(w, (n, 0), x, j, b), s as i8);
    }
    true
}

/// Rows per kernel call of [`latent16`]: 64 (a 512-byte sum buffer), so
/// that the 48 rows of the shipped decoders take one call per sample (two
/// 32-row chunks cost ~115 instructions more per sample).
#[cfg(all(target_arch = "arm", target_feature = "dsp"))]
const LATENT_CHUNK: usize = 64;

/// [`latent_with`] for exactly 16 latent columns on a Cortex-M4/M7: for at
/// most [`LATENT_CHUNK`] rows, `buf_j = part_j + Σ_{i<16} q_j,lo/2+i · z_i`
/// by `kernels::latent_rows_q15` (one unrolled `asm!` row loop), then
/// `out_j = activate_q(act, buf_j, s_j)` in a loop of its own, or, for
/// `act == Sine`, [`sine_rows`] without a bias (`short`: the layer's
/// shifts are all in −31..=32); more rows are taken in
/// chunks of `LATENT_CHUNK`, each by a call of this function (one level
/// deep). Out of line and not generic (one copy for every activation), so
/// that the loops get the registers that the caller (the whole prediction,
/// inlined) keeps busy. Returns `false`, having written nothing, unless
/// `part`, `shifts` and `w` hold a row for every output and the 16 columns
/// lie inside a row (`lo + 32 ≤ n`); a chunk the kernel refuses
/// (alignment) takes the portable [`dot_row`]. The same exact `i64` sums
/// as [`rows_with`], so the same outputs.
#[cfg(all(target_arch = "arm", target_feature = "dsp"))]
#[inline(never)]
fn latent16(
    w: &[u8],
    (n, lo): (usize, usize),
    z: &[i16; 16],
    part: &[i64],
    shifts: &[u8],
    out: &mut [i16],
    (act, short): (Activation, bool),
) -> bool {
    let rows = out.len();
    if part.len() < rows
        || shifts.len() < rows
        || rows.saturating_mul(n) > w.len()
        || lo.saturating_add(32) > n
    {
        return false;
    }
    if rows > LATENT_CHUNK {
        // Chunks of LATENT_CHUNK rows, each by a call of this function
        // (which then takes the path below): one copy of the row loops.
        let mut start = 0;
        while start < rows {
            let end = rows.min(start + LATENT_CHUNK);
            if let (Some(wc), Some(pc), Some(sc), Some(oc)) = (
                w.get(start * n..),
                part.get(start..end),
                shifts.get(start..end),
                out.get_mut(start..end),
            ) {
                latent16(wc, (n, lo), z, pc, sc, oc, (act, short));
            }
            start = end;
        }
        return true;
    }
    // At most LATENT_CHUNK rows (the shipped decoders' 48): the kernel's
    // sums, then the activation; rows the kernel refuses (alignment) take
    // the portable [`dot_row`].
    let (Some(part), Some(shifts)) = (part.get(..rows), shifts.get(..rows)) else {
        return true;
    };
    let mut buf = [core::mem::MaybeUninit::uninit(); LATENT_CHUNK];
    let acc = crate::kernels::latent_rows_q15(w, n, lo, z, part, &mut buf);
    if acc.len() == rows && act == Activation::Sine {
        sine_rows(acc, None, shifts, out, short);
    } else {
        latent_other(w, (n, lo), z, (part, acc), shifts, out, act);
    }
    true
}

/// The rest of [`latent16`]'s cases (none of the shipped models takes
/// them), out of line and cold so that they do not grow the hot function:
/// `out_j = activate_q(act, acc_j, s_j)` with the kernel's sums `acc`, or,
/// when the kernel refused (`acc` shorter than `out`: alignment), with
/// `part_j` plus the portable [`dot_row`].
#[cfg(all(target_arch = "arm", target_feature = "dsp"))]
#[inline(never)]
#[cold]
fn latent_other(
    w: &[u8],
    (n, lo): (usize, usize),
    z: &[i16; 16],
    (part, acc): (&[i64], &[i64]),
    shifts: &[u8],
    out: &mut [i16],
    act: Activation,
) {
    let done = acc.len() == out.len();
    for (j, ((o, &p), &s)) in out.iter_mut().zip(part).zip(shifts).enumerate() {
        let a = match acc.get(j) {
            Some(&a) if done => a,
            _ => dot_row(w, (n, lo), &z[..], j, p),
        };
        *o = activate_q(act, a, s as i8);
    }
}

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

#[cfg(test)]
mod tests {
    use super::*;

    /// `quantize` as the module docs specify it, with the branches it had
    /// before the branch-free form.
    fn quantize_ref(x: f32, e: i8) -> i32 {
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

    #[test]
    fn quantize_matches_reference() {
        let edges = [
            0.0f32,
            -0.0,
            0.5,
            -0.5,
            1.5,
            2.5,
            32766.5,
            32767.0,
            32767.5,
            32768.0,
            -32767.5,
            -32768.0,
            -32768.5,
            -32769.0,
            4_194_303.5,
            4_194_304.0,
            8_388_608.0,
            12_582_912.0,
            f32::MAX,
            f32::MIN_POSITIVE,
            f32::from_bits(1),
            f32::INFINITY,
            f32::NAN,
        ];
        for e in [-20i8, -3, 0, 7, 12, 15, 30] {
            for &x in &edges {
                for v in [
                    x,
                    -x,
                    f32::from_bits(x.to_bits() + 1),
                    f32::from_bits(x.to_bits().wrapping_sub(1)),
                ] {
                    assert_eq!(quantize(v, e), quantize_ref(v, e), "{v:e} e {e}");
                }
            }
            // A stride through all f32 bit patterns (both signs, every exponent).
            let mut b = 0u32;
            while let Some(n) = b.checked_add(4099) {
                let x = f32::from_bits(b);
                assert_eq!(quantize(x, e), quantize_ref(x, e), "{b:#x} e {e}");
                b = n;
            }
        }
        // Every f32 with 2^13 <= |x| <= 2^16 at e = 0 (around the clamp bounds).
        for b in 0x4600_0000..=0x4780_0000u32 {
            for x in [f32::from_bits(b), -f32::from_bits(b)] {
                assert_eq!(quantize(x, 0), quantize_ref(x, 0), "{x:e}");
            }
        }
    }

    /// `sin_q15` as specified, with two loads from `QUARTER_SINE`.
    fn sin_q15_ref(phase: u32) -> i32 {
        let neg = (phase as i32) >> 31;
        let mut p = phase & 0x3fff_ffff;
        if phase & (1 << 30) != 0 {
            p = (1 << 30) - p;
        }
        let idx = (p >> 22) as usize;
        let frac = ((p >> 6) & 0xffff) as i32;
        let (a, b) = match QUARTER_SINE.get(idx..idx + 2) {
            Some(&[a, b]) => (a as i32, b as i32),
            _ => (32768, 32768),
        };
        let v = (a + (((b - a) * frac + 0x8000) >> 16)).min(32767);
        (v ^ neg) - neg
    }

    #[test]
    fn sin_q15_matches_table_form() {
        // Every distinct input (the low 6 bits are ignored), with low bits
        // 0 and 63, and the quadrant edges.
        for k in 0..(1u32 << 26) {
            for ph in [k << 6, (k << 6) | 63] {
                assert_eq!(sin_q15(ph), sin_q15_ref(ph), "{ph:#x}");
            }
        }
        for ph in [0u32, 1 << 30, 1 << 31, 3 << 30, u32::MAX] {
            assert_eq!(sin_q15(ph), sin_q15_ref(ph), "{ph:#x}");
        }
    }

    /// `rshr` exactly, in `i128`.
    fn rshr_ref(a: i64, s: i8) -> i64 {
        if s <= 0 {
            a
        } else {
            ((i128::from(a) + (1i128 << (s - 1))) >> s) as i64
        }
    }

    /// The phase steps of `kernels::sine_rows_q15` (Cortex-M4/M7 asm), in
    /// Rust with the Armv7-M register-shift rule (`LSL`/`LSR` by a register
    /// use its low byte; an amount of 32 or more gives 0): for `1 ≤ s ≤
    /// 32` `t = lo >> (s − 1)`, `((hi << (32 − s)) | (t >> 1)) + (t & 1)`;
    /// for `−31 ≤ s ≤ 0` `lo << −s`; the 64-bit sum first gets the
    /// sign-extended i32 bias (`ADDS`/`ADC … ASR #31`).
    fn asm_phase(sum: i64, bias: i32, s: i32) -> u32 {
        let lsl = |v: u32, a: i32| {
            let a = (a as u32) & 0xff;
            if a >= 32 {
                0
            } else {
                v << a
            }
        };
        let lsr = |v: u32, a: i32| {
            let a = (a as u32) & 0xff;
            if a >= 32 {
                0
            } else {
                v >> a
            }
        };
        let (lo, c) = (sum as u32).overflowing_add(bias as u32);
        let hi = ((sum >> 32) as u32)
            .wrapping_add((bias >> 31) as u32)
            .wrapping_add(u32::from(c));
        if s > 0 {
            let t = lsr(lo, s - 1);
            (lsl(hi, 32 - s) | (t >> 1)).wrapping_add(t & 1)
        } else {
            lsl(lo, -s)
        }
    }

    #[test]
    fn sine_rows_phase_steps_match_reference() {
        let mut r = crate::prng::Xoshiro128PlusPlus::seed_from_u64(13);
        let bound = (1i64 << 47) - 1;
        for s in -31i8..=32 {
            let want = |a: i64| {
                if s >= 0 {
                    rshr_ref(a, s) as u32
                } else {
                    (a as u32).wrapping_shl((-(s as i32)) as u32)
                }
            };
            let check = |sum: i64, bias: i32| {
                let a = sum + i64::from(bias);
                assert_eq!(
                    asm_phase(sum, bias, s.into()),
                    want(a),
                    "{sum} {bias} s {s}"
                );
                assert_eq!(sine_phase(a, s), want(a), "{sum} {bias} s {s}");
            };
            let h = if s > 0 { 1i64 << (s - 1) } else { 1 };
            let edges = [
                (0i64, 0i32),
                (bound, i32::MAX),
                (-bound, i32::MIN),
                (bound - i64::from(i32::MAX), i32::MAX),
                (-bound - i64::from(i32::MIN), i32::MIN),
                ((1 << 32) - 1, 1),
                (-(1 << 32), -1),
                (-1, 0),
                (0, -1),
                (h, 0),
                (h - 1, 0),
                (-h, 0),
                (-h - 1, 0),
                (h, -1),
            ];
            for (sum, bias) in edges {
                check(sum, bias);
            }
            for _ in 0..20_000 {
                let raw = (u64::from(r.next_u32()) << 32 | u64::from(r.next_u32())) as i64;
                check(raw >> (17 + r.next_u32() % 47), r.next_u32() as i32);
            }
        }
    }

    #[test]
    fn sine_phase_matches_reference() {
        let mut r = crate::prng::Xoshiro128PlusPlus::seed_from_u64(5);
        for s in -31i8..=62 {
            let want = |a: i64| {
                if s >= 0 {
                    rshr_ref(a, s) as u32
                } else {
                    (a as u32).wrapping_shl((-(s as i32)) as u32)
                }
            };
            let bound = (1i64 << 47) - 1;
            let mut edges = [
                0i64,
                1,
                -1,
                bound,
                -bound,
                1 << 31,
                -(1 << 31),
                (1 << 32) - 1,
                1 << 32,
            ];
            if s > 0 {
                let h = 1i64 << (s - 1);
                edges[1] = h;
                edges[2] = h - 1;
                edges[3] = -h;
                edges[4] = -h - 1;
            }
            for a in edges {
                assert_eq!(sine_phase(a, s), want(a), "a {a} s {s}");
                assert_eq!(rshr(a, s), rshr_ref(a, s), "a {a} s {s}");
            }
            for _ in 0..20_000 {
                let raw = (u64::from(r.next_u32()) << 32 | u64::from(r.next_u32())) as i64;
                // |a| < 2^47 at every magnitude.
                let a = raw >> (17 + r.next_u32() % 47);
                assert_eq!(sine_phase(a, s), want(a), "a {a} s {s}");
                let act = activate_q(Activation::Sine, a, s);
                assert_eq!(act, sin_q15(want(a)) as i16, "a {a} s {s}");
            }
        }
    }
}
