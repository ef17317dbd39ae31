//! The latent sampler: a seedable PRNG and a Gaussian transform, specified
//! exactly so that any implementation (the trainer's, a Python script's, the
//! firmware's) reproduces the same latent vectors bit for bit.
//!
//! # Specification
//!
//! 1. **Seeding** — SplitMix64 (Steele, Lea, Flood 2014). With a 64-bit state
//!    `x` initialised to the caller's `seed`, each call does
//!    `x += 0x9E3779B97F4A7C15; z = x; z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9;`
//!    `z = (z ^ (z >> 27)) * 0x94D049BB133111EB; return z ^ (z >> 31)` (all
//!    wrapping). Two calls give `a` then `b`; the xoshiro state is
//!    `s = [a as u32, (a >> 32) as u32, b as u32, (b >> 32) as u32]`. (An
//!    all-zero state, which no known seed produces, is replaced by `[1, 0, 0, 0]`.)
//! 2. **Generator** — xoshiro128++ 1.0 (Blackman, Vigna 2019), 32-bit output:
//!    `r = rotl(s0 + s3, 7) + s0; t = s1 << 9; s2 ^= s0; s3 ^= s1; s1 ^= s2;`
//!    `s0 ^= s3; s2 ^= t; s3 = rotl(s3, 11); return r`.
//! 3. **Uniforms** — from one output `r`: `u_open = ((r >> 8) + 1) · 2^-24`
//!    in (0, 1] and `u_half = (r >> 8) · 2^-24` in [0, 1). Both are exact in f32.
//! 4. **Normals** — Box–Muller in f32, two normals per pair of outputs
//!    `(r1, r2)`, drawn in that order: `u1 = u_open(r1)`, `t = u_half(r2)`,
//!    `ρ = sqrt(-2 · ln(u1))` with [`crate::math::ln`] and a correctly rounded
//!    square root, then `n0 = ρ · cos_turns(t)` and `n1 = ρ · sin_turns(t)`
//!    ([`crate::math`]), each product rounded once. `n0` is returned first;
//!    `n1` is kept and returned by the next call. `-2 · ln(u1)` is computed as
//!    `-(ln(u1) + ln(u1))`, exact.
//! 5. **Latents** — sample `j` of a prediction with seed `s` uses a fresh
//!    sampler seeded with `s`; its latent `z` is the next `zdim` normals, each
//!    multiplied by the model's `sigma` (`z_i = sigma · n`), sample after sample.
//!
//! # Reference sequence
//!
//! From the raw state `[1, 2, 3, 4]` xoshiro128++ yields
//! `641, 1573767, 3222811527, 3517856514, 836907274, 4247214768, 3867114732, 1355841295`
//! (the first two are the published reference values). SplitMix64 from 0 yields
//! `0xe220a8397b1dcdaf, 0x6e789e6aa1b965f4, 0x06c45d188009454f`. Seed 42 gives the
//! state `[0x2feb6e95, 0xbdd73226, 0xb266f103, 0x28efe333]` and the outputs
//! `2643743425, 1762251840, 1632151183, 1417845339, 3326664244, 3989346982`.
//!
//! ```
//! use gpecnet_core::prng::{Xoshiro128PlusPlus, Gaussian};
//! let mut g = Xoshiro128PlusPlus::from_state([1, 2, 3, 4]);
//! assert_eq!(g.next_u32(), 641);
//! let mut n = Gaussian::new(42);
//! let z = n.next(); // a standard normal draw, identical on every target
//! assert!(z.is_finite());
//! ```

use crate::math;

/// SplitMix64, used only to expand a 64-bit seed into xoshiro state.
#[derive(Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SplitMix64 {
    state: u64,
}

impl SplitMix64 {
    /// Starts from `seed`.
    pub const fn new(seed: u64) -> Self {
        Self { state: seed }
    }

    /// Next 64-bit output.
    pub fn next_u64(&mut self) -> u64 {
        self.state = self.state.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.state;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
}

/// xoshiro128++ 1.0: 128-bit state, 32-bit outputs, period 2^128 - 1.
#[derive(Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Xoshiro128PlusPlus {
    s: [u32; 4],
}

impl Xoshiro128PlusPlus {
    /// Seeds the state through [`SplitMix64`] as the module docs specify.
    pub fn seed_from_u64(seed: u64) -> Self {
        let mut sm = SplitMix64::new(seed);
        let a = sm.next_u64();
        let b = sm.next_u64();
        Self::from_state([a as u32, (a >> 32) as u32, b as u32, (b >> 32) as u32])
    }

    /// Uses `s` as the raw state (an all-zero state becomes `[1, 0, 0, 0]`).
    pub const fn from_state(s: [u32; 4]) -> Self {
        if s[0] == 0 && s[1] == 0 && s[2] == 0 && s[3] == 0 {
            Self { s: [1, 0, 0, 0] }
        } else {
            Self { s }
        }
    }

    /// The raw state.
    pub const fn state(&self) -> [u32; 4] {
        self.s
    }

    /// Next 32-bit output.
    pub fn next_u32(&mut self) -> u32 {
        let s = &mut self.s;
        let r = s[0].wrapping_add(s[3]).rotate_left(7).wrapping_add(s[0]);
        let t = s[1] << 9;
        s[2] ^= s[0];
        s[3] ^= s[1];
        s[1] ^= s[2];
        s[0] ^= s[3];
        s[2] ^= t;
        s[3] = s[3].rotate_left(11);
        r
    }

    /// Uniform in (0, 1], a multiple of 2^-24.
    pub fn next_open01(&mut self) -> f32 {
        (((self.next_u32() >> 8) + 1) as f32) * (1.0 / 16_777_216.0)
    }

    /// Uniform in [0, 1), a multiple of 2^-24.
    pub fn next_half_open01(&mut self) -> f32 {
        ((self.next_u32() >> 8) as f32) * (1.0 / 16_777_216.0)
    }
}

/// Standard normal draws by Box–Muller (see the module docs for the exact
/// recipe). Deterministic and identical on every IEEE-754 target.
#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Gaussian {
    rng: Xoshiro128PlusPlus,
    spare: Option<f32>,
}

impl Gaussian {
    /// A sampler seeded with `seed`.
    pub fn new(seed: u64) -> Self {
        Self {
            rng: Xoshiro128PlusPlus::seed_from_u64(seed),
            spare: None,
        }
    }

    /// Next N(0, 1) draw.
    #[allow(clippy::should_implement_trait)]
    pub fn next(&mut self) -> f32 {
        if let Some(v) = self.spare.take() {
            return v;
        }
        let [c, s] = self.box_muller();
        self.spare = Some(s);
        c
    }

    /// [`Gaussian::next`], out of line: for a caller that also inlines
    /// [`Gaussian::next_pair`] (the engine's odd last latent element), so
    /// that the Box–Muller step is not inlined twice there.
    #[inline(never)]
    pub(crate) fn next_alone(&mut self) -> f32 {
        self.next()
    }

    /// The next two draws of the stream, `[next(), next()]` (the same
    /// values in the same order, the same state afterwards), without the
    /// spare's store and reload when no spare is pending (the engine draws
    /// its even-length latent vectors this way).
    pub fn next_pair(&mut self) -> [f32; 2] {
        match self.spare.take() {
            None => self.box_muller(),
            Some(v) => {
                let [c, s] = self.box_muller();
                self.spare = Some(s);
                [v, c]
            }
        }
    }

    /// One Box–Muller step: `[ρ·cos 2πt, ρ·sin 2πt]` from two fresh uniforms
    /// (the first is returned first, the second becomes the spare).
    #[inline(always)]
    fn box_muller(&mut self) -> [f32; 2] {
        let u1 = self.rng.next_open01();
        let t = self.rng.next_half_open01();
        // u1 in [2^-24, 1] is normal and t in [0, 1): the guard-free forms
        // of `ln`, `sin_turns` and `cos_turns(t) = sin_turns(t + 1/4)`,
        // which give the same bits there.
        let l = math::ln_normal(u1);
        let rho = math::sqrt(-(l + l));
        [
            rho * math::sin_turns_small(t + 0.25),
            rho * math::sin_turns_small(t),
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn next_pair_is_two_nexts() {
        // Pairs at both parities of the stream (a single `next` between
        // pairs leaves a spare pending), against one `next` per draw.
        let (mut a, mut b) = (Gaussian::new(7), Gaussian::new(7));
        for round in 0..2_000 {
            if round % 3 == 1 {
                assert_eq!(a.next().to_bits(), b.next().to_bits());
            }
            let [p0, p1] = a.next_pair();
            assert_eq!(p0.to_bits(), b.next().to_bits());
            assert_eq!(p1.to_bits(), b.next().to_bits());
            assert_eq!(a, b);
        }
    }

    #[test]
    fn xoshiro_reference_sequence() {
        let mut g = Xoshiro128PlusPlus::from_state([1, 2, 3, 4]);
        let want = [
            641u32, 1573767, 3222811527, 3517856514, 836907274, 4247214768, 3867114732, 1355841295,
        ];
        for w in want {
            assert_eq!(g.next_u32(), w);
        }
    }

    #[test]
    fn splitmix_reference_sequence() {
        let mut s = SplitMix64::new(0);
        assert_eq!(s.next_u64(), 0xe220a8397b1dcdaf);
        assert_eq!(s.next_u64(), 0x6e789e6aa1b965f4);
        assert_eq!(s.next_u64(), 0x06c45d188009454f);
    }

    #[test]
    fn seeded_reference_sequence() {
        let mut g = Xoshiro128PlusPlus::seed_from_u64(42);
        assert_eq!(g.state(), [0x2feb6e95, 0xbdd73226, 0xb266f103, 0x28efe333]);
        for w in [
            2643743425u32,
            1762251840,
            1632151183,
            1417845339,
            3326664244,
            3989346982,
        ] {
            assert_eq!(g.next_u32(), w);
        }
    }

    #[test]
    fn zero_state_is_replaced() {
        let mut g = Xoshiro128PlusPlus::from_state([0; 4]);
        assert_ne!(g.next_u32() | g.next_u32(), 0);
    }

    #[test]
    fn uniform_ranges() {
        let mut g = Xoshiro128PlusPlus::seed_from_u64(7);
        for _ in 0..10_000 {
            let a = g.next_open01();
            assert!(a > 0.0 && a <= 1.0);
            let b = g.next_half_open01();
            assert!((0.0..1.0).contains(&b));
        }
    }

    #[test]
    fn gaussian_moments() {
        let mut g = Gaussian::new(1234);
        let n = 200_000;
        let (mut s1, mut s2, mut s4) = (0.0f64, 0.0f64, 0.0f64);
        for _ in 0..n {
            let v = g.next() as f64;
            assert!(v.is_finite());
            s1 += v;
            s2 += v * v;
            s4 += v * v * v * v;
        }
        let mean = s1 / n as f64;
        let var = s2 / n as f64 - mean * mean;
        let kurt = s4 / n as f64 / (var * var);
        assert!(mean.abs() < 0.01, "mean {mean}");
        assert!((var - 1.0).abs() < 0.01, "var {var}");
        assert!((kurt - 3.0).abs() < 0.05, "kurtosis {kurt}");
    }

    #[test]
    fn gaussian_first_pair_follows_spec() {
        // Recompute the first pair by the spec, step by step.
        let mut r = Xoshiro128PlusPlus::seed_from_u64(42);
        let u1 = (((r.next_u32() >> 8) + 1) as f32) / 16_777_216.0;
        let t = ((r.next_u32() >> 8) as f32) / 16_777_216.0;
        let rho = libm::sqrtf(-2.0 * math::ln(u1));
        let mut g = Gaussian::new(42);
        assert_eq!(g.next().to_bits(), (rho * math::cos_turns(t)).to_bits());
        assert_eq!(g.next().to_bits(), (rho * math::sin_turns(t)).to_bits());
    }
}
