//! Sine implementations for the SIREN activation `sin(W x + b)`.
//!
//! The predictor is generic over [`Sine`], resolved at compile time (no
//! function pointers, no dynamic dispatch). A model's golden vectors are
//! produced with one of them, so pick the same one on the device:
//!
//! | type | accuracy | cost on a Cortex-M4F | bit-reproducible across targets |
//! |---|---|---|---|
//! | [`LibmSine`] (reference) | faithfully rounded, max error 0.5009 ulp; *not* correctly rounded: differs from the correctly rounded sine on ~0.03 % of arguments uniform in [−8, 8] (FreeBSD/musl `sinf`, `libm` 0.2.16) | ~1,400 instructions: evaluates in f64, which the M4F emulates | yes (IEEE f64 operations only; specified bit for bit in `weights/FORMAT.md`) |
//! | [`FastSine`] | < 4e-7 absolute for \|x\| ≤ 200 (measured by `sine::tests`) | ~20 single-precision FPU instructions | yes (fixed evaluation order, f32 only) |
//! | `MicromathSine` (feature `micromath`) | ~1e-3 absolute (micromath's approximation) | ~30 instructions | yes for the same micromath version |
//! | [`crate::fixed::sin_q15`] (fixed-point blobs only; phase in turns, u32) | 3.10e-5 absolute (1.02 Q15 LSB) over all 2^26 distinct inputs (`core/tests/fixed_sine.rs`) | integer only, no FPU; not yet profiled with `cargo xtask profile` | yes (integer) |
//!
//! The reference is an algorithm, not "the" sine: a correctly rounded `sinf`
//! does not reproduce golden vectors made with [`LibmSine`]. The algorithm
//! (range-reduction branches, polynomial kernels, evaluation order,
//! Payne–Hanek path) is specified exactly in `weights/FORMAT.md`, section
//! "The reference sine (`libm`)", and `tests/tests/sine_spec.rs` checks a
//! re-implementation written from that text against [`LibmSine`] bit for bit.
//!
//! ```
//! use gpecnet_core::sine::{FastSine, LibmSine, Sine};
//! let x = 1.0f32;
//! assert!((FastSine::sin(x) - LibmSine::sin(x)).abs() < 1e-6);
//! ```

use crate::math;

/// A sine function usable as the SIREN activation.
pub trait Sine {
    /// A short name used in model cards and logs.
    const NAME: &'static str;
    /// `sin(x)` for `x` in radians; NaN for non-finite `x`.
    fn sin(x: f32) -> f32;
}

/// The reference: `libm::sinf` from the `libm` crate 0.2.16 (pinned with
/// `=0.2.16`), a port of FreeBSD's / musl's `sinf`.
///
/// Range reduction by π/2 in f64 (one multiple of π/2 up to 9π/4, two-term
/// Cody–Waite below 2^28·π/2, Payne–Hanek above), then a degree-9 odd
/// (sine) or degree-8 even (cosine) polynomial evaluated in f64 and rounded
/// once to f32. Faithfully rounded (largest error observed 0.5009 ulp) but
/// not correctly rounded: about 0.03 % of arguments uniform in [−200, 200]
/// differ from the correctly rounded sine by one ulp. Specified bit for bit,
/// for re-implementation, in `weights/FORMAT.md` ("The reference sine
/// (`libm`)"). NaN for ±∞ and NaN (sign and payload unspecified).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct LibmSine;

impl Sine for LibmSine {
    const NAME: &'static str = "libm";
    #[inline]
    fn sin(x: f32) -> f32 {
        libm::sinf(x)
    }
}

/// Single-precision sine with a fixed evaluation order.
///
/// Cody–Waite range reduction: `n = round(x / 2π)`, `r = (x − n·H) − n·L`
/// where `H = 6.28125` (8 significant bits, so `n·H` is exact for |n| < 2^16)
/// and `L = 2π − H` in f32; then `sin_turns(r · 1/2π)` ([`math::sin_turns`]).
/// For |x| ≥ 2^16·2π the reduction falls back to `sin_turns(x · 1/2π)`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FastSine;

impl Sine for FastSine {
    const NAME: &'static str = "fast-f32";
    #[inline]
    fn sin(x: f32) -> f32 {
        const H: f32 = 6.281_25;
        const L: f32 = 1.935_307_2e-3;
        let t = x * math::INV_TWO_PI;
        if t.is_nan() || t.abs() >= 65_536.0 {
            return math::sin_turns(t);
        }
        let n = math::round_ties_even(t);
        let r = (x - n * H) - n * L;
        math::sin_turns(r * math::INV_TWO_PI)
    }
}

/// micromath's approximate sine (`F32Ext::sin`).
#[cfg(feature = "micromath")]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct MicromathSine;

#[cfg(feature = "micromath")]
impl Sine for MicromathSine {
    const NAME: &'static str = "micromath";
    #[inline]
    fn sin(x: f32) -> f32 {
        if !x.is_finite() {
            return f32::NAN;
        }
        micromath::F32Ext::sin(x)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn max_err<S: Sine>(lo: f32, hi: f32, n: u32) -> f64 {
        let mut worst = 0.0f64;
        for k in 0..n {
            let x = lo + (hi - lo) * (k as f32) / (n as f32);
            let err = (S::sin(x) as f64 - libm::sin(x as f64)).abs();
            if err > worst {
                worst = err;
            }
        }
        worst
    }

    #[test]
    fn libm_is_accurate() {
        assert!(max_err::<LibmSine>(-100.0, 100.0, 100_000) < 1.0e-7);
    }

    #[test]
    fn fast_sine_accuracy_over_siren_range() {
        // SIREN pre-activations (w0 = 30 folded in) stay well within ±200.
        let e = max_err::<FastSine>(-200.0, 200.0, 400_000);
        assert!(e < 4.0e-7, "max error {e}");
        let e = max_err::<FastSine>(-7.0, 7.0, 100_000);
        assert!(e < 4.0e-7, "max error {e}");
    }

    #[test]
    fn non_finite_gives_nan() {
        for x in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
            assert!(LibmSine::sin(x).is_nan());
            assert!(FastSine::sin(x).is_nan());
        }
    }

    #[cfg(feature = "micromath")]
    #[test]
    fn micromath_is_close() {
        assert!(max_err::<MicromathSine>(-50.0, 50.0, 100_000) < 2.0e-3);
    }
}
