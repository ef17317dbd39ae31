//! The dense layer on `L` lanes side by side
//! ([`crate::engine::Backend::dense_lanes`]), one skeleton for both
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

use crate::blob::{Activation, Layer};
use crate::engine::Backend;

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
/// add latency (on x86-64's 16 SSE registers with `L = 8`).
const ROWS: usize = 4;

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

/// [`row_lanes`] for the [`ROWS`] rows of `g` (stride `n` bytes) at once:
/// each `x[i]` loaded once for the four, and `4·L` independent sums (in
/// registers). Rows shorter than `x` (never for a validated layer) go one
/// by one.
#[inline(always)]
fn rows_lanes<K: LaneArith, const L: usize>(
    g: &[u8],
    n: usize,
    x: &[[K::Act; L]],
    acc: &mut [[K::Acc; L]; ROWS],
) {
    let len = K::WEIGHT_BYTES * x.len();
    let rows: [&[u8]; ROWS] = core::array::from_fn(|r| {
        g.get(r * n..(r + 1) * n)
            .and_then(|row| row.get(..len))
            .unwrap_or(&[])
    });
    let [r0, r1, r2, r3] = rows;
    if rows.iter().any(|r| r.len() != len) {
        for (r, a) in acc.iter_mut().enumerate() {
            let row = g.get(r * n..(r + 1) * n).unwrap_or(&[]);
            row_lanes::<K, L>(row, x, a);
        }
        return;
    }
    let [mut a0, mut a1, mut a2, mut a3] = *acc;
    let q = r0
        .chunks_exact(K::WEIGHT_BYTES)
        .zip(r1.chunks_exact(K::WEIGHT_BYTES))
        .zip(r2.chunks_exact(K::WEIGHT_BYTES))
        .zip(r3.chunks_exact(K::WEIGHT_BYTES));
    for (xi, (((q0, q1), q2), q3)) in x.iter().zip(q) {
        K::axpy(&mut a0, K::weight(q0), xi);
        K::axpy(&mut a1, K::weight(q1), xi);
        K::axpy(&mut a2, K::weight(q2), xi);
        K::axpy(&mut a3, K::weight(q3), xi);
    }
    *acc = [a0, a1, a2, a3];
}

/// [`Backend::dense_lanes`] for backend `K` (see the module docs):
/// [`ROWS`] rows at a time ([`rows_lanes`]), the last `out_dim mod 4` rows
/// one at a time, then [`LaneArith::finish`] per row.
#[inline]
pub(crate) fn dense_lanes<K: LaneArith, const L: usize>(
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
    let mut blocks = out.chunks_exact_mut(ROWS);
    for o in &mut blocks {
        let g = w.get(j * n..).unwrap_or(&[]);
        let mut acc: [[K::Acc; L]; ROWS] = core::array::from_fn(|r| [K::bias(layer, j + r); L]);
        rows_lanes::<K, L>(g, n, x, &mut acc);
        for (r, (o, a)) in o.iter_mut().zip(&acc).enumerate() {
            K::finish::<L>(layer, act, j + r, a, used, o);
        }
        j += ROWS;
    }
    for o in blocks.into_remainder() {
        let g = w.get(j * n..).unwrap_or(&[]);
        let mut acc = [K::bias(layer, j); L];
        row_lanes::<K, L>(g.get(..n).unwrap_or(g), x, &mut acc);
        K::finish::<L>(layer, act, j, &acc, used, o);
        j += 1;
    }
}
