//! Test-time sampling on the host: an independent re-implementation of the
//! k-means reduction specified in `gpecnet_core::cluster` (draw `n` latent
//! samples, reduce them to `k` centres), written from that specification and
//! not by calling the core, so the workspace test `kmeans_vs_core` can compare
//! the two bit for bit (the same convention as [`crate::reference`]).
//!
//! Differences in *structure* from the core (none in arithmetic): the
//! farthest-point initialisation keeps a vector of nearest-centre distances
//! and updates it with each new centre (the minimum of f32 values is exact,
//! so this equals recomputing it); the Lloyd step stores the assignment of
//! every sample and then sums the members of each centre in sample order.

use anyhow::{bail, Result};

/// Largest `k` the core accepts (`gpecnet_core::cluster::MAX_CENTERS`).
pub const MAX_CENTERS: usize = 64;

/// Centre initialisation (mirrors `gpecnet_core::cluster::Init`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum TtsInit {
    /// The first `k` samples.
    First,
    /// Farthest-point from sample 0, ties to the lowest sample index.
    Farthest,
}

impl TtsInit {
    /// Short name for tables.
    pub fn name(self) -> &'static str {
        match self {
            TtsInit::First => "first",
            TtsInit::Farthest => "farthest",
        }
    }
}

/// `(a0 - b0)·(a0 - b0) + (a1 - b1)·(a1 - b1)` in f32, in that order.
pub fn squared_distance(a: &[f32; 2], b: &[f32; 2]) -> f32 {
    let x = (a[0] - b[0]) * (a[0] - b[0]);
    let y = (a[1] - b[1]) * (a[1] - b[1]);
    x + y
}

/// `k` k-means centres of `samples` after `iters` Lloyd iterations.
///
/// Errors (in this order) for `k == 0`, `k > MAX_CENTERS`, `k > n`, and a
/// non-finite sample coordinate.
pub fn kmeans(samples: &[[f32; 2]], k: usize, iters: u32, init: TtsInit) -> Result<Vec<[f32; 2]>> {
    let n = samples.len();
    if k == 0 {
        bail!("k-means: k = 0");
    }
    if k > MAX_CENTERS {
        bail!("k-means: k = {k} > {MAX_CENTERS}");
    }
    if k > n {
        bail!("k-means: k = {k} > n = {n}");
    }
    if samples
        .iter()
        .any(|s| !s[0].is_finite() || !s[1].is_finite())
    {
        bail!("k-means: non-finite sample");
    }

    let mut centers: Vec<[f32; 2]> = match init {
        TtsInit::First => samples[..k].to_vec(),
        TtsInit::Farthest => {
            let mut c = vec![samples[0]];
            let mut near: Vec<f32> = samples
                .iter()
                .map(|s| squared_distance(s, &samples[0]))
                .collect();
            while c.len() < k {
                let mut pick = 0usize;
                for i in 1..n {
                    if near[i] > near[pick] {
                        pick = i;
                    }
                }
                let new = samples[pick];
                c.push(new);
                for (m, s) in near.iter_mut().zip(samples) {
                    *m = m.min(squared_distance(s, &new));
                }
            }
            c
        }
    };

    let mut owner = vec![0usize; n];
    for _ in 0..iters {
        for (o, s) in owner.iter_mut().zip(samples) {
            let mut best = 0usize;
            let mut best_d = squared_distance(s, &centers[0]);
            for (j, c) in centers.iter().enumerate().skip(1) {
                let d = squared_distance(s, c);
                if d < best_d {
                    best = j;
                    best_d = d;
                }
            }
            *o = best;
        }
        for (j, c) in centers.iter_mut().enumerate() {
            let mut sx = 0.0f32;
            let mut sy = 0.0f32;
            let mut count = 0u32;
            for (s, &o) in samples.iter().zip(&owner) {
                if o == j {
                    sx += s[0];
                    sy += s[1];
                    count += 1;
                }
            }
            if count > 0 {
                *c = [sx / count as f32, sy / count as f32];
            }
        }
    }
    Ok(centers)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hand_checked() {
        let s = [[0.0, 0.0], [10.0, 0.0], [0.0, 1.0], [10.0, 1.0], [0.0, 2.0]];
        assert_eq!(
            kmeans(&s, 2, 0, TtsInit::Farthest).unwrap(),
            vec![[0.0, 0.0], [10.0, 1.0]]
        );
        for init in [TtsInit::First, TtsInit::Farthest] {
            assert_eq!(
                kmeans(&s, 2, 3, init).unwrap(),
                vec![[0.0, 1.0], [10.0, 0.5]]
            );
        }
        assert!(kmeans(&s, 0, 1, TtsInit::First).is_err());
        assert!(kmeans(&s, 6, 1, TtsInit::First).is_err());
        assert!(kmeans(&[[f32::NAN, 0.0]], 1, 1, TtsInit::First).is_err());
    }
}
