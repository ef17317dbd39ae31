//! The dense layer on `L` lanes side by side
//! ([`crate::backend::Backend::dense_lanes`]), one skeleton for both
//! backends: the f32 ([`crate::float`]) and Q15 ([`crate::fixed`]) ones
//! supply only their weight width, the multiply-add of one weight into
//! every lane and the bias and activation of a row ([`LaneArith`]).
//!
//! # Order
//!
//! For each row `j`: every lane's sum starts at the bias `b_j`, then
//! `acc[l] = acc[l] + W_ji · x[i][l]` for `i` ascending (f32: product and
//! sum each rounded once, never fused; Q15: the `i32` product added to an
//! `i64`, exact), so each lane's sum is the scalar [`Backend::dense`]'s,
//! operation for operation. [`ROWS`] rows are summed at once (each `x[i]`
//! loaded once for all of them), the last `out_dim mod ROWS` rows one at a
//! time; then the row's activation, lane by lane, for the lanes
//! `l < used` (0 for the others).

use crate::backend::Backend;
use crate::blob::{Activation, Layer};

/// What a backend supplies to the lane skeleton. The sum type is the
/// backend's [`Backend::Acc`] (f32, or an exact `i64`).
pub(crate) trait LaneArith: Backend {
    /// One weight, as it is multiplied (f32; the i16 widened to `i32`).
    type Weight: Copy;
    /// Bytes per weight in the blob (4 for f32, 2 for i16), little-endian.
    const WEIGHT_BYTES: usize;
    /// The weight in `b` (`WEIGHT_BYTES` bytes; 0 if short).
    fn weight(b: &[u8]) -> Self::Weight;
    /// `a[l] += q · x[l]` for every lane, in the backend's arithmetic.
    fn axpy<const L: usize>(a: &mut [Self::Acc; L], q: Self::Weight, x: &[Self::Act; L]);
    /// Row `j`'s bias as the starting sum.
    fn bias(layer: &Layer<'_>, j: usize) -> Self::Acc;
    /// `o[l] = act(acc[l])` for row `j` (Q15: with the row's shift) for the
    /// lanes `l < used`, 0 for the others.
    fn finish<const L: usize>(
        layer: &Layer<'_>,
        act: Activation,
        j: usize,
        acc: &[Self::Acc; L],
        used: usize,
        o: &mut [Self::Act; L],
    );
}

/// Rows of a layer that [`dense_lanes`] sums together: 4 rows share each
/// load of `x[i]` and give `4·L` independent sums, enough to hide the f32
/// add latency (on x86-64's 16 SSE registers with `L = 8`). Wider vectors
/// sum more rows at once ([`dense_rows`]; AVX: 8 rows of one 8-lane vector).
pub(crate) const ROWS: usize = 4;

/// `acc[l] += Σ_i W_i · x[i][l]`, `i` ascending, over the shorter of `row`
/// (weight bytes) and `x`, every lane `l` (innermost, so that LLVM
/// vectorises across lanes).
#[inline(always)]
fn row_lanes<K: LaneArith, const L: usize>(row: &[u8], x: &[[K::Act; L]], acc: &mut [K::Acc; L]) {
    let mut a = *acc;
    for (xi, q) in x.iter().zip(row.chunks_exact(K::WEIGHT_BYTES)) {
        K::axpy(&mut a, K::weight(q), xi);
    }
    *acc = a;
}

/// The columns of four rows of equal length side by side: item `i` holds
/// column `i`'s `wb` weight bytes of each row. (Zipped `chunks_exact`, so
/// that LLVM checks the lengths once, not per column.)
#[inline(always)]
fn quad_cols(q: [&[u8]; 4], wb: usize) -> impl Iterator<Item = [&[u8]; 4]> {
    let [r0, r1, r2, r3] = q;
    r0.chunks_exact(wb)
        .zip(r1.chunks_exact(wb))
        .zip(r2.chunks_exact(wb))
        .zip(r3.chunks_exact(wb))
        .map(|(((a, b), c), d)| [a, b, c, d])
}

/// `a[r] += W_ri · xi` for the four rows of one column (`w`: their weight
/// bytes).
#[inline(always)]
fn axpy4<K: LaneArith, const L: usize>(a: &mut [[K::Acc; L]; 4], w: [&[u8]; 4], xi: &[K::Act; L]) {
    for (ar, q) in a.iter_mut().zip(w) {
        K::axpy(ar, K::weight(q), xi);
    }
}

/// [`row_lanes`] for the `R` rows of `g` (stride `n` bytes) at once, `R` =
/// 4 or 8: each `x[i]` loaded once for all of them, and `R·L` independent
/// sums (in registers: local arrays of four rows, which LLVM keeps in
/// vector registers). Rows shorter than `x` (never for a validated layer)
/// and any other `R` go one by one.
#[inline(always)]
fn rows_lanes<K: LaneArith, const L: usize, const R: usize>(
    g: &[u8],
    n: usize,
    x: &[[K::Act; L]],
    acc: &mut [[K::Acc; L]; R],
) {
    let wb = K::WEIGHT_BYTES;
    let len = wb * x.len();
    let row = |r: usize| {
        g.get(r * n..(r + 1) * n)
            .and_then(|row| row.get(..len))
            .unwrap_or(&[])
    };
    let quad = |r0: usize| [row(r0), row(r0 + 1), row(r0 + 2), row(r0 + 3)];
    let whole = (0..R).all(|r| row(r).len() == len);
    let four = |r0: usize| -> [[K::Acc; L]; 4] {
        core::array::from_fn(|r| acc.get(r0 + r).copied().unwrap_or([K::Acc::default(); L]))
    };
    match (whole, R) {
        (true, 4) => {
            let mut a = four(0);
            for (xi, w) in x.iter().zip(quad_cols(quad(0), wb)) {
                axpy4::<K, L>(&mut a, w, xi);
            }
            for (o, a) in acc.iter_mut().zip(a) {
                *o = a;
            }
        }
        (true, 8) => {
            let (mut lo, mut hi) = (four(0), four(4));
            let cols = quad_cols(quad(0), wb).zip(quad_cols(quad(4), wb));
            for (xi, (w_lo, w_hi)) in x.iter().zip(cols) {
                // One load of `x[i]` (a register) for the eight rows.
                let xi = *xi;
                axpy4::<K, L>(&mut lo, w_lo, &xi);
                axpy4::<K, L>(&mut hi, w_hi, &xi);
            }
            for (o, a) in acc.iter_mut().zip(lo.into_iter().chain(hi)) {
                *o = a;
            }
        }
        _ => {
            for (r, a) in acc.iter_mut().enumerate() {
                let row = g.get(r * n..(r + 1) * n).unwrap_or(&[]);
                row_lanes::<K, L>(row, x, a);
            }
        }
    }
}

/// [`Backend::dense_lanes`] for backend `K` (see the module docs):
/// [`dense_rows`] with [`ROWS`] rows at a time.
#[inline]
pub(crate) fn dense_lanes<K: LaneArith, const L: usize>(
    layer: &Layer<'_>,
    x: &[[K::Act; L]],
    out: &mut [[K::Act; L]],
    used: usize,
) {
    if L <= 8 {
        dense_rows::<K, L, ROWS>(layer, x, out, used);
    } else {
        // Wider lanes are enough independent sums per row; 4 rows of them
        // would not fit the 16 SSE registers.
        dense_rows::<K, L, 1>(layer, x, out, used);
    }
}

/// The dense layer on `L` lanes, `R` rows at a time ([`rows_lanes`]), the
/// last `out_dim mod R` rows one at a time, then [`LaneArith::finish`] per
/// row. The bits do not depend on `R` (each lane's sum of each row runs in
/// the same order whatever the rows beside it); `R` only sets how many
/// independent sums the CPU sees at once. Always inlined, so that a caller
/// compiled with wider vectors ([`crate::kernels`]) compiles all of it so.
#[inline(always)]
pub(crate) fn dense_rows<K: LaneArith, const L: usize, const R: usize>(
    layer: &Layer<'_>,
    x: &[[K::Act; L]],
    out: &mut [[K::Act; L]],
    used: usize,
) {
    let n = K::WEIGHT_BYTES * layer.in_dim();
    let w = layer.tensors_q().0;
    let act = layer.activation();
    let out_len = out.len().min(layer.out_dim());
    let out = &mut out[..out_len];
    let mut j = 0;
    let mut blocks = out.chunks_exact_mut(R);
    for o in &mut blocks {
        let g = w.get(j * n..).unwrap_or(&[]);
        let mut acc: [[K::Acc; L]; R] = core::array::from_fn(|r| [K::bias(layer, j + r); L]);
        rows_lanes::<K, L, R>(g, n, x, &mut acc);
        for (r, (o, a)) in o.iter_mut().zip(&acc).enumerate() {
            K::finish::<L>(layer, act, j + r, a, used, o);
        }
        j += R;
    }
    for o in blocks.into_remainder() {
        let g = w.get(j * n..).unwrap_or(&[]);
        let mut acc = [K::bias(layer, j); L];
        row_lanes::<K, L>(g.get(..n).unwrap_or(g), x, &mut acc);
        K::finish::<L>(layer, act, j, &acc, used, o);
        j += 1;
    }
}
