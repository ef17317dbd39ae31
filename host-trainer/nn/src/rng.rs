//! Seeded, checkpointable random numbers for everything stochastic in training:
//! weight init, epoch shuffling, the CVAE's reparameterisation noise and the
//! validation latents.
//!
//! The generator is ChaCha8 (`rand_chacha`), keyed by `seed` and split into
//! independent `stream`s (see [`streams`]). Its complete state is
//! `(seed, stream, word_pos)`: [`Rng::state`] / [`Rng::from_state`] round-trip it
//! exactly, which is what makes `gpecnet train --resume` bit-identical to an
//! uninterrupted run. No other source of randomness (candle's `randn`,
//! `thread_rng`, ...) is used anywhere in training.
//!
//! All sampling routines are written here (not taken from `rand`'s
//! distributions) so that the sequence of values for a given seed can never
//! change under a dependency upgrade.

use rand_chacha::rand_core::{RngCore, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

/// Stream ids: one independent ChaCha8 stream per purpose, all from the same seed.
pub mod streams {
    /// Weight initialisation.
    pub const INIT: u64 = 1;
    /// Epoch shuffling and the training reparameterisation noise `eps`.
    pub const TRAIN: u64 = 2;
    /// Validation latents: re-created identically at every validation so that
    /// epochs are compared on the same `z` draws.
    pub const VALIDATION: u64 = 3;
}

/// Complete, serialisable state of an [`Rng`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct RngState {
    /// The user seed (expanded to a ChaCha key by `seed_from_u64`).
    pub seed: u64,
    /// ChaCha stream id.
    pub stream: u64,
    /// Position in the key stream, in 32-bit words.
    pub word_pos: u128,
}

/// Seeded ChaCha8 generator with an exactly restorable state.
#[derive(Clone, Debug)]
pub struct Rng {
    seed: u64,
    inner: ChaCha8Rng,
}

impl Rng {
    /// Generator for `seed` on stream 0.
    pub fn new(seed: u64) -> Self {
        Self::with_stream(seed, 0)
    }

    /// Generator for `seed` on an explicit stream (see [`streams`]).
    pub fn with_stream(seed: u64, stream: u64) -> Self {
        let mut inner = ChaCha8Rng::seed_from_u64(seed);
        inner.set_stream(stream);
        Self { seed, inner }
    }

    /// The exact state, for checkpoints.
    pub fn state(&self) -> RngState {
        RngState {
            seed: self.seed,
            stream: self.inner.get_stream(),
            word_pos: self.inner.get_word_pos(),
        }
    }

    /// Restore a generator saved with [`Rng::state`]; it continues the same sequence.
    pub fn from_state(state: &RngState) -> Self {
        let mut r = Self::with_stream(state.seed, state.stream);
        r.inner.set_word_pos(state.word_pos);
        r
    }

    /// Raw 32 random bits.
    pub fn next_u32(&mut self) -> u32 {
        self.inner.next_u32()
    }

    /// Uniform in `[0, 1)` with 24 bits of resolution (exactly representable in f32).
    pub fn unit_f32(&mut self) -> f32 {
        (self.next_u32() >> 8) as f32 * (1.0 / 16_777_216.0)
    }

    /// Uniform in `[lo, hi)`.
    pub fn uniform(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.unit_f32()
    }

    /// Standard normal sample (Box–Muller in f64, one pair of uniforms per sample,
    /// no cached second value so that the state stays `word_pos` only).
    pub fn normal(&mut self) -> f32 {
        // u1 in (0, 1] so that ln(u1) is finite.
        let u1 = ((self.next_u32() as f64) + 1.0) / 4_294_967_296.0;
        let u2 = (self.next_u32() as f64) / 4_294_967_296.0;
        ((-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()) as f32
    }

    /// `n` samples of N(0, std^2).
    pub fn normal_vec(&mut self, n: usize, std: f32) -> Vec<f32> {
        (0..n).map(|_| self.normal() * std).collect()
    }

    /// Uniform integer in `0..n` (`n > 0`), rejection sampling (unbiased).
    pub fn below(&mut self, n: usize) -> usize {
        assert!(n > 0 && n <= u32::MAX as usize, "Rng::below: bad range {n}");
        let n = n as u32;
        let zone = u32::MAX - (u32::MAX - n + 1) % n;
        loop {
            let x = self.next_u32();
            if x <= zone {
                return (x % n) as usize;
            }
        }
    }

    /// In-place Fisher–Yates shuffle.
    pub fn shuffle<T>(&mut self, xs: &mut [T]) {
        for i in (1..xs.len()).rev() {
            let j = self.below(i + 1);
            xs.swap(i, j);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn state_roundtrip_continues_sequence() {
        let mut a = Rng::with_stream(7, streams::TRAIN);
        for _ in 0..13 {
            a.normal();
        }
        let st = a.state();
        let mut b = Rng::from_state(&st);
        let xa: Vec<u32> = (0..100).map(|_| a.next_u32()).collect();
        let xb: Vec<u32> = (0..100).map(|_| b.next_u32()).collect();
        assert_eq!(xa, xb);
    }

    #[test]
    fn streams_differ_and_normal_is_sane() {
        let mut a = Rng::with_stream(7, 1);
        let mut b = Rng::with_stream(7, 2);
        assert_ne!(a.next_u32(), b.next_u32());
        let xs = a.normal_vec(20_000, 1.0);
        let mean: f32 = xs.iter().sum::<f32>() / xs.len() as f32;
        let var: f32 = xs.iter().map(|x| (x - mean) * (x - mean)).sum::<f32>() / xs.len() as f32;
        assert!(mean.abs() < 0.03, "{mean}");
        assert!((var - 1.0).abs() < 0.05, "{var}");
        let mut v: Vec<usize> = (0..50).collect();
        a.shuffle(&mut v);
        let mut s = v.clone();
        s.sort();
        assert_eq!(s, (0..50).collect::<Vec<_>>());
    }
}
