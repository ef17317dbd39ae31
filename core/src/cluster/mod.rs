//! Test-time sampling: reduce `n` sampled endpoints to `k` representatives
//! by k-means, with a fully specified f32 arithmetic order.
//!
//! Drawing `n > k` latent samples and clustering them into `k` centres (the
//! "test-time sampling trick" of PECNet/Y-Net) covers the endpoint
//! distribution more evenly than `k` raw samples. On a device, call
//! [`crate::Predictor::predict_samples`] with `n` samples, then
//! [`kmeans_reduce`] into a `k`-element buffer.
//!
//! ```
//! use gpecnet_core::cluster::{kmeans_reduce, Init};
//! let samples = [[0.0, 0.0], [10.0, 0.0], [0.0, 1.0], [10.0, 1.0]];
//! let mut centers = [[0.0f32; 2]; 2];
//! kmeans_reduce(&samples, &mut centers, 5, Init::Farthest).unwrap();
//! assert_eq!(centers, [[0.0, 0.5], [10.0, 0.5]]);
//! ```
//!
//! # The computation, in order (bit for bit)
//!
//! All arithmetic is IEEE-754 binary32 with round to nearest (Rust never
//! fuses a multiply and an add). `n = samples.len()`, `k = centers.len()`.
//!
//! 0. **Checks**, in this order; on error `centers` is left untouched:
//!    `k == 0` → [`ClusterError::NoCenters`]; `k > MAX_CENTERS` →
//!    [`ClusterError::TooManyCenters`]; `k > n` →
//!    [`ClusterError::TooFewSamples`]; any sample coordinate NaN or infinite
//!    → [`ClusterError::NonFiniteSample`].
//! 1. **Squared distance** between a sample `s` and a centre `c`:
//!    `d(s, c) = (s[0] - c[0]) * (s[0] - c[0]) + (s[1] - c[1]) * (s[1] - c[1])`:
//!    two subtractions, two products, one addition, evaluated in exactly that
//!    order (each operation rounded to f32).
//! 2. **Initialisation** ([`Init`]):
//!    - [`Init::First`]: `centers[j] = samples[j]` for `j < k`.
//!    - [`Init::Farthest`]: `centers[0] = samples[0]`; for `c = 1 .. k`,
//!      every sample `i` gets `m_i = min_{j < c} d(samples[i], centers[j])`
//!      (the minimum of f32 values, which is exact and independent of the
//!      scan order), and `centers[c] = samples[i*]` with `i*` the lowest
//!      index attaining the largest `m_i` (scan `i = 0 .. n` and replace the
//!      best only on a strict `>`). Duplicate samples can therefore yield
//!      duplicate centres (all `m_i == 0` picks `i* = 0`).
//! 3. **`iters` Lloyd iterations**, each:
//!    - *assign*: sample `i` belongs to the centre `j` with the smallest
//!      `d(samples[i], centers[j])`; scan `j = 0 .. k`, replace the best only
//!      on a strict `<` (ties go to the lowest centre index);
//!    - *update*: for each centre `j` with `count_j >= 1` members,
//!      `sum_x = 0.0; sum_x = sum_x + s[0]` over members in increasing sample
//!      index, likewise `sum_y`; then `centers[j] = [sum_x / (count_j as f32),
//!      sum_y / (count_j as f32)]` (`count_j` converted from an integer to
//!      f32 with round to nearest; exact for `count_j <= 2^24`). A centre with
//!      no member keeps its value. All assignments of an iteration use the
//!      centres of the previous iteration.
//!
//!    `iters == 0` returns the initialisation.
//!
//! ## Exact shortcuts
//!
//! The implementation takes two shortcuts, each provably a no-op on the
//! result (every output bit is the one of the procedure above):
//!
//! - **Early exit.** An iteration is a deterministic function of the centres
//!   it starts from (the samples are fixed, the sums and counts start from
//!   zero). If after an update every centre has exactly the bits it had
//!   before (`to_bits` equal; a centre without members keeps its value by
//!   definition), the next iteration starts from the same bits, so it makes
//!   the same assignment and writes the same centres again, and so does
//!   every later one. The remaining iterations are then skipped. Nothing
//!   else stops early: `iters` is an upper bound that is always reached
//!   unless the centres reached such a fixed point.
//! - **Partial distance.** In the assignment and in the farthest-point
//!   minimum, a centre is skipped as soon as `dx * dx` (with
//!   `dx = s[0] - c[0]`) is not `< best`: then `d(s, c) < best` is false too.
//!   `dy * dy` is `+0` or more (or NaN), and f32 addition with round to
//!   nearest is monotonic, so `d = dx*dx + dy*dy >= dx*dx` unless `d` is
//!   NaN; a NaN in `dx*dx`, `d` or `best` makes both comparisons false. The
//!   distances that are compared are still computed exactly as in step 1.
//!
//! With finite samples of ordinary magnitude everything stays finite. With
//! magnitudes near `f32::MAX` a distance or a sum can overflow to infinity
//! (or a centre become NaN); the procedure above still runs to the end,
//! deterministically and without panicking, and comparisons behave as IEEE
//! `<`/`>` (false on NaN).
//!
//! # Cost and memory
//!
//! Distance evaluations (at most; see *Exact shortcuts*): `n·(k-1)·k/2` for
//! [`Init::Farthest`] (the nearest chosen centre is recomputed rather than
//! stored, since `n` is unbounded and there is no heap), `0` for
//! [`Init::First`], plus `n·k` per iteration that runs.
//! Stack: per-centre sums and counts for [`MAX_CENTERS`] centres,
//! `MAX_CENTERS · (8 + size_of::<usize>())` bytes (768 B on a 32-bit MCU,
//! 1 KiB on a 64-bit host), plus a few scalars. No heap, no `unsafe`, no
//! panics on any input.

/// Largest supported `k` (size of the internal per-centre accumulators).
pub const MAX_CENTERS: usize = 64;

/// How the centres are initialised before the Lloyd iterations.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Init {
    /// `centers = samples[0..k]`: with i.i.d. samples this is a random
    /// initialisation for free.
    First,
    /// Farthest-point: `samples[0]`, then repeatedly the sample farthest from
    /// its nearest chosen centre (ties: lowest index).
    Farthest,
}

/// Why [`kmeans_reduce`] refused its input.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum ClusterError {
    /// `centers` is empty (`k == 0`).
    NoCenters,
    /// `k` exceeds [`MAX_CENTERS`].
    TooManyCenters {
        /// Requested `k`.
        k: usize,
    },
    /// Fewer samples than centres (`n < k`).
    TooFewSamples {
        /// Number of centres `k`.
        k: usize,
        /// Number of samples `n`.
        n: usize,
    },
    /// A sample coordinate is NaN or infinite.
    NonFiniteSample,
}

impl core::fmt::Display for ClusterError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            ClusterError::NoCenters => f.write_str("k-means needs at least one centre"),
            ClusterError::TooManyCenters { k } => {
                write!(f, "k = {k} exceeds the maximum of {MAX_CENTERS} centres")
            }
            ClusterError::TooFewSamples { k, n } => {
                write!(f, "k = {k} centres need at least {k} samples, got {n}")
            }
            ClusterError::NonFiniteSample => f.write_str("non-finite sample coordinate"),
        }
    }
}

impl core::error::Error for ClusterError {}

/// The specified squared distance `(a0 - b0)² + (a1 - b1)²` (module docs, step 1).
#[inline]
pub fn sq_dist(a: [f32; 2], b: [f32; 2]) -> f32 {
    let dx = a[0] - b[0];
    let dy = a[1] - b[1];
    dx * dx + dy * dy
}

/// Index of the centre nearest to `s` (strict `<`, lowest index on ties).
///
/// Centre 0 is always taken first (even if its distance is NaN or `+inf`),
/// then only strictly closer ones, exactly as in step 3 of the module docs.
/// A centre whose `dx²` alone is not `< best_d` is skipped without its `y`
/// part: its full distance could not be `< best_d` either (module docs,
/// *Exact shortcuts*).
#[inline]
fn nearest(s: [f32; 2], centers: &[[f32; 2]]) -> usize {
    let Some((c0, rest)) = centers.split_first() else {
        return 0;
    };
    let mut best = 0;
    let mut best_d = sq_dist(s, *c0);
    for (j, c) in rest.iter().enumerate() {
        let dx = s[0] - c[0];
        let dx2 = dx * dx;
        if dx2 < best_d {
            let dy = s[1] - c[1];
            let d = dx2 + dy * dy;
            if d < best_d {
                best = j + 1;
                best_d = d;
            }
        }
    }
    best
}

/// Smallest distance from `s` to any of `centers` (exact, order-independent
/// for non-NaN distances; `+inf` for an empty slice). Same partial-distance
/// skip as [`nearest`]: the minimum is replaced only on a strict `<`, which a
/// skipped centre cannot satisfy.
#[inline]
fn nearest_dist(s: [f32; 2], centers: &[[f32; 2]]) -> f32 {
    // The same pruned scan as `nearest`, written out again on purpose: this is
    // the k-means' innermost loop, and one shared scan returning an index and a
    // distance cost test-time-sampling models about 5 % more instructions per
    // prediction on the Cortex-M4F (the same bits either way).
    let mut m = f32::INFINITY;
    for c in centers {
        let dx = s[0] - c[0];
        let dx2 = dx * dx;
        if dx2 < m {
            let dy = s[1] - c[1];
            let d = dx2 + dy * dy;
            if d < m {
                m = d;
            }
        }
    }
    m
}

/// Reduces `samples` (`n` points) to `centers.len()` (`k`) k-means centres,
/// written into `centers`, with `iters` Lloyd iterations after the
/// initialisation `init`. The exact arithmetic is in the [module
/// docs](self); the same inputs give the same bits on every target.
///
/// Requires `1 <= k <= min(n, MAX_CENTERS)` and finite samples; otherwise
/// returns the [`ClusterError`] and leaves `centers` untouched.
pub fn kmeans_reduce(
    samples: &[[f32; 2]],
    centers: &mut [[f32; 2]],
    iters: u8,
    init: Init,
) -> Result<(), ClusterError> {
    let (n, k) = (samples.len(), centers.len());
    if k == 0 {
        return Err(ClusterError::NoCenters);
    }
    if k > MAX_CENTERS {
        return Err(ClusterError::TooManyCenters { k });
    }
    if k > n {
        return Err(ClusterError::TooFewSamples { k, n });
    }
    if samples.iter().flatten().any(|v| !v.is_finite()) {
        return Err(ClusterError::NonFiniteSample);
    }

    match init {
        Init::First => {
            for (c, s) in centers.iter_mut().zip(samples) {
                *c = *s;
            }
        }
        Init::Farthest => {
            for c in 1..=k {
                // `chosen` = centres 0 .. c-1 (none yet for c == 1, where every
                // m_i is +inf and the lowest index, 0, wins).
                let (chosen, rest) = centers.split_at_mut(c - 1);
                let mut best = *samples.first().unwrap_or(&[0.0; 2]);
                let mut best_m = f32::NEG_INFINITY;
                for (i, s) in samples.iter().enumerate() {
                    let m = nearest_dist(*s, chosen);
                    if i == 0 || m > best_m {
                        best = *s;
                        best_m = m;
                    }
                }
                if let Some(slot) = rest.first_mut() {
                    *slot = best;
                }
            }
        }
    }

    let mut sums = [[0.0f32; 2]; MAX_CENTERS];
    let mut counts = [0usize; MAX_CENTERS];
    for _ in 0..iters {
        // Only the first k accumulators are ever used (k <= MAX_CENTERS).
        for (s, c) in sums.iter_mut().zip(counts.iter_mut()).take(k) {
            *s = [0.0; 2];
            *c = 0;
        }
        for s in samples {
            let j = nearest(*s, centers);
            if let (Some(sum), Some(count)) = (sums.get_mut(j), counts.get_mut(j)) {
                sum[0] += s[0];
                sum[1] += s[1];
                *count += 1;
            }
        }
        let mut moved = false;
        for ((c, sum), count) in centers.iter_mut().zip(&sums).zip(&counts) {
            if *count > 0 {
                let cf = *count as f32;
                let new = [sum[0] / cf, sum[1] / cf];
                moved |=
                    (new[0].to_bits() != c[0].to_bits()) | (new[1].to_bits() != c[1].to_bits());
                *c = new;
            }
        }
        // A fixed point (same bits in, same bits out): every remaining
        // iteration would reproduce these centres exactly (module docs,
        // *Exact shortcuts*).
        if !moved {
            break;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests;
