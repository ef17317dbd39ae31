//! An embassy task skeleton: detections → [`TrackTable`] → forecasts, with the
//! task yielding to the executor between latent samples (a whole forecast of
//! the shipped MCU model is ~1.14 M instructions on a Cortex-M4F for 80
//! samples, so one sample is ~14,000: the flight loop's other tasks never wait
//! much longer than that).
//!
//! The same `async fn` runs on the host (`embassy_futures::block_on`) and on
//! a Cortex-M4F under the embassy executor:
//!
//! ```sh
//! cargo run -p gpecnet-core --example embassy_task          # host
//! cargo xtask build-core-thumb                              # also builds this for thumbv7em
//! ```
//!
//! On a board, feed `frame` from your detector at 2.5 Hz (an embassy-time
//! `Ticker::every(Duration::from_millis(400))`) and send the forecasts to the
//! planner through an `embassy_sync::channel::Channel`.
#![cfg_attr(target_os = "none", no_std, no_main)]

use embassy_futures::yield_now;
use gpecnet_core::sampling::{reduce, samples_needed};
use gpecnet_core::tracks::{Observation, TrackTable, HISTORY};
use gpecnet_core::{LibmSine, Model, PredictError, Predictor};
use heapless::Vec;

/// `BLOB`: the shipped MCU model, linked into flash 8-byte aligned and read in place.
mod common;
use common::BLOB;

/// Scratch width: at least `Model::scratch_width()` of the blob (64 for it).
const W: usize = 64;
/// Tracks the table holds.
const TRACKS: usize = 8;
/// Endpoints per forecast.
const K: usize = 20;
/// Latent samples a forecast may draw (the blob asks for 80): 8 bytes each.
const N: usize = 128;

/// One pedestrian's forecast.
pub struct Forecast {
    /// Track id.
    pub id: u32,
    /// Where the point forecast puts it 4.8 s ahead.
    pub point: Option<[f32; 2]>,
    /// The model's K possible endpoints.
    pub endpoints: [[f32; 2]; K],
}

/// Forecasts every ready track of `table` at `frame`, yielding between
/// samples; `sink` gets each forecast.
async fn forecast_frame(
    p: &mut Predictor<'static, LibmSine, W>,
    table: &TrackTable<TRACKS>,
    frame: u32,
    mut sink: impl FnMut(&Forecast),
) -> Result<(), PredictError> {
    let ext = *p.model().extensions();
    let n = samples_needed(&ext, K);
    for track in table.ready() {
        let past = track.past();
        let point = if p.model().has_point_head() {
            p.predict_point(&past)?.last().copied()
        } else {
            None
        };
        // Seed from frame and id: every run (and the host) reproduces it.
        let seed = (u64::from(frame) << 32) | u64::from(track.id());
        p.start(&past, seed)?;
        let mut samples: Vec<[f32; 2], N> = Vec::new();
        for _ in 0..n {
            let e = p.next_endpoint()?;
            samples
                .push(e)
                .map_err(|_| PredictError::CapacityExceeded)?;
            yield_now().await;
        }
        let mut endpoints = [[0.0f32; 2]; K];
        reduce(&ext, &samples, &mut endpoints)?;
        sink(&Forecast {
            id: track.id(),
            point,
            endpoints,
        });
    }
    Ok(())
}

/// Two pedestrians crossing a scene, 2.5 Hz (pixels).
fn detections(frame: u32) -> [Observation; 2] {
    let t = frame as f32;
    [
        Observation {
            id: 1,
            pos: [100.0 + 9.0 * t, 200.0 + 2.0 * t],
        },
        Observation {
            id: 7,
            pos: [600.0 - 6.0 * t, 150.0 + 7.5 * t],
        },
    ]
}

/// The application: track, then forecast once the histories are full.
async fn run(mut sink: impl FnMut(u32, &Forecast)) -> Result<(), gpecnet_core::Error> {
    let model = Model::from_blob(BLOB)?;
    let mut p = Predictor::<LibmSine, W>::new(model)?;
    let mut table = TrackTable::<TRACKS>::new(3);
    for frame in 0..(HISTORY as u32 + 2) {
        table.update(frame, &detections(frame));
        forecast_frame(&mut p, &table, frame, |f| sink(frame, f)).await?;
    }
    Ok(())
}

#[cfg(not(target_os = "none"))]
fn main() {
    let mut n = 0;
    let r = embassy_futures::block_on(run(|frame, f| {
        n += 1;
        println!(
            "frame {frame} id {}: point forecast {:?}, first endpoint {:?}",
            f.id, f.point, f.endpoints[0]
        );
        // The stream + reduce gives exactly the one-call endpoint set.
        let model = Model::from_blob(BLOB).unwrap();
        let mut q = Predictor::<LibmSine, W>::new(model).unwrap();
        let past: std::vec::Vec<[f32; 2]> = (frame + 1 - HISTORY as u32..=frame)
            .map(|t| detections(t)[if f.id == 1 { 0 } else { 1 }].pos)
            .collect();
        let mut ends = [[0.0f32; 2]; K];
        let seed = (u64::from(frame) << 32) | u64::from(f.id);
        q.predict_endpoint_set::<N>(&past, seed, &mut ends).unwrap();
        assert_eq!(ends, f.endpoints);
    }));
    if let Err(e) = r {
        eprintln!("error: {e}");
        std::process::exit(1);
    }
    println!("{n} forecasts");
}

#[cfg(target_os = "none")]
mod device {
    use embassy_executor::Executor;

    #[embassy_executor::task]
    async fn forecaster() {
        // Hand each forecast to the planner here (a Channel); this skeleton drops them.
        let _ = super::run(|_, _| {}).await;
    }

    #[cortex_m_rt::entry]
    fn main() -> ! {
        let executor = cortex_m::singleton!(: Executor = Executor::new()).unwrap();
        executor.run(|spawner| {
            spawner.spawn(forecaster().unwrap());
        })
    }

    #[panic_handler]
    fn panic(_: &core::panic::PanicInfo) -> ! {
        loop {
            cortex_m::asm::wfi();
        }
    }
}
