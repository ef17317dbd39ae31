//! Batch inference on the SDD test set with the shipped `sdd-small` blobs:
//! through `gpecnet-core` (f32 libm sine, f32 fast sine, fixed point) and the
//! trainer's reference path. One iteration = 256 test windows × K = 20
//! trajectories, on all cores.
//!
//! `cargo bench -p gpecnet-trainer --bench inference`

use std::path::Path;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use gpecnet_trainer::core_eval::{evaluate_core, evaluate_reference};
use gpecnet_trainer::data::{self, load_sdd, SddSplit};
use gpecnet_trainer::export::read_blob;
use gpecnet_trainer::quantize::evaluate_core_fixed;
use gpecnet_trainer::reference::SineKind;

fn bench_inference(c: &mut Criterion) {
    let weights = Path::new(env!("CARGO_MANIFEST_DIR")).join("../weights");
    let blob = std::fs::read(weights.join("sdd-small.gpec")).expect("weights/sdd-small.gpec");
    let qblob = std::fs::read(weights.join("sdd-small-q.gpec")).expect("weights/sdd-small-q.gpec");
    let model = read_blob(&blob).expect("blob");
    let mut test = load_sdd(&data::default_data_root(), SddSplit::Test).expect("SDD test set");
    test.windows.truncate(256);
    let mut g = c.benchmark_group("inference_256_windows_k20");
    g.sample_size(10);
    g.throughput(Throughput::Elements(256));
    g.bench_function("core_f32_libm", |b| {
        b.iter(|| evaluate_core(&blob, SineKind::Libm, &test, 20, 0).expect("eval"))
    });
    g.bench_function("core_f32_fast_sine", |b| {
        b.iter(|| evaluate_core(&blob, SineKind::Fast, &test, 20, 0).expect("eval"))
    });
    g.bench_function("core_fixed_q15", |b| {
        b.iter(|| evaluate_core_fixed(&qblob, &test, 20, 0).expect("eval"))
    });
    g.bench_function("reference_f32_libm", |b| {
        b.iter(|| evaluate_reference(&model, SineKind::Libm, &test, 20, 0).expect("eval"))
    });
    g.finish();
}

criterion_group!(benches, bench_inference);
criterion_main!(benches);
