//! One output channel's last step (the parent module's docs, step 2): the
//! rounding shift [`rshr`], the phase of a `Sine` channel [`sine_phase`] and
//! the activation [`activate_q`].

use crate::blob::Activation;

use super::sin_q15;

/// `(a + 2^(s−1)) >> s`, or `a` for `s ≤ 0`.
///
/// Computed as `((a >> (s−1)) + 1) >> 1`, which is the same integer
/// (`⌊(a/2^(s−1) + 1)/2⌋ = ⌊(⌊a/2^(s−1)⌋ + 1)/2⌋`) but needs one variable
/// 64-bit shift instead of a variable 64-bit constant, an add and a shift.
#[inline]
pub(super) fn rshr(a: i64, s: i8) -> i64 {
    if s <= 0 {
        a
    } else {
        let t = a >> ((s as u32).min(62) - 1);
        (t + 1) >> 1
    }
}

/// The phase of a `Sine` channel: `rshr(acc, s) mod 2^32` for `s ≥ 0`, else
/// `(acc mod 2^32) · 2^(−s) mod 2^32` (module docs, step 2).
///
/// For `1 ≤ s ≤ 31`: `rshr(acc, s) = ⌊(acc + 2^(s−1)) / 2^s⌋`, which is
/// `⌊acc / 2^s⌋` plus bit `s − 1` of `acc` (adding `2^(s−1)` carries into
/// bit `s` exactly when that bit is set), and only the low 32 bits of
/// `⌊acc / 2^s⌋ = acc >> s` are needed: bits `s .. s + 31` of `acc`, i.e.
/// `(lo >> s) | (hi << (32 − s))` of its two words. Four shifts, an `and`
/// and an add instead of a variable 64-bit shift; `s ≥ 32` takes [`rshr`].
#[inline(always)]
pub(super) fn sine_phase(acc: i64, shift: i8) -> u32 {
    if shift <= 0 {
        (acc as u32).wrapping_shl((-(shift as i32)) as u32)
    } else if shift < 32 {
        let s = shift as u32;
        let (lo, hi) = (acc as u32, (acc >> 32) as u32);
        // Bits s .. s + 31 of acc, plus bit s − 1 (the rounding).
        ((lo >> s) | hi.wrapping_shl(32 - s)).wrapping_add((lo >> (s - 1)) & 1)
    } else {
        rshr(acc, shift) as u32
    }
}

#[doc(hidden)]
/// The activation of one accumulated channel (see the module docs).
#[inline]
pub fn activate_q(act: Activation, acc: i64, shift: i8) -> i16 {
    match act {
        Activation::Linear | Activation::Relu => {
            let v = rshr(acc, shift).clamp(-32768, 32767) as i16;
            if act == Activation::Relu {
                v.max(0)
            } else {
                v
            }
        }
        Activation::Sine => sin_q15(sine_phase(acc, shift)) as i16,
    }
}
