//! The online forecaster through the C ABI, called exactly as C calls it:
//! every bad argument is a status code (NULL, misaligned or short storage, a
//! predictor that is not initialised or of another blob, a too-small output
//! array, a stale time), the forecasts equal the core's `Forecaster` field
//! for field, and the calibration state survives a round trip while a
//! damaged one is refused.
use std::ptr::{null, null_mut};

use gpecnet_core::online::{Config, Forecaster, TrackForecast};
use gpecnet_core::tracks::Observation;
use gpecnet_core::units::CallerUnit;
use gpecnet_core::{LibmSine, Model, Predictor};
use gpecnet_ffi::*;

use crate::common::weights_static as weights;

/// Predictor storage as C declares it.
#[repr(C, align(8))]
struct PredMem([u8; GPECNET_PREDICTOR_SIZE]);

/// Forecaster storage as C declares it, with room to misalign it.
#[repr(C, align(8))]
struct FcMem([u8; GPECNET_FORECASTER_SIZE + 16]);

impl FcMem {
    fn new() -> Box<Self> {
        Box::new(FcMem([0; GPECNET_FORECASTER_SIZE + 16]))
    }
    fn f(&mut self) -> *mut GpecnetForecaster {
        self.0.as_mut_ptr().cast()
    }
}

/// A predictor of `blob` in metres.
fn predictor(blob: &'static [u8]) -> Box<PredMem> {
    let mut s = Box::new(PredMem([0; GPECNET_PREDICTOR_SIZE]));
    // SAFETY: test: storage and blob valid for their lengths; the blob is leaked ('static).
    let st = unsafe {
        gpecnet_init_units(
            s.0.as_mut_ptr().cast(),
            s.0.len(),
            blob.as_ptr(),
            blob.len(),
            GPECNET_UNIT_METRES,
            0.0,
        )
    };
    assert_eq!(st, GPECNET_OK);
    s
}

fn p(s: &mut PredMem) -> *mut GpecnetPredictor {
    s.0.as_mut_ptr().cast()
}

fn default_config() -> GpecnetOnlineConfig {
    let mut c = std::mem::MaybeUninit::<GpecnetOnlineConfig>::uninit();
    // SAFETY: test: a writable struct.
    assert_eq!(
        unsafe { gpecnet_online_config_default(c.as_mut_ptr()) },
        GPECNET_OK
    );
    // SAFETY: written on GPECNET_OK.
    unsafe { c.assume_init() }
}

fn init(f: &mut FcMem, pred: &mut PredMem, cfg: &GpecnetOnlineConfig) -> i32 {
    // SAFETY: test: storage valid for its length, an initialised predictor, a config.
    unsafe { gpecnet_forecaster_init(f.0.as_mut_ptr().cast(), f.0.len(), p(pred), cfg, 1_000) }
}

/// A forecaster of the metric model with probabilities, and its predictor.
fn setup() -> (Box<FcMem>, Box<PredMem>) {
    let mut pred = predictor(weights("sdd-m-lp-qe.gpec"));
    let mut f = FcMem::new();
    assert_eq!(init(&mut f, &mut pred, &default_config()), GPECNET_OK);
    (f, pred)
}

/// Two walkers at 10 Hz, frame `i` (metres).
fn dets(i: u32) -> [GpecnetDetection; 2] {
    let t = (i * 100) as f32 / 1000.0;
    [
        GpecnetDetection {
            id: 1,
            x: 1.2 * t,
            y: 0.5,
        },
        GpecnetDetection {
            id: 2,
            x: 3.0,
            y: -2.0 + 0.9 * t,
        },
    ]
}

/// One frame through the C ABI: (status, forecasts written, *n_out, report).
fn frame(
    f: &mut FcMem,
    pred: &mut PredMem,
    t_ms: u32,
    d: &[GpecnetDetection],
    cap: usize,
) -> (i32, Vec<GpecnetTrackForecast>, usize, GpecnetOnlineReport) {
    let mut out = Vec::<GpecnetTrackForecast>::with_capacity(cap);
    let mut n = usize::MAX;
    let mut rep = GpecnetOnlineReport::default();
    // SAFETY: test: initialised storages, `d.len()` detections, room for `cap` forecasts.
    let st = unsafe {
        gpecnet_forecaster_frame(
            f.f(),
            p(pred),
            t_ms,
            d.as_ptr(),
            d.len(),
            out.as_mut_ptr(),
            cap,
            &mut n,
            &mut rep,
        )
    };
    // SAFETY: the first min(n, cap) elements were written.
    unsafe { out.set_len(n.min(cap)) };
    (st, out, n, rep)
}

fn state(f: &mut FcMem) -> (i32, Vec<u8>) {
    let mut out = vec![0u8; GPECNET_ONLINE_STATE_LEN + 8];
    let mut n = 0usize;
    // SAFETY: test: an initialised forecaster, room for out.len() bytes.
    let st = unsafe { gpecnet_forecaster_state(f.f(), out.as_mut_ptr(), out.len(), &mut n) };
    out.truncate(n);
    (st, out)
}

fn restore(f: &mut FcMem, bytes: &[u8]) -> i32 {
    // SAFETY: test: an initialised forecaster, `bytes.len()` readable bytes.
    unsafe { gpecnet_forecaster_restore(f.f(), bytes.as_ptr(), bytes.len()) }
}

/// Runs frames `0..frames` of [`dets`]; returns every forecast.
fn run(
    f: &mut FcMem,
    pred: &mut PredMem,
    frames: std::ops::Range<u32>,
) -> Vec<GpecnetTrackForecast> {
    let mut all = Vec::new();
    for i in frames {
        let (st, out, n, rep) = frame(f, pred, i * 100, &dets(i), GPECNET_ONLINE_TRACKS);
        assert_eq!(st, GPECNET_OK);
        assert_eq!((n, rep.forecasts, rep.failed), (out.len(), n as u32, 0));
        all.extend(out);
    }
    all
}

#[test]
fn storage_constants_hold_the_forecaster() {
    let n = gpecnet_forecaster_size();
    println!("forecaster storage: {n} B of {GPECNET_FORECASTER_SIZE}");
    assert!(n <= GPECNET_FORECASTER_SIZE, "{n}");
    // The constant is a tight upper bound on the 64-bit host.
    assert!(GPECNET_FORECASTER_SIZE - n < 512, "{n}");
    assert_eq!(GPECNET_ONLINE_STATE_LEN, gpecnet_core::online::STATE_LEN);
}

#[test]
fn config_default_and_scaled_are_the_cores() {
    let c = default_config();
    assert_eq!(Config::from(c), Config::metres());
    assert_eq!(c.adapt, u8::from(Config::metres().adapt));
    assert_eq!(c.motion_bins, u8::from(Config::metres().motion_bins));
    let mut px = c;
    // SAFETY: test: the same struct in and out is allowed.
    let st = unsafe { gpecnet_online_config_scaled(&px, 25.0, &mut px) };
    assert_eq!(st, GPECNET_OK);
    assert_eq!(Config::from(px), Config::metres().scaled(25.0));
    // SAFETY: test: NULL pointers are refused before any access.
    unsafe {
        assert_eq!(
            gpecnet_online_config_default(null_mut()),
            GPECNET_E_NULL_POINTER
        );
        assert_eq!(
            gpecnet_online_config_scaled(null(), 1.0, &mut px),
            GPECNET_E_NULL_POINTER
        );
        assert_eq!(
            gpecnet_online_config_scaled(&c, 1.0, null_mut()),
            GPECNET_E_NULL_POINTER
        );
    }
}

#[test]
fn init_refuses_bad_arguments_and_marks_the_storage() {
    let mut pred = predictor(weights("sdd-m-lp-qe.gpec"));
    let cfg = default_config();
    let mut f = FcMem::new();
    let base = f.0.as_mut_ptr();
    let need = gpecnet_forecaster_size();
    // SAFETY: test: every pointer is NULL or valid for the length given.
    unsafe {
        let st = gpecnet_forecaster_init(null_mut(), need, p(&mut pred), &cfg, 1_000);
        assert_eq!(st, GPECNET_E_NULL_POINTER);
        let st = gpecnet_forecaster_init(base.add(4).cast(), need, p(&mut pred), &cfg, 1_000);
        assert_eq!(st, GPECNET_E_MISALIGNED);
        let st = gpecnet_forecaster_init(base.cast(), need - 1, p(&mut pred), &cfg, 1_000);
        assert_eq!(st, GPECNET_E_BAD_LENGTH);
        // A good init, then failed ones: each leaves the storage not initialised.
        assert_eq!(init(&mut f, &mut pred, &cfg), GPECNET_OK);
        let st = gpecnet_forecaster_init(base.cast(), need, p(&mut pred), null(), 1_000);
        assert_eq!(st, GPECNET_E_NULL_POINTER);
        assert_eq!(gpecnet_forecaster_reset(f.f()), GPECNET_E_NOT_INITIALISED);
        let st = gpecnet_forecaster_init(base.cast(), need, null(), &cfg, 1_000);
        assert_eq!(st, GPECNET_E_NULL_POINTER);
        let mut blank = Box::new(PredMem([0; GPECNET_PREDICTOR_SIZE]));
        let st = gpecnet_forecaster_init(base.cast(), need, p(&mut blank), &cfg, 1_000);
        assert_eq!(st, GPECNET_E_NOT_INITIALISED);
        let mut bad = cfg;
        bad.alpha = [0.1, 0.5]; // r90's miss rate above r50's
        let st = gpecnet_forecaster_init(base.cast(), need, p(&mut pred), &bad, 1_000);
        assert_eq!(st, GPECNET_E_ONLINE_BAD_CONFIG);
        assert_eq!(gpecnet_forecaster_clear(f.f()), GPECNET_E_NOT_INITIALISED);
        bad = cfg;
        bad.multiplier_bounds = [2.0, 3.0]; // the blob's multipliers outside them
        let st = gpecnet_forecaster_init(base.cast(), need, p(&mut pred), &bad, 1_000);
        assert_eq!(st, GPECNET_E_ONLINE_BAD_CONFIG);
        // Exactly the size it reports is enough.
        let st = gpecnet_forecaster_init(base.cast(), need, p(&mut pred), &cfg, 1_000);
        assert_eq!(st, GPECNET_OK);
    }
    // A zero-filled storage is not initialised.
    let mut zero = FcMem::new();
    // SAFETY: test: a zero-filled, aligned storage.
    assert_eq!(
        unsafe { gpecnet_forecaster_reset(zero.f()) },
        GPECNET_E_NOT_INITIALISED
    );
}

#[test]
fn frame_refuses_bad_arguments() {
    let (mut f, mut pred) = setup();
    let d = dets(0);
    let mut out = [std::mem::MaybeUninit::<GpecnetTrackForecast>::uninit(); 2];
    let o = out.as_mut_ptr().cast::<GpecnetTrackForecast>();
    let mut n = 7usize;
    let fp = f.f();
    let pp = p(&mut pred);
    // SAFETY: test: every pointer is NULL or valid for the length given.
    unsafe {
        let call = |f, p, dets, nd, out, cap, n_out| {
            gpecnet_forecaster_frame(f, p, 0, dets, nd, out, cap, n_out, null_mut())
        };
        assert_eq!(
            call(fp, pp, d.as_ptr(), 2, o, 2, null_mut()),
            GPECNET_E_NULL_POINTER
        );
        assert_eq!(
            call(null_mut(), pp, d.as_ptr(), 2, o, 2, &mut n),
            GPECNET_E_NULL_POINTER
        );
        assert_eq!(n, 0);
        assert_eq!(
            call(fp, null_mut(), d.as_ptr(), 2, o, 2, &mut n),
            GPECNET_E_NULL_POINTER
        );
        assert_eq!(
            call(fp, pp, null(), 2, o, 2, &mut n),
            GPECNET_E_NULL_POINTER
        );
        assert_eq!(
            call(fp, pp, d.as_ptr(), 2, null_mut(), 2, &mut n),
            GPECNET_E_NULL_POINTER
        );
        let mis = f.0.as_mut_ptr().add(4).cast();
        assert_eq!(
            call(mis, pp, d.as_ptr(), 2, o, 2, &mut n),
            GPECNET_E_MISALIGNED
        );
        let mut blank = Box::new(PredMem([0; GPECNET_PREDICTOR_SIZE]));
        assert_eq!(
            call(fp, p(&mut blank), d.as_ptr(), 2, o, 2, &mut n),
            GPECNET_E_NOT_INITIALISED
        );
        // No detections and no output array are fine: an empty frame.
        assert_eq!(call(fp, pp, null(), 0, null_mut(), 0, &mut n), GPECNET_OK);
        assert_eq!(n, 0);
        // A time before the last one refuses the whole call.
        assert_eq!(call(fp, pp, d.as_ptr(), 2, o, 2, &mut n), GPECNET_OK);
        assert_eq!(call(fp, pp, d.as_ptr(), 2, o, 2, &mut n), GPECNET_OK);
        let st = gpecnet_forecaster_frame(fp, pp, 0, d.as_ptr(), 2, o, 2, &mut n, null_mut());
        assert_eq!(st, GPECNET_OK, "the same time continues the frame");
    }
    assert_eq!(frame(&mut f, &mut pred, 500, &d, 2).0, GPECNET_OK);
    assert_eq!(
        frame(&mut f, &mut pred, 400, &d, 2).0,
        GPECNET_E_TRACKS_STALE_TIME
    );
}

#[test]
fn a_predictor_of_another_blob_or_unit_is_refused() {
    let (mut f, _pred) = setup();
    let mut other = predictor(weights("sdd-m-tiny-qe.gpec"));
    let d = dets(0);
    let (st, _, n, _) = frame(&mut f, &mut other, 0, &d, 2);
    assert_eq!((st, n), (GPECNET_E_ONLINE_OTHER_MODEL, 0));
    // The same blob declared in another unit converts differently.
    let blob = weights("sdd-m-lp-qe.gpec");
    let mut px = Box::new(PredMem([0; GPECNET_PREDICTOR_SIZE]));
    // SAFETY: test: storage and blob valid for their lengths; the blob is leaked ('static).
    let st = unsafe {
        gpecnet_init_units(
            px.0.as_mut_ptr().cast(),
            px.0.len(),
            blob.as_ptr(),
            blob.len(),
            GPECNET_UNIT_SCALED_PIXELS,
            0.04,
        )
    };
    assert_eq!(st, GPECNET_OK);
    assert_eq!(
        frame(&mut f, &mut px, 0, &d, 2).0,
        GPECNET_E_ONLINE_OTHER_MODEL
    );
}

/// More forecasts than the output array holds: the first `out_cap` are
/// written, `*n_out` and the report say how many the frame made, the status
/// says some were dropped, and the frame was applied all the same (the
/// forecaster goes on exactly as one given a large enough array).
#[test]
fn a_too_small_output_array_drops_and_counts() {
    let (mut small, mut pred) = setup();
    let (mut full, _) = setup();
    let mut dropped = 0;
    for i in 0..80 {
        let d = dets(i);
        let (st_s, out_s, n_s, rep_s) = frame(&mut small, &mut pred, i * 100, &d, 1);
        let (st_f, out_f, n_f, rep_f) =
            frame(&mut full, &mut pred, i * 100, &d, GPECNET_ONLINE_TRACKS);
        assert_eq!(st_f, GPECNET_OK);
        assert_eq!(n_s, n_f);
        assert_eq!(out_s.first(), out_f.first());
        if n_f > 1 {
            assert_eq!(st_s, GPECNET_E_ONLINE_FORECASTS_DROPPED);
            assert_eq!(out_s.len(), 1);
            assert_eq!(rep_s.dropped, n_f as u32 - 1);
            dropped += 1;
        } else {
            assert_eq!(st_s, GPECNET_OK);
        }
        assert_eq!(rep_s.forecasts, rep_f.forecasts);
        assert_eq!(rep_s.feedback, rep_f.feedback);
    }
    assert!(dropped > 10, "{dropped}");
}

/// Field for field what the core's `Forecaster<16, 2>` gives for the same
/// frames, and the same feedback counts.
#[test]
fn forecasts_are_the_cores() {
    let (mut f, mut pred) = setup();
    let got = run(&mut f, &mut pred, 0..120);

    let blob = weights("sdd-m-lp-qe.gpec");
    let model = Model::from_blob(blob).unwrap();
    let mut cp = Predictor::<LibmSine, 128>::with_units(model, CallerUnit::Metres).unwrap();
    let mut cf: Forecaster<16, 2> = Forecaster::new(&model, Config::metres(), 1_000).unwrap();
    let mut want: Vec<TrackForecast<20>> = Vec::new();
    for i in 0..120 {
        let obs: Vec<Observation> = dets(i)
            .iter()
            .map(|d| Observation {
                id: d.id,
                pos: [d.x, d.y],
            })
            .collect();
        cf.frame::<_, 128, 20>(&mut cp, i * 100, &obs, |fc| want.push(fc.clone()));
    }
    assert!(want.len() > 40, "{}", want.len());
    assert_eq!(got.len(), want.len());
    for (g, w) in got.iter().zip(&want) {
        let n = w.endpoints.len();
        assert_eq!(
            (g.id, g.end_ms, g.n_endpoints as usize),
            (w.id, w.end_ms, n)
        );
        assert_eq!(g.speed.to_bits(), w.speed.to_bits());
        assert_eq!(g.motion, w.motion as u8);
        assert_eq!(g.learned, u8::from(w.learned));
        assert_eq!(&g.endpoints[..n], &w.endpoints[..]);
        assert_eq!(&g.probabilities[..n], &w.probabilities[..]);
        let head = w.head.as_ref().unwrap();
        assert_eq!((g.has_head, &g.head[..]), (1, &head[..]));
        assert_eq!(g.point, w.point);
        for h in 0..GPECNET_ONLINE_HORIZONS {
            assert_eq!((g.r50[h], g.r90[h]), (w.radii[h].r50, w.radii[h].r90));
        }
        assert_eq!((g.scale, g.weights), (w.scale, w.weights));
        let s = w.static_radii.unwrap();
        assert_eq!(g.static_radii, [s.r50, s.r90]);
    }
    let mut counts = [0u32; GPECNET_ONLINE_MOTION_STATES];
    // SAFETY: test: an initialised forecaster, room for 4 counts.
    let st = unsafe { gpecnet_forecaster_feedback(f.f(), counts.as_mut_ptr(), counts.len()) };
    assert_eq!(st, GPECNET_OK);
    let want_counts =
        gpecnet_core::online::MotionState::ALL.map(|s| cf.calibration().feedback_count(s));
    assert_eq!(counts, want_counts);
    assert!(counts.iter().sum::<u32>() > 0);
    // SAFETY: test: a short array is refused before any write.
    let st = unsafe { gpecnet_forecaster_feedback(f.f(), counts.as_mut_ptr(), 3) };
    assert_eq!(st, GPECNET_E_BAD_LENGTH);
}

/// More than GPECNET_ONLINE_MAX_DETECTIONS detections in one call: applied in
/// pieces; 16 tracks at most, the rest counted as rejected.
#[test]
fn many_detections_are_applied_in_pieces() {
    let (mut f, mut pred) = setup();
    let many: Vec<GpecnetDetection> = (0..150u32)
        .map(|id| GpecnetDetection {
            id,
            x: id as f32,
            y: 0.0,
        })
        .collect();
    let (st, _, _, rep) = frame(&mut f, &mut pred, 0, &many, GPECNET_ONLINE_TRACKS);
    assert_eq!(st, GPECNET_OK);
    assert_eq!(rep.entered as usize, GPECNET_ONLINE_TRACKS);
    assert_eq!(rep.rejected as usize, 150 - GPECNET_ONLINE_TRACKS);
}

/// The calibration state after a run restores into a fresh forecaster, which
/// then writes the same bytes and forecasts exactly as the original; reset
/// returns to a fresh forecaster's state.
#[test]
fn state_restore_round_trip() {
    let (mut a, mut pred) = setup();
    let (fresh_st, fresh) = state(&mut a);
    assert_eq!(fresh_st, GPECNET_OK);
    run(&mut a, &mut pred, 0..100);
    let (st, bytes) = state(&mut a);
    assert_eq!((st, bytes.len()), (GPECNET_OK, GPECNET_ONLINE_STATE_LEN));
    assert_ne!(bytes, fresh, "the loop learned something");

    let (mut b, _) = setup();
    assert_eq!(restore(&mut b, &bytes), GPECNET_OK);
    assert_eq!(state(&mut b).1, bytes);
    // Same calibration, same tracks from here on: the same forecasts.
    // SAFETY: test: an initialised forecaster.
    assert_eq!(unsafe { gpecnet_forecaster_clear(a.f()) }, GPECNET_OK);
    let fa = run(&mut a, &mut pred, 100..160);
    let fb = run(&mut b, &mut pred, 100..160);
    assert!(!fa.is_empty());
    assert_eq!(fa, fb);

    // SAFETY: test: an initialised forecaster.
    assert_eq!(unsafe { gpecnet_forecaster_reset(b.f()) }, GPECNET_OK);
    assert_eq!(state(&mut b).1, fresh);
}

/// A damaged, cut or foreign state is refused with its status and changes
/// nothing; a short output buffer is refused before any write.
#[test]
fn corrupt_state_is_refused() {
    let (mut f, mut pred) = setup();
    run(&mut f, &mut pred, 0..100);
    let (_, good) = state(&mut f);
    let (mut g, _) = setup();
    let (_, before) = state(&mut g);
    // Every single-bit flip: the CRC catches it, or the header's own check
    // for the magic, version and shape bytes (the 12-byte header).
    for (i, bit) in (0..good.len()).flat_map(|i| (0..8).map(move |b| (i, b))) {
        let mut bad = good.clone();
        bad[i] ^= 1 << bit;
        let st = restore(&mut g, &bad);
        let want = match i {
            0..=3 => GPECNET_E_ONLINE_STATE_MAGIC,
            4 => GPECNET_E_ONLINE_STATE_VERSION,
            // bins, horizons, levels, experts and the reserved zeros
            5..=11 => GPECNET_E_ONLINE_STATE_SHAPE,
            _ => GPECNET_E_ONLINE_STATE_CRC,
        };
        assert_eq!(st, want, "byte {i} bit {bit}");
    }
    assert_eq!(
        restore(&mut g, &good[..good.len() - 1]),
        GPECNET_E_ONLINE_STATE_LENGTH
    );
    let mut long = good.clone();
    long.push(0);
    assert_eq!(restore(&mut g, &long), GPECNET_E_ONLINE_STATE_LENGTH);
    assert_eq!(state(&mut g).1, before, "nothing changed");
    // SAFETY: test: NULL pointers and a short buffer are refused before any access.
    unsafe {
        assert_eq!(
            gpecnet_forecaster_restore(g.f(), null(), GPECNET_ONLINE_STATE_LEN),
            GPECNET_E_NULL_POINTER
        );
        let mut buf = [0u8; GPECNET_ONLINE_STATE_LEN];
        let mut n = 0usize;
        let st = gpecnet_forecaster_state(g.f(), buf.as_mut_ptr(), buf.len() - 1, &mut n);
        assert_eq!((st, n), (GPECNET_E_ONLINE_BUFFER_TOO_SMALL, 0));
        assert_eq!(buf, [0u8; GPECNET_ONLINE_STATE_LEN]);
        let st = gpecnet_forecaster_state(g.f(), null_mut(), buf.len(), &mut n);
        assert_eq!(st, GPECNET_E_NULL_POINTER);
        let st = gpecnet_forecaster_state(g.f(), buf.as_mut_ptr(), buf.len(), null_mut());
        assert_eq!(st, GPECNET_E_NULL_POINTER);
        let st = gpecnet_forecaster_state(null(), buf.as_mut_ptr(), buf.len(), &mut n);
        assert_eq!(st, GPECNET_E_NULL_POINTER);
    }
    // A state whose values are outside this forecaster's bounds (a
    // multiplier above c_max), re-sealed with a valid CRC.
    let mut cfg = default_config();
    cfg.multiplier_bounds = [0.02, 5.0];
    let mut tight = FcMem::new();
    assert_eq!(init(&mut tight, &mut pred, &cfg), GPECNET_OK);
    let mut out_of_bounds = good.clone();
    out_of_bounds[12..16].copy_from_slice(&10.0f32.to_le_bytes());
    out_of_bounds[16..20].copy_from_slice(&20.0f32.to_le_bytes());
    let n = out_of_bounds.len();
    let crc = gpecnet_core::blob::CRC32.checksum(&out_of_bounds[..n - 4]);
    out_of_bounds[n - 4..].copy_from_slice(&crc.to_le_bytes());
    assert_eq!(
        restore(&mut tight, &out_of_bounds),
        GPECNET_E_ONLINE_STATE_VALUE
    );
}

#[test]
fn every_online_status_has_its_text() {
    for (code, text) in [
        (GPECNET_E_ONLINE_BAD_CONFIG, "config out of range"),
        (GPECNET_E_ONLINE_MODEL_SHAPE, "12 steps from 8"),
        (GPECNET_E_ONLINE_STATE_LENGTH, "wrong length"),
        (GPECNET_E_ONLINE_STATE_MAGIC, "bad magic"),
        (GPECNET_E_ONLINE_STATE_VERSION, "layout version"),
        (GPECNET_E_ONLINE_STATE_SHAPE, "another shape"),
        (GPECNET_E_ONLINE_STATE_CRC, "checksum mismatch"),
        (GPECNET_E_ONLINE_STATE_VALUE, "bounds"),
        (GPECNET_E_ONLINE_BUFFER_TOO_SMALL, "too small"),
        (GPECNET_E_ONLINE_FORECASTS_DROPPED, "dropped"),
        (GPECNET_E_ONLINE_OTHER_MODEL, "initialised with"),
    ] {
        // SAFETY: gpecnet_status_str returns a static NUL-terminated string.
        let s = unsafe { std::ffi::CStr::from_ptr(gpecnet_status_str(code)) };
        assert!(s.to_str().unwrap().contains(text), "{code}: {s:?}");
    }
}
