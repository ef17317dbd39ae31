//! `gpecnet_core::cluster::kmeans_reduce` against the trainer's independent
//! re-implementation `gpecnet_reference::tts::kmeans`, bit for bit, on many
//! random point sets (both initialisations, several k, n and iteration
//! counts), including sets with many exact ties.

use gpecnet_core::cluster::{kmeans_reduce, ClusterError, Init, MAX_CENTERS};
use gpecnet_reference::tts::{kmeans, TtsInit};
use gpecnet_tests::SplitMix64 as Rng;

/// A point set of one of several shapes: Gaussian-ish blobs in pixels, a
/// coarse integer grid (many exact ties and duplicates), tiny and huge scales.
fn points(rng: &mut Rng, n: usize) -> Vec<[f32; 2]> {
    let shape = rng.below(4);
    let blobs: Vec<[f32; 2]> = (0..1 + rng.below(6))
        .map(|_| [rng.unit() * 800.0, rng.unit() * 600.0])
        .collect();
    (0..n)
        .map(|_| match shape {
            0 => {
                let b = blobs[rng.below(blobs.len())];
                let r = 40.0 * rng.unit();
                [b[0] + r * (rng.unit() - 0.5), b[1] + r * (rng.unit() - 0.5)]
            }
            1 => [rng.below(4) as f32, rng.below(3) as f32],
            2 => [(rng.unit() - 0.5) * 1e-3, (rng.unit() - 0.5) * 1e-3],
            _ => [(rng.unit() - 0.5) * 1e6, (rng.unit() - 0.5) * 3.0],
        })
        .collect()
}

fn core_init(i: TtsInit) -> Init {
    match i {
        TtsInit::First => Init::First,
        TtsInit::Farthest => Init::Farthest,
    }
}

#[test]
fn core_matches_trainer_reference_bit_for_bit() {
    let mut rng = Rng(2024);
    let mut cases = 0usize;
    for &n in &[1usize, 2, 3, 7, 20, 40, 64, 100, 257, 500] {
        for &k in &[1usize, 2, 3, 5, 20, 64] {
            if k > n {
                continue;
            }
            for &iters in &[0u8, 1, 3, 5, 10, 30] {
                for init in [TtsInit::First, TtsInit::Farthest] {
                    for _ in 0..3 {
                        let s = points(&mut rng, n);
                        let want = kmeans(&s, k, u32::from(iters), init).unwrap();
                        let mut got = vec![[f32::NAN; 2]; k];
                        kmeans_reduce(&s, &mut got, iters, core_init(init)).unwrap();
                        for (j, (a, b)) in got.iter().zip(&want).enumerate() {
                            assert!(
                                a[0].to_bits() == b[0].to_bits()
                                    && a[1].to_bits() == b[1].to_bits(),
                                "n={n} k={k} iters={iters} {init:?} centre {j}: core {a:?} ref {b:?}"
                            );
                        }
                        cases += 1;
                    }
                }
            }
        }
    }
    assert!(cases > 1000, "{cases}");
}

#[test]
fn both_refuse_the_same_inputs() {
    let s = vec![[0.0f32, 0.0]; MAX_CENTERS + 2];
    for (k, n, want) in [
        (0usize, 3usize, ClusterError::NoCenters),
        (4, 3, ClusterError::TooFewSamples { k: 4, n: 3 }),
        (
            MAX_CENTERS + 1,
            MAX_CENTERS + 2,
            ClusterError::TooManyCenters { k: MAX_CENTERS + 1 },
        ),
    ] {
        let mut c = vec![[0.0f32; 2]; k];
        assert_eq!(kmeans_reduce(&s[..n], &mut c, 1, Init::First), Err(want));
        assert!(kmeans(&s[..n], k, 1, TtsInit::First).is_err());
    }
    let bad = [[0.0, 0.0], [f32::NAN, 1.0]];
    let mut c = [[0.0f32; 2]; 1];
    assert_eq!(
        kmeans_reduce(&bad, &mut c, 1, Init::Farthest),
        Err(ClusterError::NonFiniteSample)
    );
    assert!(kmeans(&bad, 1, 1, TtsInit::Farthest).is_err());
}
