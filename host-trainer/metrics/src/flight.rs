//! A synthetic flight: a recording's real tracks seen by a simulated drone, for the streaming
//! evaluation (`gpecnet stream --flight`, docs/camera.md "Synthetic flight").
//!
//! **The drone.** It orbits the recording's centre (the mean of all its detections) at
//! [`FlightSettings::orbit_m`] once every [`FlightSettings::orbit_period_s`], at
//! [`FlightSettings::altitude_m`] above the ground plus [`FlightSettings::altitude_swing_m`]
//! × sin(2π t / 60 s), rolling ±3° (period 7 s) and pitched forward 4.6° ± 2.3° (period 11 s).
//! Its body faces the centre, and every [`FlightSettings::yaw_every_s`] it yaws 90° (away,
//! then back at the next event, alternately) in [`FlightSettings::yaw_s`] (a cosine ramp). A
//! three-axis gimbal keeps the camera pointed at the centre: its body-relative angles are
//! whatever the body's attitude needs (computed in f64, the camera's world orientation
//! `R_z(bearing)·R_y(−depression)`, the gimbal's `A_bodyᵀ·R`).
//!
//! **The camera and the detector.** A 1920 × 1080 camera, `fx = fy = 1100` px (82° × 53°),
//! a mild barrel lens (`k1 = −0.12`, `k2 = 0.03`), `max_range` 150 m. Each pedestrian's
//! ground point goes into the image through the true pose ([`Pose::ground_to_image`]); one
//! outside the image is not detected; one is missed with probability
//! [`FlightSettings::miss_rate`]; the rest get i.i.d. Gaussian pixel noise of
//! [`FlightSettings::pixel_noise`] on u and v.
//!
//! **The flight stack's estimate.** The pose the pipeline uses is the true one with the
//! attitude quaternion turned by a fresh small rotation per frame, i.i.d. Gaussian of
//! [`FlightSettings::attitude_noise_deg`] about each world axis (attitude and gimbal errors
//! together). Each noisy pixel goes back to the ground through that pose
//! ([`Pose::image_to_ground`], the core's f32 arithmetic, as on the device), with the
//! measurement model's σ ([`Pose::ground_covariance`]) for the filter.
//!
//! Draws, in order, from one seeded stream per recording ([`FlightSettings::seed`]): per
//! frame three attitude normals (north, east, down), then per pedestrian in the frame's order
//! one uniform (miss) and, when detected, two normals (u, v).

use gpecnet_core::camera::{Camera, CameraError, Euler, MeasurementNoise, Pose, State};
use gpecnet_core::prng::{Gaussian, Xoshiro128PlusPlus};
use serde::Serialize;

/// Image width and height, pixels.
pub const IMAGE: [f32; 2] = [1920.0, 1080.0];

/// The simulated flight and detector (module docs).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct FlightSettings {
    /// Mean altitude above the ground, metres.
    pub altitude_m: f32,
    /// Amplitude of the altitude's sine (period 60 s), metres.
    pub altitude_swing_m: f32,
    /// Radius of the orbit around the recording's centre, metres.
    pub orbit_m: f32,
    /// Seconds per orbit.
    pub orbit_period_s: f32,
    /// Seconds between two 90° yaws of the body.
    pub yaw_every_s: f32,
    /// Seconds one 90° yaw takes.
    pub yaw_s: f32,
    /// Detector noise on each pixel coordinate, pixels.
    pub pixel_noise: f32,
    /// Orientation noise about each world axis, degrees.
    pub attitude_noise_deg: f32,
    /// Correlation time of the orientation noise, seconds: 0 draws it afresh every frame
    /// (i.i.d., the worst case for the velocities the predictor reads); `τ > 0` makes it a
    /// first-order Gauss–Markov process of the same standard deviation, `e ← ρ·e +
    /// √(1 − ρ²)·σ·n` with `ρ = exp(−Δt / τ)` (an attitude estimator's error drifts slowly).
    pub attitude_correlation_s: f32,
    /// Probability that a pedestrian in the image is not detected in a frame.
    pub miss_rate: f32,
    /// Seed of the draws.
    pub seed: u64,
}

impl Default for FlightSettings {
    /// 30 m ± 5 m up on a 20 m orbit of 120 s, a 90° yaw in 2 s every 30 s, 2 px detector
    /// noise, 0.5° orientation noise, 5 % misses.
    fn default() -> Self {
        FlightSettings {
            altitude_m: 30.0,
            altitude_swing_m: 5.0,
            orbit_m: 20.0,
            orbit_period_s: 120.0,
            yaw_every_s: 30.0,
            yaw_s: 2.0,
            pixel_noise: 2.0,
            attitude_noise_deg: 0.5,
            attitude_correlation_s: 0.0,
            miss_rate: 0.05,
            seed: 1,
        }
    }
}

impl FlightSettings {
    /// Checks every value: finite; altitude above its swing; the orbit, periods and
    /// durations positive (a yaw shorter than the time between two); noises `>= 0`; the
    /// miss rate in `[0, 1)`. The error names the setting.
    pub fn validate(&self) -> Result<(), String> {
        let f = |name: &str, v: f32, ok: bool| {
            if v.is_finite() && ok {
                Ok(())
            } else {
                Err(format!("flight {name} = {v} is out of range"))
            }
        };
        f("altitude", self.altitude_m, self.altitude_m > 1.0)?;
        f(
            "altitude swing",
            self.altitude_swing_m,
            self.altitude_swing_m >= 0.0 && self.altitude_swing_m < self.altitude_m - 1.0,
        )?;
        f("orbit", self.orbit_m, self.orbit_m >= 0.0)?;
        f(
            "orbit period",
            self.orbit_period_s,
            self.orbit_period_s > 0.0,
        )?;
        f("yaw interval", self.yaw_every_s, self.yaw_every_s > 0.0)?;
        f(
            "yaw duration",
            self.yaw_s,
            self.yaw_s > 0.0 && self.yaw_s < self.yaw_every_s,
        )?;
        f("pixel noise", self.pixel_noise, self.pixel_noise >= 0.0)?;
        f(
            "attitude noise",
            self.attitude_noise_deg,
            self.attitude_noise_deg >= 0.0,
        )?;
        f(
            "miss rate",
            self.miss_rate,
            (0.0..1.0).contains(&self.miss_rate),
        )?;
        Ok(())
    }

    /// The camera (module docs): the golden replay's flight scene's, so the host's flight
    /// and the MCUs' replay of its camera stage see through the same lens.
    pub fn camera() -> Camera {
        gpecnet_replay::flight_camera()
    }
}

/// What the detector and the camera did over a recording.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct FlightStats {
    /// Pedestrian positions in the recording's frames.
    pub positions: usize,
    /// Of them outside the image (or behind the camera).
    pub outside: usize,
    /// Missed by the detector.
    pub missed: usize,
    /// Refused on the way back to the ground (above the horizon, beyond range).
    pub refused: usize,
    /// Ground points given to the pipeline.
    pub detections: usize,
    /// Of them in frames during a yaw.
    pub detections_yawing: usize,
    /// Root mean square distance between a ground point and the truth, metres.
    pub rms_error_m: f64,
    /// The same over the frames during a yaw.
    pub rms_error_yawing_m: f64,
    /// The largest distance, metres.
    pub max_error_m: f64,
    /// The largest during a yaw.
    pub max_error_yawing_m: f64,
    /// Root mean square of the measurement model's isotropic σ, metres (to compare with the
    /// realised error's RMS per axis, `rms_error_m / √2`).
    pub rms_model_sigma_m: f64,
    /// The drone's lowest and highest altitude, metres.
    pub altitude_range_m: [f64; 2],
}

/// The root of the mean of `n` squares summing to `sum_sq` (0 for none).
fn rms(sum_sq: f64, n: usize) -> f64 {
    if n == 0 {
        0.0
    } else {
        (sum_sq / n as f64).sqrt()
    }
}

impl FlightStats {
    /// Counts summed and errors pooled over `parts` (weighted by their detections).
    pub fn pooled(parts: &[FlightStats]) -> FlightStats {
        let mut o = FlightStats {
            altitude_range_m: [f64::INFINITY, f64::NEG_INFINITY],
            ..FlightStats::default()
        };
        let (mut se, mut sy, mut ss) = (0.0, 0.0, 0.0);
        for p in parts {
            o.positions += p.positions;
            o.outside += p.outside;
            o.missed += p.missed;
            o.refused += p.refused;
            o.detections += p.detections;
            o.detections_yawing += p.detections_yawing;
            se += p.rms_error_m.powi(2) * p.detections as f64;
            sy += p.rms_error_yawing_m.powi(2) * p.detections_yawing as f64;
            ss += p.rms_model_sigma_m.powi(2) * p.detections as f64;
            o.max_error_m = o.max_error_m.max(p.max_error_m);
            o.max_error_yawing_m = o.max_error_yawing_m.max(p.max_error_yawing_m);
            o.altitude_range_m[0] = o.altitude_range_m[0].min(p.altitude_range_m[0]);
            o.altitude_range_m[1] = o.altitude_range_m[1].max(p.altitude_range_m[1]);
        }
        o.rms_error_m = rms(se, o.detections);
        o.rms_error_yawing_m = rms(sy, o.detections_yawing);
        o.rms_model_sigma_m = rms(ss, o.detections);
        if parts.is_empty() {
            o.altitude_range_m = [0.0; 2];
        }
        o
    }
}

/// One frame's state of the drone: the true one and the flight stack's estimate.
#[derive(Clone, Copy, Debug)]
pub struct FrameStates {
    /// Where the drone and its camera really are.
    pub truth: State,
    /// What the flight stack reports (the attitude with its error).
    pub estimate: State,
    /// Whether the body is yawing.
    pub yawing: bool,
}

/// The simulated drone over one recording (module docs).
pub struct Flight {
    s: FlightSettings,
    centre: [f64; 2],
    t0_ms: u32,
    normal: Gaussian,
    uniform: Xoshiro128PlusPlus,
    camera: Camera,
    stats: FlightStats,
    sum_sq: [f64; 3],
    /// The orientation error and the time it was drawn at (seconds), once drawn.
    att_err: Option<([f64; 3], f64)>,
}

type M3 = [[f64; 3]; 3];

fn rz(a: f64) -> M3 {
    let (s, c) = a.sin_cos();
    [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]
}
fn ry(a: f64) -> M3 {
    let (s, c) = a.sin_cos();
    [[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]]
}
fn rx(a: f64) -> M3 {
    let (s, c) = a.sin_cos();
    [[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]]
}
fn mm(a: &M3, b: &M3) -> M3 {
    let mut o = [[0.0; 3]; 3];
    for (i, row) in o.iter_mut().enumerate() {
        for (j, x) in row.iter_mut().enumerate() {
            *x = (0..3).map(|k| a[i][k] * b[k][j]).sum();
        }
    }
    o
}
fn transpose(a: &M3) -> M3 {
    let mut o = [[0.0; 3]; 3];
    for (i, row) in a.iter().enumerate() {
        for (j, x) in row.iter().enumerate() {
            o[j][i] = *x;
        }
    }
    o
}

/// Intrinsic Z-Y-X angles `(roll, pitch, yaw)` of a rotation matrix.
fn zyx_angles(m: &M3) -> [f64; 3] {
    let pitch = (-m[2][0]).clamp(-1.0, 1.0).asin();
    let roll = m[2][1].atan2(m[2][2]);
    let yaw = m[1][0].atan2(m[0][0]);
    [roll, pitch, yaw]
}

/// The unit quaternion `(w, x, y, z)` of a rotation matrix.
fn quaternion(m: &M3) -> [f64; 4] {
    let tr = m[0][0] + m[1][1] + m[2][2];
    let q = if tr > 0.0 {
        let s = (tr + 1.0).sqrt() * 2.0;
        [
            0.25 * s,
            (m[2][1] - m[1][2]) / s,
            (m[0][2] - m[2][0]) / s,
            (m[1][0] - m[0][1]) / s,
        ]
    } else if m[0][0] > m[1][1] && m[0][0] > m[2][2] {
        let s = (1.0 + m[0][0] - m[1][1] - m[2][2]).sqrt() * 2.0;
        [
            (m[2][1] - m[1][2]) / s,
            0.25 * s,
            (m[0][1] + m[1][0]) / s,
            (m[0][2] + m[2][0]) / s,
        ]
    } else if m[1][1] > m[2][2] {
        let s = (1.0 + m[1][1] - m[0][0] - m[2][2]).sqrt() * 2.0;
        [
            (m[0][2] - m[2][0]) / s,
            (m[0][1] + m[1][0]) / s,
            0.25 * s,
            (m[1][2] + m[2][1]) / s,
        ]
    } else {
        let s = (1.0 + m[2][2] - m[0][0] - m[1][1]).sqrt() * 2.0;
        [
            (m[1][0] - m[0][1]) / s,
            (m[0][2] + m[2][0]) / s,
            (m[1][2] + m[2][1]) / s,
            0.25 * s,
        ]
    };
    let n = q.iter().map(|c| c * c).sum::<f64>().sqrt();
    q.map(|c| c / n)
}

impl Flight {
    /// The drone over `rec` (metres): its centre is the mean of every detection, its clock
    /// starts at the first frame.
    pub fn over(s: FlightSettings, rec: &crate::data::Recording) -> Result<Flight, String> {
        let (mut sum, mut n) = ([0.0f64; 2], 0usize);
        for (_, p) in rec.frames.iter().flat_map(|f| &f.detections) {
            sum[0] += f64::from(p[0]);
            sum[1] += f64::from(p[1]);
            n += 1;
        }
        let centre = [sum[0] / n.max(1) as f64, sum[1] / n.max(1) as f64];
        Flight::new(s, centre, rec.frames.first().map_or(0, |f| f.t_ms))
    }

    /// The drone over a recording whose detections (metres) have mean `centre` and whose
    /// first frame is at `t0_ms`.
    pub fn new(s: FlightSettings, centre: [f64; 2], t0_ms: u32) -> Result<Flight, String> {
        s.validate()?;
        Ok(Flight {
            s,
            centre,
            t0_ms,
            normal: Gaussian::new(s.seed),
            uniform: Xoshiro128PlusPlus::seed_from_u64(s.seed ^ 0x9e37_79b9_7f4a_7c15),
            camera: FlightSettings::camera(),
            stats: FlightStats {
                altitude_range_m: [f64::INFINITY, f64::NEG_INFINITY],
                ..FlightStats::default()
            },
            sum_sq: [0.0; 3],
            att_err: None,
        })
    }

    /// The body's yaw offset from facing the centre at `t` seconds (0 or π/2, cosine ramps
    /// between), and whether it is turning.
    fn yaw_offset(&self, t: f64) -> (f64, bool) {
        let every = f64::from(self.s.yaw_every_s);
        let dur = f64::from(self.s.yaw_s);
        let k = (t / every).floor();
        let since = t - k * every;
        let away = |k: f64| (k as i64).rem_euclid(2) == 1;
        let (from, to) = (
            if away(k) {
                0.0
            } else {
                std::f64::consts::FRAC_PI_2
            },
            if away(k) {
                std::f64::consts::FRAC_PI_2
            } else {
                0.0
            },
        );
        if k < 1.0 {
            return (0.0, false);
        }
        if since < dur {
            let f = 0.5 - 0.5 * (std::f64::consts::PI * since / dur).cos();
            (from + (to - from) * f, true)
        } else {
            (to, false)
        }
    }

    /// The drone's true and estimated state at `t_ms` (draws the attitude error).
    pub fn states(&mut self, t_ms: u32) -> FrameStates {
        let s = self.s;
        let t = f64::from(t_ms.wrapping_sub(self.t0_ms)) / 1000.0;
        let tau = std::f64::consts::TAU;
        let phi = tau * t / f64::from(s.orbit_period_s);
        let pos = [
            self.centre[0] + f64::from(s.orbit_m) * phi.cos(),
            self.centre[1] + f64::from(s.orbit_m) * phi.sin(),
        ];
        let alt = f64::from(s.altitude_m) + f64::from(s.altitude_swing_m) * (tau * t / 60.0).sin();
        self.stats.altitude_range_m[0] = self.stats.altitude_range_m[0].min(alt);
        self.stats.altitude_range_m[1] = self.stats.altitude_range_m[1].max(alt);
        let (dn, de) = (self.centre[0] - pos[0], self.centre[1] - pos[1]);
        let bearing = de.atan2(dn);
        let depression = alt.atan2(dn.hypot(de));
        let (offset, yawing) = self.yaw_offset(t);
        let roll = 0.05 * (tau * t / 7.0).sin();
        let pitch = -0.08 + 0.04 * (tau * t / 11.0).sin();
        let body = mm(&rz(bearing + offset), &mm(&ry(pitch), &rx(roll)));
        let camera = mm(&rz(bearing), &ry(-depression));
        let g = zyx_angles(&mm(&transpose(&body), &camera));
        let q = quaternion(&body);
        let sigma = f64::from(s.attitude_noise_deg).to_radians();
        let fresh = [0, 1, 2].map(|_| sigma * f64::from(self.normal.next()));
        let tau = f64::from(s.attitude_correlation_s);
        let e = match self.att_err {
            Some((prev, at)) if tau > 0.0 => {
                let rho = (-(t - at).max(0.0) / tau).exp();
                let k = (1.0 - rho * rho).sqrt();
                [0, 1, 2].map(|i| rho * prev[i] + k * fresh[i])
            }
            _ => fresh,
        };
        self.att_err = Some((e, t));
        let err = mm(&rz(e[2]), &mm(&ry(e[1]), &rx(e[0])));
        let q_est = quaternion(&mm(&err, &body));
        let state = |q: [f64; 4]| State {
            attitude: q.map(|c| c as f32),
            position: [pos[0] as f32, pos[1] as f32, -alt as f32],
            gimbal: Euler {
                roll: g[0] as f32,
                pitch: g[1] as f32,
                yaw: g[2] as f32,
            },
            ground_down: 0.0,
        };
        FrameStates {
            truth: state(q),
            estimate: state(q_est),
            yawing,
        }
    }

    /// One frame: the pedestrians' true ground points `truth` (id, `[north, east]` metres)
    /// seen by the camera, detected, and mapped back to the ground through the estimated
    /// pose. Appends `(id, ground point, measurement-model σ)` to `out`.
    pub fn detect(
        &mut self,
        t_ms: u32,
        truth: &[(u32, [f32; 2])],
        out: &mut Vec<(u32, [f32; 2], f32)>,
    ) -> Result<(), CameraError> {
        let st = self.states(t_ms);
        let real = Pose::new(&self.camera, &st.truth)?;
        let est = Pose::new(&self.camera, &st.estimate)?;
        let noise = MeasurementNoise {
            pixel: self.s.pixel_noise,
            attitude: self.s.attitude_noise_deg.to_radians(),
        };
        for &(id, p) in truth {
            self.stats.positions += 1;
            let seen = real
                .ground_to_image(p)
                .ok()
                .filter(|uv| (0.0..IMAGE[0]).contains(&uv[0]) && (0.0..IMAGE[1]).contains(&uv[1]));
            let Some(uv) = seen else {
                self.stats.outside += 1;
                continue;
            };
            if self.uniform.next_half_open01() < self.s.miss_rate {
                self.stats.missed += 1;
                continue;
            }
            let uv = [
                uv[0] + self.s.pixel_noise * self.normal.next(),
                uv[1] + self.s.pixel_noise * self.normal.next(),
            ];
            let (Ok(g), Ok(c)) = (est.image_to_ground(uv), est.ground_covariance(uv, &noise))
            else {
                self.stats.refused += 1;
                continue;
            };
            let err = f64::from(g[0] - p[0]).hypot(f64::from(g[1] - p[1]));
            self.stats.detections += 1;
            self.sum_sq[0] += err * err;
            self.sum_sq[2] += f64::from(c.sigma()).powi(2);
            self.stats.max_error_m = self.stats.max_error_m.max(err);
            if st.yawing {
                self.stats.detections_yawing += 1;
                self.sum_sq[1] += err * err;
                self.stats.max_error_yawing_m = self.stats.max_error_yawing_m.max(err);
            }
            out.push((id, g, c.sigma()));
        }
        Ok(())
    }

    /// What happened so far.
    pub fn stats(&self) -> FlightStats {
        let mut o = self.stats;
        o.rms_error_m = rms(self.sum_sq[0], o.detections);
        o.rms_error_yawing_m = rms(self.sum_sq[1], o.detections_yawing);
        o.rms_model_sigma_m = rms(self.sum_sq[2], o.detections);
        if o.positions == 0 {
            o.altitude_range_m = [0.0; 2];
        }
        o
    }
}
