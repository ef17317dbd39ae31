//! The walk over a layer's weight rows, [`rows_with`]: each output's
//! start value plus its row's dot product, handed to a closure. Portable:
//! two rows at a time with the loops of [`super::dot`]; on a Cortex-M4/M7
//! (`cfg(all(target_arch = "arm", target_feature = "dsp"))`, the other
//! block of [`rows_with`]): up to 32 rows per call of the `SMLALD` row
//! kernel. The same exact sums either way.

#[cfg(all(target_arch = "arm", target_feature = "dsp"))]
use super::dot::dot1;

/// `(acc0 + Σ_i q0_i · x_i, acc1 + Σ_i q1_i · x_i)` for the two rows of `g`
/// (stride `n` bytes), columns from byte `lo`: the portable
/// [`dot1`](super::dot::dot1)/[`dot_even`](super::dot::dot_even) twice (a Cortex-M4/M7 takes the other
/// block of [`rows_with`] and never comes here). Integer sums are exact.
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

/// For each output `o_j` of `out` zipped with `inits` (`(init_j, s_j)`),
/// calls `f(o_j, init_j + Σ_i q_j,i · x_i, s_j)` (exact, in `i64`), where
/// row `j` of `w` has `n` bytes and its columns start at byte `lo`
/// (`(n, lo)`, the second argument).
///
/// Portable: two rows at a time (`dot2`; an odd last row with `dot`).
/// On a Cortex-M4/M7: up to `kernels::ROW_CHUNK` (32) rows at a time,
/// their dot products by one call of the `SMLALD` row kernel
/// (`kernels::dot_rows_q15`, which loops over the row pairs in assembly)
/// into a stack array, the columns it leaves by `dot_rows_rest` (and an
/// odd last row by `dot_row`), then `f(o_j, init_j + dot_j, s_j)` row by
/// row: the same exact `i64` sums as the portable walk, so the same outputs.
#[inline(always)]
pub(super) fn rows_with<T>(
    w: &[u8],
    (n, lo): (usize, usize),
    x: &[i16],
    mut inits: impl Iterator<Item = (i64, i8)>,
    out: &mut [T],
    mut f: impl FnMut(&mut T, i64, i8),
    dot: impl Fn(&[u8], &[i16], i64) -> i64,
) {
    #[cfg(all(target_arch = "arm", target_feature = "dsp"))]
    {
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
    #[cfg(not(all(target_arch = "arm", target_feature = "dsp")))]
    {
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
}

/// What `kernels::dot_rows_q15` left of [`rows_with`]'s chunk: adds
/// `Σ_i q_j,i · x_i` over the columns `k..` (fewer than 4) to `acc[j]` for
/// each row it did, with the portable [`dot1`](super::dot::dot1); out of line so that it is
/// compiled once. `lo + 2·x.len() ≤ n` (checked by the caller).
#[cfg(all(target_arch = "arm", target_feature = "dsp"))]
#[inline(never)]
pub(super) fn dot_rows_rest(
    w: &[u8],
    (n, lo): (usize, usize),
    x: &[i16],
    k: usize,
    acc: &mut [i64],
) {
    let hi = lo + 2 * x.len();
    let xs = x.get(k..).unwrap_or(&[]);
    for (a, row) in acc.iter_mut().zip(w.chunks_exact(n.max(1))) {
        let r = row.get(lo + 2 * k..hi).unwrap_or(&[]);
        *a = dot1(r, xs, *a);
    }
}

/// `init + Σ_i q_j,i · x_i` for row `j` of [`rows_with`]'s chunk `w`, all
/// columns, with the portable [`dot1`](super::dot::dot1) (a row the kernel did not take);
/// out of line. `lo + 2·x.len() ≤ n` (checked by the caller).
#[cfg(all(target_arch = "arm", target_feature = "dsp"))]
#[inline(never)]
pub(super) fn dot_row(w: &[u8], (n, lo): (usize, usize), x: &[i16], j: usize, init: i64) -> i64 {
    let start = j.saturating_mul(n).saturating_add(lo);
    let r = w
        .get(start..start.saturating_add(2 * x.len()))
        .unwrap_or(&[]);
    dot1(r, x, init)
}
