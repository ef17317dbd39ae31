//! The online loop (`gpecnet_core::online`) against its rules: the update rules against an
//! independent reference on a recorded feedback stream (bit for bit), the bounds under hostile
//! feedback (NaN, teleports, 10^6 updates), the forecaster under hostile detections (id
//! switches, stale and wrapping timestamps, long pauses), the loop off reproducing the
//! static forecast exactly, shared model outputs (`frame_with`) giving the same forecasts,
//! and `restore` refusing every damaged state.
use crate::common::xorshift32;

use gpecnet_core::online::{
    forecast, Calibration, Config, Forecaster, MotionState, OnlineError, TrackForecast, BINS,
    EXPERTS, HORIZONS, STATE_LEN,
};
use gpecnet_core::planner::Forecast;
use gpecnet_core::tracks::Observation;
use gpecnet_core::{LibmSine, Model, Predictor};

static BLOB: &[u8] = include_bytes!("../../weights/sdd-m-lp-qe.gpec");

/// A feedback event of a recorded stream: state, horizon, miss distance, scale, expert errors.
type Event = (MotionState, usize, f32, f32, [f32; EXPERTS]);

/// A deterministic stream of feedback: walkers whose errors grow with the horizon, some
/// standing, occasional teleports (id switches) and non-finite values.
fn recorded_stream(n: usize) -> Vec<Event> {
    let mut r = xorshift32(0x5eed_1234);
    let mut u = move || (r() >> 8) as f32 / 16_777_216.0;
    (0..n)
        .map(|i| {
            let state = MotionState::ALL[i % 7 % 4];
            let h = 1 + i % HORIZONS;
            let scale = 0.05 + 0.6 * u() * h as f32 / 12.0;
            let mut d = scale * 2.5 * u() * u();
            if i % 97 == 0 {
                d = 40.0 * u(); // a teleport
            }
            if i % 211 == 0 {
                d = f32::NAN; // refused feedback
            }
            let e = [0.9 * d, d + 0.1 * u(), d * (1.0 + u()), 0.5 + u()];
            (state, h, d, scale, e)
        })
        .collect()
}

/// The update rules written again from the module docs, independently of the core's code.
struct Reference {
    c: [[[f32; 2]; HORIZONS]; BINS],
    l: [[[f32; EXPERTS]; HORIZONS]; BINS],
}

impl Reference {
    fn new(cfg: &Config, initial: [f32; 2]) -> Self {
        let mut l = [[[0.0; EXPERTS]; HORIZONS]; BINS];
        for b in &mut l {
            for (h, cell) in b.iter_mut().enumerate() {
                let p = cfg.expert_prior * ((h + 1) as f32 / 12.0);
                *cell = [0.0, p, p, p];
            }
        }
        Reference {
            c: [[initial; HORIZONS]; BINS],
            l,
        }
    }

    fn update(&mut self, cfg: &Config, (state, h, d, scale, e): Event) {
        if !(d.is_finite() && scale.is_finite() && scale > 0.0 && e.iter().all(|x| x.is_finite())) {
            return;
        }
        let b = if cfg.motion_bins { state as usize } else { 0 };
        let cell = &mut self.c[b][h - 1];
        for (lvl, c) in cell.iter_mut().enumerate() {
            let a = cfg.alpha[lvl];
            let up = libm::expf(cfg.gamma * (1.0 - a));
            let down = libm::expf(-(cfg.gamma * a));
            let f = if d > *c * scale { up } else { down };
            *c = (*c * f).clamp(cfg.multiplier_bounds[0], cfg.multiplier_bounds[1]);
        }
        if cell[0] > cell[1] {
            cell[0] = cell[1];
        }
        let max = cfg.loss_cap / (1.0 - cfg.forgetting);
        for (l, &x) in self.l[b][h - 1].iter_mut().zip(&e) {
            *l = (cfg.forgetting * *l + x.min(cfg.loss_cap)).min(max);
        }
    }
}

#[test]
fn the_update_rules_match_an_independent_reference_bit_for_bit() {
    for bins in [true, false] {
        let cfg = Config {
            motion_bins: bins,
            ..Config::metres()
        };
        let initial = [0.47, 1.59];
        let mut cal = Calibration::new(cfg, initial).unwrap();
        let mut reference = Reference::new(&cfg, initial);
        let all = [true; EXPERTS];
        for ev in recorded_stream(20_000) {
            let (s, h, d, scale, e) = ev;
            cal.update(s, h, d, scale, e, all);
            reference.update(&cfg, ev);
        }
        for (b, state) in MotionState::ALL.iter().enumerate() {
            let b = if bins { b } else { 0 };
            for h in 1..=HORIZONS {
                let got = cal.multipliers(*state, h);
                assert_eq!(
                    got.map(f32::to_bits),
                    reference.c[b][h - 1].map(f32::to_bits),
                    "{state:?} h {h}"
                );
                // Rule 3 on the reference's losses.
                let l = reference.l[b][h - 1];
                let m = l.iter().copied().fold(f32::INFINITY, f32::min);
                let eta = cfg.eta / (h as f32 / 12.0);
                let w: Vec<f32> = l.iter().map(|x| libm::expf(-(eta * (x - m)))).collect();
                let s = w.iter().fold(0.0f32, |a, x| a + x);
                let want: Vec<u32> = w.iter().map(|x| (x / s).to_bits()).collect();
                let got = cal.weights(*state, h, [true; EXPERTS]).map(f32::to_bits);
                assert_eq!(got.to_vec(), want, "{state:?} h {h}");
            }
        }
    }
}

#[test]
fn a_million_hostile_updates_never_leave_the_bounds() {
    let cfg = Config::metres();
    let mut cal = Calibration::new(cfg, [0.47, 1.59]).unwrap();
    let mut r = xorshift32(77);
    let hostile = [
        f32::NAN,
        f32::INFINITY,
        -1.0,
        0.0,
        1e30,
        f32::MAX,
        1e-30,
        f32::MIN_POSITIVE,
    ];
    for i in 0..1_000_000u32 {
        let pick = |k: u32| hostile[(k % hostile.len() as u32) as usize];
        let x = r();
        let d = if x.is_multiple_of(3) {
            pick(x >> 4)
        } else {
            (x >> 8) as f32 / 1e6
        };
        let scale = if x.is_multiple_of(5) {
            pick(x >> 6)
        } else {
            0.3
        };
        let e = [d, pick(x >> 9), 0.2, (x % 100) as f32];
        let state = MotionState::ALL[(i % 4) as usize];
        cal.update(state, 1 + (x as usize % 14), d, scale, e, [true; EXPERTS]);
    }
    let [lo, hi] = cfg.multiplier_bounds;
    for state in MotionState::ALL {
        for h in 1..=HORIZONS {
            let [c50, c90] = cal.multipliers(state, h);
            assert!(
                lo <= c50 && c50 <= c90 && c90 <= hi,
                "{state:?} {h}: {c50} {c90}"
            );
            let w = cal.weights(state, h, [true; EXPERTS]);
            assert!(w.iter().all(|w| w.is_finite() && (0.0..=1.0).contains(w)));
            let s: f32 = w.iter().sum();
            assert!((s - 1.0).abs() < 1e-5, "{s}");
        }
    }
}

#[test]
fn restore_refuses_every_damaged_state_and_round_trips_a_good_one() {
    let mut cal = Calibration::new(Config::metres(), [0.47, 1.59]).unwrap();
    for ev in recorded_stream(3_000) {
        let (s, h, d, scale, e) = ev;
        cal.update(s, h, d, scale, e, [true; EXPERTS]);
    }
    let mut bytes = [0u8; STATE_LEN];
    assert_eq!(cal.state(&mut bytes), Ok(STATE_LEN));
    assert_eq!(
        cal.state(&mut [0u8; STATE_LEN - 1]),
        Err(OnlineError::BufferTooSmall)
    );
    let mut fresh = Calibration::new(Config::metres(), [0.47, 1.59]).unwrap();
    assert_ne!(fresh, cal);
    fresh.restore(&bytes).unwrap();
    assert_eq!(fresh, cal);
    // Every single-bit flip is refused and changes nothing.
    for i in 0..STATE_LEN {
        for bit in [0, 3, 7] {
            let mut bad = bytes;
            bad[i] ^= 1 << bit;
            let before = fresh.clone();
            assert!(fresh.restore(&bad).is_err(), "byte {i} bit {bit}");
            assert_eq!(fresh, before);
        }
    }
    assert_eq!(
        fresh.restore(&bytes[..STATE_LEN - 1]),
        Err(OnlineError::StateLength)
    );
    let mut bad = bytes;
    bad[0] = b'X';
    assert_eq!(fresh.restore(&bad), Err(OnlineError::StateMagic));
    // A value out of bounds, correctly checksummed, is refused too.
    let mut bad = bytes;
    bad[12..16].copy_from_slice(&f32::NAN.to_le_bytes());
    let crc = gpecnet_core::blob::CRC32.checksum(&bad[..STATE_LEN - 4]);
    bad[STATE_LEN - 4..].copy_from_slice(&crc.to_le_bytes());
    assert_eq!(fresh.restore(&bad), Err(OnlineError::StateValue));
    // Reset returns to the start.
    fresh.reset();
    assert_eq!(
        fresh,
        Calibration::new(Config::metres(), [0.47, 1.59]).unwrap()
    );
}

#[test]
fn configs_out_of_range_are_refused() {
    let good = Config::metres();
    let bad = [
        Config { gamma: 0.0, ..good },
        Config {
            gamma: f32::NAN,
            ..good
        },
        Config {
            alpha: [0.1, 0.5],
            ..good
        },
        Config {
            forgetting: 1.0,
            ..good
        },
        Config { eta: -1.0, ..good },
        Config {
            min_scale: 0.0,
            ..good
        },
        Config {
            multiplier_bounds: [1.0, 0.5],
            ..good
        },
        Config {
            speed_thresholds: [1.0, 0.5, 2.0],
            ..good
        },
        Config {
            expert_prior: 1e9,
            ..good
        },
    ];
    for c in bad {
        assert_eq!(c.validate(), Err(OnlineError::BadConfig), "{c:?}");
        assert!(Calibration::new(c, [0.5, 1.5]).is_err());
    }
    assert!(Calibration::new(good, [2.0, 1.0]).is_err(), "c50 above c90");
    assert!(Calibration::new(good, [0.5, f32::NAN]).is_err());
}

const PAST: [[f32; 2]; 8] = [
    [0.0, 0.0],
    [0.5, 0.1],
    [1.0, 0.2],
    [1.5, 0.2],
    [2.0, 0.3],
    [2.5, 0.4],
    [3.0, 0.4],
    [3.5, 0.5],
];

#[test]
fn with_the_loop_off_the_forecast_is_the_static_one_bit_for_bit() {
    let model = Model::from_blob(BLOB).unwrap();
    let mut p = Predictor::<LibmSine, 64>::new(model).unwrap();
    let cfg = Config {
        adapt: false,
        ..Config::metres()
    };
    let cal = Calibration::new(cfg, model.radius_scales()).unwrap();
    let mut fc = TrackForecast::<20>::new();
    forecast(&mut p, &cal, &PAST, 9, 0.4, &mut fc).unwrap();
    let f: Forecast<20> = p.predict_forecast(&PAST, 9).unwrap();
    let head = p.predict_point(&PAST).unwrap();
    assert_eq!(fc.endpoints, f.endpoints);
    assert_eq!(fc.probabilities, f.probabilities);
    for (a, b) in fc.point.iter().zip(head.iter()) {
        assert_eq!(a.map(f32::to_bits), b.map(f32::to_bits));
    }
    let r = f.radii.unwrap();
    assert_eq!(
        fc.radii[HORIZONS - 1],
        r,
        "the endpoint radius is the planner's"
    );
    assert_eq!(fc.static_radii, Some(r));
    assert!(
        fc.radii.windows(2).all(|w| w[0].r90 < w[1].r90),
        "the tube widens"
    );
    assert_eq!(fc.motion, MotionState::Walking, "{} m/s", fc.speed);
}

/// A walker at `v` m/s along x from `x0`, seen at time `t_ms`.
fn walker(id: u32, t_ms: u32, x0: f32, v: f32) -> Observation {
    Observation {
        id,
        pos: [x0 + v * t_ms as f32 / 1000.0, 1.0 + 0.1 * id as f32],
    }
}

#[test]
fn the_forecaster_survives_hostile_detections_and_keeps_its_radii_sane() {
    let model = Model::from_blob(BLOB).unwrap();
    let mut p = Predictor::<LibmSine, 64>::new(model).unwrap();
    let mut f: Box<Forecaster<8, 2>> =
        Box::new(Forecaster::new(&model, Config::metres(), 1_000).unwrap());
    let mut r = xorshift32(4242);
    let mut count = 0u32;
    // Start near the u32 wrap so the clock wraps mid-run.
    let mut t: u32 = u32::MAX - 30_000;
    for frame in 0..3_000u32 {
        t = t.wrapping_add(100);
        let x = r();
        let mut obs = vec![
            walker(1, frame * 100, 0.0, 1.2),
            walker(2, frame * 100, 5.0, 0.0),
        ];
        match x % 50 {
            // An id switch: track 1 teleports 30 m.
            0 => obs[0].pos[0] += 30.0,
            // A NaN detection.
            1 => obs[1].pos[1] = f32::NAN,
            // A burst of newcomers (more than the table holds).
            2 => obs.extend((10..30).map(|id| walker(id, frame * 100, -3.0, 0.8))),
            _ => {}
        }
        if frame % 700 == 350 {
            // A long pause: everything leaves, then comes back.
            t = t.wrapping_add(10_000);
        }
        let stale = x.is_multiple_of(173);
        let at = if stale { t.wrapping_sub(5_000) } else { t };
        let rep = f.frame::<LibmSine, 64, 20>(&mut p, at, &obs, |fc| {
            count += 1;
            for (h, rad) in fc.radii.iter().enumerate() {
                assert!(
                    rad.r50.is_finite() && rad.r50 > 0.0 && rad.r50 <= rad.r90,
                    "h {h}: {rad:?}"
                );
            }
            assert!(fc.point.iter().flatten().all(|v| v.is_finite()));
            let s: f32 = fc.weights.iter().sum();
            assert!((s - 1.0).abs() < 1e-5);
        });
        assert_eq!(rep.delta.stale, stale);
    }
    assert!(count > 1_000, "{count} forecasts");
    let cal = f.calibration();
    assert!(cal.feedback_count(MotionState::Walking) > 100);
    assert!(cal.feedback_count(MotionState::Standing) > 100);
}

#[test]
fn a_constant_velocity_scene_moves_the_weight_to_constant_velocity_and_covers_it() {
    // Walkers in straight lines: constant velocity is exact, the head is not. The loop must
    // learn that, and the r90 coverage of the loop's own pending forecasts must approach 0.9.
    let model = Model::from_blob(BLOB).unwrap();
    let mut p = Predictor::<LibmSine, 64>::new(model).unwrap();
    let mut f: Box<Forecaster<8, 12>> =
        Box::new(Forecaster::new(&model, Config::metres(), 1_000).unwrap());
    let mut last = [0.0f32; 4];
    for frame in 0..6_000u32 {
        let t = frame * 100;
        let obs: Vec<Observation> = (1..=4)
            .map(|id| walker(id, t % 60_000, -20.0, 0.4 * id as f32))
            .collect();
        if t % 60_000 == 0 {
            f.clear(); // the walkers restart: a new sequence
        }
        f.frame::<LibmSine, 64, 20>(&mut p, t % 60_000, &obs, |fc| last = fc.weights);
    }
    assert!(last[0] < 0.5, "the head keeps {last:?}");
}

/// `Forecaster::frame_with` fed model outputs computed once (by another forecaster over the
/// same detections) forecasts and learns exactly what `Forecaster::frame` does with its own
/// predictor: the host's loop-off / loop-on comparison runs the model once.
#[test]
fn shared_model_outputs_give_the_same_forecasts_and_calibration() {
    let model = Model::from_blob(BLOB).unwrap();
    let mut p = Predictor::<LibmSine, 64>::new(model).unwrap();
    let mut off_cfg = Config::metres();
    off_cfg.adapt = false;
    let mut own: Box<Forecaster<4, 2>> =
        Box::new(Forecaster::new(&model, Config::metres(), 1_000).unwrap());
    let mut first: Box<Forecaster<4, 2>> =
        Box::new(Forecaster::new(&model, off_cfg, 1_000).unwrap());
    let mut shared: Box<Forecaster<4, 2>> =
        Box::new(Forecaster::new(&model, Config::metres(), 1_000).unwrap());
    let mut r = xorshift32(77);
    let mut compared = 0;
    for frame in 0..600u32 {
        let t = frame * 100;
        let mut obs = vec![walker(1, t, 0.0, 1.3), walker(2, t, 4.0, 0.4)];
        if r().is_multiple_of(9) {
            obs[1].pos[0] += 0.5;
        }
        let mut want: Vec<TrackForecast<20>> = Vec::new();
        own.frame::<LibmSine, 64, 20>(&mut p, t, &obs, |fc| want.push(fc.clone()));
        // The first forecaster (loop off) computes the model's part; the second copies it.
        let mut made: Vec<(u64, TrackForecast<20>)> = Vec::new();
        first.frame_with::<20>(
            t,
            &obs,
            |past, seed, out| {
                gpecnet_core::online::model_outputs(&mut p, past, seed, out)?;
                made.push((seed, out.clone()));
                Ok(())
            },
            |_| {},
        );
        let mut got: Vec<TrackForecast<20>> = Vec::new();
        shared.frame_with::<20>(
            t,
            &obs,
            |_, seed, out| {
                let (_, done) = made.iter().find(|(s, _)| *s == seed).unwrap();
                out.copy_model_outputs(done);
                Ok(())
            },
            |fc| got.push(fc.clone()),
        );
        assert_eq!(got, want, "frame {frame}");
        compared += got.len();
    }
    assert!(compared > 200, "{compared} forecasts");
    let (mut a, mut b) = ([0u8; STATE_LEN], [0u8; STATE_LEN]);
    shared.calibration().state(&mut a).unwrap();
    own.calibration().state(&mut b).unwrap();
    assert_eq!(a, b, "the calibration learned the same");
}
