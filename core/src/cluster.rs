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
//!    There is no early exit; `iters == 0` returns the initialisation.
//!
//! With finite samples of ordinary magnitude everything stays finite. With
//! magnitudes near `f32::MAX` a distance or a sum can overflow to infinity
//! (or a centre become NaN); the procedure above still runs to the end,
//! deterministically and without panicking, and comparisons behave as IEEE
//! `<`/`>` (false on NaN).
//!
//! # Cost and memory
//!
//! Distance evaluations: `n·(k-1)·k/2` for [`Init::Farthest`] (the nearest
//! chosen centre is recomputed rather than stored, since `n` is unbounded and
//! there is no heap), `0` for [`Init::First`], plus `n·k` per iteration.
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
#[inline]
fn nearest(s: [f32; 2], centers: &[[f32; 2]]) -> usize {
    let mut best = 0;
    let mut best_d = f32::INFINITY;
    for (j, c) in centers.iter().enumerate() {
        let d = sq_dist(s, *c);
        // The first centre is always taken (even if its distance is NaN or
        // +inf), then only strictly closer ones.
        if j == 0 || d < best_d {
            best = j;
            best_d = d;
        }
    }
    best
}

/// Smallest distance from `s` to any of `centers` (exact, order-independent
/// for non-NaN distances; `+inf` for an empty slice).
#[inline]
fn nearest_dist(s: [f32; 2], centers: &[[f32; 2]]) -> f32 {
    let mut m = f32::INFINITY;
    for c in centers {
        let d = sq_dist(s, *c);
        if d < m {
            m = d;
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
        for (s, c) in sums.iter_mut().zip(counts.iter_mut()) {
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
        for ((c, sum), count) in centers.iter_mut().zip(&sums).zip(&counts) {
            if *count > 0 {
                let cf = *count as f32;
                *c = [sum[0] / cf, sum[1] / cf];
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run(samples: &[[f32; 2]], k: usize, iters: u8, init: Init) -> [[f32; 2]; 8] {
        let mut c = [[f32::NAN; 2]; 8];
        kmeans_reduce(samples, &mut c[..k], iters, init).unwrap();
        c
    }

    #[test]
    fn two_clusters_by_hand() {
        let s = [[0.0, 0.0], [10.0, 0.0], [0.0, 1.0], [10.0, 1.0], [0.0, 2.0]];
        // Farthest: c0 = s0; farthest from (0,0) is s3 (d = 101).
        let c = run(&s, 2, 0, Init::Farthest);
        assert_eq!(&c[..2], &[[0.0, 0.0], [10.0, 1.0]]);
        let c = run(&s, 2, 3, Init::Farthest);
        assert_eq!(&c[..2], &[[0.0, 1.0], [10.0, 0.5]]);
        // First: c0 = (0,0), c1 = (10,0) → same partition.
        let c = run(&s, 2, 1, Init::First);
        assert_eq!(&c[..2], &[[0.0, 1.0], [10.0, 0.5]]);
    }

    #[test]
    fn mean_is_sequential_sum_over_count() {
        // 0.1 + 0.2 + 0.7 in f32 left to right, then / 3.
        let s = [[0.1, 1.0], [0.2, 2.0], [0.7, 4.0]];
        let c = run(&s, 1, 1, Init::First);
        let x = (0.0f32 + 0.1 + 0.2 + 0.7) / 3.0;
        let y = (0.0f32 + 1.0 + 2.0 + 4.0) / 3.0;
        assert_eq!(c[0][0].to_bits(), x.to_bits());
        assert_eq!(c[0][1].to_bits(), y.to_bits());
    }

    #[test]
    fn distance_order() {
        let (a, b) = ([0.3f32, -1.7], [2.9f32, 0.4]);
        let e = (0.3f32 - 2.9) * (0.3 - 2.9) + (-1.7f32 - 0.4) * (-1.7 - 0.4);
        assert_eq!(sq_dist(a, b).to_bits(), e.to_bits());
    }

    #[test]
    fn assignment_ties_go_to_lowest_centre() {
        // Sample (1,0) is equidistant from (0,0) and (2,0): joins centre 0.
        let s = [[0.0, 0.0], [2.0, 0.0], [1.0, 0.0]];
        let c = run(&s, 2, 1, Init::First);
        assert_eq!(&c[..2], &[[0.5, 0.0], [2.0, 0.0]]);
    }

    #[test]
    fn farthest_ties_go_to_lowest_sample() {
        // s1 and s2 are both at d = 4 from s0: s1 is chosen.
        let s = [[0.0, 0.0], [2.0, 0.0], [0.0, 2.0], [1.0, 0.0]];
        let c = run(&s, 2, 0, Init::Farthest);
        assert_eq!(&c[..2], &[[0.0, 0.0], [2.0, 0.0]]);
        // Third centre: m = (0, 0, 4, 1) → s2.
        let c = run(&s, 3, 0, Init::Farthest);
        assert_eq!(&c[..3], &[[0.0, 0.0], [2.0, 0.0], [0.0, 2.0]]);
    }

    #[test]
    fn duplicates_give_duplicate_centres_and_empty_clusters_keep_value() {
        let s = [[1.0, 1.0]; 4];
        let c = run(&s, 3, 0, Init::Farthest);
        assert_eq!(&c[..3], &[[1.0, 1.0]; 3]);
        // All samples join centre 0; centres 1 and 2 are empty and keep their values.
        let s = [[0.0, 0.0], [0.0, 0.0], [5.0, 5.0], [0.0, 0.0]];
        let c = run(&s, 3, 2, Init::First);
        assert_eq!(&c[..3], &[[0.0, 0.0], [0.0, 0.0], [5.0, 5.0]]);
        // Two identical initial centres: every tie goes to centre 0, centre 1
        // has no member and keeps its value (not 0/0 = NaN).
        let s = [[0.0, 0.0], [0.0, 0.0], [1.0, 0.0]];
        let c = run(&s, 2, 1, Init::First);
        assert_eq!(&c[..2], &[[1.0 / 3.0, 0.0], [0.0, 0.0]]);
        // A second iteration splits them: (0,0) is now nearer centre 1.
        let c = run(&s, 2, 2, Init::First);
        assert_eq!(&c[..2], &[[1.0, 0.0], [0.0, 0.0]]);
    }

    #[test]
    fn k_equals_n_is_identity() {
        let s = [[3.0, -1.0], [0.5, 7.25], [-2.0, 2.0], [9.0, 9.0]];
        for init in [Init::First, Init::Farthest] {
            for iters in [0u8, 1, 10] {
                let c = run(&s, 4, iters, init);
                let mut got = [[0.0f32; 2]; 4];
                got.copy_from_slice(&c[..4]);
                if init == Init::First {
                    assert_eq!(got, s);
                } else {
                    // Farthest permutes: the set is the same.
                    for p in s {
                        assert!(got.contains(&p));
                    }
                }
            }
        }
    }

    #[test]
    fn zero_iterations_return_the_initialisation() {
        let s = [[1.0, 2.0], [3.0, 4.0], [5.0, 6.0], [100.0, 0.0]];
        assert_eq!(&run(&s, 2, 0, Init::First)[..2], &s[..2]);
        assert_eq!(
            &run(&s, 2, 0, Init::Farthest)[..2],
            &[[1.0, 2.0], [100.0, 0.0]]
        );
    }

    #[test]
    fn errors_leave_centres_untouched() {
        let s = [[0.0f32, 0.0]; 4];
        let mut none: [[f32; 2]; 0] = [];
        assert_eq!(
            kmeans_reduce(&s, &mut none, 1, Init::First),
            Err(ClusterError::NoCenters)
        );
        let mut c = [[7.0f32; 2]; 5];
        assert_eq!(
            kmeans_reduce(&s, &mut c, 1, Init::First),
            Err(ClusterError::TooFewSamples { k: 5, n: 4 })
        );
        assert_eq!(c, [[7.0; 2]; 5]);
        let big = [[0.0f32; 2]; MAX_CENTERS + 1];
        let mut c = [[7.0f32; 2]; MAX_CENTERS + 1];
        assert_eq!(
            kmeans_reduce(&big, &mut c, 1, Init::Farthest),
            Err(ClusterError::TooManyCenters { k: MAX_CENTERS + 1 })
        );
        let mut c = [[7.0f32; 2]; 2];
        for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
            let s = [[0.0, 0.0], [1.0, bad], [2.0, 2.0]];
            assert_eq!(
                kmeans_reduce(&s, &mut c, 1, Init::First),
                Err(ClusterError::NonFiniteSample)
            );
            assert_eq!(c, [[7.0; 2]; 2]);
        }
        // k == MAX_CENTERS is accepted.
        let mut c = [[7.0f32; 2]; MAX_CENTERS];
        assert!(kmeans_reduce(&big, &mut c, 1, Init::Farthest).is_ok());
    }

    #[test]
    fn huge_magnitudes_do_not_panic() {
        let s = [
            [f32::MAX, -f32::MAX],
            [-f32::MAX, f32::MAX],
            [f32::MAX, f32::MAX],
        ];
        for init in [Init::First, Init::Farthest] {
            let mut c = [[0.0f32; 2]; 2];
            assert!(kmeans_reduce(&s, &mut c, 4, init).is_ok());
        }
    }
}
