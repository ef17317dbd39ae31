//! One training epoch of `configs/sdd-small.toml` on SDD (data loaded once, outside the loop).
//!
//! `cargo bench -p gpecnet-trainer --bench train_epoch`

use std::path::Path;

use criterion::{criterion_group, criterion_main, Criterion};
use gpecnet_trainer::config::TrainConfig;
use gpecnet_trainer::data;
use gpecnet_trainer::train::{prepare_data, Trainer};

fn bench_train_epoch(c: &mut Criterion) {
    let cfg_path = Path::new(env!("CARGO_MANIFEST_DIR")).join("configs/sdd-small.toml");
    let cfg = TrainConfig::from_file(&cfg_path).expect("sdd-small.toml");
    let data = prepare_data(&cfg, &data::default_data_root()).expect("SDD data (see shared/data)");
    let mut trainer = Trainer::new(cfg, data).expect("trainer");
    let mut group = c.benchmark_group("train");
    group.sample_size(10);
    group.bench_function("sdd_small_epoch", |b| {
        b.iter(|| trainer.train_epoch(None).expect("epoch"))
    });
    group.finish();
}

criterion_group!(benches, bench_train_epoch);
criterion_main!(benches);
