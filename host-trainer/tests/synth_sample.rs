//! The synthetic pool: deterministic, in range, classified as labelled, type shares followed.

use gpecnet_trainer::rng::Rng;
use gpecnet_trainer::synth::agent::new_policy;
use gpecnet_trainer::synth::classify::{classify, TrajType};
use gpecnet_trainer::synth::in_range;
use gpecnet_trainer::synth::sample::{build_pool, pool_csv, read_pool, shares, take_first_pct};

fn counts() -> [usize; 10] {
    // A made-up training distribution over all 9 types (+ "other", ignored).
    [90, 90, 5, 50, 5, 15, 20, 5, 700, 40]
}

#[test]
fn pool_is_deterministic_in_range_and_follows_the_shares() {
    let policy = new_policy(&mut Rng::new(1)).unwrap();
    let p = shares(&counts());
    assert_eq!(p[TrajType::Other.index()], 0.0);
    let a = build_pool(200, &p, &policy, 42).unwrap();
    let b = build_pool(200, &p, &policy, 42).unwrap();
    assert_eq!(a, b);
    assert_ne!(a, build_pool(200, &p, &policy, 43).unwrap());
    for it in &a {
        assert!(in_range(&it.traj));
        assert_eq!(classify(&it.traj), it.ty);
    }
    // Every prefix follows the shares to within one trajectory per type.
    for n in [10usize, 50, 200] {
        for t in &TrajType::ALL[..9] {
            let c = a[..n].iter().filter(|it| it.ty == *t).count() as f64;
            assert!(
                (c - p[t.index()] * n as f64).abs() <= 1.0 + 1e-9,
                "{n} {t:?} {c}"
            );
        }
    }
    // A longer pool starts with the shorter one (fixed order).
    let long = build_pool(300, &p, &policy, 42).unwrap();
    assert_eq!(&long[..200], &a[..]);
}

#[test]
fn csv_round_trip_and_first_k_percent() {
    let policy = new_policy(&mut Rng::new(1)).unwrap();
    let pool = build_pool(50, &shares(&counts()), &policy, 7).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("pool.csv");
    std::fs::write(&path, pool_csv(&pool).unwrap()).unwrap();
    let back = read_pool(&path).unwrap();
    assert_eq!(back, pool);
    let w = take_first_pct(&back, 10.0, 300).unwrap();
    assert_eq!(w.len(), 30);
    assert_eq!(w[3].pos, pool[3].traj);
    assert_eq!(w[3].frames[1] - w[3].frames[0], 12);
    assert!(take_first_pct(&back, 50.0, 300).is_err());
}
