//! Input guards: the same inputs give the same typed error on the f32 and the
//! fixed-point engine (the shipped `sdd-tiny-v2` pair: one model, two numeric
//! kinds), and nothing outside the documented range produces a number.
use gpecnet_core::frame::{MAX_COORDINATE, MAX_INPUT};
use gpecnet_core::{LibmSine, Model, PredictError, Predictor, Trajectory};

static F32: &[u8] = include_bytes!("../../weights/sdd-tiny-v2.gpec");
static Q15: &[u8] = include_bytes!("../../weights/sdd-tiny-v2-qe.gpec");

/// A pedestrian walking right and slightly down, about 2.5 px per 0.4 s step (SDD pixels).
const PAST: [[f32; 2]; 8] = walk([512.0, 300.0], [2.3, 1.1]);

/// Eight positions from `start`, `step` apart.
const fn walk(start: [f32; 2], step: [f32; 2]) -> [[f32; 2]; 8] {
    let mut p = [start; 8];
    let mut t = 1;
    while t < 8 {
        p[t] = [p[t - 1][0] + step[0], p[t - 1][1] + step[1]];
        t += 1;
    }
    p
}

type P = Predictor<'static, LibmSine, 64>;

fn both() -> [Box<P>; 2] {
    [F32, Q15].map(|b| Box::new(P::new(Model::from_blob(b).unwrap()).unwrap()))
}

/// Every way to ask: point forecast, endpoint set, plain samples, a stream.
fn all_calls(p: &mut P, past: &[[f32; 2]]) -> [Result<(), PredictError>; 4] {
    let mut ends = [[0.0f32; 2]; 20];
    [
        p.predict_point(past).map(|t| assert_eq!(t.len(), 12)),
        p.predict_endpoint_set::<128>(past, 1, &mut ends),
        p.predict_samples(past, 1, &mut ends[..3]),
        p.start(past, 1).and_then(|_| p.next_endpoint().map(|_| ())),
    ]
}

/// Every output of every call is finite and within reach of the track.
fn assert_sane(p: &mut P, past: &[[f32; 2]]) {
    let mut ends = [[0.0f32; 2]; 20];
    p.predict_endpoint_set::<128>(past, 3, &mut ends).unwrap();
    let t = p.predict_point(past).unwrap();
    let last = past[7];
    for e in ends.iter().chain(t.iter()) {
        assert!(e[0].is_finite() && e[1].is_finite());
        let d = ((e[0] - last[0]).powi(2) + (e[1] - last[1]).powi(2)).sqrt();
        assert!(d < 5_000.0, "{e:?} is {d} from the last point");
    }
}

fn with(i: usize, v: [f32; 2]) -> [[f32; 2]; 8] {
    let mut p = PAST;
    p[i] = v;
    p
}

#[test]
fn the_pair_has_the_same_limits() {
    let [f, q] = both();
    assert_eq!(f.model().input_limit(), MAX_INPUT);
    assert_eq!(q.model().input_limit(), MAX_INPUT);
    assert_eq!((f.sine_name(), q.sine_name()), ("libm", "q15-table"));
}

#[test]
fn non_finite_coordinates_are_refused_alike() {
    for v in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
        for i in [0, 3, 7] {
            for past in [with(i, [v, 300.0]), with(i, [512.0, v])] {
                for mut p in both() {
                    for r in all_calls(&mut p, &past) {
                        assert_eq!(r, Err(PredictError::NonFiniteInput));
                    }
                }
            }
        }
    }
}

#[test]
fn huge_coordinates_are_refused_alike() {
    for v in [
        1e30,
        -1e30,
        3e38,
        f32::MAX,
        1.0e7,
        1.0e8,
        MAX_COORDINATE * 1.0001,
    ] {
        for i in [0, 7] {
            for mut p in both() {
                for r in all_calls(&mut p, &with(i, [v, 300.0])) {
                    assert_eq!(r, Err(PredictError::InputOutOfRange), "{v} at {i}");
                }
            }
        }
        // The whole track far away (a large offset): refused too, not shifted silently.
        let far: Vec<[f32; 2]> = PAST.iter().map(|p| [p[0] + v, p[1]]).collect();
        for mut p in both() {
            for r in all_calls(&mut p, &far) {
                assert_eq!(r, Err(PredictError::InputOutOfRange), "offset {v}");
            }
        }
    }
}

#[test]
fn the_edge_of_the_coordinate_range_is_accepted_and_sane() {
    // The track moved to just inside ±MAX_COORDINATE: still a forecast near it.
    let off = MAX_COORDINATE - 2_000.0;
    let far: Vec<[f32; 2]> = PAST.iter().map(|p| [p[0] + off, p[1] - off]).collect();
    for mut p in both() {
        assert_sane(&mut p, &far);
    }
}

#[test]
fn displacement_beyond_the_input_limit_is_refused_alike() {
    // 1.86 per pixel: the limit is 4096 / 1.86 = 2202 px from the first point.
    let limit_px = MAX_INPUT / 1.86;
    for (dx, ok) in [(limit_px * 0.99, true), (limit_px * 1.01, false)] {
        let past = with(7, [512.0 + dx, 300.0]);
        for mut p in both() {
            let r = all_calls(&mut p, &past);
            if ok {
                assert!(r.iter().all(|r| r.is_ok()), "{dx}: {r:?}");
            } else {
                assert!(r.iter().all(|r| *r == Err(PredictError::InputOutOfRange)));
            }
        }
    }
}

#[test]
fn standing_still_is_a_forecast_near_the_pedestrian() {
    for mut p in both() {
        assert_sane(&mut p, &[[700.0, 250.0]; 8]);
        assert_sane(&mut p, &[[0.0, 0.0]; 8]);
    }
}

#[test]
fn counts_and_capacities() {
    for mut p in both() {
        let mut none: [[f32; 2]; 0] = [];
        // K = 0.
        assert_eq!(
            p.predict_endpoint_set::<128>(&PAST, 1, &mut none),
            Err(PredictError::BadSampleCount)
        );
        assert_eq!(
            p.predict_samples(&PAST, 1, &mut none),
            Err(PredictError::BadSampleCount)
        );
        // K above the model's 80 test-time samples.
        let mut many = [[0.0f32; 2]; 81];
        assert_eq!(
            p.predict_endpoint_set::<128>(&PAST, 1, &mut many),
            Err(PredictError::BadSampleCount)
        );
        // A sample buffer N below the 80 the model draws: a capacity error, not a wrong answer.
        let mut ends = [[0.0f32; 2]; 20];
        assert_eq!(
            p.predict_endpoint_set::<79>(&PAST, 1, &mut ends),
            Err(PredictError::CapacityExceeded)
        );
        // Wrong track lengths.
        assert_eq!(
            p.predict_point(&PAST[..7]),
            Err(PredictError::WrongPastLength {
                expected: 8,
                got: 7
            })
        );
        assert!(p.predict_point(&[]).is_err());
        // Trajectories only from a model with a predictor network.
        let mut t = [Trajectory::new()];
        let r = p.predict_trajectories(&PAST, 1, &mut t);
        if p.model().has_predictor() {
            assert_eq!((r, t[0].len()), (Ok(()), 12));
        } else {
            assert_eq!(r, Err(PredictError::NoPredictor));
        }
    }
}

#[test]
fn a_stream_is_the_same_as_one_call() {
    for mut p in both() {
        let mut ends = [[0.0f32; 2]; 12];
        p.predict_samples(&PAST, 9, &mut ends).unwrap();
        assert_eq!(p.next_endpoint().map(|_| ()), Ok(()), "the stream goes on");
        p.start(&PAST, 9).unwrap();
        // A point forecast in the middle does not disturb the stream.
        for (i, e) in ends.iter().enumerate() {
            if i == 5 {
                p.predict_point(&PAST).unwrap();
            }
            assert_eq!(p.next_endpoint().unwrap(), *e);
        }
        // A failed start ends the stream.
        assert!(p.start(&PAST[..3], 9).is_err());
        assert_eq!(p.next_endpoint(), Err(PredictError::NotStarted));
    }
}

#[test]
fn a_fresh_predictor_has_no_stream() {
    for mut p in both() {
        assert_eq!(p.next_endpoint(), Err(PredictError::NotStarted));
        let want = if p.model().has_predictor() {
            PredictError::NotStarted
        } else {
            PredictError::NoPredictor
        };
        assert_eq!(p.last_trajectory(), Err(want));
    }
}

/// The predictor owns its model view (one lifetime): it can live in a
/// `static` and move between threads / tasks.
#[test]
fn a_predictor_lives_in_a_static() {
    static SLOT: std::sync::Mutex<Option<P>> = std::sync::Mutex::new(None);
    *SLOT.lock().unwrap() = Some(P::new(Model::from_blob(Q15).unwrap()).unwrap());
    let ends = std::thread::spawn(|| {
        let mut guard = SLOT.lock().unwrap();
        let p = guard.as_mut().unwrap();
        let mut ends = [[0.0f32; 2]; 20];
        p.predict_endpoint_set::<128>(&PAST, 5, &mut ends).unwrap();
        ends
    })
    .join()
    .unwrap();
    let mut again = [[0.0f32; 2]; 20];
    let [_, mut q] = both();
    q.predict_endpoint_set::<128>(&PAST, 5, &mut again).unwrap();
    assert_eq!(ends, again);
}

/// A doctored but valid blob (the decoder's output bias set to 10^9: finite, CRC correct,
/// every check of the reader passed) gives endpoints far beyond any input: refused with
/// `OutputOutOfRange` on every call that returns them, not returned as numbers.
#[test]
fn absurd_outputs_of_a_doctored_blob_are_refused() {
    let m = Model::from_blob(F32).unwrap();
    let dec = m.decoder();
    let last = dec.layer(dec.len() - 1).unwrap();
    let (_, bias, _) = last.tensors_q();
    let off = bias.as_ptr() as usize - F32.as_ptr() as usize;
    let mut blob = F32.to_vec();
    for i in 0..last.out_dim() {
        blob[off + 4 * i..off + 4 * i + 4].copy_from_slice(&1.0e9f32.to_le_bytes());
    }
    let n = blob.len() - 4;
    let crc = gpecnet_core::blob::CRC32.checksum(&blob[..n]);
    blob[n..].copy_from_slice(&crc.to_le_bytes());
    let model = Model::from_blob(&blob).expect("a valid blob");
    let mut p = Box::new(Predictor::<LibmSine, 64>::new(model).unwrap());
    let mut ends = [[0.0f32; 2]; 20];
    assert_eq!(
        p.predict_endpoint_set::<128>(&PAST, 1, &mut ends),
        Err(PredictError::OutputOutOfRange)
    );
    assert_eq!(
        p.predict_samples(&PAST, 1, &mut ends[..3]),
        Err(PredictError::OutputOutOfRange)
    );
    assert_eq!(
        p.start(&PAST, 1).and_then(|_| p.next_endpoint()),
        Err(PredictError::OutputOutOfRange)
    );
    // The point head is untouched: its forecast is still given, and near the track.
    let t = p.predict_point(&PAST).unwrap();
    assert!(t.iter().all(|q| (q[0] - PAST[7][0]).abs() < 5_000.0));
    // A track at the edge of the input range still gets its forecast from the shipped blob:
    // the bound leaves room for every real forecast there.
    let edge = walk([MAX_COORDINATE - 100.0, 0.0], [2.3, 1.1]);
    let mut real = Box::new(P::new(Model::from_blob(F32).unwrap()).unwrap());
    assert!(real
        .predict_endpoint_set::<128>(&edge, 1, &mut ends)
        .is_ok());
}
