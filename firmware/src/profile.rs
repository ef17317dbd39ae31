//! Profiling build (`--features profile`, driven by `cargo xtask profile`):
//! for each embedded model, one K = 20 prediction through the sine selected
//! at build time (GPECNET_SINE -> cfg `prof_sine`; `q15-table` = the
//! fixed-point engine for `Int16Q15` blobs), between `bench_start` and
//! `bench_end`. The QEMU TCG plugin (tools/insn_window.c) counts the guest
//! instructions executed between the two markers; on a real board
//! (`--features board`) DWT CYCCNT gives the cycles. A second window,
//! once per image after the models, measures the timed track table: one
//! model period (12 camera frames at 30 Hz) of 16 tracks in steady state
//! ([`track_table_period`]); a third, the camera stage for the same 16
//! pedestrians over the same period (pose, ground points, the measurement
//! model's σ, the per-track filter: [`camera_period`]); a fourth, when the
//! image embeds a signed blob, one signature verification
//! ([`verify_first_signed`]). An image built with
//! `GPECNET_PROFILE_EXTRAS=online` instead measures, after the models'
//! windows, one grid step of one pedestrian through the online forecaster:
//! its forecast (endpoints, probabilities, point forecast, per-step radii)
//! and the loop's update (`online_step`); in an image of its own, because
//! the forecaster's predictor links both engines, which changes how the
//! compiler lays out the measured call's code.
use core::hint::black_box;
use core::ptr::{addr_of_mut, write_volatile};

use gpecnet_core::planner::Radii;
use gpecnet_core::{Model, PredictError, Trajectory};
use heapless::Vec;

use crate::golden::MAX_SAMPLES;
use crate::SCRATCH;

#[cfg(prof_sine = "libm")]
type ProfSine = gpecnet_core::sine::LibmSine;
#[cfg(prof_sine = "fast-f32")]
type ProfSine = gpecnet_core::sine::FastSine;
#[cfg(all(prof_sine = "micromath", feature = "micromath"))]
type ProfSine = gpecnet_core::sine::MicromathSine;

/// The engine of this image's numeric path: one backend only, as an
/// integrator who knows the blob's kind would link it.
#[cfg(not(prof_sine = "q15-table"))]
type ProfPredictor<'a> = gpecnet_core::Engine<'a, gpecnet_core::float::Float<ProfSine>, SCRATCH>;
#[cfg(prof_sine = "q15-table")]
type ProfPredictor<'a> = gpecnet_core::Engine<'a, gpecnet_core::fixed::Q15, SCRATCH>;
#[cfg(not(prof_sine = "q15-table"))]
const PATH_NAME: &str = <ProfSine as gpecnet_core::Sine>::NAME;
#[cfg(prof_sine = "q15-table")]
const PATH_NAME: &str = gpecnet_core::fixed::SINE_NAME;

pub const K: usize = 20;

static mut BENCH_MARK: u32 = 0;

/// Marker: the plugin starts counting when this executes. Distinct body from
/// `bench_end`, so LTO cannot merge the two into one address.
#[inline(never)]
#[no_mangle]
pub extern "C" fn bench_start() {
    unsafe { write_volatile(addr_of_mut!(BENCH_MARK), 1) };
}

#[inline(never)]
#[no_mangle]
pub extern "C" fn bench_end() {
    unsafe { write_volatile(addr_of_mut!(BENCH_MARK), 2) };
}

/// The measured function: out of line, so its instruction count does not
/// depend on what LTO inlines around it. One call of what a planner asks for
/// (`Predictor::predict_planner`): the model's set of K = 20 endpoints (plain
/// samples, or test-time sampling when the blob says so), their probabilities,
/// the point forecast (when the model has a point head) and, for a model with
/// probabilities, the radii (`gpecnet_core::planner`).
#[inline(never)]
#[no_mangle]
pub fn gpecnet_predict_k20(
    p: &mut ProfPredictor<'_>,
    past: &[[f32; 2]; 8],
    seed: u64,
) -> Result<(Vec<[f32; 2], K>, Trajectory, [f32; K], Option<Radii>), PredictError> {
    let mut ends: Vec<[f32; 2], K> = Vec::new();
    let _ = ends.resize(K, [0.0; 2]);
    let mut probs = [0.0f32; K];
    let out = p.predict_planner::<MAX_SAMPLES>(past, seed, &mut ends, &mut probs)?;
    Ok((ends, out.point.unwrap_or_default(), probs, out.radii))
}

/// A pedestrian walking ~2.5 px per step (pixel units, like the SDD models).
const PAST: [[f32; 2]; 8] = [
    [512.0, 300.0],
    [514.0, 301.0],
    [516.5, 302.0],
    [519.0, 303.5],
    [521.0, 304.5],
    [523.5, 305.0],
    [526.0, 306.0],
    [528.0, 307.5],
];

#[cfg(prof_extras)]
/// Tracks of the track-table measurement.
pub const TRACKS: usize = 16;
#[cfg(prof_extras)]
/// Camera frames per model period at 30 Hz (400 ms / 33.3 ms).
pub const FRAMES_PER_PERIOD: u32 = 12;

#[cfg(prof_extras)]
/// Frame `f` of 16 pedestrians at 30 Hz (metres, walking), all detected.
fn frame_detections(f: u32) -> (u32, Vec<gpecnet_core::tracks::Observation, TRACKS>) {
    let t_ms = f * 1000 / 30;
    let t = t_ms as f32 / 1000.0;
    let mut v = Vec::new();
    for id in 0..TRACKS as u32 {
        let k = id as f32;
        let _ = v.push(gpecnet_core::tracks::Observation {
            id,
            pos: [k + 1.2 * t, 0.5 * k - 0.3 * t],
        });
    }
    (t_ms, v)
}

#[cfg(prof_extras)]
/// The measured track-table work: the updates of frames `from .. from + n`.
#[inline(never)]
#[no_mangle]
pub fn gpecnet_track_frames(
    table: &mut gpecnet_core::tracks::TimedTrackTable<TRACKS>,
    from: u32,
    n: u32,
) -> usize {
    let mut fresh = 0;
    for f in from..from + n {
        let (t_ms, obs) = frame_detections(f);
        table.update(t_ms, &obs);
        fresh += table.fresh().count();
    }
    fresh
}

#[cfg(prof_extras)]
/// One model period (12 frames at 30 Hz, one of them completing a grid
/// point for every track) of a 16-track table in steady state (3.6 s of
/// frames fed before), between the markers; logs the table's size.
fn track_table_period() -> bool {
    use gpecnet_core::tracks::{TimedTrack, TimedTrackTable};
    let period = core::num::NonZeroU32::MIN.saturating_add(399);
    let mut table: TimedTrackTable<TRACKS> = TimedTrackTable::new(period, 1_000);
    let warm = 108; // 3.6 s: every track full
    gpecnet_track_frames(&mut table, 0, warm);
    bench_start();
    let fresh = gpecnet_track_frames(black_box(&mut table), warm, black_box(FRAMES_PER_PERIOD));
    bench_end();
    defmt::println!(
        "tracktable tracks={=usize} frames={=u32} fresh={=usize} table_size={=u32} track_size={=u32}",
        TRACKS,
        FRAMES_PER_PERIOD,
        fresh,
        core::mem::size_of_val(&table) as u32,
        core::mem::size_of::<TimedTrack>() as u32
    );
    fresh == TRACKS
}

#[cfg(prof_online)]
/// The online measurement's forecaster: one pedestrian, two forecasts awaiting
/// their truth (the golden replay's and the C ABI's `P`).
type OnlineForecaster = gpecnet_core::online::Forecaster<1, 2>;

#[cfg(prof_online)]
/// The predictor the online forecaster drives (the engine follows the blob;
/// the sine is that of an f32 blob's path).
#[cfg(not(prof_sine = "q15-table"))]
type OnlinePredictor<'a> = gpecnet_core::Predictor<'a, ProfSine, SCRATCH>;
#[cfg(prof_online)]
#[cfg(prof_sine = "q15-table")]
type OnlinePredictor<'a> = gpecnet_core::Predictor<'a, gpecnet_core::LibmSine, SCRATCH>;

#[cfg(prof_online)]
/// Grid steps fed before the measured one (one camera frame per 0.4 s step):
/// 12 s, so the track's history is full and both forecasts are pending.
pub const ONLINE_WARM_STEPS: u32 = 30;

#[cfg(prof_online)]
/// A pedestrian walking at 1.3 m/s on a gentle curve, seen at grid step `k`
/// (metres, 0.4 s apart).
fn online_detection(k: u32) -> (u32, gpecnet_core::tracks::Observation) {
    let t = k as f32 * 0.4;
    let pos = [1.0 + 1.3 * t, 2.0 + 0.15 * t - 0.004 * t * t];
    (k * 400, gpecnet_core::tracks::Observation { id: 1, pos })
}

#[cfg(prof_online)]
/// The measured online work: one camera frame of one pedestrian that
/// completes a grid point (the track table's update, the feedback of the new
/// point to the pending forecasts, the forecast sequence
/// [`gpecnet_core::online::forecast`] with the loop on). Returns (forecasts,
/// feedback updates, FNV-1a over the forecast's point and radii).
#[inline(never)]
#[no_mangle]
pub fn gpecnet_online_step(
    f: &mut OnlineForecaster,
    p: &mut OnlinePredictor<'_>,
    t_ms: u32,
    detections: &[gpecnet_core::tracks::Observation],
) -> (u32, u32, u32) {
    let mut hash = 0;
    let r = f.frame::<_, SCRATCH, K>(p, t_ms, detections, |fc| {
        hash = gpecnet_core::golden::fnv1a(
            fc.point
                .iter()
                .flat_map(|q| [q[0].to_bits(), q[1].to_bits()])
                .chain(
                    fc.radii
                        .iter()
                        .flat_map(|r| [r.r50.to_bits(), r.r90.to_bits()]),
                ),
        );
    });
    (r.forecasts, r.feedback, hash)
}

#[cfg(prof_online)]
/// One grid step of one pedestrian through the online forecaster in steady
/// state ([`gpecnet_online_step`]), between the markers, with its stack; logs
/// the forecaster's RAM: its size with one and with two tracks, the track
/// table's share of a track, and the calibration. `true` when the model is not
/// one the loop takes at K = 20 (no period, or test-time sampling of more
/// than K samples: no window) or the step forecast and fed back.
fn online_step(name: &str, model: Model<'static>) -> bool {
    use core::mem::size_of;
    use gpecnet_core::online::{Calibration, Config, Forecaster};
    use gpecnet_core::tracks::TimedTrackTable;
    let Ok(mut f) = OnlineForecaster::new(&model, Config::metres(), 1_000) else {
        return true;
    };
    // `online::forecast` draws at most K samples: a model whose test-time sampling
    // needs more gives no endpoint set at K = 20.
    if gpecnet_core::sampling::max_endpoints_of(&model, K) == 0 {
        defmt::println!(
            "online-skipped {=str}: test-time sampling needs more than K = {=usize} samples",
            name,
            K
        );
        return true;
    }
    let Ok(mut p) = OnlinePredictor::new(model) else {
        return false;
    };
    for k in 0..ONLINE_WARM_STEPS {
        let (t_ms, d) = online_detection(k);
        f.frame::<_, SCRATCH, K>(&mut p, t_ms, &[d], |_| {});
    }
    let (t_ms, d) = online_detection(ONLINE_WARM_STEPS);
    let base = crate::stack::repaint();
    bench_start();
    let (forecasts, feedback, hash) =
        gpecnet_online_step(black_box(&mut f), black_box(&mut p), t_ms, black_box(&[d]));
    bench_end();
    let used = crate::stack::high_water().saturating_sub(base);
    let one = size_of::<Forecaster<1, 2>>();
    let two = size_of::<Forecaster<2, 2>>();
    let table_track = size_of::<TimedTrackTable<2>>() - size_of::<TimedTrackTable<1>>();
    defmt::println!(
        "online model={=str} forecasts={=u32} feedback={=u32} online_stack={=u32} forecaster_1={=u32} per_track={=u32} loop_per_track={=u32} calibration={=u32} predictor_size={=u32} hash={=u32:08x}",
        name,
        forecasts,
        feedback,
        used as u32,
        one as u32,
        (two - one) as u32,
        (two - one - table_track) as u32,
        size_of::<Calibration>() as u32,
        core::mem::size_of_val(&p) as u32,
        hash
    );
    forecasts == 1 && feedback > 0
}

#[cfg(prof_extras)]
/// The camera stage's frame `f` (30 Hz): the reported pose of a drone 30 m
/// up, flying at 0.5 m/s, its camera 56° down, and 16 pedestrians' pixels
/// (walking, spread over the image).
fn camera_frame(f: u32) -> (u32, gpecnet_core::camera::State, [[f32; 2]; TRACKS]) {
    let t_ms = f * 1000 / 30;
    let t = t_ms as f32 / 1000.0;
    let state = gpecnet_core::camera::State {
        attitude: [1.0, 0.0, 0.0, 0.0],
        position: [-20.0 + 0.5 * t, 0.2 * t, -30.0],
        gimbal: gpecnet_core::camera::Euler {
            roll: 0.0,
            pitch: -0.98,
            yaw: 0.0,
        },
        ground_down: 0.0,
    };
    let mut px = [[0.0f32; 2]; TRACKS];
    for (id, p) in px.iter_mut().enumerate() {
        let k = id as f32;
        *p = [200.0 + 95.0 * k + 12.0 * t, 300.0 + 30.0 * k - 5.0 * t];
    }
    (t_ms, state, px)
}

#[cfg(prof_extras)]
/// The measured camera stage: frames `from .. from + n`, each the reported
/// pose (`Pose::new`), every pedestrian's pixel to the ground with the
/// measurement model's σ (`image_to_ground`, `ground_covariance`) and the
/// per-track filter (`TrackFilter::update_with`); returns the detections
/// filtered.
#[inline(never)]
#[no_mangle]
pub fn gpecnet_camera_frames(
    filter: &mut gpecnet_core::tracks::filter::TrackFilter<TRACKS>,
    from: u32,
    n: u32,
) -> u32 {
    use gpecnet_core::camera::{MeasurementNoise, Pose};
    let camera = crate::golden::flight_camera();
    let noise = MeasurementNoise {
        pixel: 2.0,
        attitude: 0.0087,
    };
    let mut filtered = 0;
    for f in from..from + n {
        let (t_ms, state, px) = camera_frame(f);
        let Ok(pose) = Pose::new(&camera, &state) else {
            continue;
        };
        let mut obs: Vec<gpecnet_core::tracks::Observation, TRACKS> = Vec::new();
        let mut sigma = [0.0f32; TRACKS];
        for (id, uv) in px.iter().enumerate() {
            if let (Ok(g), Ok(c)) = (pose.image_to_ground(*uv), pose.ground_covariance(*uv, &noise)) {
                sigma[obs.len()] = c.sigma();
                let _ = obs.push(gpecnet_core::tracks::Observation {
                    id: id as u32,
                    pos: g,
                });
            }
        }
        let r = filter.update_with(t_ms, &mut obs, |i, _| sigma.get(i).copied().unwrap_or(f32::NAN));
        filtered += r.filtered;
    }
    filtered
}

#[cfg(prof_extras)]
/// One model period (12 frames at 30 Hz) of the camera stage for 16
/// pedestrians in steady state (every track filtered for 3.6 s before),
/// between the markers; logs the filter's size. `true` when every
/// detection of the window was filtered.
fn camera_period() -> bool {
    use gpecnet_core::tracks::filter::{FilterConfig, TrackFilter};
    let Ok(mut filter) = TrackFilter::<TRACKS>::new(FilterConfig::metres()) else {
        return false;
    };
    let warm = 108;
    gpecnet_camera_frames(&mut filter, 0, warm);
    bench_start();
    let filtered = gpecnet_camera_frames(black_box(&mut filter), warm, black_box(FRAMES_PER_PERIOD));
    bench_end();
    defmt::println!(
        "camera tracks={=usize} frames={=u32} filtered={=u32} filter_size={=u32}",
        TRACKS,
        FRAMES_PER_PERIOD,
        filtered,
        core::mem::size_of_val(&filter) as u32
    );
    filtered == TRACKS as u32 * FRAMES_PER_PERIOD
}

#[cfg(prof_extras)]
/// The measured verification: a signed blob against the compiled-in keys.
#[inline(never)]
#[no_mangle]
pub fn gpecnet_verify_blob(blob: &'static [u8]) -> Option<u32> {
    Model::from_signed_blob(blob, crate::models::TRUSTED_KEYS, 0)
        .ok()
        .map(|(_, v)| v)
}

#[cfg(prof_extras)]
/// One Ed25519 verification of the first embedded signed blob (once per
/// boot or update on a drone, not per prediction), between the markers,
/// with its stack; `true` when there is none or it verified.
fn verify_first_signed() -> bool {
    let Some(&(name, blob)) = crate::models::BLOBS
        .iter()
        .find(|(_, b)| gpecnet_core::blob::signed::split(b).is_some())
    else {
        return true;
    };
    let base = crate::stack::repaint();
    bench_start();
    let v = gpecnet_verify_blob(black_box(blob));
    bench_end();
    let used = crate::stack::high_water().saturating_sub(base);
    defmt::println!(
        "verify model={=str} bytes={=usize} ok={=bool} verify_stack={=u32}",
        name,
        blob.len(),
        v.is_some(),
        used as u32
    );
    v.is_some()
}

pub fn run() -> bool {
    let mut ok = !crate::models::BLOBS.is_empty();
    if !ok {
        defmt::error!("profile: no model embedded");
    }
    #[cfg(all(feature = "board", not(armv6m)))]
    let mut cp = unsafe { cortex_m::Peripherals::steal() };
    #[cfg(all(feature = "board", not(armv6m)))]
    {
        cp.DCB.enable_trace();
        cp.DWT.enable_cycle_counter();
    }
    for &(name, blob) in crate::models::BLOBS {
        crate::watchdog::feed();
        let model = match Model::from_blob(blob) {
            Ok(m) => m,
            Err(e) => {
                defmt::error!("profile {=str}: {}", name, e);
                ok = false;
                continue;
            }
        };
        let mut p = match ProfPredictor::new(model) {
            Ok(p) => p,
            Err(e) => {
                defmt::error!("profile {=str}: {}", name, e);
                ok = false;
                continue;
            }
        };
        let base = crate::stack::repaint();
        #[cfg(all(feature = "board", not(armv6m)))]
        let c0 = cortex_m::peripheral::DWT::cycle_count();
        bench_start();
        let r = gpecnet_predict_k20(black_box(&mut p), black_box(&PAST), black_box(0x5eed));
        bench_end();
        #[cfg(all(feature = "board", not(armv6m)))]
        {
            let c1 = cortex_m::peripheral::DWT::cycle_count();
            defmt::println!("cycles {=str} {=u32}", name, c1.wrapping_sub(c0));
        }
        let used = crate::stack::high_water().saturating_sub(base);
        match r {
            Ok((ends, point, probs, radii)) => {
                let r = radii.map(|r| [r.r50, r.r90]);
                let hash = gpecnet_core::golden::fnv1a(
                    ends.iter()
                        .chain(point.iter())
                        .chain(r.iter())
                        .flat_map(|e| [e[0].to_bits(), e[1].to_bits()])
                        .chain(probs.iter().map(|p| p.to_bits())),
                );
                let samples = gpecnet_core::sampling::samples_needed(model.extensions(), K);
                let macs = model.endpoint_macs(samples) + model.point_head().macs();
                defmt::println!(
                    "profile {=str} sine={=str} k={=usize} macs={=usize} predict_stack={=u32} predictor_size={=u32} hash={=u32:08x}",
                    name,
                    PATH_NAME,
                    ends.len(),
                    macs,
                    used as u32,
                    core::mem::size_of_val(&p) as u32,
                    hash
                );
            }
            Err(e) => {
                defmt::error!("profile {=str}: {}", name, e);
                ok = false;
            }
        }
    }
    // `cargo xtask profile` only (GPECNET_PROFILE_EXTRAS=1): the multi-model images of
    // the MCU x model table keep one window per model and no verifier in flash.
    #[cfg(prof_extras)]
    {
        crate::watchdog::feed();
        ok &= track_table_period();
        crate::watchdog::feed();
        ok &= camera_period();
        crate::watchdog::feed();
        ok &= verify_first_signed();
    }
    // `cargo xtask profile`'s online image (GPECNET_PROFILE_EXTRAS=online).
    #[cfg(prof_online)]
    for &(name, blob) in crate::models::BLOBS {
        crate::watchdog::feed();
        if let Ok(model) = Model::from_blob(blob) {
            ok &= online_step(name, model);
        }
    }
    ok
}
