//! Single-precision elementary functions with a **fixed evaluation order**.
//!
//! Every function here uses only IEEE-754 binary32 `+ - * /`, comparisons and
//! bit manipulation, in an order written out in the source. Rust never
//! contracts `a * b + c` into a fused multiply-add on its own, and both x86-64
//! (SSE) and the Cortex-M4F (VFPv4-SP, FZ = 0) round every operation to nearest
//! even, so these functions return the same bits on every target. That is what
//! lets the latent sampler ([`crate::prng`]) and the fast sine
//! ([`crate::sine::FastSine`]) be reproduced bit for bit by the trainer and the
//! firmware. None of them touches `f64`, which a Cortex-M4F would emulate in
//! software.

/// 2π rounded to f32.
pub const TWO_PI: f32 = core::f32::consts::TAU;
/// 1/(2π) rounded to f32.
pub const INV_TWO_PI: f32 = 0.159_154_94;

/// Rounds to the nearest integer, ties to even, for |x| < 2^22; returns `x`
/// unchanged when it is larger (every such f32 is already an integer) or NaN.
#[inline]
pub fn round_ties_even(x: f32) -> f32 {
    // 1.5 * 2^23: adding and subtracting it rounds away the fraction.
    const MAGIC: f32 = 12_582_912.0;
    if x.abs() < 4_194_304.0 {
        (x + MAGIC) - MAGIC
    } else {
        x
    }
}

/// `sin(2π·t)` for a phase `t` in **turns**, any finite `t`.
///
/// Range reduction: `r = t - round(t)` (exact in f32 for |t| < 2^22), then
/// fold `r` into [-1/4, 1/4] by `sin(π - a) = sin(a)`, then the odd Taylor
/// polynomial of degree 11 in `r`, evaluated by Horner's rule on `r²`:
///
/// `r·(C1 + r²·(C3 + r²·(C5 + r²·(C7 + r²·(C9 + r²·C11)))))`
///
/// with `C(2n+1) = (-1)^n (2π)^(2n+1) / (2n+1)!` rounded to f32. The
/// truncation error is below 6e-8 on the folded range; the measured maximum
/// error against f64 `sin` over 2^24 phases is documented in `sine.rs`.
/// Non-finite input gives NaN. For |t| >= 2^22 the phase carries no
/// fractional part and the result is `±0`.
#[inline]
pub fn sin_turns(t: f32) -> f32 {
    if !t.is_finite() {
        return f32::NAN;
    }
    sin_reduced(t - round_ties_even(t))
}

/// [`sin_turns`] for a phase known to satisfy `|t| < 2^22` (finite): the
/// same operations without the two guards, which cannot fire there
/// (`round_ties_even` takes its `(t + M) − M` branch, and a finite `t`
/// needs no NaN check), so the same bits. The latent sampler's phases are
/// in `[0, 1.25]`.
#[inline]
pub(crate) fn sin_turns_small(t: f32) -> f32 {
    // 1.5 * 2^23, as in `round_ties_even`.
    const MAGIC: f32 = 12_582_912.0;
    sin_reduced(t - ((t + MAGIC) - MAGIC))
}

/// The fold and polynomial of [`sin_turns`] for a reduced phase `r`
/// (`|r| ≤ 1/2`).
#[inline(always)]
fn sin_reduced(mut r: f32) -> f32 {
    const C1: f32 = core::f32::consts::TAU;
    const C3: f32 = -41.341_7;
    const C5: f32 = 81.605_25;
    const C7: f32 = -76.705_86;
    const C9: f32 = 42.058_693;
    const C11: f32 = -15.094_643;
    if r > 0.25 {
        r = 0.5 - r;
    } else if r < -0.25 {
        r = -0.5 - r;
    }
    let r2 = r * r;
    r * (C1 + r2 * (C3 + r2 * (C5 + r2 * (C7 + r2 * (C9 + r2 * C11)))))
}

/// `cos(2π·t)` as `sin_turns(t + 1/4)`.
#[inline]
pub fn cos_turns(t: f32) -> f32 {
    sin_turns(t + 0.25)
}

/// Natural logarithm of a positive, finite, normal `x`; NaN for `x <= 0`,
/// non-finite or subnormal input.
///
/// `x = m·2^e` with `m` in [√½, √2), then `ln x = e·ln2 + 2·atanh(s)` with
/// `s = (m-1)/(m+1)` and `atanh(s) = s·(1 + s²/3 + s⁴/5 + s⁶/7 + s⁸/9)`
/// (Horner on `s²`; |s| < 0.172, truncation below 3e-9). `ln 2` is split into
/// a high part exact in f32 and a low part, so `e·LN2_HI` is exact.
#[inline]
pub fn ln(x: f32) -> f32 {
    if x.is_nan() || x < f32::MIN_POSITIVE || !x.is_finite() {
        return f32::NAN;
    }
    ln_normal(x)
}

/// [`ln`] for an `x` known to be positive, finite and normal: the same
/// operations without the guard (which cannot fire there), so the same
/// bits. The latent sampler's `u1` is in `[2^-24, 1]`.
#[inline]
pub(crate) fn ln_normal(x: f32) -> f32 {
    const LN2_HI: f32 = 0.693_145_75; // 0x3f317200: 8 trailing zero bits
    const LN2_LO: f32 = 1.428_606_8e-6;
    const SQRT2: f32 = core::f32::consts::SQRT_2;
    let bits = x.to_bits();
    let mut e = ((bits >> 23) & 0xff) as i32 - 127;
    let mut m = f32::from_bits((bits & 0x007f_ffff) | 0x3f80_0000);
    if m > SQRT2 {
        m *= 0.5;
        e += 1;
    }
    let s = (m - 1.0) / (m + 1.0);
    let s2 = s * s;
    let atanh =
        s * (1.0 + s2 * (0.333_333_34 + s2 * (0.2 + s2 * (0.142_857_15 + s2 * 0.111_111_11))));
    let ef = e as f32;
    (ef * LN2_HI + (atanh + atanh)) + ef * LN2_LO
}

/// Square root, correctly rounded (so identical on every IEEE target):
/// `libm::sqrtf`, or on a Cortex-M4F/M7 the FPU's `VSQRT.F32`, which is
/// correctly rounded too (IEEE 754 requires it of a square root; the same
/// bits for every input `≥ −0`, negative inputs and NaN give a NaN either
/// way). The golden replay on the Cortex-M4F/M7 in QEMU takes a root per
/// pair of latent normals and checks every output bit (`docs/kernels.md`).
#[inline]
pub fn sqrt(x: f32) -> f32 {
    #[cfg(all(target_arch = "arm", target_feature = "dsp", target_feature = "fpregs"))]
    {
        crate::kernels::sqrt_f32(x)
    }
    #[cfg(not(all(target_arch = "arm", target_feature = "dsp", target_feature = "fpregs")))]
    {
        libm::sqrtf(x)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_matches_ties_even() {
        assert_eq!(round_ties_even(0.5), 0.0);
        assert_eq!(round_ties_even(1.5), 2.0);
        assert_eq!(round_ties_even(2.5), 2.0);
        assert_eq!(round_ties_even(-0.5), -0.0);
        assert_eq!(round_ties_even(-1.6), -2.0);
        assert_eq!(round_ties_even(1.0e7), 1.0e7);
        assert!(round_ties_even(f32::NAN).is_nan());
    }

    #[test]
    fn sin_turns_against_f64() {
        let mut worst = 0.0f64;
        let mut k = 0u32;
        while k < 200_000 {
            let t = (k as f32) * 1.0e-4 - 10.0;
            let want = libm::sin(2.0 * core::f64::consts::PI * t as f64);
            let err = (sin_turns(t) as f64 - want).abs();
            if err > worst {
                worst = err;
            }
            k += 1;
        }
        assert!(worst < 2.5e-7, "max error {worst}");
        assert_eq!(sin_turns(0.0), 0.0);
        assert_eq!(sin_turns(0.25), 1.0);
        assert_eq!(sin_turns(-0.25), -1.0);
        assert!(sin_turns(f32::INFINITY).is_nan());
        assert!(sin_turns(f32::NAN).is_nan());
    }

    #[test]
    fn guard_free_forms_match_every_sampler_input() {
        // Every u1 = k · 2^-24 (k = 1 ..= 2^24) and every t = k · 2^-24
        // (k < 2^24) the latent sampler can produce, and t + 1/4 (cos).
        for k in 1..=(1u32 << 24) {
            let u = (k as f32) * (1.0 / 16_777_216.0);
            assert_eq!(ln_normal(u).to_bits(), ln(u).to_bits(), "u {u:e}");
            let t = ((k - 1) as f32) * (1.0 / 16_777_216.0);
            assert_eq!(
                sin_turns_small(t).to_bits(),
                sin_turns(t).to_bits(),
                "t {t:e}"
            );
            let c = t + 0.25;
            assert_eq!(
                sin_turns_small(c).to_bits(),
                cos_turns(t).to_bits(),
                "t {t:e}"
            );
        }
        // And a stride through all finite |t| < 2^22.
        let mut b = 0u32;
        while let Some(n) = b.checked_add(997) {
            let t = f32::from_bits(b);
            if t.abs() < 4_194_304.0 {
                assert_eq!(
                    sin_turns_small(t).to_bits(),
                    sin_turns(t).to_bits(),
                    "t {t:e}"
                );
            }
            b = n;
        }
    }

    #[test]
    fn ln_against_f64() {
        let mut worst = 0.0f64;
        let mut x = 1.0e-30f32;
        while x < 1.0e30 {
            let want = libm::log(x as f64);
            let rel = ((ln(x) as f64 - want) / want.abs().max(1e-3)).abs();
            if rel > worst {
                worst = rel;
            }
            x *= 1.013;
        }
        assert!(worst < 4.0e-7, "max rel error {worst}");
        assert_eq!(ln(1.0), 0.0);
        assert!(ln(0.0).is_nan());
        assert!(ln(-1.0).is_nan());
        assert!(ln(f32::INFINITY).is_nan());
        assert!(ln(f32::from_bits(1)).is_nan());
    }
}
