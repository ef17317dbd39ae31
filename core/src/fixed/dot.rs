//! The portable dot products of one weight row (i16 LE bytes) with an
//! activation vector, exact in `i64`: the reference loops, written for
//! LLVM's ARM parallel-DSP pass.

/// One i16 LE weight from `w[0..2]` (0 if short).
#[inline(always)]
pub(super) fn w16(w: &[u8]) -> i32 {
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
pub(super) fn dot1(w: &[u8], x: &[i16], mut acc: i64) -> i64 {
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
pub(super) fn dot_even(w: &[u8], x: &[i16], mut acc: i64) -> i64 {
    for (xx, q) in x.chunks_exact(2).zip(w.chunks_exact(4)) {
        acc = pair_step(xx, q, acc);
    }
    acc
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
pub(super) fn dot16_packed(q: &[u8; 32], zp: &[i32; 8], mut acc: i64) -> i64 {
    for (w, &z) in q.chunks_exact(4).zip(zp) {
        if let Some((a, b)) = w.split_first_chunk::<2>() {
            acc += i64::from(i32::from(i16::from_le_bytes(*a)) * i32::from(z as i16));
            acc += i64::from(w16(b) * (z >> 16));
        }
    }
    acc
}
