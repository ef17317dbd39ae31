//! The tracker application: `ingest` -> timed track table -> `predict` ->
//! Channel -> `report`, in metres, at a camera's rate.
//!
//! Time is simulated by the task sequence (deterministic under QEMU, no time
//! driver): `ingest` feeds one camera frame at a time, 30 Hz with 0–8 ms of
//! jitter and one detection in ten dropped, positions in metres, into the
//! timed track table ([`gpecnet_core::tracks::TimedTrackTable`]), which
//! resamples every track onto the model's 0.4 s period. When a frame made
//! histories fresh, `ingest` hands the frame's time to `predict` through a
//! 1-slot channel and waits until `predict` has copied those histories out
//! (`TAKEN`); `predict` then runs the metric model on them, declared in
//! metres ([`Predictor::with_units`]: a model in another unit is refused
//! with its typed error), while `ingest` moves on, and sends the forecasts
//! to `report` through a bounded channel. Each forecast is logged with its
//! time and unit.
//!
//! On a board replace the frame loop with the detector's output and an
//! embassy-time timestamp (`Instant::now().as_millis() as u32`), with a
//! TIM/RTC time driver from your HAL (e.g. embassy-stm32's `time-driver-tim2`).
use core::cell::RefCell;

use core::num::NonZeroU32;
use embassy_executor::Spawner;
use embassy_sync::blocking_mutex::{raw::ThreadModeRawMutex, Mutex};
use embassy_sync::channel::Channel;
use embassy_sync::signal::Signal;

use gpecnet_core::blob::PositionUnit;
use gpecnet_core::planner::{most_probable, Radii};
use gpecnet_core::units::CallerUnit;
use gpecnet_core::{LibmSine, Model, NumericKind, PredictError, Predictor};
use heapless::Vec;

use crate::golden::{MAX_K, MAX_SAMPLES};
use crate::SCRATCH;
use gpecnet_core::tracks::{Observation, TimedTrackTable, HISTORY};

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
/// The grid period the shipped models record (0.4 s); the table takes the
/// model's own ([`gpecnet_core::tracks::period_ms_of`]).
const DEFAULT_PERIOD: NonZeroU32 = match NonZeroU32::new(400) {
    Some(p) => p,
    None => NonZeroU32::MIN,
};
/// The sine of the demo's f32 path (the reference sine).
type DemoSine = LibmSine;

/// What `predict` hands to `report` for one track.
pub struct Forecast {
    /// The model's endpoints (its protocol: plain, test-time sampling or a proposal).
    pub endpoints: Vec<[f32; 2], K>,
    /// The point forecast's endpoint (`None` for a model without a point head).
    pub point: Option<[f32; 2]>,
    /// The most probable endpoint's index and probability (`1/K` each for a model
    /// without probabilities: then `learned` is false).
    pub top: (usize, f32),
    /// Whether the probabilities are the model's own.
    pub learned: bool,
    /// `r50` / `r90` around the point forecast (a model with probabilities).
    pub radii: Option<Radii>,
}

/// The model's forecast for one track ([`Forecast`]). The predictor picks its engine (f32
/// or fixed point) from the blob.
fn forecast(
    p: &mut Predictor<'static, DemoSine, SCRATCH>,
    past: &[[f32; 2]],
    seed: u64,
) -> Result<Forecast, PredictError> {
    let mut ends: Vec<[f32; 2], K> = Vec::new();
    let n = gpecnet_core::sampling::max_endpoints_of(p.model(), K);
    let _ = ends.resize(n, [0.0; 2]);
    let mut probs = [0.0f32; K];
    let probs = &mut probs[..n];
    let out = p.predict_planner::<MAX_SAMPLES>(past, seed, &mut ends, probs)?;
    let (learned, radii) = (out.learned, out.radii);
    let point = out.point.and_then(|t| t.last().copied());
    let top = most_probable(probs)
        .and_then(|i| probs.get(i).map(|&q| (i, q)))
        .unwrap_or((0, 0.0));
    Ok(Forecast {
        endpoints: ends,
        point,
        top,
        learned,
        radii,
    })
}

static TABLE: Mutex<ThreadModeRawMutex, RefCell<TimedTrackTable<MAX_TRACKS>>> = Mutex::new(
    RefCell::new(TimedTrackTable::new(DEFAULT_PERIOD, MAX_GAP_MS)),
);
/// ingest -> predict: the frame's timestamp (ms), `None` = end of stream.
static FRAME_TICKS: Channel<ThreadModeRawMutex, Option<u32>, 1> = Channel::new();
/// predict -> ingest: the frame's ready histories are copied out, the table may move on.
static TAKEN: Channel<ThreadModeRawMutex, (), 1> = Channel::new();
/// predict -> report.
static REPORTS: Channel<ThreadModeRawMutex, Report, 4> = Channel::new();
/// report -> supervisor: number of predictions logged.
static DONE: Signal<ThreadModeRawMutex, u32> = Signal::new();

pub enum Report {
    Frame {
        t_ms: u32,
        active: u8,
        fresh: u8,
        entered: Vec<u32, MAX_TRACKS>,
        left: Vec<u32, MAX_TRACKS>,
        rejected: u32,
    },
    Prediction {
        /// Time of the history's newest point (the forecast starts there).
        t_ms: u32,
        /// Time of the forecast's endpoint.
        end_ms: u32,
        id: u32,
        last: [f32; 2],
        forecast: Forecast,
    },
    Failed {
        t_ms: u32,
        id: u32,
    },
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
    TABLE.lock(|t| *t.borrow_mut() = TimedTrackTable::new(period, MAX_GAP_MS));
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
    spawner.spawn(predict(predictor).unwrap());
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
        let obs = scene(frame, t_ms);
        let (d, active, fresh) = TABLE.lock(|t| {
            let mut t = t.borrow_mut();
            let d = t.update(t_ms, &obs);
            (d, t.len() as u8, t.fresh().count() as u8)
        });
        // Log the frames where something happened, not all 30 a second.
        if fresh > 0 || !d.entered.is_empty() || !d.left.is_empty() || d.rejected > 0 {
            REPORTS
                .send(Report::Frame {
                    t_ms,
                    active,
                    fresh,
                    entered: d.entered,
                    left: d.left,
                    rejected: d.rejected,
                })
                .await;
        }
        if fresh > 0 {
            FRAME_TICKS.send(Some(t_ms)).await;
            // Do not update the table before predict has copied this frame's
            // histories out (it then runs while we ingest the next frames).
            TAKEN.receive().await;
        }
    }
    FRAME_TICKS.send(None).await;
}

#[embassy_executor::task]
async fn predict(mut p: Predictor<'static, DemoSine, SCRATCH>) {
    while FRAME_TICKS.receive().await.is_some() {
        // Copy the fresh histories out, so the table is not held during inference.
        let (period, fresh) = TABLE.lock(|t| {
            let t = t.borrow();
            let fresh: Vec<(u32, u32, [[f32; 2]; HISTORY]), MAX_TRACKS> = t
                .fresh()
                .map(|tr| (tr.end_ms(), tr.id(), tr.past()))
                .collect();
            (t.period_ms(), fresh)
        });
        let horizon = period * u32::from(p.model().config().future_len);
        TAKEN.send(()).await;
        for (t_ms, id, past) in fresh {
            // Seed: time and id, so every run (and the host) reproduces it.
            let seed = ((t_ms as u64) << 32) | id as u64;
            let r = match forecast(&mut p, &past, seed) {
                Ok(forecast) => Report::Prediction {
                    t_ms,
                    end_ms: t_ms.wrapping_add(horizon),
                    id,
                    last: past[HISTORY - 1],
                    forecast,
                },
                Err(_) => Report::Failed { t_ms, id },
            };
            REPORTS.send(r).await;
        }
    }
    REPORTS.send(Report::Done).await;
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
                match (point, radii) {
                    (Some(q), Some(r)) => defmt::info!(
                        "  t={=u32}ms track {=u32}: point forecast for t={=u32}ms ({=f32}, {=f32}) m, r50 {=f32} m, r90 {=f32} m",
                        t_ms,
                        id,
                        end_ms,
                        q[0],
                        q[1],
                        r.r50,
                        r.r90
                    ),
                    (Some(q), None) => defmt::info!(
                        "  t={=u32}ms track {=u32}: point forecast for t={=u32}ms ({=f32}, {=f32}) m",
                        t_ms,
                        id,
                        end_ms,
                        q[0],
                        q[1]
                    ),
                    _ => {}
                }
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
            Report::Failed { t_ms, id } => {
                defmt::error!("  t={=u32}ms track {=u32}: prediction failed", t_ms, id)
            }
            Report::Done => break,
        }
    }
    DONE.signal(n);
}
