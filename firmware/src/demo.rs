//! The tracker application: `ingest` -> track table -> `predict` -> Channel -> `report`.
//!
//! Time is simulated by the task sequence (deterministic under QEMU, no time
//! driver): frame `n` is t = n × 400 ms (2.5 Hz). `ingest` feeds one frame of
//! observations into the table, then hands the frame number to `predict`
//! through a 1-slot channel and waits until `predict` has copied that frame's
//! ready histories out (`TAKEN`); `predict` then runs the model on them while
//! `ingest` moves on to the next frame, and sends the endpoints to `report`
//! through a bounded channel.
//!
//! On a real board replace the frame hand-off with embassy-time tickers
//! (`Ticker::every(Duration::from_millis(400))` in both tasks, with a TIM/RTC
//! time driver from your HAL, e.g. embassy-stm32's `time-driver-tim2`) and the
//! synthetic scene with the detector's output.
use core::cell::RefCell;

use embassy_executor::Spawner;
use embassy_sync::blocking_mutex::{raw::ThreadModeRawMutex, Mutex};
use embassy_sync::channel::Channel;
use embassy_sync::signal::Signal;
use gpecnet_core::{LibmSine, Model, NumericKind, PredictError, Predictor};
use heapless::Vec;

use crate::golden::{MAX_K, MAX_SAMPLES};
use crate::SCRATCH;
use gpecnet_core::tracks::{Observation, TrackTable, HISTORY};

/// Table capacity (tracks).
pub const MAX_TRACKS: usize = 16;
/// A track is dropped after this many frames without an observation.
pub const MAX_MISSED: u32 = 3;
/// Endpoint samples per prediction.
pub const K: usize = MAX_K;
/// Frame period (ms): 2.5 Hz.
pub const FRAME_MS: u32 = 400;
/// Length of the synthetic scene.
pub const FRAMES: u32 = 24;
/// The sine of the demo's f32 path (the reference sine).
type DemoSine = LibmSine;

/// The model's K endpoints (its protocol: plain or test-time sampling) and its point
/// forecast's endpoint (`None` for a model without a point head). The predictor picks
/// its engine (f32 or fixed point) from the blob.
fn forecast(
    p: &mut Predictor<'static, DemoSine, SCRATCH>,
    past: &[[f32; 2]],
    seed: u64,
) -> Result<(Vec<[f32; 2], K>, Option<[f32; 2]>), PredictError> {
    let mut ends: Vec<[f32; 2], K> = Vec::new();
    let _ = ends.resize(K, [0.0; 2]);
    p.predict_endpoint_set::<MAX_SAMPLES>(past, seed, &mut ends)?;
    let point = if p.model().has_point_head() {
        p.predict_point(past)?.last().copied()
    } else {
        None
    };
    Ok((ends, point))
}

static TABLE: Mutex<ThreadModeRawMutex, RefCell<TrackTable<MAX_TRACKS>>> =
    Mutex::new(RefCell::new(TrackTable::new(MAX_MISSED)));
/// ingest -> predict: frame number, `None` = end of stream.
static FRAME_TICKS: Channel<ThreadModeRawMutex, Option<u32>, 1> = Channel::new();
/// predict -> ingest: the frame's ready histories are copied out, the table may move on.
static TAKEN: Channel<ThreadModeRawMutex, (), 1> = Channel::new();
/// predict -> report.
static REPORTS: Channel<ThreadModeRawMutex, Report, 4> = Channel::new();
/// report -> supervisor: number of predictions logged.
static DONE: Signal<ThreadModeRawMutex, u32> = Signal::new();

pub enum Report {
    Frame {
        frame: u32,
        active: u8,
        ready: u8,
        entered: Vec<u32, MAX_TRACKS>,
        left: Vec<u32, MAX_TRACKS>,
        rejected: u32,
    },
    Prediction {
        frame: u32,
        id: u32,
        last: [f32; 2],
        endpoints: Vec<[f32; 2], K>,
        /// The point forecast's endpoint, when the model has a point head.
        point: Option<[f32; 2]>,
    },
    Failed {
        frame: u32,
        id: u32,
    },
    Done,
}

/// Spawns the three tasks and waits for the end of the scene.
pub async fn run(spawner: Spawner) -> bool {
    let want = crate::models::DEMO_MODEL;
    let pick = if want.is_empty() {
        crate::models::BLOBS.first()
    } else {
        crate::models::BLOBS.iter().find(|(n, _)| *n == want)
    };
    let Some(&(name, blob)) = pick else {
        if want.is_empty() {
            defmt::error!("demo: no model embedded (weights/*.gpec), skipping");
        } else {
            defmt::error!("demo: GPECNET_DEMO_MODEL={=str} is not embedded", want);
        }
        return false;
    };
    let model = match Model::from_blob(blob) {
        Ok(m) => m,
        Err(e) => {
            defmt::error!("demo: model {=str} rejected: {}", name, e);
            return false;
        }
    };
    defmt::println!(
        "demo: model {=str} ({=str}), {=usize} tracks max, K={=usize}, {=u32} frames at {=u32} ms",
        name,
        match model.numeric() {
            NumericKind::F32 => "f32, libm sine",
            NumericKind::Int16Q15 => "int16/Q15 fixed point, q15-table sine",
        },
        MAX_TRACKS,
        K,
        FRAMES,
        FRAME_MS
    );
    spawner.spawn(report().unwrap());
    spawner.spawn(predict(model).unwrap());
    spawner.spawn(ingest().unwrap());
    let n = DONE.wait().await;
    defmt::println!("demo: done, {=u32} predictions", n);
    n > 0
}

/// Deterministic scene: scripted pedestrians (id, first frame, last frame,
/// start position px, velocity px/frame); id 3 is occluded for frames 9-10.
fn scene(frame: u32) -> Vec<Observation, MAX_TRACKS> {
    const WALKERS: [(u32, u32, u32, [f32; 2], [f32; 2]); 6] = [
        (1, 0, 23, [100.0, 200.0], [4.0, 1.5]),
        (2, 0, 14, [600.0, 120.0], [-3.0, 2.0]),
        (3, 2, 23, [300.0, 500.0], [0.5, -3.5]),
        (4, 5, 9, [50.0, 50.0], [2.0, 2.0]),
        (5, 8, 23, [700.0, 400.0], [-5.0, 0.0]),
        (6, 12, 23, [400.0, 20.0], [1.0, 4.0]),
    ];
    let mut v = Vec::new();
    for &(id, from, to, p0, vel) in WALKERS.iter() {
        if frame < from || frame > to || (id == 3 && (9..=10).contains(&frame)) {
            continue;
        }
        let t = (frame - from) as f32;
        let _ = v.push(Observation {
            id,
            pos: [p0[0] + vel[0] * t, p0[1] + vel[1] * t],
        });
    }
    v
}

#[embassy_executor::task]
async fn ingest() {
    for frame in 0..FRAMES {
        // One frame per 400 ms on a board: the watchdog's heartbeat.
        crate::watchdog::feed();
        let obs = scene(frame);
        let (d, active, ready) = TABLE.lock(|t| {
            let mut t = t.borrow_mut();
            let d = t.update(frame, &obs);
            (d, t.len() as u8, t.ready().count() as u8)
        });
        REPORTS
            .send(Report::Frame {
                frame,
                active,
                ready,
                entered: d.entered,
                left: d.left,
                rejected: d.rejected,
            })
            .await;
        FRAME_TICKS.send(Some(frame)).await;
        // Do not update the table before predict has copied this frame's
        // histories out (it then runs while we ingest the next frame).
        TAKEN.receive().await;
    }
    FRAME_TICKS.send(None).await;
}

#[embassy_executor::task]
async fn predict(model: Model<'static>) {
    let mut p = match Predictor::<DemoSine, SCRATCH>::new(model) {
        Ok(p) => p,
        Err(e) => {
            defmt::error!("predict: {}", e);
            REPORTS.send(Report::Done).await;
            return;
        }
    };
    while let Some(frame) = FRAME_TICKS.receive().await {
        // Copy the ready histories out, so the table is not held during inference.
        let ready: Vec<(u32, [[f32; 2]; HISTORY]), MAX_TRACKS> =
            TABLE.lock(|t| t.borrow().ready().map(|tr| (tr.id(), tr.past())).collect());
        TAKEN.send(()).await;
        for (id, past) in ready {
            // Seed: frame and id, so every run (and the host) reproduces it.
            let seed = ((frame as u64) << 32) | id as u64;
            let r = match forecast(&mut p, &past, seed) {
                Ok((endpoints, point)) => Report::Prediction {
                    frame,
                    id,
                    last: past[HISTORY - 1],
                    endpoints,
                    point,
                },
                Err(_) => Report::Failed { frame, id },
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
                frame,
                active,
                ready,
                entered,
                left,
                rejected,
            } => {
                defmt::info!(
                    "t={=u32}ms frame {=u32}: {=u8} tracks ({=u8} ready), entered {=[?]}, left {=[?]}, rejected {=u32}",
                    frame * FRAME_MS,
                    frame,
                    active,
                    ready,
                    entered.as_slice(),
                    left.as_slice(),
                    rejected
                );
            }
            Report::Prediction {
                frame,
                id,
                last,
                endpoints,
                point,
            } => {
                n += 1;
                if let Some(q) = point {
                    defmt::info!(
                        "  frame {=u32} track {=u32}: point forecast 4.8 s ahead ({=f32}, {=f32})",
                        frame,
                        id,
                        q[0],
                        q[1]
                    );
                }
                // mean endpoint and spread as a compact summary of the K samples
                let k = endpoints.len() as f32;
                let mx = endpoints.iter().map(|e| e[0]).sum::<f32>() / k;
                let my = endpoints.iter().map(|e| e[1]).sum::<f32>() / k;
                defmt::info!(
                    "  frame {=u32} track {=u32}: at ({=f32}, {=f32}) -> {=usize} endpoints, mean ({=f32}, {=f32}), e0 ({=f32}, {=f32})",
                    frame,
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
            Report::Failed { frame, id } => {
                defmt::error!("  frame {=u32} track {=u32}: prediction failed", frame, id)
            }
            Report::Done => break,
        }
    }
    DONE.signal(n);
}
