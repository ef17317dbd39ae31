//! The f32 backend ([`NumericKind::F32`] blobs): f32 weights read in place,
//! a [`Sine`] chosen at compile time.
//!
//! # One layer, exactly
//!
//! `y_j = act(b_j + W_j0 x_0 + W_j1 x_1 + …)`: the bias first, then the
//! products added strictly left to right in f32, each product and each sum
//! rounded once (separate multiply and add: Rust never fuses them). `Relu` is
//! `if v < 0 { 0 } else { v }` (NaN passes through); `Sine` is `S::sin`.
//! The decoder's first layer is split at its feature columns
//! ([`crate::backend::Backend::partial`] then [`crate::backend::Backend::latent`]),
//! which continues the same left-to-right sum: the result equals one pass.

use core::marker::PhantomData;

use crate::backend::{Backend, Sealed};
use crate::blob::{Activation, Layer, NumericKind};
use crate::lanes::LaneArith;
use crate::sine::Sine;

/// The f32 backend with sine `S`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Float<S: Sine>(PhantomData<S>);

/// Applies `act` with sine `S`.
#[inline]
fn activate<S: Sine>(act: Activation, v: f32) -> f32 {
    match act {
        Activation::Linear => v,
        // `v < 0` is false for NaN, so NaN propagates instead of turning into 0.
        Activation::Relu => {
            if v < 0.0 {
                0.0
            } else {
                v
            }
        }
        Activation::Sine => S::sin(v),
    }
}

/// `s + W_0 x_0 + W_1 x_1 + …` left to right (`w`: f32 LE bytes), over the
/// shorter of `w` and `x`.
#[inline(always)]
fn row_sum(w: &[u8], x: &[f32], mut s: f32) -> f32 {
    for (w, &xi) in w.chunks_exact(4).zip(x) {
        let w = match w {
            &[b0, b1, b2, b3] => f32::from_le_bytes([b0, b1, b2, b3]),
            _ => 0.0,
        };
        s += w * xi;
    }
    s
}

/// The columns `k..` that `kernels::dot4_f32` left, for the four
/// rows of `g` (stride `n` bytes, columns from byte `lo`), continued with
/// [`row_sum`] (out of line: compiled once).
#[cfg(all(target_arch = "arm", target_feature = "dsp", target_feature = "fpregs"))]
#[inline(never)]
fn quad_rest(g: &[u8], n: usize, lo: usize, x: &[f32], k: usize, acc: &mut [f32; 4]) {
    let xr = x.get(k..).unwrap_or(&[]);
    let lo = lo + 4 * k;
    for (j, a) in acc.iter_mut().enumerate() {
        let start = j * n + lo;
        let r = g.get(start..(j + 1) * n).unwrap_or(&[]);
        *a = row_sum(r, xr, *a);
    }
}

/// `acc_j += Σ_{i} W[j][col0 + i] · x[i]`, left to right, for `j < acc.len()`.
///
/// On a Cortex-M4F/M7 (`thumbv7em-none-eabihf`) four rows at a time go
/// through the `VMLA.F32` kernel (`kernels::dot4_f32`: the same
/// roundings in the same order) for the longest prefix of columns it takes,
/// and [`row_sum`] continues each row from there; the result is the same
/// bits as the portable loop.
#[inline]
fn accumulate(layer: &Layer<'_>, col0: usize, x: &[f32], acc: &mut [f32]) {
    #[allow(unused_mut)]
    let mut j0 = 0;
    #[cfg(all(target_arch = "arm", target_feature = "dsp", target_feature = "fpregs"))]
    {
        let n = 4 * layer.in_dim();
        let lo = 4 * col0;
        let w = layer.tensors_q().0;
        let mut quads = acc.chunks_exact_mut(4);
        for (a, g) in (&mut quads).zip(w.chunks_exact(4 * n.max(1))) {
            if let Ok(a) = <&mut [f32; 4]>::try_from(a) {
                let k = crate::kernels::dot4_f32(g, n, lo, x, a);
                if k < x.len() {
                    quad_rest(g, n, lo, x, k, a);
                }
            }
            j0 += 4;
        }
    }
    for (j, a) in acc.iter_mut().enumerate().skip(j0) {
        let row = layer.row_bytes(j);
        let cols = row.get(col0 * 4..).unwrap_or(&[]);
        *a = row_sum(cols, x, *a);
    }
}

/// `acc_j = b_j` for `j < acc.len()`.
#[inline]
fn biases(layer: &Layer<'_>, acc: &mut [f32]) {
    for (j, o) in acc.iter_mut().enumerate() {
        *o = layer.bias(j);
    }
}

/// One f32 LE weight from `c[0..4]` (0 if short).
#[inline(always)]
fn w32(c: &[u8]) -> f32 {
    match *c {
        [b0, b1, b2, b3] => f32::from_le_bytes([b0, b1, b2, b3]),
        _ => 0.0,
    }
}

impl<S: Sine> LaneArith for Float<S> {
    type Weight = f32;
    const WEIGHT_BYTES: usize = 4;

    #[inline(always)]
    fn weight(b: &[u8]) -> f32 {
        w32(b)
    }

    /// `a[l] += q · x[l]` (one rounding for the product, one for the sum):
    /// each lane's sum is [`row_sum`]'s, left to right.
    #[inline(always)]
    fn axpy<const L: usize>(a: &mut [f32; L], q: f32, x: &[f32; L]) {
        for (al, &xl) in a.iter_mut().zip(x) {
            *al += q * xl;
        }
    }

    #[inline(always)]
    fn bias(layer: &Layer<'_>, j: usize) -> f32 {
        layer.bias(j)
    }

    /// The activation of each lane; the sine through [`Sine::sin_lanes`]
    /// (all lanes at once: the same bits as [`Sine::sin`] lane by lane).
    #[inline(always)]
    fn finish<const L: usize>(
        _layer: &Layer<'_>,
        act: Activation,
        _j: usize,
        acc: &[f32; L],
        used: usize,
        o: &mut [f32; L],
    ) {
        if act == Activation::Sine {
            *o = *acc;
            S::sin_lanes(o);
        } else {
            for (o, &v) in o.iter_mut().zip(acc) {
                *o = activate::<S>(act, v);
            }
        }
        for o in o.iter_mut().skip(used) {
            *o = 0.0;
        }
    }
}

impl<S: Sine> Sealed for Float<S> {}

impl<S: Sine> Backend for Float<S> {
    type Act = f32;
    type Acc = f32;
    const KIND: NumericKind = NumericKind::F32;
    const SINE: &'static str = S::NAME;

    #[inline]
    fn from_f32(v: f32, _exp: i8) -> f32 {
        v
    }

    #[inline]
    fn to_f32(v: f32, _exp: i8) -> f32 {
        v
    }

    #[inline]
    fn dense(layer: &Layer<'_>, x: &[f32], out: &mut [f32]) {
        biases(layer, out);
        accumulate(layer, 0, x, out);
        for o in out.iter_mut() {
            *o = activate::<S>(layer.activation(), *o);
        }
    }

    fn partial(layer: &Layer<'_>, x: &[f32], part: &mut [f32]) {
        let out = layer.out_dim().min(part.len());
        biases(layer, &mut part[..out]);
        accumulate(layer, 0, x, &mut part[..out]);
    }

    fn dense_lanes<const L: usize>(
        layer: &Layer<'_>,
        x: &[[f32; L]],
        out: &mut [[f32; L]],
        used: usize,
    ) {
        #[cfg(target_arch = "x86_64")]
        crate::kernels::x86::dense_lanes::<Self, L>(layer, x, out, used);
        #[cfg(not(target_arch = "x86_64"))]
        crate::lanes::dense_lanes::<Self, L>(layer, x, out, used);
    }

    fn latent(layer: &Layer<'_>, skip: usize, z: &[f32], part: &[f32], out: &mut [f32]) {
        let n = out.len().min(part.len());
        out[..n].copy_from_slice(&part[..n]);
        accumulate(layer, skip, z, &mut out[..n]);
        for o in out[..n].iter_mut() {
            *o = activate::<S>(layer.activation(), *o);
        }
    }
}
