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
    /// `x[l] = sin(x[l])` for every lane: the same bits as [`Sine::sin`]
    /// lane by lane (the batched path, [`crate::batch`]). The default calls
    /// [`Sine::sin`] per lane; [`LibmSine`] overrides it with a branch-free
    /// form that LLVM vectorises across lanes.
    #[inline]
    fn sin_lanes<const L: usize>(x: &mut [f32; L]) {
        for v in x.iter_mut() {
            *v = Self::sin(*v);
        }
    }
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
    /// When every lane is below `2^28·π/2` in magnitude (the case of every
    /// SIREN pre-activation): `libm::sinf`'s algorithm written without
    /// branches (each case's reduced argument and both f64 kernels computed,
    /// the right one selected by bit masks), so the lanes vectorise — and
    /// when every lane is at most `9π/4` (nearly every call of the shipped
    /// models), without the medium reduction's work; otherwise
    /// `libm::sinf` lane by lane. The same bits as `libm::sinf`
    /// either way (`sine::tests::lanes_equal_libm_sampled`, and
    /// `lanes_equal_libm_all` over every f32). Always inlined, so that it
    /// takes the vector width of its caller (`crate::kernels`).
    #[inline(always)]
    fn sin_lanes<const L: usize>(x: &mut [f32; L]) {
        if x.iter().any(|v| v.to_bits() & 0x7fff_ffff >= MEDIUM_LIMIT) {
            for v in x.iter_mut() {
                *v = libm::sinf(*v);
            }
            return;
        }
        if x.iter().all(|v| v.to_bits() & 0x7fff_ffff <= SMALL_LIMIT) {
            // Every SIREN layer of the shipped models, nearly always.
            for v in x.iter_mut() {
                *v = libm_sinf_small(*v);
            }
            return;
        }
        for v in x.iter_mut() {
            *v = libm_sinf_medium(*v);
        }
    }
}

/// `|x|` bits from which `libm::sinf` reduces with Payne–Hanek (`2^28·π/2`;
/// infinities and NaN above it too).
const MEDIUM_LIMIT: u32 = 0x4dc9_0fdb;

/// The largest `|x|` bits that `libm::sinf` reduces by a fixed multiple of
/// `π/2` (`9π/4` rounded down; above it the medium reduction).
const SMALL_LIMIT: u32 = 0x40e2_31d5;

/// Thresholds on `|x|` of `libm::sinf`'s cases (libm compares the bits of
/// `|x|`; for finite `x` the order of the bits is the order of the values):
/// `π/4`, `3π/4`, `5π/4`, `7π/4`, `9π/4`.
const T_PIO4: f64 = f32::from_bits(0x3f49_0fda) as f64;
/// See [`T_PIO4`].
const T_3PIO4: f64 = f32::from_bits(0x4016_cbe3) as f64;
/// See [`T_PIO4`].
const T_5PIO4: f64 = f32::from_bits(0x407b_53d1) as f64;
/// See [`T_PIO4`].
const T_7PIO4: f64 = f32::from_bits(0x40af_eddf) as f64;
/// See [`T_PIO4`].
const T_9PIO4: f64 = f32::from_bits(SMALL_LIMIT) as f64;
/// `1·π/2` … `4·π/2` in f64, libm's `s1pio2` … `s4pio2`.
const S1_PIO2: f64 = core::f64::consts::FRAC_PI_2;
/// See [`S1_PIO2`].
const S2_PIO2: f64 = 2. * core::f64::consts::FRAC_PI_2;
/// See [`S1_PIO2`].
const S3_PIO2: f64 = 3. * core::f64::consts::FRAC_PI_2;
/// See [`S1_PIO2`].
const S4_PIO2: f64 = 4. * core::f64::consts::FRAC_PI_2;

/// [`libm_sinf_medium`] for `|x| ≤ 9π/4` (bits ≤ [`SMALL_LIMIT`]; larger
/// `x` give wrong values): the same cases, with the reduced argument formed
/// once instead of per case. Case `k` = the number of thresholds `π/4`,
/// `3π/4`, `5π/4`, `7π/4` that `|x|` exceeds; `y = x − copysign(k·π/2, x)`,
/// which is libm's `x ∓ k·π/2` operation for operation (`a − (−b)` is
/// `a + b` exactly, and `k = 0` gives `x`: `x − 0 = x`; the one difference,
/// `−0 − (−0) = +0`, is below `2^-12`, where `x` itself is returned);
/// negated for `k = 2` (libm's `k_sinf(−(x ± π))`); the cosine kernel for
/// odd `k`, negated for `x < 0` at `k = 1` and for `x > 0` at `k = 3`.
#[inline(always)]
fn libm_sinf_small(x: f32) -> f32 {
    let x64 = x as f64;
    let ax = if x64 < 0.0 { -x64 } else { x64 };
    let mn = mask(x64 < 0.0);
    let (c1, c2, c3, c4) = (
        mask(ax <= T_PIO4),
        mask(ax <= T_3PIO4),
        mask(ax <= T_5PIO4),
        mask(ax <= T_7PIO4),
    );
    let kpio2 = pick(
        c1,
        0.0,
        pick(c2, S1_PIO2, pick(c3, S2_PIO2, pick(c4, S3_PIO2, S4_PIO2))),
    );
    let y = x64 - f64::from_bits(kpio2.to_bits() | (x64.to_bits() & SIGN));
    let k2 = c3 & !c2;
    let y = f64::from_bits(y.to_bits() ^ (k2 & SIGN));
    let k1 = c2 & !c1;
    let k3 = c4 & !c3;
    let use_cos = k1 | k3;
    let negate = (k1 & mn) | (k3 & !mn);
    sinf_tail(x, y, use_cos, negate)
}

/// `libm::sinf` (libm 0.2.16, FreeBSD's `s_sinf.c`) for `|x| < 2^28·π/2`,
/// written without branches: every case's reduced argument is computed and
/// the right one selected, then both kernels (`k_sinf`, `k_cosf`, the same
/// f64 polynomials in the same order) and the result selected and signed.
/// The cases, by `|x|` bits `ix`: below `2^-12` `x` itself; up to `π/4`
/// `k_sinf(x)`; up to `3π/4` `∓k_cosf(x ± π/2)`; up to `5π/4`
/// `k_sinf(−(x ± π))`; up to `7π/4` `±k_cosf(x ± 3π/2)`; up to `9π/4`
/// `k_sinf(x ± 2π)`; beyond, `n = rint(x·2/π)` (the `1.5·2^52` trick),
/// `y = x − n·P1 − n·P1T` and quadrant `n mod 4` picks `k_sinf(y)`,
/// `k_cosf(y)`, `k_sinf(−y)` or `−k_cosf(y)`.
#[inline(always)]
fn libm_sinf_medium(x: f32) -> f32 {
    const TOINT: f64 = 1.5 / f64::EPSILON;
    const INV_PIO2: f64 = f64::from_bits(0x3fe4_5f30_6dc9_c883);
    const PIO2_1: f64 = f64::from_bits(0x3ff9_21fb_5000_0000);
    const PIO2_1T: f64 = f64::from_bits(0x3e51_10b4_611a_6263);
    let x64 = x as f64;
    let ax = if x64 < 0.0 { -x64 } else { x64 };
    let neg = x64 < 0.0;
    // Medium reduction (`rem_pio2f`): n = rint(x·2/π) sits in the low bits
    // of `tmp` (|n| < 2^28), `f_n` = n exactly.
    let tmp = x64 * INV_PIO2 + TOINT;
    let f_n = tmp - TOINT;
    let nb = tmp.to_bits();
    let y_med = x64 - f_n * PIO2_1 - f_n * PIO2_1T;
    // Quadrant 2 (`k_sinf(-y)`): n & 3 == 2.
    let q2 = mask(nb & 3 == 2);
    let y_med = f64::from_bits(y_med.to_bits() ^ (q2 & SIGN));
    // The small multiples of π/2, sign-dependent.
    let mn = mask(neg);
    let y1 = pick(mn, x64 + S1_PIO2, x64 - S1_PIO2);
    let y2 = pick(mn, -(x64 + S2_PIO2), -(x64 - S2_PIO2));
    let y3 = pick(mn, x64 + S3_PIO2, x64 - S3_PIO2);
    let y4 = pick(mn, x64 + S4_PIO2, x64 - S4_PIO2);
    let (c1, c2, c3, c4, c5) = (
        mask(ax <= T_PIO4),
        mask(ax <= T_3PIO4),
        mask(ax <= T_5PIO4),
        mask(ax <= T_7PIO4),
        mask(ax <= T_9PIO4),
    );
    // Innermost case first: the first true threshold wins.
    let y = pick(
        c1,
        x64,
        pick(c2, y1, pick(c3, y2, pick(c4, y3, pick(c5, y4, y_med)))),
    );
    let odd = mask(nb & 1 == 1);
    let q3 = mask(nb & 3 == 3);
    let all = u64::MAX;
    let use_cos = pick_bits(
        c1,
        0,
        pick_bits(
            c2,
            all,
            pick_bits(c3, 0, pick_bits(c4, all, pick_bits(c5, 0, odd))),
        ),
    );
    let negate = pick_bits(
        c1,
        0,
        pick_bits(
            c2,
            mn,
            pick_bits(c3, 0, pick_bits(c4, !mn, pick_bits(c5, 0, q3))),
        ),
    );
    sinf_tail(x, y, use_cos, negate)
}

/// The end of [`libm_sinf_medium`] and [`libm_sinf_small`]: both kernels on
/// the reduced argument `y` (libm's `k_sinf.rs`, `k_cosf.rs`: the same f64
/// polynomials in the same order), the cosine where `use_cos` is all ones,
/// negated where `negate` is, rounded once to f32; `x` itself where
/// `|x| < 2^-12`.
#[inline(always)]
fn sinf_tail(x: f32, y: f64, use_cos: u64, negate: u64) -> f32 {
    // The kernels' coefficients (libm's `k_sinf.rs` S1..S4, `k_cosf.rs` C0..C3).
    const KS3: f64 = f64::from_bits(0xbf2a00f9e2cae774); // -0.000198393348360966317347
    const KS4: f64 = f64::from_bits(0x3ec6cd878c3b46a7); // 0.0000027183114939898219064
    const KS1: f64 = f64::from_bits(0xbfc5555554cbac77); // -0.166666666416265235595
    const KS2: f64 = f64::from_bits(0x3f811110896efbb2); // 0.0083333293858894631756
    const KC2: f64 = f64::from_bits(0xbf56c087e80f1e27); // -0.00138867637746099294692
    const KC3: f64 = f64::from_bits(0x3ef99342e0ee5069); // 0.0000243904487962774090654
    const KC0: f64 = f64::from_bits(0xbfdffffffd0c5e81); // -0.499999997251031003120
    const KC1: f64 = f64::from_bits(0x3fa55553e1053a42); // 0.0416666233237390631894
    const TINY: f32 = f32::from_bits(0x3980_0000);
    // k_sinf and k_cosf (libm's `k_sinf.rs`, `k_cosf.rs`), both, in f64.
    let z = y * y;
    let w = z * z;
    let r = KS3 + z * KS4;
    let s = z * y;
    let sin = (y + s * (KS1 + z * KS2)) + s * w * r;
    let rc = KC2 + z * KC3;
    let cos = ((1.0 + z * KC0) + w * KC1) + (w * z) * rc;
    // Selecting and negating before the rounding to f32 gives the same bits
    // (rounding to nearest is symmetric).
    let v = pick(use_cos, cos, sin);
    let v = f64::from_bits(v.to_bits() ^ (negate & SIGN)) as f32;
    let tiny = ((x.abs() < TINY) as u32).wrapping_neg();
    f32::from_bits((x.to_bits() & tiny) | (v.to_bits() & !tiny))
}

/// The sign bit of an f64.
const SIGN: u64 = 1 << 63;

/// All ones for `true`, 0 for `false`.
#[inline(always)]
fn mask(c: bool) -> u64 {
    (c as u64).wrapping_neg()
}

/// `a` where `m` is all ones, `b` where it is 0 (bitwise).
#[inline(always)]
fn pick_bits(m: u64, a: u64, b: u64) -> u64 {
    (a & m) | (b & !m)
}

/// [`pick_bits`] on f64s.
#[inline(always)]
fn pick(m: u64, a: f64, b: f64) -> f64 {
    f64::from_bits(pick_bits(m, a.to_bits(), b.to_bits()))
}

// Each sine is its own zero-sized type implementing `Sine` (its `NAME` and
// `sin`), so the derive and impl frame of `LibmSine` repeats here.
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

    /// Bit patterns `start, start + step, …` of one sign, through
    /// `sin_lanes` 8 at a time, against `libm::sinf`.
    fn lanes_vs_libm(start: u32, step: u32, end: u32) {
        let mut b = start;
        while b < end {
            let mut x = [0.0f32; 8];
            for (l, v) in x.iter_mut().enumerate() {
                *v = f32::from_bits(b.wrapping_add(l as u32 * step));
            }
            let mut y = x;
            LibmSine::sin_lanes(&mut y);
            for (a, v) in x.iter().zip(y) {
                let want = libm::sinf(*a);
                assert!(
                    want.to_bits() == v.to_bits() || (want.is_nan() && v.is_nan()),
                    "{a:e} ({:#x}): {v:e} != {want:e}",
                    a.to_bits()
                );
            }
            b = b.saturating_add(8 * step);
        }
    }

    #[test]
    fn lanes_equal_libm_sampled() {
        // Every 97th pattern of both signs (inf/NaN and Payne–Hanek
        // included: they take the scalar fallback), and densely around the
        // case boundaries.
        lanes_vs_libm(0, 97, 0x7fff_ffff);
        lanes_vs_libm(0x8000_0000, 97, 0xffff_ffff);
        for edge in [
            0x3980_0000u32,
            0x3f49_0fda,
            0x4016_cbe3,
            0x407b_53d1,
            0x40af_eddf,
            0x40e2_31d5,
            0x4dc9_0fdb,
        ] {
            for sign in [0, 0x8000_0000] {
                lanes_vs_libm((edge - 5000) | sign, 1, (edge + 5000) | sign);
            }
        }
    }

    #[test]
    fn small_path_equals_libm() {
        // `libm_sinf_small` directly, every 61st pattern up to 9π/4 of both
        // signs, and every pattern around its case thresholds.
        let check = |b: u32| {
            let x = f32::from_bits(b);
            let (want, got) = (libm::sinf(x), libm_sinf_small(x));
            assert_eq!(want.to_bits(), got.to_bits(), "{x:e} ({b:#x})");
        };
        for sign in [0, 0x8000_0000u32] {
            (0..=SMALL_LIMIT).step_by(61).for_each(|b| check(b | sign));
            for edge in [
                0x3980_0000u32,
                0x3f49_0fda,
                0x4016_cbe3,
                0x407b_53d1,
                0x40af_eddf,
            ] {
                (edge - 20_000..=edge + 20_000).for_each(|b| check(b | sign));
            }
            (SMALL_LIMIT - 20_000..=SMALL_LIMIT).for_each(|b| check(b | sign));
        }
    }

    /// Every f32 (1–8 minutes): `cargo test -p gpecnet-core --release --lib lanes_equal_libm_all -- --ignored`.
    #[test]
    #[ignore]
    fn lanes_equal_libm_all() {
        lanes_vs_libm(0, 1, 0x7fff_ffff);
        lanes_vs_libm(0x8000_0000, 1, 0xffff_ffff);
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
