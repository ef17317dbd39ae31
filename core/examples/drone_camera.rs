//! From a drone's camera to forecasts: bounding boxes in the image of a
//! gimballed camera, and the flight stack's attitude, position and gimbal
//! angles at each frame, become ground points in NED metres
//! (`camera::to_observations`), which `online::Forecaster` turns into
//! calibrated forecasts with the metric model `weights/sdd-m-lp-qe.gpec`.
//! Each forecast's endpoint is also drawn back into the current image
//! (`Pose::ground_to_image`), as an overlay would.
//!
//! ```sh
//! cargo run -p gpecnet-core --example drone_camera
//! ```
//!
//! The scene is synthetic: five pedestrians walk north-east; the drone
//! follows them at 30–34 m, wobbling, and yaws 90° in 2 s halfway through.
//! Their boxes are the exact projections of their feet plus up to ±1 px of
//! detector noise, at 30 Hz. Because every position is in the world frame,
//! the drone's own motion never looks like pedestrian motion: the endpoint
//! errors printed at the end are those of the tracks, not of the flight.
use gpecnet_core::camera::{
    to_observations, BoundingBox, Camera, Detection, Distortion, Euler, Intrinsics, Pose, State,
};
use gpecnet_core::online::{Config, Forecaster, TrackForecast};
use gpecnet_core::tracks::Observation;
use gpecnet_core::units::CallerUnit;
use gpecnet_core::{LibmSine, Model, Predictor};

/// The metric model with probabilities and radii, 8-byte aligned (the
/// Cortex-M4/M7 kernels' word loads).
#[repr(C, align(8))]
struct Aligned<T>(T);
static BLOB: &Aligned<[u8; include_bytes!("../../weights/sdd-m-lp-qe.gpec").len()]> =
    &Aligned(*include_bytes!("../../weights/sdd-m-lp-qe.gpec"));

/// Pedestrians in the scene.
const PEDESTRIANS: u32 = 5;
/// Camera frames: 20 s at 30 Hz.
const FRAMES: u32 = 600;

/// Pedestrian `id`'s feet at `t` seconds, `[north, east]` metres.
fn pedestrian(id: u32, t: f32) -> [f32; 2] {
    let k = id as f32;
    let speed = 1.0 + 0.1 * k;
    let turn = 0.02 * (k - 2.0); // gentle curves, rad/s
    let heading = 0.6 + 0.15 * k + turn * t;
    [
        -4.0 + 2.0 * k + speed * t * libm::cosf(heading),
        3.0 - 1.5 * k + speed * t * libm::sinf(heading),
    ]
}

/// The flight stack at `t` seconds: the drone follows the group north-east,
/// climbs from 30 to 34 m, wobbles, and yaws from 0 to 90° between 9 and
/// 11 s.
fn flight(t: f32) -> State {
    let yaw = core::f32::consts::FRAC_PI_2 * ((t - 9.0) / 2.0).clamp(0.0, 1.0);
    let roll = 0.03 * libm::sinf(1.7 * t);
    let pitch = -0.05 + 0.02 * libm::sinf(2.3 * t);
    State {
        attitude: quaternion(roll, pitch, yaw),
        position: [1.0 * t - 6.0, 0.8 * t, -30.0 - 0.2 * t],
        // The gimbal holds 70° down and compensates the vehicle's pitch.
        gimbal: Euler {
            roll: 0.0,
            pitch: -1.22 - pitch,
            yaw: 0.0,
        },
        ground_down: 0.0,
    }
}

/// PX4's `vehicle_attitude.q` `(w, x, y, z)` of Z-Y-X Euler angles.
fn quaternion(roll: f32, pitch: f32, yaw: f32) -> [f32; 4] {
    let (sr, cr) = (libm::sinf(roll / 2.0), libm::cosf(roll / 2.0));
    let (sp, cp) = (libm::sinf(pitch / 2.0), libm::cosf(pitch / 2.0));
    let (sy, cy) = (libm::sinf(yaw / 2.0), libm::cosf(yaw / 2.0));
    [
        cr * cp * cy + sr * sp * sy,
        sr * cp * cy - cr * sp * sy,
        cr * sp * cy + sr * cp * sy,
        cr * cp * sy - sr * sp * cy,
    ]
}

/// Up to ±1 px of detector noise, deterministic.
fn noise(seed: u32) -> f32 {
    let h = seed.wrapping_mul(0x9E37_79B9).rotate_left(13) ^ 0x5bd1_e995;
    (h >> 8) as f32 / (1u32 << 23) as f32 - 1.0
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let camera = Camera {
        intrinsics: Intrinsics {
            fx: 1100.0,
            fy: 1100.0,
            cx: 960.0,
            cy: 540.0,
        },
        distortion: Distortion {
            k1: -0.12,
            k2: 0.03,
            p1: 0.0,
            p2: 0.0,
        },
        mount: Euler::ZERO,
        max_range: 150.0,
    };
    let model = Model::from_blob(&BLOB.0)?;
    let mut predictor = Predictor::<LibmSine, 64>::with_units(model, CallerUnit::Metres)?;
    // 16 tracks, 2 forecasts per track awaiting their truth, 1 s gaps bridged.
    let mut forecaster: Forecaster<16, 2> = Forecaster::new(&model, Config::metres(), 1_000)?;
    println!(
        "{}: boxes at 30 Hz from a drone at 30-34 m, yawing 90 deg at 9-11 s",
        model.name()
    );

    let (mut forecasts, mut refused, mut sum_err) = (0u32, 0u32, 0.0f32);
    for f in 0..FRAMES {
        let t_ms = f * 1000 / 30;
        let t = t_ms as f32 / 1000.0;
        let pose = Pose::new(&camera, &flight(t))?;
        // The detector: each pedestrian's box, feet at the bottom centre.
        let mut detections = heapless::Vec::<Detection, 16>::new();
        for id in 0..PEDESTRIANS {
            let Ok([u, v]) = pose.ground_to_image(pedestrian(id, t)) else {
                continue; // out of view
            };
            let (u, v) = (u + noise(f * 8 + id), v + noise(f * 8 + id + 4));
            if !(0.0..1920.0).contains(&u) || !(0.0..1080.0).contains(&v) {
                continue;
            }
            let bbox = BoundingBox {
                x_min: u - 15.0,
                y_min: v - 70.0,
                x_max: u + 15.0,
                y_max: v,
            };
            let _ = detections.push(Detection::from_box(id, &bbox));
        }
        // One call: image → world, every refusal reported.
        let mut observations = [Observation {
            id: 0,
            pos: [0.0; 2],
        }; 16];
        let n = to_observations(&pose, &detections, &mut observations, |_, id, e| {
            println!("t={t_ms:>5} ms id={id}: refused ({e})");
            refused += 1;
        });
        forecaster.frame::<_, 64, 20>(
            &mut predictor,
            t_ms,
            &observations[..n],
            |fc: &TrackForecast<20>| {
                let end = fc.point[11];
                let at_ms = fc.end_ms + 12 * 400;
                let truth = pedestrian(fc.id, at_ms as f32 / 1000.0);
                let err = (end[0] - truth[0]).hypot(end[1] - truth[1]);
                forecasts += 1;
                sum_err += err;
                // Every 2 s, the forecast drawn into the current image.
                if fc.end_ms.is_multiple_of(2000) {
                    let drawn = match pose.ground_to_image(end) {
                        Ok([u, v]) => format!("({u:>6.1}, {v:>6.1}) px"),
                        Err(e) => format!("not in view ({e})"),
                    };
                    println!(
                        "t={:>5} ms id={} endpoint at {:>5} ms: N {:>6.2} E {:>6.2} m (truth {:>6.2} {:>6.2}, error {:.2} m, r90 {:.2} m), image {}",
                        fc.end_ms, fc.id, at_ms, end[0], end[1], truth[0], truth[1], err,
                        fc.radii[11].r90, drawn
                    );
                }
            },
        );
    }
    println!(
        "{forecasts} forecasts, mean endpoint error {:.3} m (4.8 s ahead), {refused} detections refused",
        sum_err / forecasts.max(1) as f32
    );
    Ok(())
}
