//! The reference sine is fully specified by `weights/FORMAT.md`, section
//! "The reference sine (`libm`)": [`spec::sinf`] below is written from that
//! section alone (it does not call `libm`) and must give the same bits as
//! `gpecnet_core::LibmSine` (`libm::sinf`, libm 0.2.16) for every input.
//!
//! - `matches_libm_on_a_grid_of_minus_8_to_8`: every f32 with
//!   2^−12 ≤ |x| ≤ 8 (252 million), every 61st below (where the result is
//!   `x`), and every bit pattern within 4096 of each branch threshold;
//! - `matches_libm_on_random_bit_patterns`: 4 million uniformly random bit
//!   patterns (every exponent: about 40 % take the large-argument path), and
//!   checks that they reach every branch of the large reduction;
//! - `matches_libm_on_special_inputs`: ±0, every subnormal, NaNs, ±∞,
//!   powers of two, and the f32 nearest to k·π/2 for k < 2^18 (hardest
//!   medium reductions) with neighbours;
//! - `differs_from_correctly_rounded_rarely`: the measured rate recorded in
//!   FORMAT.md and `core/src/sine.rs`;
//! - `musl_directed_rounding_fixup_never_fires`: why musl's newer
//!   `__rem_pio2f` gives the same bits;
//! - `large_reduction_reads_at_most_digit_8` (ignored, ~1 min in release):
//!   every input of the large reduction, every branch of it reached;
//! - `matches_libm_on_every_f32` (ignored, ~7 min with 2 threads in
//!   release): all 2^32 bit patterns.
//!
//! NaN results are compared as "both NaN": the NaN's sign and payload are not
//! part of the contract (x86-64 and Arm produce different default NaNs).

use gpecnet_core::{LibmSine, Sine};
use gpecnet_tests::SplitMix64;

/// The specification of `weights/FORMAT.md`, transcribed.
mod spec {
    /// Digits of 2/π: digit i is bits 24i+1 ..= 24i+24 after the binary point.
    pub const TWO_OVER_PI: [u32; 20] = [
        0xA2F983, 0x6E4E44, 0x1529FC, 0x2757D1, 0xF534DD, 0xC0DB62, 0x95993C, 0x439041, 0xFE5163,
        0xABDEBB, 0xC561B7, 0x246E3A, 0x424DD2, 0xE00649, 0x2EEA09, 0xD1921C, 0xFE1DEB, 0x1CB129,
        0xA73EE8, 0x8235F5,
    ];
    /// π/2 in 24-bit pieces P0..P3.
    const PIO2_PIECES: [u64; 4] = [
        0x3FF9_21FB_4000_0000,
        0x3E74_442D_0000_0000,
        0x3CF8_4698_8000_0000,
        0x3B78_CC51_6000_0000,
    ];

    fn c(bits: u64) -> f64 {
        f64::from_bits(bits)
    }

    /// 2^e, exact, for −1022 ≤ e ≤ 1023.
    fn pow2(e: i32) -> f64 {
        f64::from_bits(((e + 1023) as u64) << 52)
    }

    /// The sine kernel S, |x| ≲ π/4.
    pub fn s(x: f64) -> f32 {
        let s1 = c(0xBFC5_5555_54CB_AC77);
        let s2 = c(0x3F81_1110_896E_FBB2);
        let s3 = c(0xBF2A_00F9_E2CA_E774);
        let s4 = c(0x3EC6_CD87_8C3B_46A7);
        let z = x * x;
        let w = z * z;
        let r = s3 + z * s4;
        let s = z * x;
        ((x + s * (s1 + z * s2)) + s * w * r) as f32
    }

    /// The cosine kernel C, |x| ≲ π/4.
    pub fn c_(x: f64) -> f32 {
        let c0 = c(0xBFDF_FFFF_FD0C_5E81);
        let c1 = c(0x3FA5_5553_E105_3A42);
        let c2 = c(0xBF56_C087_E80F_1E27);
        let c3 = c(0x3EF9_9342_E0EE_5069);
        let z = x * x;
        let w = z * z;
        let r = c2 + z * c3;
        (((1.0 + z * c0) + w * c1) + (w * z) * r) as f32
    }

    /// Which branches of the large reduction one call took (test coverage).
    pub mod trace {
        pub const RECOMPUTE: u32 = 1;
        pub const Q0_POS: u32 = 2;
        pub const Q0_ZERO: u32 = 4;
        pub const Q0_NEG: u32 = 8;
        pub const IH1: u32 = 16;
        pub const IH2: u32 = 32;
        pub const IH2_BORROW: u32 = 64;
        pub const TOP_NONZERO: u32 = 128;
        pub const ALL: u32 = 255;
    }

    /// The large reduction for |x| = m·2^e0: (n mod 8, y, branches taken,
    /// largest 2/π digit index read).
    pub fn reduce_large(m: u32, e0: i32) -> (i32, f64, u32, usize) {
        let m = f64::from(m);
        let jv = ((e0 - 3) / 24) as usize;
        let mut q0 = e0 - 24 * (jv as i32 + 1);
        let mut jz = 3usize;
        let mut q = [0.0f64; 20];
        let mut iq = [0i32; 20];
        let mut tr = 0;
        for (i, qi) in q.iter_mut().enumerate().take(jz + 1) {
            *qi = m * f64::from(TWO_OVER_PI[jv + i]);
        }
        let (two24, twom24) = (pow2(24), pow2(-24));
        let (mut n, mut z, ih);
        loop {
            // carry-propagate into 24-bit digits, least significant first
            z = q[jz];
            for j in (1..=jz).rev() {
                let hi = f64::from((z * twom24) as i32);
                iq[jz - j] = (z - two24 * hi) as i32;
                z = q[j - 1] + hi;
            }
            // integer part mod 8
            z *= pow2(q0);
            z -= 8.0 * (z * 0.125).floor();
            n = z as i32;
            z -= f64::from(n);
            let mut h = 0;
            if q0 > 0 {
                tr |= trace::Q0_POS;
                let i = iq[jz - 1] >> (24 - q0);
                n += i;
                iq[jz - 1] -= i << (24 - q0);
                h = iq[jz - 1] >> (23 - q0);
            } else if q0 == 0 {
                tr |= trace::Q0_ZERO;
                h = iq[jz - 1] >> 23;
            } else {
                tr |= trace::Q0_NEG;
                if z >= 0.5 {
                    h = 2;
                }
            }
            if h > 0 {
                tr |= if h == 1 { trace::IH1 } else { trace::IH2 };
                n += 1;
                let mut borrow = false;
                for d in iq.iter_mut().take(jz) {
                    if borrow {
                        *d = 0xFF_FFFF - *d;
                    } else if *d != 0 {
                        borrow = true;
                        *d = 0x100_0000 - *d;
                    }
                }
                if q0 == 1 {
                    iq[jz - 1] &= 0x7F_FFFF;
                } else if q0 == 2 {
                    iq[jz - 1] &= 0x3F_FFFF;
                }
                if h == 2 {
                    z = 1.0 - z;
                    if borrow {
                        tr |= trace::IH2_BORROW;
                        z -= pow2(q0);
                    }
                }
            }
            if z == 0.0 && iq[3..jz].iter().all(|&d| d == 0) {
                tr |= trace::RECOMPUTE;
                let mut k = 1;
                while iq[3 - k] == 0 {
                    k += 1;
                }
                for (i, qi) in q.iter_mut().enumerate().take(jz + k + 1).skip(jz + 1) {
                    *qi = m * f64::from(TWO_OVER_PI[jv + i]);
                }
                jz += k;
                continue;
            }
            ih = h;
            break;
        }
        let max_index = jv + jz;
        if z == 0.0 {
            jz -= 1;
            q0 -= 24;
            while iq[jz] == 0 {
                jz -= 1;
                q0 -= 24;
            }
        } else {
            tr |= trace::TOP_NONZERO;
            z *= pow2(-q0);
            assert!(q0 < 0 && z < pow2(21));
            iq[jz] = z as i32;
        }
        let mut w = pow2(q0);
        for i in (0..=jz).rev() {
            q[i] = w * f64::from(iq[i]);
            w *= twom24;
        }
        let mut fq = [0.0f64; 20];
        for i in (0..=jz).rev() {
            let mut acc = 0.0;
            for (k, &p) in PIO2_PIECES.iter().enumerate().take(3.min(jz - i) + 1) {
                acc += c(p) * q[i + k];
            }
            fq[jz - i] = acc;
        }
        let mut y = 0.0;
        for &f in fq[..=jz].iter().rev() {
            y += f;
        }
        (n & 7, if ih == 0 { y } else { -y }, tr, max_index)
    }

    pub fn sinf(x: f32) -> f32 {
        let b = x.to_bits();
        let a = b & 0x7FFF_FFFF;
        let neg = b >> 31 == 1;
        let d = f64::from(x);
        let pio2 = c(0x3FF9_21FB_5444_2D18);
        let pi = c(0x4009_21FB_5444_2D18);
        let pi3o2 = c(0x4012_D97C_7F33_21D2);
        let pi2 = c(0x4019_21FB_5444_2D18);
        if a < 0x3980_0000 {
            return x;
        }
        if a <= 0x3F49_0FDA {
            return s(d);
        }
        if a <= 0x4016_CBE3 {
            return if neg { -c_(d + pio2) } else { c_(d - pio2) };
        }
        if a <= 0x407B_53D1 {
            return s(if neg { -(d + pi) } else { -(d - pi) });
        }
        if a <= 0x40AF_EDDF {
            return if neg { c_(d + pi3o2) } else { -c_(d - pi3o2) };
        }
        if a <= 0x40E2_31D5 {
            return s(if neg { d + pi2 } else { d - pi2 });
        }
        if a >= 0x7F80_0000 {
            return f32::NAN;
        }
        let (n, y) = if a < 0x4DC9_0FDB {
            let toint = c(0x4338_0000_0000_0000);
            let t = d * c(0x3FE4_5F30_6DC9_C883) + toint;
            let k = t - toint;
            let y = (d - k * c(0x3FF9_21FB_5000_0000)) - k * c(0x3E51_10B4_611A_6263);
            (k as i32, y)
        } else {
            let (n, y, _, _) = reduce_large((a & 0x7F_FFFF) | 0x80_0000, (a >> 23) as i32 - 150);
            if neg {
                (-n, -y)
            } else {
                (n, y)
            }
        };
        match n & 3 {
            0 => s(y),
            1 => c_(y),
            2 => s(-y),
            _ => -c_(y),
        }
    }
}

fn same(a: f32, b: f32) -> bool {
    a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan())
}

/// Checks `bits`, returning how many disagreed (printing the first few).
fn check(bits: impl Iterator<Item = u32>) -> (u64, u64) {
    let (mut n, mut bad) = (0u64, 0u64);
    for b in bits {
        let x = f32::from_bits(b);
        let (r, m) = (LibmSine::sin(x), spec::sinf(x));
        n += 1;
        if !same(r, m) {
            bad += 1;
            if bad <= 5 {
                eprintln!(
                    "x = {x:e} ({b:#010x}): libm {:#010x}, spec {:#010x}",
                    r.to_bits(),
                    m.to_bits()
                );
            }
        }
    }
    (n, bad)
}

/// Bit patterns of the branch thresholds of the specification.
const THRESHOLDS: [u32; 8] = [
    0x3980_0000,
    0x3F49_0FDA,
    0x4016_CBE3,
    0x407B_53D1,
    0x40AF_EDDF,
    0x40E2_31D5,
    0x4DC9_0FDB,
    0x7F80_0000,
];

#[test]
fn matches_libm_on_a_grid_of_minus_8_to_8() {
    // Every bit pattern of 2^-12 ≤ |x| ≤ 8; every 61st below (returned unchanged).
    let tiny = (0..0x3980_0000u32).step_by(61);
    let grid = tiny
        .chain(0x3980_0000..=8.0f32.to_bits())
        .flat_map(|b| [b, b | 0x8000_0000]);
    let near = THRESHOLDS.iter().flat_map(|&t| {
        (t.saturating_sub(4096)..t.saturating_add(4096).min(0x7F80_0001))
            .flat_map(|b| [b, b | 0x8000_0000])
    });
    let (n, bad) = check(grid.chain(near));
    assert_eq!(bad, 0, "{bad} of {n} differ");
    assert!(n > 280_000_000);
}

#[test]
fn matches_libm_on_random_bit_patterns() {
    let mut rng = SplitMix64(11);
    let bits: Vec<u32> = (0..4_000_000).map(|_| rng.next_u64() as u32).collect();
    let (n, bad) = check(bits.iter().copied());
    assert_eq!(bad, 0, "{bad} of {n} differ");
    // The sample reaches every branch of the large reduction, and never
    // reads past digit 8 of 2/π.
    let (mut seen, mut max_index, mut large) = (0, 0, 0);
    for &b in &bits {
        let a = b & 0x7FFF_FFFF;
        if (0x4DC9_0FDB..0x7F80_0000).contains(&a) {
            let (_, _, tr, i) =
                spec::reduce_large((a & 0x7F_FFFF) | 0x80_0000, (a >> 23) as i32 - 150);
            seen |= tr;
            max_index = max_index.max(i);
            large += 1;
        }
    }
    assert!(large > 1_500_000, "{large}");
    assert_eq!(seen, spec::trace::ALL, "branches seen: {seen:#b}");
    assert!(max_index <= 8, "{max_index}");
}

#[test]
fn matches_libm_on_special_inputs() {
    // ±0 keep their sign; NaN and ±∞ give NaN.
    assert_eq!(LibmSine::sin(0.0).to_bits(), 0);
    assert_eq!(LibmSine::sin(-0.0).to_bits(), 0x8000_0000);
    assert_eq!(spec::sinf(-0.0).to_bits(), 0x8000_0000);
    for x in [f32::NAN, -f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
        assert!(LibmSine::sin(x).is_nan() && spec::sinf(x).is_nan());
    }
    // Every subnormal (returned unchanged), NaN payloads, the extremes.
    let subnormals = (0..0x80_0000u32).flat_map(|b| [b, b | 0x8000_0000]);
    let nans = [
        0x7F80_0001u32,
        0x7FC0_0000,
        0x7FFF_FFFF,
        0xFFC0_0000,
        0xFF80_0001,
    ];
    let extremes = [f32::MAX, f32::MIN, f32::MIN_POSITIVE, f32::EPSILON].map(f32::to_bits);
    // Every power of two and its neighbours.
    let powers = (1..255u32).flat_map(|e| {
        let p = e << 23;
        [p - 1, p, p + 1]
            .into_iter()
            .flat_map(|b| [b, b | 0x8000_0000])
    });
    // The f32 nearest k·π/2 (and ±3 ulps) for k < 2^18: the arguments the
    // medium reduction cancels most on.
    let near_pio2 = (1..1u32 << 18).flat_map(|k| {
        let b = ((k as f64) * std::f64::consts::FRAC_PI_2) as f32;
        (b.to_bits() - 3..=b.to_bits() + 3).flat_map(|b| [b, b | 0x8000_0000])
    });
    let (n, bad) = check(
        subnormals
            .chain(nans)
            .chain(extremes)
            .chain(powers)
            .chain(near_pio2),
    );
    assert_eq!(bad, 0, "{bad} of {n} differ");
}

/// How often `libm::sinf` differs from the correctly rounded sine.
///
/// The correctly rounded value is the f64 sine rounded to f32; samples whose
/// f64 sine lies within 4 f64 ulps of a midpoint between two f32 (where that
/// rounding could be wrong) are skipped and counted.
#[test]
fn differs_from_correctly_rounded_rarely() {
    let mut rng = SplitMix64(2024);
    for (lo, hi, expect) in [
        (
            -std::f64::consts::FRAC_PI_4,
            std::f64::consts::FRAC_PI_4,
            0.00004,
        ),
        (-8.0, 8.0, 0.0003),
        (-200.0, 200.0, 0.0003),
    ] {
        let n = 4_000_000u32;
        let (mut differ, mut ambiguous, mut worst) = (0u32, 0u32, 0.0f64);
        for _ in 0..n {
            let x = rng.uniform(lo, hi) as f32;
            let e = f64::from(x).sin();
            let r = LibmSine::sin(x);
            // error in units of the f32 spacing at |r|
            let ulp = f64::from(f32::from_bits(r.abs().to_bits() + 1) - r.abs());
            worst = worst.max((f64::from(r) - e).abs() / ulp);
            let cr = e as f32;
            let up = f64::from(f32::from_bits(cr.abs().to_bits() + 1));
            let down = f64::from(f32::from_bits(cr.abs().to_bits() - 1));
            let mid = if e.abs() >= f64::from(cr.abs()) {
                (f64::from(cr.abs()) + up) / 2.0
            } else {
                (f64::from(cr.abs()) + down) / 2.0
            };
            if (e.abs() - mid).abs() <= 4.0 * f64::EPSILON * e.abs() {
                ambiguous += 1;
            } else if r.to_bits() != cr.to_bits() {
                differ += 1;
            }
        }
        let rate = f64::from(differ) / f64::from(n);
        eprintln!(
            "[{lo:.4}, {hi}]: {differ} of {n} ({:.4} %) differ from correctly rounded, \
             {ambiguous} undecided, max error {worst:.4} ulp",
            rate * 100.0
        );
        assert!(rate > expect * 0.5 && rate < expect * 1.5, "{rate}");
        assert!(ambiguous < 20, "{ambiguous}");
        // Faithful, and never worse than half an ulp by much.
        assert!(worst < 0.501, "{worst}");
    }
}

#[test]
#[ignore = "all 2^32 inputs: ~7 min with 2 threads in release"]
fn matches_libm_on_every_f32() {
    let threads = std::thread::available_parallelism().map_or(2, |n| n.get()) as u64;
    let bad: u64 = std::thread::scope(|s| {
        let handles: Vec<_> = (0..threads)
            .map(|t| {
                s.spawn(move || {
                    let lo = (t << 32) / threads;
                    let hi = ((t + 1) << 32) / threads;
                    check((lo..hi).map(|b| b as u32)).1
                })
            })
            .collect();
        handles.into_iter().map(|h| h.join().unwrap()).sum()
    });
    assert_eq!(bad, 0);
}

#[test]
#[ignore = "all 834 million |x| ≥ 421657440: ~1 min in release"]
fn large_reduction_reads_at_most_digit_8() {
    let threads = std::thread::available_parallelism().map_or(2, |n| n.get()) as u32;
    let (lo, hi) = (0x4DC9_0FDBu32, 0x7F80_0000u32);
    let (max_index, seen) = std::thread::scope(|s| {
        let handles: Vec<_> = (0..threads)
            .map(|t| {
                s.spawn(move || {
                    let (mut max_index, mut seen) = (0, 0);
                    for a in (lo + t..hi).step_by(threads as usize) {
                        let (_, _, tr, i) =
                            spec::reduce_large((a & 0x7F_FFFF) | 0x80_0000, (a >> 23) as i32 - 150);
                        max_index = max_index.max(i);
                        seen |= tr;
                    }
                    (max_index, seen)
                })
            })
            .collect();
        handles
            .into_iter()
            .map(|h| h.join().unwrap())
            .fold((0, 0), |(m, s), (i, t)| (m.max(i), s | t))
    });
    assert_eq!(seen, spec::trace::ALL);
    assert_eq!(max_index, 8);
}

/// Newer musl redoes the medium reduction with n ∓ 1 when |y| > pio4
/// (`0x1.921fb6p-1`), for directed rounding; in round-to-nearest that never
/// happens for an f32 (all 432 million medium-path inputs are checked), so
/// musl's `sinf` equals this one.
#[test]
fn musl_directed_rounding_fixup_never_fires() {
    let pio4 = f64::from(f32::from_bits(0x3F49_0FDB));
    let fired = (0x40E2_31D6u32..0x4DC9_0FDB)
        .flat_map(|b| [b, b | 0x8000_0000])
        .filter(|&b| {
            let d = f64::from(f32::from_bits(b));
            let toint = f64::from_bits(0x4338_0000_0000_0000);
            let k = (d * f64::from_bits(0x3FE4_5F30_6DC9_C883) + toint) - toint;
            let y = (d - k * f64::from_bits(0x3FF9_21FB_5000_0000))
                - k * f64::from_bits(0x3E51_10B4_611A_6263);
            y.abs() > pio4
        })
        .count();
    assert_eq!(fired, 0);
}
