//! The camera at one instant: [`Camera`] (fixed) and [`State`] (per frame)
//! make a [`Pose`], which maps image points to ground points and back.
//!
//! # The arithmetic (f32, in this order)
//!
//! **Pose** ([`Pose::new`]): checks (in this order) every number finite,
//! the focal lengths, `max_range > 0`, `|q|²` within
//! `1 ± QUATERNION_TOLERANCE`, and the height `h = ground_down − down > 0`
//! (one f32 subtraction); then the camera → NED matrix
//! `R = A·(M·(G·P))` with `A` the attitude's matrix, `M` the mounting's
//! and `G` the gimbal's Euler matrices and `P` the camera → gimbal
//! permutation (`rotation`'s rules; `G·P` is exact, then two products,
//! inner first). `R` is `|q|²` times a rotation.
//!
//! **Image → ground** ([`Pose::image_to_ground`]) of pixel `(u, v)`:
//! `(x, y)` = the undistorted normalised point (`intrinsics`' rules);
//! `d = R·(x, y, 1)` (north, east, down components `d_n, d_e, d_d`); a
//! ray with `d_d ≤ 0` is [`CameraError::AboveHorizon`]; with
//! `s = sqrtf(d_n·d_n + d_e·d_e)`, `h·s > max_range·d_d` is
//! [`CameraError::BeyondRange`] (the horizontal distance `h·s/d_d` from the
//! point below the camera, compared without a division); else
//! `t = h / d_d`, `north = n₀ + d_n·t`, `east = e₀ + d_e·t` for the
//! camera's position `(n₀, e₀)`. A result that is not finite (an image
//! point absurdly far outside the image) is [`CameraError::Overflow`].
//!
//! **Ground → image** ([`Pose::ground_to_image`]) of `(north, east)`:
//! `w = (north − n₀, east − e₀, ground_down − down)` (the last is `h`);
//! `c = Rᵀ·w` (camera frame, scaled by `|q|²`); `c_z ≤ 0` is
//! [`CameraError::BehindCamera`]; `(x, y) = (c_x / c_z, c_y / c_z)`,
//! distorted and mapped to pixels (`intrinsics`' rules). A pixel that is
//! not finite is [`CameraError::Overflow`]. Ground → image accepts any
//! range (a forecast drawn into the image may lie beyond `max_range`).

use nalgebra::{Matrix3, Vector3};

use super::intrinsics::{Distortion, Intrinsics};
use super::rotation::{apply, attitude_matrix, camera_to_gimbal, mul, norm2, Euler};
use super::CameraError;

/// How far `|q|²` of an attitude quaternion may be from 1: 10⁻³ (PX4
/// publishes normalised quaternions, `|q|² − 1` of a few 10⁻⁷; a larger
/// error is a corrupted or mis-ordered message).
pub const QUATERNION_TOLERANCE: f32 = 1e-3;

/// What does not change during a flight: the lens, how the camera (or the
/// gimbal's base) is mounted on the body, and how far a ground point may be.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Camera {
    /// Focal lengths and principal point, pixels.
    pub intrinsics: Intrinsics,
    /// Lens distortion ([`Distortion::NONE`] for a rectified image).
    pub distortion: Distortion,
    /// The gimbal's base (or a fixed camera) relative to the body (FRD):
    /// [`Euler::ZERO`] when the gimbal's zero looks forward along the
    /// body's x axis, image right along the body's right. A fixed camera
    /// looking down at 30° is `pitch = −30°` here with a zero gimbal.
    pub mount: Euler,
    /// The farthest ground point, horizontal metres from the point below
    /// the camera (beyond it: [`CameraError::BeyondRange`]). Near the
    /// horizon a pixel covers metres of ground; 100–200 m is a sensible
    /// limit from 30 m altitude.
    pub max_range: f32,
}

/// The flight stack's state at a frame's timestamp (the camera's exposure
/// time; interpolate the attitude there if the detector is slow).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct State {
    /// The vehicle's attitude `(w, x, y, z)`, body (FRD) → NED: PX4's
    /// `vehicle_attitude.q`, MAVLink's `ATTITUDE_QUATERNION (q1, q2, q3,
    /// q4)`, in that order. `|q|²` must be within
    /// `1 ±` [`QUATERNION_TOLERANCE`]. From ROS: [`super::attitude_from_ros`].
    pub attitude: [f32; 4],
    /// The camera's position, NED metres `(north, east, down)` in the local
    /// frame (PX4's `vehicle_local_position x, y, z`; from ROS:
    /// [`super::position_from_ros`]). The offset between the vehicle's
    /// origin and the camera's optical centre (centimetres on most
    /// drones) is the caller's to add, if it matters.
    pub position: [f32; 3],
    /// The gimbal's angles relative to its base ([`Camera::mount`]),
    /// roll/pitch/yaw in radians ([`Euler::ZERO`] for a fixed camera). A
    /// gimbal that reports its yaw in the world frame (yaw lock) must be
    /// converted to the body frame first: subtract the vehicle's yaw.
    pub gimbal: Euler,
    /// The ground plane's down coordinate in the same NED frame, metres
    /// (0 for ground at the local origin's height; `−terrain_height` above
    /// it). The camera must be above it: `position[2] < ground_down`.
    pub ground_down: f32,
}

/// A camera at one frame: the validated, precomputed geometry that maps
/// image points to ground points (NED north, east) and back.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pose {
    intrinsics: Intrinsics,
    distortion: Distortion,
    /// Camera → NED, scaled by `|q|²`.
    r: Matrix3<f32>,
    /// `(north, east)` of the camera.
    origin: [f32; 2],
    /// `ground_down − down` (> 0).
    height: f32,
    max_range: f32,
}

impl Camera {
    /// Checks the fixed part: every number finite
    /// ([`CameraError::NonFinite`]), focal lengths
    /// ([`CameraError::FocalLength`]), `max_range > 0`
    /// ([`CameraError::MaxRange`]).
    pub fn validate(&self) -> Result<(), CameraError> {
        let Distortion { k1, k2, p1, p2 } = self.distortion;
        let finite = k1.is_finite()
            && k2.is_finite()
            && p1.is_finite()
            && p2.is_finite()
            && self.mount.is_finite()
            && self.max_range.is_finite();
        if !finite {
            return Err(CameraError::NonFinite);
        }
        self.intrinsics.validate()?;
        if self.max_range <= 0.0 {
            return Err(CameraError::MaxRange);
        }
        Ok(())
    }
}

impl Pose {
    /// The camera's geometry at one frame (the module's checks and
    /// matrix), or the first check that failed.
    pub fn new(camera: &Camera, state: &State) -> Result<Pose, CameraError> {
        let [w, x, y, z] = state.attitude;
        let [n0, e0, d0] = state.position;
        let finite = [w, x, y, z, n0, e0, d0, state.ground_down]
            .iter()
            .all(|v| v.is_finite())
            && state.gimbal.is_finite();
        if !finite {
            return Err(CameraError::NonFinite);
        }
        camera.validate()?;
        let n2 = norm2(state.attitude);
        // A sum of finite squares is never NaN (at worst infinite).
        if (n2 - 1.0).abs() > QUATERNION_TOLERANCE {
            return Err(CameraError::Quaternion);
        }
        let height = state.ground_down - d0;
        if height <= 0.0 {
            return Err(CameraError::BelowGround);
        }
        let g = camera_to_gimbal(&state.gimbal.matrix());
        let body = mul(&camera.mount.matrix(), &g);
        let r = mul(&attitude_matrix(state.attitude), &body);
        Ok(Pose {
            intrinsics: camera.intrinsics,
            distortion: camera.distortion,
            r,
            origin: [n0, e0],
            height,
            max_range: camera.max_range,
        })
    }

    /// The camera's height above the ground plane, metres.
    pub fn height(&self) -> f32 {
        self.height
    }

    /// The lens's focal lengths and principal point.
    pub(super) fn intrinsics(&self) -> &Intrinsics {
        &self.intrinsics
    }

    /// Camera → NED, scaled by `|q|²`.
    pub(super) fn rotation(&self) -> &Matrix3<f32> {
        &self.r
    }

    /// The ray through pixel `uv` in NED, `R·(x, y, 1)`: its direction only
    /// (length `|q|²·√(x² + y² + 1)`).
    pub fn ray(&self, uv: [f32; 2]) -> Result<[f32; 3], CameraError> {
        if !(uv[0].is_finite() && uv[1].is_finite()) {
            return Err(CameraError::NonFinite);
        }
        let [x, y] = self.distortion.undistort(self.intrinsics.normalise(uv))?;
        let d = apply(&self.r, &Vector3::new(x, y, 1.0));
        Ok([d[0], d[1], d[2]])
    }

    /// The ground point `(north, east)` in metres seen at pixel `uv` (the
    /// module's rules), or why there is none.
    pub fn image_to_ground(&self, uv: [f32; 2]) -> Result<[f32; 2], CameraError> {
        self.ground_and_ray(uv).map(|(g, _)| g)
    }

    /// [`Pose::image_to_ground`] with the ray it cast (for the measurement
    /// model, `uncertainty`).
    pub(super) fn ground_and_ray(&self, uv: [f32; 2]) -> Result<([f32; 2], [f32; 3]), CameraError> {
        let [dn, de, dd] = self.ray(uv)?;
        if dd.is_nan() {
            return Err(CameraError::Overflow);
        }
        if dd <= 0.0 {
            return Err(CameraError::AboveHorizon);
        }
        let s = libm::sqrtf(dn * dn + de * de);
        if self.height * s > self.max_range * dd {
            return Err(CameraError::BeyondRange);
        }
        let t = self.height / dd;
        let ground = [self.origin[0] + dn * t, self.origin[1] + de * t];
        if ground[0].is_finite() && ground[1].is_finite() {
            Ok((ground, [dn, de, dd]))
        } else {
            Err(CameraError::Overflow)
        }
    }

    /// The pixel `(u, v)` at which the ground point `(north, east)` (metres)
    /// is seen (the module's rules), or why there is none.
    pub fn ground_to_image(&self, ne: [f32; 2]) -> Result<[f32; 2], CameraError> {
        if !(ne[0].is_finite() && ne[1].is_finite()) {
            return Err(CameraError::NonFinite);
        }
        let w = Vector3::new(ne[0] - self.origin[0], ne[1] - self.origin[1], self.height);
        let c = apply(&self.r.transpose(), &w);
        if c[2].is_nan() {
            return Err(CameraError::Overflow);
        }
        if c[2] <= 0.0 {
            return Err(CameraError::BehindCamera);
        }
        let d = self.distortion.distort([c[0] / c[2], c[1] / c[2]]);
        let uv = self.intrinsics.to_pixel(d);
        if uv[0].is_finite() && uv[1].is_finite() {
            Ok(uv)
        } else {
            Err(CameraError::Overflow)
        }
    }
}
