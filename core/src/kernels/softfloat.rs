//! IEEE 754 single-precision multiply, add and subtract in integer
//! arithmetic, for cores without an FPU (Cortex-M0/M0+, `thumbv6m-none-eabi`):
//! the `softfloat` feature exports them as `__aeabi_fmul`, `__aeabi_fadd` and
//! `__aeabi_fsub`, the symbols LLVM calls for every `f32` multiply, add and
//! subtract on such a core.
//!
//! compiler-builtins' routines are written for every float width at once:
//! its multiply forms the 48-bit significand product with a 64 × 64-bit
//! multiply (`__aeabi_lmul`, itself a call on a core whose `MULS` keeps only
//! the low 32 bits), and both handle zeros, subnormals, infinities and NaN on
//! every call. [`mul_normal`] and [`add_normal`] cover the common case only
//! (normal operands, a normal result; for the add also an exact zero) in
//! 32-bit arithmetic, and return `None` for everything else, which the
//! exports hand to compiler-builtins' `__mulsf3` and `__addsf3`. Both sides
//! round to nearest, ties to even, so the result is the same bits either
//! way: the golden replay on the Cortex-M0 and the host test against the
//! host's FPU check it (`docs/kernels.md`: 15.5 % fewer instructions in the
//! M0's f32 golden replay).
//!
//! compiler-builtins defines its intrinsics with weak linkage so that a
//! program can replace them; these definitions are strong and win. The
//! feature is off by default: a program that brings its own `__aeabi_fmul`
//! (or add, subtract) would otherwise fail to link with two definitions.

/// Bits of the significand field.
const FRAC: u32 = 0x007F_FFFF;
/// The implicit leading one of a normal number's significand.
const HIDDEN: u32 = 0x0080_0000;

/// `a × b` of two `f32` given as bits, rounded to nearest (ties to even),
/// when both are normal and so is the rounded product; `None` otherwise
/// (a zero, subnormal, infinite or NaN operand; a product that underflows
/// below the smallest normal or overflows).
///
/// Arithmetic, in order: the exponent fields `ea`, `eb` (1..=254), the
/// significands with their hidden bit `ma`, `mb` (24 bits each), their
/// 48-bit product `p = ma × mb` from 16-bit halves (`a1 < 2^8`, `a0 < 2^16`:
/// `p = (a1·b1 << 32) + ((a1·b0 + a0·b1) << 16) + a0·b0`, every partial
/// product fits 32 bits), kept as `top = p >> 16` (32 bits: the sum
/// `(a1·b1 << 16) + (a1·b0 + a0·b1) + (a0·b0 >> 16)`) and whether any of
/// `p`'s low 16 bits is set (sticky); `top` shifted left by one when below
/// `2^31` (the exponent one lower), so that its top 24 bits are the
/// significand and the rest, with the sticky bit, the remainder; the
/// significand incremented when the remainder is above half, or exactly half
/// with the significand odd; the exponent field
/// `ea + eb - 126` (or `- 127` after the shift), checked to be at least 1
/// before rounding; the result `(exponent - 1) << 23` plus the significand
/// (its hidden bit carries into the exponent, as does a rounding overflow to
/// `2^24`), checked to stay below the infinity exponent 255; the sign
/// `(a ^ b)` bit 31 on top.
#[inline]
pub(crate) fn mul_normal(a: u32, b: u32) -> Option<u32> {
    let ea = (a << 1) >> 24;
    let eb = (b << 1) >> 24;
    // 0 (zero, subnormal) and 255 (infinity, NaN) both fail `e - 1 < 254`.
    if ea.wrapping_sub(1) >= 254 || eb.wrapping_sub(1) >= 254 {
        return None;
    }
    let ma = (a & FRAC) | HIDDEN;
    let mb = (b & FRAC) | HIDDEN;
    let (a1, a0) = (ma >> 16, ma & 0xFFFF);
    let (b1, b0) = (mb >> 16, mb & 0xFFFF);
    let low = a0 * b0;
    let mid = a1 * b0 + a0 * b1;
    let high = a1 * b1;
    // p >> 16 (p < 2^48: fits 32 bits); the 16 bits below only as "any set".
    let mut top = (high << 16) + mid + (low >> 16);
    let sticky = (low & 0xFFFF != 0) as u32;
    // ea + eb <= 508: the sums below stay in i32.
    let mut exp = (ea + eb) as i32 - 126;
    if top < 1 << 31 {
        top <<= 1;
        exp -= 1;
    }
    if exp < 1 {
        return None;
    }
    // The sticky bit in the remainder's lowest bit: exactly half only when it is 0.
    top |= sticky;
    let mut sig = top >> 8;
    // Round half to even: carries out of the eight remainder bits when they
    // are above 0x80, or exactly 0x80 with the significand odd.
    sig += ((top & 0xFF) + 0x7F + (sig & 1)) >> 8;
    let mag = ((exp as u32 - 1) << 23) + sig;
    if mag >= 0x7F80_0000 {
        return None;
    }
    Some(mag | (((a ^ b) >> 31) << 31))
}

/// `a + b` of two `f32` given as bits, rounded to nearest (ties to even),
/// when both are normal and the sum is normal or an exact zero; `None`
/// otherwise (a zero, subnormal, infinite or NaN operand; a sum that
/// underflows below the smallest normal or overflows).
///
/// Arithmetic, in order: `x` the operand of larger magnitude, `y` the other
/// (their exponent fields `ex >= ey`, 1..=254); both significands with their
/// hidden bit shifted left by six (bit 29 the leading one, six bits below
/// the last significand bit); `y`'s shifted right by `d = ex - ey`, the bits
/// it loses ORed into its lowest bit (sticky; `d >= 30` leaves just that
/// bit); same signs: the sum, shifted right by one (sticky again) and the
/// exponent one higher when it reaches bit 30; different signs: the
/// difference (`+0` when zero), shifted left until bit 29 leads and the
/// exponent lowered as much, checked to be at least 1; the significand the
/// sum's top 24 bits, incremented when the six bits below are above half, or
/// exactly half with the significand odd; the result `(exponent - 1) << 23`
/// plus the significand, checked to stay below the infinity exponent 255;
/// `x`'s sign on top.
#[inline]
pub(crate) fn add_normal(a: u32, b: u32) -> Option<u32> {
    // Magnitudes compared without the sign bit.
    let (x, y) = if b << 1 > a << 1 { (b, a) } else { (a, b) };
    let ex = (x << 1) >> 24;
    let ey = (y << 1) >> 24;
    // ex >= ey: y is zero or subnormal when ey is 0, x infinite or NaN when ex is 255.
    if ey == 0 || ex == 255 {
        return None;
    }
    let mx = ((x << 8) | 0x8000_0000) >> 2;
    let mut my = ((y << 8) | 0x8000_0000) >> 2;
    let d = ex - ey;
    if d >= 30 {
        my = 1;
    } else if d > 0 {
        let lost = my << (32 - d) != 0;
        my = (my >> d) | lost as u32;
    }
    let mut exp = ex as i32;
    let mut sum;
    if (x ^ y) >> 31 == 0 {
        sum = mx + my;
        if sum >> 30 != 0 {
            sum = (sum >> 1) | (sum & 1);
            exp += 1;
        }
    } else {
        sum = mx - my;
        if sum >> 29 == 0 {
            // Cancellation: one bit when d >= 2, any number when d <= 1 (then exact).
            if sum >> 28 != 0 {
                sum <<= 1;
                exp -= 1;
            } else if sum == 0 {
                return Some(0);
            } else {
                let shift = sum.leading_zeros() - 2;
                sum <<= shift;
                exp -= shift as i32;
            }
            if exp < 1 {
                return None;
            }
        }
    }
    let mut sig = sum >> 6;
    // Round half to even: carries out of the six remainder bits when they are
    // above 0x20, or exactly 0x20 with the significand odd.
    sig += ((sum & 0x3F) + 0x1F + (sig & 1)) >> 6;
    let mag = ((exp as u32 - 1) << 23) + sig;
    if mag >= 0x7F80_0000 {
        return None;
    }
    Some(mag | ((x >> 31) << 31))
}

#[cfg(all(feature = "softfloat", target_arch = "arm", target_os = "none"))]
mod export {
    extern "C" {
        /// compiler-builtins' multiply: every case, including those
        /// [`super::mul_normal`] leaves to it.
        fn __mulsf3(a: f32, b: f32) -> f32;
        /// compiler-builtins' add, for what [`super::add_normal`] leaves to it.
        fn __addsf3(a: f32, b: f32) -> f32;
    }

    /// The `f32` multiply LLVM calls on a core without an FPU: [`super::mul_normal`],
    /// else compiler-builtins' `__mulsf3`.
    #[no_mangle]
    pub extern "aapcs" fn __aeabi_fmul(a: f32, b: f32) -> f32 {
        match super::mul_normal(a.to_bits(), b.to_bits()) {
            Some(bits) => f32::from_bits(bits),
            // SAFETY: `__mulsf3` is compiler-builtins' safe multiply of two
            // `f32` (AAPCS soft-float: arguments and result in r0/r1); it
            // reads no memory and is always linked on this target.
            None => unsafe { __mulsf3(a, b) },
        }
    }

    /// The `f32` add LLVM calls on a core without an FPU: [`super::add_normal`],
    /// else compiler-builtins' `__addsf3`. Not inlined into `__aeabi_fsub`:
    /// one copy of the add in flash.
    #[no_mangle]
    #[inline(never)]
    pub extern "aapcs" fn __aeabi_fadd(a: f32, b: f32) -> f32 {
        match super::add_normal(a.to_bits(), b.to_bits()) {
            Some(bits) => f32::from_bits(bits),
            // SAFETY: as `__mulsf3` above, for compiler-builtins' add.
            None => unsafe { __addsf3(a, b) },
        }
    }

    /// The `f32` subtract LLVM calls on a core without an FPU: `a + (-b)`,
    /// as compiler-builtins' `__subsf3` computes it.
    #[no_mangle]
    pub extern "aapcs" fn __aeabi_fsub(a: f32, b: f32) -> f32 {
        __aeabi_fadd(a, f32::from_bits(b.to_bits() ^ 0x8000_0000))
    }
}

#[cfg(test)]
mod tests {
    use super::{add_normal, mul_normal};

    /// Marsaglia's xorshift64 (shifts 13, 7, 17): random operand bits for
    /// the comparison below. Local because the kernels sit below `prng`
    /// (whose normals use `math`, which uses the kernels' square root).
    struct XorShift64(u64);

    impl XorShift64 {
        fn next_u64(&mut self) -> u64 {
            let mut x = self.0;
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            self.0 = x;
            x
        }
    }

    /// `mul_normal` against the host FPU: the same bits whenever it answers,
    /// and an answer whenever operands and product are all normal (except a
    /// product that is normal only by rounding up to the smallest normal: the
    /// exact product was below it, which `mul_normal` leaves to `__mulsf3`).
    fn check(a: u32, b: u32) {
        let want = f32::from_bits(a) * f32::from_bits(b);
        let normal = |x: u32| f32::from_bits(x).is_normal();
        match mul_normal(a, b) {
            Some(bits) => assert_eq!(bits, want.to_bits(), "{a:#010x} * {b:#010x}"),
            None => assert!(
                !(normal(a) && normal(b) && normal(want.to_bits()))
                    || want.abs() == f32::MIN_POSITIVE,
                "{a:#010x} * {b:#010x} = {want:e} left to __mulsf3"
            ),
        }
    }

    /// `add_normal` against the host FPU, as `check` (an exact zero sum is
    /// answered too; a sum that is normal only by rounding cannot occur: sums
    /// of normals below the smallest normal are exact).
    fn check_add(a: u32, b: u32) {
        let want = f32::from_bits(a) + f32::from_bits(b);
        let normal = |x: u32| f32::from_bits(x).is_normal();
        match add_normal(a, b) {
            Some(bits) => assert_eq!(bits, want.to_bits(), "{a:#010x} + {b:#010x}"),
            None => assert!(
                !(normal(a) && normal(b) && (normal(want.to_bits()) || want == 0.0)),
                "{a:#010x} + {b:#010x} = {want:e} left to __addsf3"
            ),
        }
    }

    /// Both operations on one pair.
    fn check_both(a: u32, b: u32) {
        check(a, b);
        check_add(a, b);
    }

    #[test]
    fn matches_the_host_fpu_on_random_and_edge_operands() {
        let mut rng = XorShift64(0x5eed_f10a);
        // Random bit patterns (every exponent, NaN and infinity included), and
        // operands of the magnitudes a model multiplies (|x| in 2^-20..2^4).
        for _ in 0..10_000_000 {
            let r = rng.next_u64();
            check_both(r as u32, (r >> 32) as u32);
            let (x, y) = (r as u32 & 0x81FF_FFFF, (r >> 32) as u32 & 0x81FF_FFFF);
            check_both(x | 0x3600_0000, y | 0x3600_0000);
            // Sums of close magnitudes (cancellation): exponents at most 1 apart.
            check_add(
                x | 0x3F00_0000,
                y ^ 0x8000_0000 | 0x3F00_0000 | (x & 0x0080_0000),
            );
        }
        // Ties and near-ties: significands with few bits set make exact
        // halves in the remainder; exponents at both ends of the normal range.
        let sigs = [
            0, 1, 2, 3, 0x40_0000, 0x40_0001, 0x7F_FFFF, 0x7F_FFFE, 0x00_1000, 0x00_0FFF,
        ];
        let exps = [0, 1, 2, 63, 64, 126, 127, 128, 191, 192, 253, 254, 255];
        for &ea in &exps {
            for &eb in &exps {
                for &sa in &sigs {
                    for &sb in &sigs {
                        let (a, b) = ((ea << 23) | sa, (eb << 23) | sb);
                        check_both(a, b);
                        check_both(a | 0x8000_0000, b);
                        check_both(a, b | 0x8000_0000);
                    }
                }
            }
        }
    }
}
