//! Inference speed with the shipped blobs.
//!
//! - `inference_256_windows_k20`: the trainer's evaluation of 256 SDD test
//!   windows × K = 20 trajectories with `sdd-small` (`sdd-small-q`), on all
//!   cores: through `gpecnet-core` (f32 libm sine, f32 fast sine, fixed
//!   point) and the trainer's reference path.
//! - `one_pedestrian/<model>/<path>/<K>`: K endpoints of one SDD test window
//!   (`predict_samples`), one thread, `scalar` = `gpecnet_core::Predictor`,
//!   `batched` = `gpecnet_core::batch::BatchPredictor` (8 lanes; the same
//!   bits), for `sdd-small` and `sdd-paper`, K = 1, 20, 200, 1000.
//! - `test_set_k20/<model>/<path>`: K = 20 endpoints of every SDD test window
//!   (2829; every 10th, 283, for `sdd-paper`, whose scalar pass over the
//!   whole set takes a minute), one thread: the scalar predictor window by
//!   window, or `predict_samples_many` over all of them.
//!
//! - `forecast_k20/<model>/<path>/<n>`: the shipped defaults' whole forecast
//!   (`sdd-m-lp`, `sdd-m-lp-host`: 20 endpoints, probabilities, point forecast,
//!   radii) of n = 1, 16 and every sdd-m test window, one thread: `scalar` =
//!   `Predictor::predict_forecast` window by window, `batched` =
//!   `BatchPredictor::predict_forecasts` over all of them (the same bits).
//!
//! `cargo bench -p gpecnet-trainer --bench inference` (results:
//! `docs/host-speed.md`); one group: append its name, e.g. `-- one_pedestrian`.

use std::path::Path;

use std::time::Duration;

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use gpecnet_core::batch::HostBatchPredictor;
use gpecnet_core::{LibmSine, Model, Predictor};
use gpecnet_trainer::core_eval::HOST_WIDTH;
use gpecnet_trainer::core_eval::{evaluate_core, evaluate_reference, queries};
use gpecnet_trainer::data::{self, load_sdd, SddSplit};
use gpecnet_trainer::export::read_blob;
use gpecnet_trainer::fixed_eval::evaluate_core_fixed;
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

/// Scalar vs batched, one pedestrian and the test set, one thread.
fn bench_scalar_vs_batched(c: &mut Criterion) {
    let weights = Path::new(env!("CARGO_MANIFEST_DIR")).join("../weights");
    let test = load_sdd(&data::default_data_root(), SddSplit::Test).expect("SDD test set");
    let pasts: Vec<[[f32; 2]; 8]> = test.windows.iter().map(|w| w.obs()).collect();
    for name in ["sdd-small", "sdd-paper"] {
        let blob = std::fs::read(weights.join(format!("{name}.gpec"))).expect("blob");
        let model = Model::from_blob(&blob).expect("valid blob");
        let mut scalar = Box::new(Predictor::<LibmSine, HOST_WIDTH>::new(model).expect("fits"));
        let mut batched =
            Box::new(HostBatchPredictor::<LibmSine, HOST_WIDTH>::new(model).expect("fits"));
        let past = &pasts[0];

        let mut g = c.benchmark_group(format!("one_pedestrian/{name}"));
        g.sample_size(10)
            .warm_up_time(Duration::from_millis(500))
            .measurement_time(Duration::from_secs(2));
        for k in [1usize, 20, 200, 1000] {
            let mut out = vec![[0.0f32; 2]; k];
            g.throughput(Throughput::Elements(k as u64));
            g.bench_with_input(BenchmarkId::new("scalar", k), &k, |b, _| {
                b.iter(|| scalar.predict_samples(past, 0, &mut out).expect("ok"))
            });
            g.bench_with_input(BenchmarkId::new("batched", k), &k, |b, _| {
                b.iter(|| batched.predict_samples(past, 0, &mut out).expect("ok"))
            });
        }
        g.finish();

        let step = if name == "sdd-paper" { 10 } else { 1 };
        let picked: Vec<[[f32; 2]; 8]> = pasts.iter().step_by(step).copied().collect();
        let queries = queries(&picked, |i| i as u64);
        let mut out = vec![[0.0f32; 2]; 20 * queries.len()];
        let mut g = c.benchmark_group(format!("test_set_k20/{name}"));
        g.sample_size(10)
            .warm_up_time(Duration::from_millis(500))
            .measurement_time(Duration::from_secs(2));
        g.throughput(Throughput::Elements(queries.len() as u64));
        g.bench_function("scalar", |b| {
            b.iter(|| {
                for (q, o) in queries.iter().zip(out.chunks_mut(20)) {
                    scalar.predict_samples(q.past, q.seed, o).expect("ok");
                }
            })
        });
        g.bench_function("batched", |b| {
            b.iter(|| {
                batched
                    .predict_samples_many(&queries, 20, &mut out)
                    .expect("ok")
            })
        });
        g.finish();
    }
}

/// The shipped defaults' whole forecast (`predict_forecast`: 20 endpoints, probabilities,
/// point forecast, radii), one thread: one pedestrian, 16 (one drone frame) and the whole
/// sdd-m test split, the scalar predictor window by window or `predict_forecasts` over all.
fn bench_forecasts(c: &mut Criterion) {
    use gpecnet_core::planner::PlannerOutput;
    use gpecnet_trainer::data::{load, DatasetSpec, Split};
    let weights = Path::new(env!("CARGO_MANIFEST_DIR")).join("../weights");
    let spec = DatasetSpec::parse("sdd-m").expect("sdd-m");
    let test = load(&data::default_data_root(), &spec, Split::Test, &[]).expect("sdd-m test");
    let pasts: Vec<[[f32; 2]; 8]> = test.windows.iter().map(|w| w.obs()).collect();
    let queries = queries(&pasts, |i| i as u64);
    const K: usize = 20;
    for name in ["sdd-m-lp", "sdd-m-lp-host"] {
        let blob = std::fs::read(weights.join(format!("{name}.gpec"))).expect("blob");
        let model = Model::from_blob(&blob).expect("valid blob");
        let mut scalar = Box::new(Predictor::<LibmSine, HOST_WIDTH>::new(model).expect("fits"));
        let mut batched =
            Box::new(HostBatchPredictor::<LibmSine, HOST_WIDTH>::new(model).expect("fits"));
        let n = queries.len();
        let (mut ends, mut probs) = (vec![[0.0f32; 2]; n * K], vec![0.0f32; n * K]);
        let blank = PlannerOutput {
            learned: false,
            point: None,
            radii: None,
        };
        let mut outs = vec![blank; n];
        let mut g = c.benchmark_group(format!("forecast_k20/{name}"));
        g.sample_size(10)
            .warm_up_time(Duration::from_millis(500))
            .measurement_time(Duration::from_secs(2));
        for m in [1usize, 16, n] {
            g.throughput(Throughput::Elements(m as u64));
            g.bench_with_input(BenchmarkId::new("scalar", m), &m, |b, &m| {
                b.iter(|| {
                    for q in &queries[..m] {
                        scalar.predict_forecast::<K>(q.past, q.seed).expect("ok");
                    }
                })
            });
            g.bench_with_input(BenchmarkId::new("batched", m), &m, |b, &m| {
                b.iter(|| {
                    batched
                        .predict_forecasts::<K>(
                            &queries[..m],
                            K,
                            &mut ends[..m * K],
                            &mut probs[..m * K],
                            &mut outs[..m],
                        )
                        .expect("ok")
                })
            });
        }
        g.finish();
    }
}

criterion_group!(
    benches,
    bench_inference,
    bench_scalar_vs_batched,
    bench_forecasts
);
criterion_main!(benches);
