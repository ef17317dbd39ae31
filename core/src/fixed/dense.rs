//! One fixed-point layer: [`accumulate`] (bias plus row sums, for each
//! output), [`dense_q`] (a whole layer with its activation) and
//! [`latent_with`] (the decoder's first layer, latent columns only, from
//! the partial sums of its feature columns).

use crate::blob::{Activation, Layer};

use super::activation::activate_q;
#[cfg(not(all(target_arch = "arm", target_feature = "dsp")))]
use super::dot::dot16_packed;
use super::dot::{dot1, dot_even};
#[cfg(all(target_arch = "arm", target_feature = "dsp"))]
use super::dsp::{dense_sine, latent16};
use super::rows::rows_with;

/// For each output channel `j` (zipped with `out`, at most `out_dim`), calls
/// `f(o_j, acc_j, s_j)` with `acc_j = B_j + Σ_i q_j,skip+i · x_i` (exact,
/// in `i64`): one pass over the layer's whole weight slice, two rows at a
/// time.
#[inline(always)]
pub(super) fn accumulate<T>(
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
pub(super) fn dense_q(layer: &Layer<'_>, x: &[i16], out: &mut [i16]) {
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

/// The decoder's first layer, latent columns `skip..skip + z.len()` only:
/// `out_j = g(part_j + Σ_i q_j,skip+i · z_i, s_j)`, where `part_j` already
/// holds the bias and the feature columns. With 16 latent columns at the
/// end of each row (the shipped models) the dot product has a fixed length.
#[inline(always)]
pub(super) fn latent_with(
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
