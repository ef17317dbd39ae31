//! Unit tests of the k-means reduction: clusters worked by hand, the
//! checks and their order, and the exact shortcuts against the plain loop.

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

/// Iteration counts the random cases try: 0 to this.
const MAX_ITERS: usize = 6;

/// The documented algorithm written out as plainly as possible (no
/// shortcut, no early exit, `Vec`-free but otherwise naive): the centres
/// after 0, 1, …, [`MAX_ITERS`] iterations (with no early exit, `i`
/// iterations are the first `i` of `MAX_ITERS`).
fn reference(
    samples: &[[f32; 2]],
    k: usize,
    init: Init,
) -> [[[f32; 2]; MAX_CENTERS]; MAX_ITERS + 1] {
    let d =
        |a: [f32; 2], b: [f32; 2]| (a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]);
    let mut c = [[0.0f32; 2]; MAX_CENTERS];
    match init {
        Init::First => c[..k].copy_from_slice(&samples[..k]),
        Init::Farthest => {
            c[0] = samples[0];
            for chosen in 1..k {
                let mut best_i = 0;
                let mut best_m = f32::NAN;
                for (i, s) in samples.iter().enumerate() {
                    let mut m = f32::INFINITY;
                    for cj in &c[..chosen] {
                        let dd = d(*s, *cj);
                        if dd < m {
                            m = dd;
                        }
                    }
                    if i == 0 || m > best_m {
                        best_i = i;
                        best_m = m;
                    }
                }
                c[chosen] = samples[best_i];
            }
        }
    }
    let mut after = [[[0.0f32; 2]; MAX_CENTERS]; MAX_ITERS + 1];
    after[0] = c;
    for step in after[1..].iter_mut() {
        let mut member = [usize::MAX; 512];
        for (i, s) in samples.iter().enumerate() {
            let mut best = 0;
            for j in 1..k {
                if d(*s, c[j]) < d(*s, c[best]) {
                    best = j;
                }
            }
            member[i] = best;
        }
        let prev = c;
        for j in 0..k {
            let (mut sx, mut sy, mut count) = (0.0f32, 0.0f32, 0u32);
            for (i, s) in samples.iter().enumerate() {
                if member[i] == j {
                    sx += s[0];
                    sy += s[1];
                    count += 1;
                }
            }
            c[j] = if count == 0 {
                prev[j]
            } else {
                [sx / count as f32, sy / count as f32]
            };
        }
        *step = c;
    }
    after
}

/// SplitMix64: a small deterministic generator for the random cases.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n as u64) as usize
    }
    /// Uniform in [0, 1).
    fn unit(&mut self) -> f32 {
        (self.next() >> 40) as f32 / (1u64 << 24) as f32
    }
}

/// One random sample set of one of several shapes, written into `buf`.
fn sample_set<'a>(rng: &mut Rng, buf: &'a mut [[f32; 2]; 512]) -> &'a [[f32; 2]] {
    let n = match rng.below(4) {
        0 => 1 + rng.below(8),
        1 => 80,
        2 => 1 + rng.below(100),
        _ => 100 + rng.below(412),
    };
    let shape = rng.below(7);
    let mut blobs = [[0.0f32; 2]; 6];
    for b in &mut blobs {
        *b = [rng.unit() * 800.0, rng.unit() * 600.0];
    }
    let nb = 1 + rng.below(6);
    let big = f32::MAX / 2.0;
    for s in buf[..n].iter_mut() {
        *s = match shape {
            // Gaussian-ish blobs in pixels (like predicted endpoints).
            0 => {
                let b = blobs[rng.below(nb)];
                let r = 40.0 * rng.unit();
                [b[0] + r * (rng.unit() - 0.5), b[1] + r * (rng.unit() - 0.5)]
            }
            // A coarse grid: many exact ties and duplicates, signed zeros.
            1 => {
                let z = if rng.below(2) == 0 { 0.0 } else { -0.0 };
                [rng.below(4) as f32 + z, rng.below(3) as f32 - 1.0]
            }
            // All identical.
            2 => [3.5, -2.25],
            // Huge magnitudes: differences and sums overflow to inf,
            // centres can become inf or NaN.
            3 => [
                big * (rng.below(5) as f32 - 2.0),
                big * (rng.below(3) as f32 - 1.0),
            ],
            // Huge mixed with ordinary values.
            4 => {
                if rng.below(4) == 0 {
                    [
                        big * (rng.unit() * 2.0 - 1.0),
                        big * (rng.unit() * 2.0 - 1.0),
                    ]
                } else {
                    [rng.unit() * 10.0, rng.unit() * 10.0]
                }
            }
            // Tiny scale (products underflow, subnormals).
            5 => [(rng.unit() - 0.5) * 1e-20, (rng.unit() - 0.5) * 1e-19],
            // Very anisotropic: x spread huge, y small (dx² decides).
            _ => [(rng.unit() - 0.5) * 1e6, (rng.unit() - 0.5) * 3.0],
        };
    }
    &buf[..n]
}

#[test]
fn matches_plain_reference_bit_for_bit() {
    let mut rng = Rng(0x6b6d_6561_6e73);
    let mut buf = [[0.0f32; 2]; 512];
    let (mut cases, mut converged_early, mut non_finite) = (0usize, 0usize, 0usize);
    for _ in 0..3000 {
        let samples = sample_set(&mut rng, &mut buf);
        let n = samples.len();
        let kmax = n.min(MAX_CENTERS);
        let k = match rng.below(4) {
            0 => 1,
            1 => kmax,
            2 => kmax.min(20),
            _ => 1 + rng.below(kmax),
        };
        for init in [Init::First, Init::Farthest] {
            let after = reference(samples, k, init);
            for iters in 0..=MAX_ITERS {
                let want = after[iters];
                let mut got = [[f32::NAN; 2]; MAX_CENTERS];
                kmeans_reduce(samples, &mut got[..k], iters as u8, init).unwrap();
                for j in 0..k {
                    assert!(
                        got[j][0].to_bits() == want[j][0].to_bits()
                            && got[j][1].to_bits() == want[j][1].to_bits(),
                        "n={n} k={k} iters={iters} {init:?} centre {j}: {:?} != {:?}",
                        got[j],
                        want[j]
                    );
                }
                non_finite += want[..k].iter().flatten().any(|v| !v.is_finite()) as usize;
                // A fixed point before the last iteration: the early exit fires.
                if iters >= 2 {
                    let one_less = after[iters - 1];
                    converged_early += (one_less[..k].iter().flatten().map(|v| v.to_bits()))
                        .eq(want[..k].iter().flatten().map(|v| v.to_bits()))
                        as usize;
                }
                cases += 1;
            }
        }
    }
    // The random sets exercise the early exit, the overflowing path and
    // plenty of cases where neither applies.
    assert!(cases == 3000 * 14, "{cases}");
    assert!(converged_early > 2000, "{converged_early}");
    assert!(cases - converged_early > 2000, "{converged_early}");
    assert!(non_finite > 100, "{non_finite}");
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
