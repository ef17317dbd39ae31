//! The synthetic flight's camera stage on a deterministic scene
//! ([`flight_scene`]): a drone's camera, its detector's noise and misses,
//! the flight stack's attitude error, then the core's camera module, its
//! measurement model, the per-track Kalman filter and the timed track
//! table, as a device runs them; one [`Line::Flight`] whose hash covers
//! every ground point, σ and filtered history, so `cargo xtask qemu`
//! checks the whole chain bit for bit on each MCU class (the forecaster
//! after it is the online scene's, [`crate::online_scene`]).

use gpecnet_core::camera::{Camera, Distortion, Euler, Intrinsics, MeasurementNoise, Pose, State};
use gpecnet_core::golden::{fnv1a, fnv1a_continue};
use gpecnet_core::tracks::filter::{FilterConfig, TrackFilter};
use gpecnet_core::tracks::{Observation, TimedTrackTable};
use heapless::Vec;

use crate::Line;

/// Camera frames of [`flight_scene`]: 36 s at 10 Hz.
pub const FLIGHT_FRAMES: u32 = 360;
/// Pedestrians of [`flight_scene`] (the table's and the filter's capacity).
pub const FLIGHT_PEDESTRIANS: usize = 16;

/// The drone's camera: 1920 × 1080, 82° × 53°, a mild barrel lens.
pub fn flight_camera() -> Camera {
    Camera {
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
    }
}

/// The unit quaternion `(w, x, y, z)` of intrinsic Z-Y-X angles (f32,
/// libm's `sinf`/`cosf`, in this order).
fn quaternion(roll: f32, pitch: f32, yaw: f32) -> [f32; 4] {
    let (sr, cr) = (libm::sinf(roll * 0.5), libm::cosf(roll * 0.5));
    let (sp, cp) = (libm::sinf(pitch * 0.5), libm::cosf(pitch * 0.5));
    let (sy, cy) = (libm::sinf(yaw * 0.5), libm::cosf(yaw * 0.5));
    [
        cr * cp * cy + sr * sp * sy,
        sr * cp * cy - cr * sp * sy,
        cr * sp * cy + sr * cp * sy,
        cr * cp * sy - sr * sp * cy,
    ]
}

/// Pedestrian `id` at `t` seconds (metres, around the origin): walkers on
/// curves at 0.6–1.9 m/s, two standing, one starting at 15 s.
fn pedestrian(id: u32, t: f32) -> [f32; 2] {
    let k = id as f32;
    match id {
        0 | 1 => [-6.0 + 4.0 * k, 5.0],
        2 => {
            let s = if t > 15.0 { t - 15.0 } else { 0.0 };
            [3.0 + 1.1 * s, -4.0 + 0.4 * s]
        }
        _ => {
            let speed = 0.6 + 0.1 * k;
            let dir = 0.7 * k;
            [
                -14.0 + 1.7 * k + speed * libm::cosf(dir) * (t - 18.0) * 0.8,
                -9.0 + 1.1 * k + speed * libm::sinf(dir + 0.01 * t * t) * (t - 18.0) * 0.8,
            ]
        }
    }
}

/// The synthetic flight's camera stage, its result as one [`Line::Flight`]:
/// [`FLIGHT_PEDESTRIANS`] scripted pedestrians seen at 10 Hz for 36 s by a
/// drone orbiting them 20 m out (one orbit in 120 s) at 30 m ± 5 m (period
/// 60 s), rolling ±3° and pitching −4.6° ± 2.3° with a two-axis gimbal
/// that looks at the scene's centre and compensates only the body's yaw
/// turns: 90° in 2 s at 10 s, back at 25 s. Each pedestrian inside the
/// image is projected through the true pose, missed one time in 20 and
/// otherwise detected with ±3.5 px of pixel noise (the sum of two uniform
/// draws of ±1.75 px, σ 1.4 px) per coordinate; the flight stack reports
/// the body's angles with the same kind of error (±0.43°, σ 0.18°). The detection
/// goes back to the ground through the reported pose with
/// [`Pose::ground_covariance`]'s σ (2 px, 0.5°), into
/// [`TrackFilter::update_with`] and a [`TimedTrackTable`] of 0.4 s. The
/// hash covers every ground point's and σ's bits, every filtered position
/// and every fresh history (id, end time, positions). A 32-bit LCG draws
/// the noise; the geometry is libm's `sinf`/`cosf` in f32, the same bits
/// on every target.
///
/// Out of line: its table, filter and buffers (about 2.5 KiB) must not
/// join the golden replay's deepest frames.
#[inline(never)]
pub fn flight_scene(out: &mut dyn FnMut(Line<'_>)) {
    let camera = flight_camera();
    let period = core::num::NonZeroU32::MIN.saturating_add(399);
    let mut table: TimedTrackTable<FLIGHT_PEDESTRIANS> = TimedTrackTable::new(period, 1_000);
    let Ok(mut filter) = TrackFilter::<FLIGHT_PEDESTRIANS>::new(FilterConfig::metres()) else {
        out(Line::Flight {
            frames: 0,
            detections: 0,
            points: 0,
            hash: 0,
        });
        return;
    };
    let noise = MeasurementNoise {
        pixel: 2.0,
        attitude: 0.5 * core::f32::consts::PI / 180.0,
    };
    let mut state: u32 = 0x00f1_1647;
    let mut next = move || {
        state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        state >> 8
    };
    // A centred draw in [-1, 1): the sum of two uniform draws in [-0.5, 0.5).
    let centred = |n: &mut dyn FnMut() -> u32| {
        let u = |r: u32| (r & 0xffff) as f32 / 65_536.0 - 0.5;
        u(n()) + u(n())
    };
    let deg = core::f32::consts::PI / 180.0;
    let mut h = fnv1a([]);
    let (mut detections, mut points) = (0u32, 0u32);
    for frame in 0..FLIGHT_FRAMES {
        let t_ms = frame * 100;
        let t = t_ms as f32 / 1000.0;
        let tau = 2.0 * core::f32::consts::PI;
        let phi = tau * t / 120.0;
        let (n0, e0) = (20.0 * libm::cosf(phi), 20.0 * libm::sinf(phi));
        let alt = 30.0 + 5.0 * libm::sinf(tau * t / 60.0);
        let bearing = libm::atan2f(-e0, -n0);
        let depression = libm::atan2f(alt, libm::sqrtf(n0 * n0 + e0 * e0));
        let turn = |a: f32, b: f32| {
            if t < a {
                0.0
            } else if t < b {
                0.5 - 0.5 * libm::cosf(core::f32::consts::PI * (t - a) / (b - a))
            } else {
                1.0
            }
        };
        let offset = 90.0 * deg * (turn(10.0, 12.0) - turn(25.0, 27.0));
        let roll = 0.05 * libm::sinf(tau * t / 7.0);
        let pitch = -0.08 + 0.04 * libm::sinf(tau * t / 11.0);
        let gimbal = Euler {
            roll: 0.0,
            pitch: -depression,
            yaw: -offset,
        };
        let truth = State {
            attitude: quaternion(roll, pitch, bearing + offset),
            position: [n0, e0, -alt],
            gimbal,
            ground_down: 0.0,
        };
        let err = [0, 1, 2].map(|_| 0.35 * deg * 1.2247 * centred(&mut next));
        let reported = State {
            attitude: quaternion(roll + err[0], pitch + err[1], bearing + offset + err[2]),
            ..truth
        };
        let (Ok(real), Ok(est)) = (Pose::new(&camera, &truth), Pose::new(&camera, &reported))
        else {
            h = fnv1a_continue(h, [u32::MAX, frame]);
            continue;
        };
        let mut obs: Vec<Observation, FLIGHT_PEDESTRIANS> = Vec::new();
        let mut sigma = [0.0f32; FLIGHT_PEDESTRIANS];
        for id in 0..FLIGHT_PEDESTRIANS as u32 {
            let Ok(uv) = real.ground_to_image(pedestrian(id, t)) else {
                continue;
            };
            if !((0.0..1920.0).contains(&uv[0]) && (0.0..1080.0).contains(&uv[1])) {
                continue;
            }
            if next() % 20 == 0 {
                continue; // missed
            }
            let px = [
                uv[0] + 1.75 * 2.0 * centred(&mut next),
                uv[1] + 1.75 * 2.0 * centred(&mut next),
            ];
            match (est.image_to_ground(px), est.ground_covariance(px, &noise)) {
                (Ok(g), Ok(c)) => {
                    sigma[obs.len()] = c.sigma();
                    h = fnv1a_continue(
                        h,
                        [id, g[0].to_bits(), g[1].to_bits(), c.sigma().to_bits()],
                    );
                    let _ = obs.push(Observation { id, pos: g });
                    detections += 1;
                }
                (g, c) => {
                    let code = |r: bool| u32::from(r);
                    h = fnv1a_continue(h, [id, u32::MAX, code(g.is_err()), code(c.is_err())]);
                }
            }
        }
        let report = filter.update_with(t_ms, &mut obs, |i, _| {
            sigma.get(i).copied().unwrap_or(f32::NAN)
        });
        h = fnv1a_continue(
            h,
            [report.filtered, report.started, report.resets]
                .into_iter()
                .chain(
                    obs.iter()
                        .flat_map(|o| [o.id, o.pos[0].to_bits(), o.pos[1].to_bits()]),
                ),
        );
        table.update(t_ms, &obs);
        let (hashed, fresh) = crate::hash_fresh(h, &table);
        h = hashed;
        points += fresh;
    }
    out(Line::Flight {
        frames: FLIGHT_FRAMES,
        detections,
        points,
        hash: h,
    });
}
