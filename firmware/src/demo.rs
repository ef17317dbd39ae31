//! The tracker application: `ingest` -> `predict` (the online forecaster:
//! timed track table, forecasts, the loop that calibrates them) -> Channel
//! -> `report`, in metres, at a camera's rate.
//!
//! Time is simulated by the task sequence (deterministic under QEMU, no time
//! driver): `ingest` produces one camera frame at a time, 30 Hz with 0–8 ms
//! of jitter and one detection in ten dropped, positions in metres, and hands
//! it to `predict` through a 1-slot channel. `predict` holds a
//! [`gpecnet_core::online::Forecaster`]: one call per frame puts the
//! detections into its timed track table (resampled onto the model's 0.4 s
//! period), feeds each track's new grid points back to its pending forecasts
//! (the loop learns the radius multipliers and the experts' weights, adapt
//! on), and forecasts every track that gained a grid point through
//! [`gpecnet_core::online::forecast`], the one forecast sequence. The model
//! is declared in metres ([`Predictor::with_units`]: a model in another unit
//! is refused with its typed error). The forecasts go to `report` through a
//! bounded channel, each logged with its time and unit; now and then
//! `predict` logs the adapted multipliers.
//!
//! On a board replace the frame loop with the detector's output and an
//! embassy-time timestamp (`Instant::now().as_millis() as u32`), with a
//! TIM/RTC time driver from your HAL (e.g. embassy-stm32's `time-driver-tim2`).
use embassy_executor::Spawner;
use embassy_sync::blocking_mutex::raw::ThreadModeRawMutex;
use embassy_sync::channel::Channel;
use embassy_sync::signal::Signal;

use gpecnet_core::blob::PositionUnit;
use gpecnet_core::online::{Config, Forecaster, MotionState, TrackForecast, HORIZONS};
use gpecnet_core::planner::{most_probable, Radii};
use gpecnet_core::tracks::Observation;
use gpecnet_core::units::CallerUnit;
use gpecnet_core::{LibmSine, Model, NumericKind, Predictor};
use heapless::Vec;

use crate::golden::MAX_K;
use crate::SCRATCH;

/// Table capacity (tracks).
pub const MAX_TRACKS: usize = 16;
/// A track is dropped after this long without a detection (ms).
pub const MAX_GAP_MS: u32 = 1_000;
/// Endpoint samples per prediction.
pub const K: usize = MAX_K;
/// The camera's nominal frame period (ms): 30 Hz.
pub const CAMERA_MS: u32 = 33;
/// Camera frames of the synthetic scene (9.6 s at 30 Hz).
pub const FRAMES: u32 = 288;
/// Forecasts per track awaiting their truth in the online loop.
pub const PENDING: usize = 2;
/// Camera frames between two logs of the adapted multipliers (1.2 s).
pub const LOG_MULTIPLIERS_EVERY: u32 = 36;
/// The sine of the demo's f32 path (the reference sine).
type DemoSine = LibmSine;
/// The demo's forecaster: the track table, the pending forecasts, the loop.
type DemoForecaster = Forecaster<MAX_TRACKS, PENDING>;

/// What `predict` hands to `report` for one track.
pub struct Forecast {
    /// The model's endpoints (its protocol: plain, test-time sampling or a proposal).
    pub endpoints: Vec<[f32; 2], K>,
    /// The point forecast's endpoint: the loop's aggregate of the point head and
    /// the constant-velocity experts.
    pub point: [f32; 2],
    /// The most probable endpoint's index and probability (`1/K` each for a model
    /// without probabilities: then `learned` is false).
    pub top: (usize, f32),
    /// Whether the probabilities are the model's own.
    pub learned: bool,
    /// `r50` / `r90` around the point forecast's endpoint, calibrated by the loop.
    pub radii: Radii,
}

impl Forecast {
    /// The report of one forecast of the online sequence.
    fn of(fc: &TrackForecast<K>) -> Self {
        let top = most_probable(&fc.probabilities)
            .and_then(|i| fc.probabilities.get(i).map(|&q| (i, q)))
            .unwrap_or((0, 0.0));
        Forecast {
            endpoints: fc.endpoints.clone(),
            point: fc.point[HORIZONS - 1],
            top,
            learned: fc.learned,
            radii: fc.radii[HORIZONS - 1],
        }
    }
}

/// One camera frame: its timestamp (ms) and detections.
type CameraFrame = (u32, Vec<Observation, MAX_TRACKS>);
/// ingest -> predict: one camera frame, `None` = end of stream.
static FRAMES_IN: Channel<ThreadModeRawMutex, Option<CameraFrame>, 1> = Channel::new();
/// predict -> report.
static REPORTS: Channel<ThreadModeRawMutex, Report, 4> = Channel::new();
/// report -> supervisor: number of predictions logged.
static DONE: Signal<ThreadModeRawMutex, u32> = Signal::new();

/// What `predict` hands to `report`.
pub enum Report {
    /// A frame where something happened (tracks entered or left, forecasts).
    Frame {
        /// The frame's timestamp (ms).
        t_ms: u32,
        /// Tracks in the table.
        active: u8,
        /// Forecasts the frame issued.
        fresh: u8,
        /// Ids that entered.
        entered: Vec<u32, MAX_TRACKS>,
        /// Ids that left.
        left: Vec<u32, MAX_TRACKS>,
        /// Detections refused (table full).
        rejected: u32,
    },
    /// One track's forecast.
    Prediction {
        /// Time of the history's newest point (the forecast starts there).
        t_ms: u32,
        /// Time of the forecast's endpoint.
        end_ms: u32,
        /// The track id.
        id: u32,
        /// The newest observed point.
        last: [f32; 2],
        /// The forecast.
        forecast: Forecast,
    },
    /// Forecasts a frame refused.
    Failed {
        /// The frame's timestamp (ms).
        t_ms: u32,
        /// How many.
        count: u32,
    },
    /// End of the scene.
    Done,
}

/// Spawns the three tasks and waits for the end of the scene.
pub async fn run(spawner: Spawner) -> bool {
    let want = crate::models::DEMO_MODEL;
    // The named model, else the first metric one embedded.
    let metric = |b: &&(&str, &'static [u8])| {
        Model::from_blob(b.1).is_ok_and(|m| m.unit() == PositionUnit::Metre)
    };
    let pick = if want.is_empty() {
        crate::models::BLOBS.iter().find(metric)
    } else {
        crate::models::BLOBS.iter().find(|(n, _)| *n == want)
    };
    let Some(&(name, blob)) = pick else {
        if want.is_empty() {
            defmt::error!("demo: no metric model embedded (weights/*.gpec), skipping");
        } else {
            defmt::error!("demo: GPECNET_DEMO_MODEL={=str} is not embedded", want);
        }
        return false;
    };
    let Some((name, model)) = trusted_model(name, blob) else {
        return false;
    };
    // The scene is in metres: a model in another unit is refused here.
    let predictor = match Predictor::<DemoSine, SCRATCH>::with_units(model, CallerUnit::Metres) {
        Ok(p) => p,
        Err(e) => {
            defmt::error!(
                "demo: model {=str} refused for positions in metres: {}",
                name,
                e
            );
            return false;
        }
    };
    let Some(period) = gpecnet_core::tracks::period_ms_of(&model) else {
        defmt::error!("demo: model {=str} does not record its period", name);
        return false;
    };
    // The scene is in metres: the loop's defaults for metres, adapt on.
    let forecaster = match DemoForecaster::new(&model, Config::metres(), MAX_GAP_MS) {
        Ok(f) => f,
        Err(e) => {
            defmt::error!("demo: the online loop refused model {=str}: {}", name, e);
            return false;
        }
    };
    defmt::println!(
        "demo: model {=str} ({=str}), unit {=str}, period {=u32} ms, {=usize} tracks max, K={=usize}, {=u32} camera frames at ~{=u32} ms",
        name,
        match model.numeric() {
            NumericKind::F32 => "f32, libm sine",
            NumericKind::Int16Q15 => "int16/Q15 fixed point, q15-table sine",
        },
        model.unit().suffix(),
        period.get(),
        MAX_TRACKS,
        K,
        FRAMES,
        CAMERA_MS
    );
    spawner.spawn(report().unwrap());
    spawner.spawn(predict(predictor, forecaster).unwrap());
    spawner.spawn(ingest().unwrap());
    let n = DONE.wait().await;
    defmt::println!("demo: done, {=u32} predictions", n);
    n > 0
}

/// The model to run: `blob` when its signature verifies under the
/// firmware's trusted keys at a version not below the stored minimum, else
/// the first other embedded blob that does (the last good model), else
/// none. Each refusal is logged with its reason; the stored minimum is
/// raised to the accepted model's version.
fn trusted_model(
    name: &'static str,
    blob: &'static [u8],
) -> Option<(&'static str, Model<'static>)> {
    let keys = crate::models::TRUSTED_KEYS;
    let min = crate::persist::min_version();
    let verified = |n: &'static str, b: &'static [u8]| match Model::from_signed_blob(b, keys, min) {
        Ok((m, version)) => {
            defmt::println!(
                "demo: model {=str} signature ok, version {=u32} (minimum {=u32})",
                n,
                version,
                min
            );
            crate::persist::raise_min_version(version);
            Some((n, m))
        }
        Err(e) => {
            defmt::error!("demo: model {=str} refused: {}", n, e);
            None
        }
    };
    if let Some(ok) = verified(name, blob) {
        return Some(ok);
    }
    let fallback = crate::models::BLOBS
        .iter()
        .filter(|(n, b)| *n != name && gpecnet_core::blob::signed::split(b).is_some())
        .find_map(|&(n, b)| verified(n, b));
    match fallback {
        Some((n, m)) => {
            defmt::warn!("demo: falling back to the last good model {=str}", n);
            Some((n, m))
        }
        None => {
            defmt::error!("demo: no trusted model embedded, not predicting");
            None
        }
    }
}

/// Camera frame `frame`'s timestamp (ms): 30 Hz with 0–8 ms of jitter.
fn camera_ms(frame: u32) -> u32 {
    frame * 1000 / 30 + (frame * 7919) % 9
}

/// Deterministic scene in metres: scripted pedestrians (id, first and last
/// ms, start position m, velocity m/s, sideways acceleration m/s²); id 3 is
/// occluded from 3.6 s to 4.3 s (bridged: under `MAX_GAP_MS`), and the
/// detector misses one detection in ten.
fn scene(frame: u32, t_ms: u32) -> Vec<Observation, MAX_TRACKS> {
    const WALKERS: [(u32, u32, u32, [f32; 2], [f32; 2], f32); 6] = [
        (1, 0, 9_600, [2.0, 4.0], [1.3, 0.4], 0.0),
        (2, 0, 5_800, [18.0, 3.0], [-1.1, 0.6], 0.05),
        (3, 800, 9_600, [9.0, 14.0], [0.2, -1.2], -0.04),
        (4, 2_000, 4_000, [1.0, 1.0], [0.8, 0.8], 0.0),
        (5, 3_200, 9_600, [21.0, 10.0], [-1.6, 0.0], 0.08),
        (6, 4_800, 9_600, [12.0, 0.5], [0.3, 1.4], 0.0),
    ];
    let mut v = Vec::new();
    for &(id, from, to, p0, vel, acc) in WALKERS.iter() {
        let occluded = id == 3 && (3_600..4_300).contains(&t_ms);
        let missed = (frame * 31 + id * 17).is_multiple_of(10);
        if t_ms < from || t_ms > to || occluded || missed {
            continue;
        }
        let t = (t_ms - from) as f32 / 1000.0;
        let _ = v.push(Observation {
            id,
            pos: [p0[0] + vel[0] * t, p0[1] + vel[1] * t + acc * t * t],
        });
    }
    v
}

#[embassy_executor::task]
async fn ingest() {
    for frame in 0..FRAMES {
        // One camera frame; on a board the watchdog's heartbeat.
        crate::watchdog::feed();
        let t_ms = camera_ms(frame);
        FRAMES_IN.send(Some((t_ms, scene(frame, t_ms)))).await;
    }
    FRAMES_IN.send(None).await;
}

#[embassy_executor::task]
async fn predict(mut p: Predictor<'static, DemoSine, SCRATCH>, mut f: DemoForecaster) {
    let horizon = f.table().period_ms() * HORIZONS as u32;
    let mut frame = 0u32;
    while let Some((t_ms, obs)) = FRAMES_IN.receive().await {
        let mut out: Vec<Report, MAX_TRACKS> = Vec::new();
        // Seeds: the forecaster's (id and time), so every run reproduces.
        let r = f.frame::<DemoSine, SCRATCH, K>(&mut p, t_ms, &obs, |fc| {
            let _ = out.push(Report::Prediction {
                t_ms: fc.end_ms,
                end_ms: fc.end_ms.wrapping_add(horizon),
                id: fc.id,
                last: fc.anchor,
                forecast: Forecast::of(fc),
            });
        });
        let d = &r.delta;
        // Log the frames where something happened, not all 30 a second.
        if r.forecasts > 0 || !d.entered.is_empty() || !d.left.is_empty() || d.rejected > 0 {
            REPORTS
                .send(Report::Frame {
                    t_ms,
                    active: f.table().len() as u8,
                    fresh: r.forecasts as u8,
                    entered: d.entered.clone(),
                    left: d.left.clone(),
                    rejected: d.rejected,
                })
                .await;
        }
        for report in out {
            REPORTS.send(report).await;
        }
        if r.failed > 0 {
            REPORTS
                .send(Report::Failed {
                    t_ms,
                    count: r.failed,
                })
                .await;
        }
        frame += 1;
        if frame % LOG_MULTIPLIERS_EVERY == 0 {
            log_multipliers(t_ms, &f);
        }
    }
    log_multipliers(camera_ms(FRAMES - 1), &f);
    REPORTS.send(Report::Done).await;
}

/// Logs what the loop has learned: the `r50`/`r90` multipliers at 0.4 s, 2.4 s
/// and 4.8 s (one calibration for every motion state, the default) and the
/// feedback updates so far.
fn log_multipliers(t_ms: u32, f: &DemoForecaster) {
    let c = f.calibration();
    let state = MotionState::Walking;
    let [m1, m6, m12] = [1, 6, 12].map(|h| c.multipliers(state, h));
    defmt::info!(
        "t={=u32}ms: online loop: multipliers r50/r90 at 0.4 s {=f32}/{=f32}, 2.4 s {=f32}/{=f32}, 4.8 s {=f32}/{=f32}; {=u32} feedback updates",
        t_ms,
        m1[0],
        m1[1],
        m6[0],
        m6[1],
        m12[0],
        m12[1],
        c.feedback_count(state)
    );
}

#[embassy_executor::task]
async fn report() {
    let mut n = 0u32;
    loop {
        match REPORTS.receive().await {
            Report::Frame {
                t_ms,
                active,
                fresh,
                entered,
                left,
                rejected,
            } => {
                defmt::info!(
                    "t={=u32}ms: {=u8} tracks ({=u8} fresh), entered {=[?]}, left {=[?]}, rejected {=u32}",
                    t_ms,
                    active,
                    fresh,
                    entered.as_slice(),
                    left.as_slice(),
                    rejected
                );
            }
            Report::Prediction {
                t_ms,
                end_ms,
                id,
                last,
                forecast:
                    Forecast {
                        endpoints,
                        point,
                        top,
                        learned,
                        radii,
                    },
            } => {
                n += 1;
                defmt::info!(
                    "  t={=u32}ms track {=u32}: point forecast for t={=u32}ms ({=f32}, {=f32}) m, r50 {=f32} m, r90 {=f32} m",
                    t_ms,
                    id,
                    end_ms,
                    point[0],
                    point[1],
                    radii.r50,
                    radii.r90
                );
                if let (true, Some(e)) = (learned, endpoints.get(top.0)) {
                    defmt::info!(
                        "  t={=u32}ms track {=u32}: most probable endpoint e{=usize} ({=f32}, {=f32}) m, p {=f32}",
                        t_ms,
                        id,
                        top.0,
                        e[0],
                        e[1],
                        top.1
                    );
                }
                // mean endpoint and spread as a compact summary of the K samples
                let k = endpoints.len() as f32;
                let mx = endpoints.iter().map(|e| e[0]).sum::<f32>() / k;
                let my = endpoints.iter().map(|e| e[1]).sum::<f32>() / k;
                defmt::info!(
                    "  t={=u32}ms track {=u32}: at ({=f32}, {=f32}) m -> {=usize} endpoints, mean ({=f32}, {=f32}) m, e0 ({=f32}, {=f32}) m",
                    t_ms,
                    id,
                    last[0],
                    last[1],
                    endpoints.len(),
                    mx,
                    my,
                    endpoints[0][0],
                    endpoints[0][1]
                );
            }
            Report::Failed { t_ms, count } => {
                defmt::error!("  t={=u32}ms: {=u32} forecast(s) failed", t_ms, count)
            }
            Report::Done => break,
        }
    }
    DONE.signal(n);
}
