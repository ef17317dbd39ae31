//! The batched path (`gpecnet_core::batch`) equals the scalar path
//! (`gpecnet_core::Predictor`) bit for bit, for every shipped blob in
//! `weights/` (f32 and Q15) on real SDD test windows: one track at K = 1,
//! 20, 200 and K = 13 (not a multiple of the lane count), many tracks side
//! by side (endpoint sets, plain samples, trajectories, point forecasts),
//! with the host's 8 lanes and with 3 lanes (every chunk boundary falls
//! inside a track); for f32 also with 16 lanes and on the portable SSE2
//! path where the host takes AVX2 (`gpecnet_core::batch::set_wide_vectors`).
//! The scalar side runs once per blob, sine and set of windows (a [`Record`]
//! of every entry point's output) and each lane width is checked against it.
//! The planner's batched call (`predict_forecasts`: endpoints, probabilities,
//! point forecast, radii) against `Predictor::predict_planner` on the whole
//! test set of every shipped proposal blob, the latents computed in lanes.

use gpecnet_core::batch::{set_wide_vectors, BatchPredictor, Query};
use gpecnet_core::blob::MAX_TTS_SAMPLES;
use gpecnet_core::{
    FastSine, LibmSine, Model, NumericKind, PredictError, Predictor, Sine, Trajectory,
};
use gpecnet_metrics::core_eval::queries;
use gpecnet_tests::{card_test_set, shipped_blobs};

type Past = [[f32; 2]; 8];

fn bits(v: &[[f32; 2]]) -> Vec<[u32; 2]> {
    v.iter().map(|p| p.map(f32::to_bits)).collect()
}

fn traj_bits(v: &[Trajectory]) -> Vec<[u32; 2]> {
    v.iter().flat_map(|t| bits(t)).collect()
}

/// One entry point's answer: the output's bits, or the error.
type Outcome = Result<Vec<[u32; 2]>, PredictError>;

/// Every entry point's answer, in call order, each with what was called.
type Record = Vec<(String, Outcome)>;

/// An entry point's endpoints.
type Ends = [[f32; 2]];
/// An entry point's trajectories.
type Trajs = [Trajectory];
/// What an entry point returns.
type Done = Result<(), PredictError>;

/// The entry points the scalar and the batched path share. On the scalar
/// path a many-track call is one call per track (seed of track `t` = `t`).
trait Path {
    fn samples(&mut self, past: &Past, seed: u64, out: &mut Ends) -> Done;
    fn endpoint_set(&mut self, past: &Past, seed: u64, out: &mut Ends) -> Done;
    fn trajectories(&mut self, past: &Past, seed: u64, out: &mut Trajs) -> Done;
    fn endpoint_sets(&mut self, q: &[Query<'_>], k: usize, out: &mut Ends) -> Done;
    fn samples_many(&mut self, q: &[Query<'_>], k: usize, out: &mut Ends) -> Done;
    fn trajectories_many(&mut self, q: &[Query<'_>], k: usize, out: &mut Trajs) -> Done;
    fn points(&mut self, q: &[Query<'_>], out: &mut Trajs) -> Done;
}

/// The one-track entry points, the same methods on both paths' predictors
/// (`self.0`): written once for both `Path` impls.
macro_rules! single_track {
    () => {
        fn samples(&mut self, past: &Past, seed: u64, out: &mut Ends) -> Done {
            self.0.predict_samples(past, seed, out)
        }
        fn endpoint_set(&mut self, past: &Past, seed: u64, out: &mut Ends) -> Done {
            self.0
                .predict_endpoint_set::<MAX_TTS_SAMPLES>(past, seed, out)
        }
        fn trajectories(&mut self, past: &Past, seed: u64, out: &mut Trajs) -> Done {
            self.0.predict_trajectories(past, seed, out)
        }
    };
}

/// A many-track call on the scalar path: `one` per track, track `t`'s `k`
/// outputs in `out[t·k..(t + 1)·k]`.
fn per_track<T>(
    q: &[Query<'_>],
    k: usize,
    out: &mut [T],
    mut one: impl FnMut(&Query<'_>, &mut [T]) -> Done,
) -> Done {
    q.iter()
        .zip(out.chunks_mut(k))
        .try_for_each(|(q, o)| one(q, o))
}

/// The scalar path (`Predictor`): the reference.
struct Scalar<'m, S: Sine>(Box<Predictor<'m, S, 1024>>);

impl<S: Sine> Path for Scalar<'_, S> {
    single_track!();
    fn endpoint_sets(&mut self, q: &[Query<'_>], k: usize, out: &mut Ends) -> Done {
        per_track(q, k, out, |q, o| {
            self.0
                .predict_endpoint_set::<MAX_TTS_SAMPLES>(q.past, q.seed, o)
        })
    }
    fn samples_many(&mut self, q: &[Query<'_>], k: usize, out: &mut Ends) -> Done {
        per_track(q, k, out, |q, o| self.0.predict_samples(q.past, q.seed, o))
    }
    fn trajectories_many(&mut self, q: &[Query<'_>], k: usize, out: &mut Trajs) -> Done {
        per_track(q, k, out, |q, o| {
            self.0.predict_trajectories(q.past, q.seed, o)
        })
    }
    fn points(&mut self, q: &[Query<'_>], out: &mut Trajs) -> Done {
        for (q, o) in q.iter().zip(out) {
            *o = self.0.predict_point(q.past)?;
        }
        Ok(())
    }
}

/// The batched path (`BatchPredictor`) with `L` lanes.
struct Batched<'m, S: Sine, const L: usize>(Box<BatchPredictor<'m, S, 1024, L>>);

impl<S: Sine, const L: usize> Path for Batched<'_, S, L> {
    single_track!();
    fn endpoint_sets(&mut self, q: &[Query<'_>], k: usize, out: &mut Ends) -> Done {
        let r = self.0.predict_endpoint_sets::<MAX_TTS_SAMPLES>(q, k, out);
        r.map_err(|e| e.error)
    }
    fn samples_many(&mut self, q: &[Query<'_>], k: usize, out: &mut Ends) -> Done {
        self.0.predict_samples_many(q, k, out).map_err(|e| e.error)
    }
    fn trajectories_many(&mut self, q: &[Query<'_>], k: usize, out: &mut Trajs) -> Done {
        let r = self.0.predict_trajectories_many(q, k, out);
        r.map_err(|e| e.error)
    }
    fn points(&mut self, q: &[Query<'_>], out: &mut Trajs) -> Done {
        self.0.predict_points(q, out).map_err(|e| e.error)
    }
}

/// Every entry point of `path` on `pasts`: one track at K = 1, 13, 20, 200
/// (plain samples; endpoint sets and trajectories up to 20), then many
/// tracks side by side (seed of track `t` = `t`, as the evaluation uses).
fn record(path: &mut impl Path, model: &Model<'_>, pasts: &[Past]) -> Record {
    let mut r = Record::new();
    let mut take = |what: String, out: Result<Vec<[u32; 2]>, PredictError>| r.push((what, out));
    let tts = model.extensions().tts_samples > 0;
    for (i, past) in pasts.iter().take(3).enumerate() {
        let seed = 1000 + i as u64;
        for k in [1usize, 13, 20, 200] {
            let mut o = vec![[0.0f32; 2]; k];
            // A proposal's stream ends after its K latents: both paths refuse.
            let res = path.samples(past, seed, &mut o).map(|()| bits(&o));
            take(format!("samples track {i} K={k}"), res);
            if k <= 20 {
                let mut o = vec![[0.0f32; 2]; k];
                let res = path.endpoint_set(past, seed, &mut o).map(|()| bits(&o));
                take(format!("endpoint set track {i} K={k}"), res);
            }
            if model.has_predictor() && k <= 20 {
                let mut o = vec![Trajectory::new(); k];
                let res = path
                    .trajectories(past, seed, &mut o)
                    .map(|()| traj_bits(&o));
                take(format!("trajectories track {i} K={k}"), res);
            }
        }
    }
    let queries = queries(pasts, |t| t as u64);
    for k in [1usize, 13, 20] {
        let mut o = vec![[0.0f32; 2]; queries.len() * k];
        let res = path.endpoint_sets(&queries, k, &mut o).map(|()| bits(&o));
        take(format!("endpoint sets, many, K={k}"), res);
        if tts {
            // A test-time-sampling blob: the plain samples too.
            let mut o = vec![[0.0f32; 2]; queries.len() * k];
            let res = path.samples_many(&queries, k, &mut o).map(|()| bits(&o));
            take(format!("samples, many, K={k}"), res);
        }
    }
    if model.has_predictor() {
        for k in [1usize, 20] {
            let mut o = vec![Trajectory::new(); queries.len() * k];
            let res = path
                .trajectories_many(&queries, k, &mut o)
                .map(|()| traj_bits(&o));
            take(format!("trajectories, many, K={k}"), res);
        }
    }
    if model.has_point_head() {
        let mut o = vec![Trajectory::new(); queries.len()];
        let res = path.points(&queries, &mut o).map(|()| traj_bits(&o));
        take("points, many".to_string(), res);
    }
    r
}

/// The scalar path's record with sine `S`: the reference the lane widths
/// are checked against. Its only refusals are a proposal's (its stream ends
/// after its K latents), so that equal records are equal outputs.
fn reference<S: Sine>(name: &str, model: &Model<'_>, pasts: &[Past]) -> Record {
    let mut scalar = Scalar::<S>(Box::new(Predictor::new(*model).unwrap()));
    let r = record(&mut scalar, model, pasts);
    for (what, o) in &r {
        if let Err(e) = o {
            let proposal = model.has_proposal() && *e == PredictError::BadSampleCount;
            assert!(proposal, "{name} {what}: {e:?}");
        }
    }
    r
}

/// One blob, sine `S`, `L` lanes: every batched entry point against `reference`.
fn check<S: Sine, const L: usize>(
    name: &str,
    model: &Model<'_>,
    pasts: &[Past],
    reference: &Record,
) {
    let mut batched = Batched::<S, L>(Box::new(BatchPredictor::new(*model).unwrap()));
    let got = record(&mut batched, model, pasts);
    assert_eq!(got.len(), reference.len(), "{name} L={L}");
    for ((what, want), (_, got)) in reference.iter().zip(&got) {
        assert_eq!(want, got, "{name} L={L} {what}");
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
                let libm = reference::<LibmSine>(&name, &model, &pasts);
                check::<LibmSine, 8>(&name, &model, &pasts, &libm);
                check::<LibmSine, 3>(&name, &model, &pasts, &libm);
                if model.parameter_count() < 500_000 {
                    let fast = reference::<FastSine>(&name, &model, &pasts);
                    check::<FastSine, 8>(&name, &model, &pasts, &fast);
                    // The extra lane width and path on the first 10 windows
                    // of the small models (the paper-size model's scalar
                    // side is what costs; the code is the same for all).
                    let few = &pasts[..pasts.len().min(10)];
                    let libm_few = reference::<LibmSine>(&name, &model, few);
                    // 16 lanes: two vectors per sum (4 rows at a time on AVX2).
                    check::<LibmSine, 16>(&name, &model, few, &libm_few);
                    // The portable SSE2 path, which a host with AVX2 skips
                    // (process-wide switch; the bits are the same either
                    // way, so other tests running meanwhile are unaffected).
                    set_wide_vectors(false);
                    check::<LibmSine, 8>(&name, &model, few, &libm_few);
                    set_wide_vectors(true);
                }
            }
            NumericKind::Int16Q15 => {
                let libm = reference::<LibmSine>(&name, &model, &pasts);
                check::<LibmSine, 8>(&name, &model, &pasts, &libm);
                check::<LibmSine, 3>(&name, &model, &pasts, &libm);
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
    assert_eq!((e.index, e.error), (2, PredictError::NonFiniteInput));
    // Tracks before the failing one are computed.
    let mut s = [[0.0f32; 2]; 2];
    scalar.predict_samples(&good, 0, &mut s).unwrap();
    assert_eq!(bits(&o[2..4]), bits(&s));
    assert_eq!(
        batch
            .predict_samples_many(&qs, 2, &mut o[..3])
            .unwrap_err()
            .error,
        PredictError::BadSampleCount
    );
    assert!(batch.predict_samples(&good, 0, &mut []).is_err());
}

/// What a planner gets ([`BatchPredictor::predict_forecasts`]: endpoints,
/// probabilities, point forecast, radii) equals the scalar sequence
/// (`Predictor::predict_planner`) bit for bit on the **whole** test set of
/// every shipped proposal blob (the latents in lanes: the shipped defaults),
/// at K = 20 with 8 lanes, and at K = 7 with 3 lanes (chunks that split
/// tracks) on every 11th window.
#[test]
fn batched_forecasts_equal_scalar_on_the_whole_test_set() {
    let blobs: Vec<_> = shipped_blobs()
        .into_iter()
        .filter(|p| {
            let b = std::fs::read(p).unwrap();
            Model::from_blob(&b).unwrap().has_proposal()
        })
        .collect();
    assert!(blobs.len() >= 3, "{blobs:?}");
    for path in blobs {
        let name = path.file_stem().unwrap().to_string_lossy().to_string();
        let blob = std::fs::read(&path).unwrap();
        let model = Model::from_blob(&blob).unwrap();
        let test = card_test_set(&path);
        let all: Vec<Past> = test.windows.iter().map(|w| w.obs()).collect();
        let every11: Vec<Past> = all.iter().step_by(11).copied().collect();
        forecasts_match::<8>(&name, model, &all, 20);
        forecasts_match::<3>(&name, model, &every11, 7);
    }
}

/// [`batched_forecasts_equal_scalar_on_the_whole_test_set`] for `L` lanes, `k` endpoints.
fn forecasts_match<const L: usize>(name: &str, model: Model<'_>, pasts: &[Past], k: usize) {
    let n = pasts.len();
    let queries: Vec<Query<'_>> = pasts
        .iter()
        .enumerate()
        .map(|(t, p)| Query {
            past: p,
            seed: t as u64,
        })
        .collect();
    let mut bp = Box::new(BatchPredictor::<LibmSine, 256, L>::new(model).unwrap());
    let (mut ends, mut probs) = (vec![[0.0f32; 2]; n * k], vec![0.0f32; n * k]);
    let mut outs = vec![
        gpecnet_core::planner::PlannerOutput {
            learned: false,
            point: None,
            radii: None,
        };
        n
    ];
    bp.predict_forecasts::<64>(&queries, k, &mut ends, &mut probs, &mut outs)
        .unwrap_or_else(|e| panic!("{name}: {e}"));
    let mut p = Box::new(Predictor::<LibmSine, 256>::new(model).unwrap());
    let (mut e1, mut p1) = (vec![[0.0f32; 2]; k], vec![0.0f32; k]);
    for (t, past) in pasts.iter().enumerate() {
        let want = p
            .predict_planner::<64>(past, t as u64, &mut e1, &mut p1)
            .unwrap_or_else(|e| panic!("{name} window {t}: {e}"));
        let r = t * k..(t + 1) * k;
        assert_eq!(
            bits(&ends[r.clone()]),
            bits(&e1),
            "{name} L={L} k={k} window {t}"
        );
        let pb = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(
            pb(&probs[r]),
            pb(&p1),
            "{name} L={L} window {t} probabilities"
        );
        let got = &outs[t];
        assert_eq!(got.learned, want.learned, "{name} window {t}");
        assert_eq!(
            got.point.as_ref().map(|t| bits(t)),
            want.point.as_ref().map(|t| bits(t)),
            "{name} window {t} point"
        );
        let rb =
            |r: Option<gpecnet_core::planner::Radii>| r.map(|r| [r.r50, r.r90].map(f32::to_bits));
        assert_eq!(rb(got.radii), rb(want.radii), "{name} window {t} radii");
    }
}
