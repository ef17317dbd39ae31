//! The numeric backend contract: [`Backend`], the element types and the
//! dense-layer arithmetic of one [`NumericKind`], which the engine
//! ([`crate::engine`]), the batched path ([`crate::batch`]) and the lane
//! skeleton run, and which the f32 ([`crate::float`]) and Q15
//! ([`crate::fixed`]) backends implement; and the exponents at a network's
//! boundaries (`in_exp`, `out_exp`) where a backend converts.
//!
//! It sits right above the blob: it names a [`Layer`] and nothing that runs
//! one, so the backends and the kernels below the engine can implement it
//! without importing the engine. `gpecnet_core::engine::Backend` is the same
//! trait.

use crate::blob::{Layer, Network, NumericKind};

mod sealed {
    pub trait Sealed {}
}
pub(crate) use sealed::Sealed;

/// A numeric backend: the element types and the dense-layer arithmetic of
/// one [`NumericKind`]. Implemented by [`crate::float::Float`] and
/// [`crate::fixed::Q15`] only (sealed).
pub trait Backend: Sealed {
    /// One activation (f32, or an `i16` fixed-point value).
    type Act: Copy + Default;
    /// One partial sum of the decoder's first layer (f32, or an exact `i64`).
    type Acc: Copy + Default;
    /// The blob kind this backend runs.
    const KIND: NumericKind;
    /// Name of the sine in golden files and model cards.
    const SINE: &'static str;
    /// An f32 value entering a network whose input exponent is `exp`
    /// (ignored by f32).
    fn from_f32(v: f32, exp: i8) -> Self::Act;
    /// A network output with exponent `exp` as f32 (exact).
    fn to_f32(v: Self::Act, exp: i8) -> f32;
    /// One dense layer: `out_j = act(b_j + Σ_i W_ji x_i)`, `out.len() = out_dim`.
    fn dense(layer: &Layer<'_>, x: &[Self::Act], out: &mut [Self::Act]);
    /// `part_j = b_j + Σ_{i < x.len()} W_ji x_i` for the first `x.len()`
    /// columns, `j < min(part.len(), out_dim)`.
    fn partial(layer: &Layer<'_>, x: &[Self::Act], part: &mut [Self::Acc]);
    /// `out_j = act(part_j + Σ_i W_j,skip+i z_i)`: the rest of a row whose
    /// first `skip` columns are summed in `part`.
    fn latent(
        layer: &Layer<'_>,
        skip: usize,
        z: &[Self::Act],
        part: &[Self::Acc],
        out: &mut [Self::Act],
    );
    /// [`Backend::dense`] on `L` lanes side by side ([`crate::batch`]):
    /// `out[j][l] = act(b_j + Σ_i W_ji x[i][l])` for `j < out.len()` and
    /// every lane `l`, where row `i` of `x` holds input `i` of every lane.
    /// Each lane gets exactly the operations of [`Backend::dense`] on its
    /// own column, in the same order (f32: bias, then the products added
    /// left to right, separate multiply and add), so the same bits; each
    /// weight is read once for all `L` lanes. Only lanes `l < used` are
    /// activated; the others are set to 0 (a short chunk does not pay for
    /// the sines of its empty lanes).
    fn dense_lanes<const L: usize>(
        layer: &Layer<'_>,
        x: &[[Self::Act; L]],
        out: &mut [[Self::Act; L]],
        used: usize,
    );
}

/// Input exponent of `net` (0 for f32 or an empty network).
pub(crate) fn in_exp(net: &Network<'_>) -> i8 {
    net.layer(0).map_or(0, |l| l.in_exp())
}

/// Output exponent of `net` (0 for f32 or an empty network).
pub(crate) fn out_exp(net: &Network<'_>) -> i8 {
    net.layers().last().map_or(0, |l| l.out_exp())
}
