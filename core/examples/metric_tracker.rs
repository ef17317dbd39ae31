//! From a 30 Hz metric tracker to forecasts: detections in metres with
//! millisecond timestamps (jitter, dropped frames) go into the timed track
//! table, which resamples them onto the model's 0.4 s period; every track
//! whose history gained a point is forecast by the metric MCU model
//! (`weights/sdd-m-tiny-qe.gpec`), declared in metres so that a model in
//! another unit would be refused. Copy this loop into your flight code.
//!
//! ```sh
//! cargo run -p gpecnet-core --example metric_tracker
//! ```
//!
//! The scene and the printed lines are the C example's
//! (`ffi/examples/c/metric_tracker.c`), bit for bit.
use gpecnet_core::tracks::{period_ms_of, Observation, TimedTrackTable};
use gpecnet_core::units::CallerUnit;
use gpecnet_core::{Error, LibmSine, Model, Predictor};

/// The metric MCU model, 8-byte aligned (the Cortex-M4/M7 kernels' word loads).
#[repr(C, align(8))]
struct Aligned<T>(T);
static BLOB: &Aligned<[u8; include_bytes!("../../weights/sdd-m-tiny-qe.gpec").len()]> =
    &Aligned(*include_bytes!("../../weights/sdd-m-tiny-qe.gpec"));

/// Pedestrians in the scene.
const PEDESTRIANS: u32 = 6;
/// Camera frames (5 s at 30 Hz).
const FRAMES: u32 = 150;

/// The synthetic camera: frame `f`'s timestamp (30 Hz, 0–8 ms of jitter)
/// and pedestrian `id`'s position in metres, or `None` when the detector
/// missed it (one detection in ten).
fn camera(f: u32, id: u32) -> (u32, Option<[f32; 2]>) {
    let t_ms = f * 1000 / 30 + (f * 7919) % 9;
    if (f * 31 + id * 17).is_multiple_of(10) {
        return (t_ms, None);
    }
    let t = t_ms as f32 / 1000.0;
    let k = id as f32;
    let x = 2.0 * k + (1.1 + 0.05 * k) * t;
    let y = -3.0 + k + (0.3 - 0.1 * k) * t + 0.05 * t * t;
    (t_ms, Some([x, y]))
}

fn main() -> Result<(), Error> {
    let model = Model::from_blob(&BLOB.0)?;
    // Metres in, metres out: a pixel or unit-less model is refused here.
    let mut predictor = Predictor::<LibmSine, 64>::with_units(model, CallerUnit::Metres)?;
    let period = period_ms_of(&model).expect("the metric model records its period");
    // 16 tracks; a track not seen for 1 s is dropped.
    let mut table: TimedTrackTable<16> = TimedTrackTable::new(period, 1_000);
    println!(
        "{}: unit {}, period {} ms",
        model.name(),
        model.unit().suffix(),
        period
    );
    for f in 0..FRAMES {
        let mut seen = heapless::Vec::<Observation, 16>::new();
        let mut t_ms = 0;
        for id in 0..PEDESTRIANS {
            let (t, pos) = camera(f, id);
            t_ms = t;
            if let Some(pos) = pos {
                let _ = seen.push(Observation { id, pos });
            }
        }
        table.update(t_ms, &seen);
        for track in table.fresh() {
            let forecast = predictor.predict_point(&track.past())?;
            let Some(end) = forecast.last() else { continue };
            let at = track.end_ms() + period.get() * forecast.len() as u32;
            println!(
                "t={:>5} ms id={} endpoint at {:>5} ms: ({:.3}, {:.3}) m [{:08x} {:08x}]",
                track.end_ms(),
                track.id(),
                at,
                end[0],
                end[1],
                end[0].to_bits(),
                end[1].to_bits()
            );
        }
    }
    Ok(())
}
