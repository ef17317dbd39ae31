//! The boundaries of the networks: f32 to fixed point ([`quantize`]) and
//! back ([`dequantize`]), through exact powers of two ([`pow2`], the blob's
//! own: its validation scales by it too).

use crate::blob::pow2;

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
