//! Unit tests of the fixed-point arithmetic: the branch-free `quantize` and
//! the word-table `sin_q15` against their reference forms, and the `Sine`
//! phase steps (of `sine_phase` and of the Cortex-M4/M7 asm loop) against
//! the exact rounding shift.

use super::activation::{rshr, sine_phase};
use super::*;

/// `quantize` as the module docs specify it, with the branches it had
/// before the branch-free form.
fn quantize_ref(x: f32, e: i8) -> i32 {
    let r = crate::math::round_ties_even(x * pow2(e as i32));
    if r.is_nan() {
        0
    } else if r < -32768.0 {
        -32768
    } else if r > 32767.0 {
        32767
    } else {
        r as i32
    }
}

#[test]
fn quantize_matches_reference() {
    let edges = [
        0.0f32,
        -0.0,
        0.5,
        -0.5,
        1.5,
        2.5,
        32766.5,
        32767.0,
        32767.5,
        32768.0,
        -32767.5,
        -32768.0,
        -32768.5,
        -32769.0,
        4_194_303.5,
        4_194_304.0,
        8_388_608.0,
        12_582_912.0,
        f32::MAX,
        f32::MIN_POSITIVE,
        f32::from_bits(1),
        f32::INFINITY,
        f32::NAN,
    ];
    for e in [-20i8, -3, 0, 7, 12, 15, 30] {
        for &x in &edges {
            for v in [
                x,
                -x,
                f32::from_bits(x.to_bits() + 1),
                f32::from_bits(x.to_bits().wrapping_sub(1)),
            ] {
                assert_eq!(quantize(v, e), quantize_ref(v, e), "{v:e} e {e}");
            }
        }
        // A stride through all f32 bit patterns (both signs, every exponent).
        let mut b = 0u32;
        while let Some(n) = b.checked_add(4099) {
            let x = f32::from_bits(b);
            assert_eq!(quantize(x, e), quantize_ref(x, e), "{b:#x} e {e}");
            b = n;
        }
    }
    // Every f32 with 2^13 <= |x| <= 2^16 at e = 0 (around the clamp bounds).
    for b in 0x4600_0000..=0x4780_0000u32 {
        for x in [f32::from_bits(b), -f32::from_bits(b)] {
            assert_eq!(quantize(x, 0), quantize_ref(x, 0), "{x:e}");
        }
    }
}

/// `sin_q15` as specified, with two loads from `QUARTER_SINE` (the same
/// quarter-turn fold, [`super::quarter`]; what differs is the table form).
fn sin_q15_ref(phase: u32) -> i32 {
    let (neg, idx, frac) = super::quarter(phase);
    let (a, b) = match QUARTER_SINE.get(idx..idx + 2) {
        Some(&[a, b]) => (a as i32, b as i32),
        _ => (32768, 32768),
    };
    let v = (a + (((b - a) * frac + 0x8000) >> 16)).min(32767);
    (v ^ neg) - neg
}

#[test]
fn sin_q15_matches_table_form() {
    // Every distinct input (the low 6 bits are ignored), with low bits
    // 0 and 63, and the quadrant edges.
    for k in 0..(1u32 << 26) {
        for ph in [k << 6, (k << 6) | 63] {
            assert_eq!(sin_q15(ph), sin_q15_ref(ph), "{ph:#x}");
        }
    }
    for ph in [0u32, 1 << 30, 1 << 31, 3 << 30, u32::MAX] {
        assert_eq!(sin_q15(ph), sin_q15_ref(ph), "{ph:#x}");
    }
}

/// `rshr` exactly, in `i128`.
fn rshr_ref(a: i64, s: i8) -> i64 {
    if s <= 0 {
        a
    } else {
        ((i128::from(a) + (1i128 << (s - 1))) >> s) as i64
    }
}

/// The phase steps of `kernels::sine_rows_q15` (Cortex-M4/M7 asm), in
/// Rust with the Armv7-M register-shift rule (`LSL`/`LSR` by a register
/// use its low byte; an amount of 32 or more gives 0): for `1 ≤ s ≤
/// 32` `t = lo >> (s − 1)`, `((hi << (32 − s)) | (t >> 1)) + (t & 1)`;
/// for `−31 ≤ s ≤ 0` `lo << −s`; the 64-bit sum first gets the
/// sign-extended i32 bias (`ADDS`/`ADC … ASR #31`).
fn asm_phase(sum: i64, bias: i32, s: i32) -> u32 {
    let lsl = |v: u32, a: i32| {
        let a = (a as u32) & 0xff;
        if a >= 32 {
            0
        } else {
            v << a
        }
    };
    let lsr = |v: u32, a: i32| {
        let a = (a as u32) & 0xff;
        if a >= 32 {
            0
        } else {
            v >> a
        }
    };
    let (lo, c) = (sum as u32).overflowing_add(bias as u32);
    let hi = ((sum >> 32) as u32)
        .wrapping_add((bias >> 31) as u32)
        .wrapping_add(u32::from(c));
    if s > 0 {
        let t = lsr(lo, s - 1);
        (lsl(hi, 32 - s) | (t >> 1)).wrapping_add(t & 1)
    } else {
        lsl(lo, -s)
    }
}

/// The phase step exactly: `a` shifted right by `s` as [`rshr_ref`] does,
/// or left by `−s`, wrapping to `u32`.
fn phase_ref(a: i64, s: i8) -> u32 {
    if s >= 0 {
        rshr_ref(a, s) as u32
    } else {
        (a as u32).wrapping_shl((-(s as i32)) as u32)
    }
}

#[test]
fn sine_rows_phase_steps_match_reference() {
    let mut r = crate::prng::Xoshiro128PlusPlus::seed_from_u64(13);
    let bound = (1i64 << 47) - 1;
    for s in -31i8..=32 {
        let want = |a: i64| phase_ref(a, s);
        let check = |sum: i64, bias: i32| {
            let a = sum + i64::from(bias);
            assert_eq!(
                asm_phase(sum, bias, s.into()),
                want(a),
                "{sum} {bias} s {s}"
            );
            assert_eq!(sine_phase(a, s), want(a), "{sum} {bias} s {s}");
        };
        let h = if s > 0 { 1i64 << (s - 1) } else { 1 };
        let edges = [
            (0i64, 0i32),
            (bound, i32::MAX),
            (-bound, i32::MIN),
            (bound - i64::from(i32::MAX), i32::MAX),
            (-bound - i64::from(i32::MIN), i32::MIN),
            ((1 << 32) - 1, 1),
            (-(1 << 32), -1),
            (-1, 0),
            (0, -1),
            (h, 0),
            (h - 1, 0),
            (-h, 0),
            (-h - 1, 0),
            (h, -1),
        ];
        for (sum, bias) in edges {
            check(sum, bias);
        }
        for _ in 0..20_000 {
            let raw = (u64::from(r.next_u32()) << 32 | u64::from(r.next_u32())) as i64;
            check(raw >> (17 + r.next_u32() % 47), r.next_u32() as i32);
        }
    }
}

#[test]
fn sine_phase_matches_reference() {
    let mut r = crate::prng::Xoshiro128PlusPlus::seed_from_u64(5);
    for s in -31i8..=62 {
        let want = |a: i64| phase_ref(a, s);
        let bound = (1i64 << 47) - 1;
        let mut edges = [
            0i64,
            1,
            -1,
            bound,
            -bound,
            1 << 31,
            -(1 << 31),
            (1 << 32) - 1,
            1 << 32,
        ];
        if s > 0 {
            let h = 1i64 << (s - 1);
            edges[1] = h;
            edges[2] = h - 1;
            edges[3] = -h;
            edges[4] = -h - 1;
        }
        for a in edges {
            assert_eq!(sine_phase(a, s), want(a), "a {a} s {s}");
            assert_eq!(rshr(a, s), rshr_ref(a, s), "a {a} s {s}");
        }
        for _ in 0..20_000 {
            let raw = (u64::from(r.next_u32()) << 32 | u64::from(r.next_u32())) as i64;
            // |a| < 2^47 at every magnitude.
            let a = raw >> (17 + r.next_u32() % 47);
            assert_eq!(sine_phase(a, s), want(a), "a {a} s {s}");
            let act = activate_q(Activation::Sine, a, s);
            assert_eq!(act, sin_q15(want(a)) as i16, "a {a} s {s}");
        }
    }
}
