//! The Cortex-M4/M7 layer paths (`cfg(all(target_arch = "arm",
//! target_feature = "dsp"))` only) around the private `kernels` module's
//! asm loops: a whole `Sine` layer ([`dense_sine`]) and the decoder's 16
//! latent columns ([`latent16`]), with the activation of their rows
//! ([`sine_rows`]). The same exact sums and activation steps as the
//! portable path, so the same outputs.

use crate::blob::Activation;

use super::activation::activate_q;
use super::rows::{dot_row, dot_rows_rest};
use super::SINE_PAIRS;

/// `out_j = activate_q(Sine, sums_j + B_j, s_j)` for `j < out.len()`
/// (`B_j`: the i32 LE bias at `bias[4j..]`, or 0 for `None` when the sums
/// hold it, as the decoder's latent rows do; `s_j = shifts[j] as i8`) on a
/// Cortex-M4/M7: runs of rows by the asm loop `kernels::sine_rows_q15`
/// (the same integer steps as [`sine_phase`](super::activation::sine_phase) and [`sin_q15`](super::sin_q15), see there);
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

/// A `Sine` layer of [`dense_q`](super::dense::dense_q) on a Cortex-M4/M7 (its weights `w`, row
/// stride `n` bytes, then its i32 LE `bias`, `shifts` and whether all of
/// them are in −31..=32, `short`): for at most
/// `kernels::ROW_CHUNK` rows the row kernel's sums (as in [`rows_with`](super::rows::rows_with):
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
pub(super) fn dense_sine(
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

/// [`latent_with`](super::dense::latent_with) for exactly 16 latent columns on a Cortex-M4/M7: for at
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
/// as [`rows_with`](super::rows::rows_with), so the same outputs.
#[cfg(all(target_arch = "arm", target_feature = "dsp"))]
#[inline(never)]
pub(super) fn latent16(
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
