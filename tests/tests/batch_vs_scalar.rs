//! The batched path (`gpecnet_core::batch`) equals the scalar path
//! (`gpecnet_core::Predictor`) bit for bit, for every shipped blob in
//! `weights/` (f32 and Q15) on real SDD test windows: one track at K = 1,
//! 20, 200 and K = 13 (not a multiple of the lane count), many tracks side
//! by side (endpoint sets, plain samples, trajectories, point forecasts),
//! with the host's 8 lanes and with 3 lanes (every chunk boundary falls
//! inside a track); for f32 also with 16 lanes and on the portable SSE2
//! path where the host takes AVX2 (`gpecnet_core::batch::set_wide_vectors`).

use gpecnet_core::batch::{set_wide_vectors, BatchPredictor};
use gpecnet_core::blob::MAX_TTS_SAMPLES;
use gpecnet_core::{FastSine, LibmSine, Model, NumericKind, Predictor, Sine, Trajectory};
use gpecnet_metrics::core_eval::queries;
use gpecnet_tests::{card_test_set, shipped_blobs};

type Past = [[f32; 2]; 8];

fn bits(v: &[[f32; 2]]) -> Vec<[u32; 2]> {
    v.iter().map(|p| p.map(f32::to_bits)).collect()
}

fn traj_bits(v: &[Trajectory]) -> Vec<Vec<[u32; 2]>> {
    v.iter().map(|t| bits(t)).collect()
}

/// One blob, sine `S`, `L` lanes: every batched entry point against the scalar one.
fn check<S: Sine, const L: usize>(name: &str, model: &Model<'_>, pasts: &[Past]) {
    let mut scalar = Box::new(Predictor::<S, 1024>::new(*model).unwrap());
    let mut batch = Box::new(BatchPredictor::<S, 1024, L>::new(*model).unwrap());
    let tts = model.extensions().tts_samples > 0;
    let at = |what: &str, k: usize| format!("{name} L={L} {what} K={k}");

    // One track, K = 1, 13, 20, 200 (plain samples; endpoint sets up to 20).
    for (i, past) in pasts.iter().take(3).enumerate() {
        let seed = 1000 + i as u64;
        for k in [1usize, 13, 20, 200] {
            let (mut a, mut b) = (vec![[0.0f32; 2]; k], vec![[0.0f32; 2]; k]);
            if model.has_proposal() && k > model.proposal_latents() {
                // A proposal's stream ends after its K latents, on both paths.
                let refused = Err(gpecnet_core::PredictError::BadSampleCount);
                assert_eq!(scalar.predict_samples(past, seed, &mut a), refused);
                assert_eq!(batch.predict_samples(past, seed, &mut b), refused);
                continue;
            }
            scalar.predict_samples(past, seed, &mut a).unwrap();
            batch.predict_samples(past, seed, &mut b).unwrap();
            assert_eq!(bits(&a), bits(&b), "{}", at("samples", k));
            if k <= 20 {
                let (mut a, mut b) = (vec![[0.0f32; 2]; k], vec![[0.0f32; 2]; k]);
                scalar
                    .predict_endpoint_set::<MAX_TTS_SAMPLES>(past, seed, &mut a)
                    .unwrap();
                batch
                    .predict_endpoint_set::<MAX_TTS_SAMPLES>(past, seed, &mut b)
                    .unwrap();
                assert_eq!(bits(&a), bits(&b), "{}", at("endpoint set", k));
            }
            if model.has_predictor() && k <= 20 {
                let mut a = vec![Trajectory::new(); k];
                let mut b = vec![Trajectory::new(); k];
                scalar.predict_trajectories(past, seed, &mut a).unwrap();
                batch.predict_trajectories(past, seed, &mut b).unwrap();
                assert_eq!(traj_bits(&a), traj_bits(&b), "{}", at("trajectories", k));
            }
        }
    }

    // Many tracks side by side (seed of track t = t, as the evaluation uses).
    let queries = queries(pasts, |t| t as u64);
    for k in [1usize, 13, 20] {
        let n = queries.len() * k;
        let mut b = vec![[0.0f32; 2]; n];
        batch
            .predict_endpoint_sets::<MAX_TTS_SAMPLES>(&queries, k, &mut b)
            .unwrap();
        let mut s = vec![[0.0f32; 2]; n];
        for (q, o) in queries.iter().zip(s.chunks_mut(k)) {
            scalar
                .predict_endpoint_set::<MAX_TTS_SAMPLES>(q.past, q.seed, o)
                .unwrap();
        }
        assert_eq!(bits(&s), bits(&b), "{}", at("endpoint sets, many", k));
        if !tts {
            continue;
        }
        // A test-time-sampling blob: the plain samples too.
        let mut b = vec![[0.0f32; 2]; n];
        batch.predict_samples_many(&queries, k, &mut b).unwrap();
        for (q, o) in queries.iter().zip(s.chunks_mut(k)) {
            scalar.predict_samples(q.past, q.seed, o).unwrap();
        }
        assert_eq!(bits(&s), bits(&b), "{}", at("samples, many", k));
    }
    if model.has_predictor() {
        for k in [1usize, 20] {
            let n = queries.len() * k;
            let mut b = vec![Trajectory::new(); n];
            batch
                .predict_trajectories_many(&queries, k, &mut b)
                .unwrap();
            let mut s = vec![Trajectory::new(); n];
            for (q, o) in queries.iter().zip(s.chunks_mut(k)) {
                scalar.predict_trajectories(q.past, q.seed, o).unwrap();
            }
            assert_eq!(
                traj_bits(&s),
                traj_bits(&b),
                "{}",
                at("trajectories, many", k)
            );
        }
    }
    if model.has_point_head() {
        let mut b = vec![Trajectory::new(); queries.len()];
        batch.predict_points(&queries, &mut b).unwrap();
        let s: Vec<Trajectory> = queries
            .iter()
            .map(|q| scalar.predict_point(q.past).unwrap())
            .collect();
        assert_eq!(traj_bits(&s), traj_bits(&b), "{}", at("points, many", 1));
    }
}

#[test]
fn batched_equals_scalar_on_every_shipped_blob() {
    let blobs = shipped_blobs();
    assert!(blobs.len() >= 8, "{blobs:?}");
    for path in blobs {
        let test = card_test_set(&path);
        let name = path.file_stem().unwrap().to_string_lossy().to_string();
        let blob = std::fs::read(&path).unwrap();
        let model = Model::from_blob(&blob).unwrap();
        // Every 97th window (30 windows; 10 for the paper-size model, whose
        // scalar reference is slow): not a multiple of the lane count.
        let step = if model.parameter_count() > 500_000 {
            283
        } else {
            97
        };
        let pasts: Vec<Past> = test.windows.iter().step_by(step).map(|w| w.obs()).collect();
        match model.numeric() {
            NumericKind::F32 => {
                check::<LibmSine, 8>(&name, &model, &pasts);
                check::<LibmSine, 3>(&name, &model, &pasts);
                if model.parameter_count() < 500_000 {
                    check::<FastSine, 8>(&name, &model, &pasts);
                    // The extra lane width and path on the first 10 windows
                    // of the small models (the paper-size model's scalar
                    // side is what costs; the code is the same for all).
                    let few = &pasts[..pasts.len().min(10)];
                    // 16 lanes: two vectors per sum (4 rows at a time on AVX2).
                    check::<LibmSine, 16>(&name, &model, few);
                    // The portable SSE2 path, which a host with AVX2 skips
                    // (process-wide switch; the bits are the same either
                    // way, so other tests running meanwhile are unaffected).
                    set_wide_vectors(false);
                    check::<LibmSine, 8>(&name, &model, few);
                    set_wide_vectors(true);
                }
            }
            NumericKind::Int16Q15 => {
                check::<LibmSine, 8>(&name, &model, &pasts);
                check::<LibmSine, 3>(&name, &model, &pasts);
            }
        }
    }
}

#[test]
fn batched_refuses_what_scalar_refuses() {
    let path = shipped_blobs()
        .into_iter()
        .find(|p| p.ends_with("sdd-small.gpec"))
        .unwrap();
    let blob = std::fs::read(path).unwrap();
    let model = Model::from_blob(&blob).unwrap();
    let mut scalar = Box::new(Predictor::<LibmSine, 1024>::new(model).unwrap());
    let mut batch = Box::new(BatchPredictor::<LibmSine, 1024, 8>::new(model).unwrap());
    let good: Past = core::array::from_fn(|t| [100.0 + t as f32, 50.0]);
    let mut nan = good;
    nan[3][1] = f32::NAN;
    let mut far = good;
    far[7][0] = 1.0e7;
    for past in [&nan[..], &far[..], &good[..5]] {
        let mut o = [[0.0f32; 2]; 4];
        let e = scalar.predict_samples(past, 0, &mut o).unwrap_err();
        assert_eq!(batch.predict_samples(past, 0, &mut o), Err(e));
    }
    // Many tracks: the first failing index, with its error.
    let tracks = [good, good, nan, good, far];
    let qs = queries(&tracks, |_| 0);
    let mut o = vec![[0.0f32; 2]; qs.len() * 2];
    let e = batch.predict_samples_many(&qs, 2, &mut o).unwrap_err();
    assert_eq!(
        (e.index, e.error),
        (2, gpecnet_core::PredictError::NonFiniteInput)
    );
    // Tracks before the failing one are computed.
    let mut s = [[0.0f32; 2]; 2];
    scalar.predict_samples(&good, 0, &mut s).unwrap();
    assert_eq!(bits(&o[2..4]), bits(&s));
    assert_eq!(
        batch
            .predict_samples_many(&qs, 2, &mut o[..3])
            .unwrap_err()
            .error,
        gpecnet_core::PredictError::BadSampleCount
    );
    assert!(batch.predict_samples(&good, 0, &mut []).is_err());
}
