//! Training-set augmentation with the synthetic pool (`augment_pct`, `gpecnet train --augment`)
//! on the real SDD data: 0 % is exactly the unaugmented set, K % adds exactly
//! round(K % × n_real) windows (twice, with time reversal), in pool order, deterministically;
//! validation is never augmented.

use std::path::Path;

use gpecnet_trainer::config::TrainConfig;
use gpecnet_trainer::data::{self, time_reversed, Window};
use gpecnet_trainer::synth::classify::TrajType;
use gpecnet_trainer::synth::sample::{pool_csv, take_first_pct, PoolItem, Source};
use gpecnet_trainer::train::{prepare_data, synthetic_windows};

/// A hand-made pool of straight walks, distinct per index (no generator needed).
fn pool(n: usize) -> Vec<PoolItem> {
    (0..n)
        .map(|i| {
            let x0 = 100.0 + (i % 1000) as f32;
            let y0 = 200.0 + (i / 1000) as f32 * 10.0;
            let v = 1.0 + (i % 7) as f32;
            PoolItem {
                ty: TrajType::T7,
                source: Source::Newtonian,
                traj: std::array::from_fn(|t| [x0 + v * t as f32, y0 + 0.5 * v * t as f32]),
            }
        })
        .collect()
}

fn write_pool(dir: &Path, n: usize) -> (String, Vec<PoolItem>) {
    let p = pool(n);
    let path = dir.join("pool.csv");
    std::fs::write(&path, pool_csv(&p).unwrap()).unwrap();
    (path.to_string_lossy().into_owned(), p)
}

fn cfg(pct: f32, pool: Option<&str>) -> TrainConfig {
    TrainConfig {
        augment_pct: pct,
        synthetic_pool: pool.map(str::to_string),
        ..TrainConfig::default()
    }
}

#[test]
fn augment_zero_is_the_unaugmented_set_and_k_adds_exactly_round_k_percent() {
    let root = data::default_data_root();
    let dir = tempfile::tempdir().unwrap();
    let (path, items) = write_pool(dir.path(), 2000);

    let base = prepare_data(&cfg(0.0, None), &root).unwrap();
    let n_real = base.n_real;
    assert_eq!(base.n_synthetic, 0);
    assert_eq!(base.train.len(), 2 * n_real);
    // 8494 SDD train windows minus the 846 of the default validation scenes.
    assert_eq!(n_real, 8494 - 846);

    // 0 % with a pool configured: exactly the unaugmented set.
    let zero = prepare_data(&cfg(0.0, Some(&path)), &root).unwrap();
    assert_eq!(zero.train, base.train);
    assert_eq!(zero.val, base.val);
    assert_eq!(zero.n_synthetic, 0);

    let scale = TrainConfig::default().data_scale;
    for pct in [1.0f32, 6.0, 18.0] {
        let a = prepare_data(&cfg(pct, Some(&path)), &root).unwrap();
        let k = (f64::from(pct) / 100.0 * n_real as f64).round() as usize;
        assert_eq!(a.n_real, n_real, "{pct}");
        assert_eq!(a.n_synthetic, k, "{pct}");
        assert_eq!(a.train.len(), 2 * (n_real + k), "{pct}");
        assert_eq!(a.val, base.val, "validation is never augmented");
        // Layout: real, synthetic (pool order), reversed real, reversed synthetic.
        let n = n_real + k;
        assert_eq!(&a.train[..n_real], &base.train[..n_real]);
        assert_eq!(&a.train[n..n + n_real], &base.train[n_real..]);
        let syn: Vec<Window> = take_first_pct(&items, f64::from(pct), n_real).unwrap();
        assert_eq!(syn.len(), k);
        for (i, w) in syn.iter().enumerate() {
            assert_eq!(w.pos, items[i].traj);
            assert_eq!(a.train[n_real + i], data::normalize(w, scale));
            assert_eq!(
                a.train[n + n_real + i],
                data::normalize(&time_reversed(w), scale)
            );
        }
        // Deterministic.
        assert_eq!(
            prepare_data(&cfg(pct, Some(&path)), &root).unwrap().train,
            a.train
        );
    }
    // 6 % of 7648 = 458.88 -> 459.
    assert_eq!(
        synthetic_windows(&cfg(6.0, Some(&path)), n_real)
            .unwrap()
            .len(),
        459
    );

    // Without time reversal: real + synthetic only.
    let mut c = cfg(10.0, Some(&path));
    c.time_reversal = false;
    let a = prepare_data(&c, &root).unwrap();
    assert_eq!(a.train.len(), n_real + 765);
    assert_eq!(
        a.train[n_real],
        data::normalize(&take_first_pct(&items, 10.0, n_real).unwrap()[0], scale)
    );
}

#[test]
fn augmentation_errors_are_clear() {
    let root = data::default_data_root();
    let dir = tempfile::tempdir().unwrap();
    let (path, _) = write_pool(dir.path(), 100);
    // 100 trajectories cannot cover 6 % of 7648.
    let e = prepare_data(&cfg(6.0, Some(&path)), &root).unwrap_err();
    assert!(format!("{e:#}").contains("the pool has 100"), "{e:#}");
    // Missing pool file.
    let missing = dir.path().join("nope.csv");
    let e = prepare_data(&cfg(1.0, Some(&missing.to_string_lossy())), &root).unwrap_err();
    assert!(format!("{e:#}").contains("cannot read pool"), "{e:#}");
    // augment without a pool is rejected by the config.
    assert!(cfg(1.0, None).validate().is_err());
}
