//! Rotations between the camera, gimbal, body and world frames, each
//! written out in f32 in a fixed order (nalgebra holds the matrices; no
//! nalgebra operator does arithmetic here, so its implementation never
//! decides a bit).
//!
//! # The arithmetic
//!
//! * **Attitude** `q = (w, x, y, z)` (body → NED) becomes the matrix
//!   `A = |q|²·R(q)` (the homogeneous form, a rotation for any non-zero
//!   `q`, scaled by `|q|²`; ray directions only need their direction, so
//!   nothing is divided by the norm):
//!   `A = [[((w·w + x·x) − y·y) − z·z, 2·(x·y − w·z), 2·(x·z + w·y)],
//!   [2·(x·y + w·z), ((w·w − x·x) + y·y) − z·z, 2·(y·z − w·x)],
//!   [2·(x·z − w·y), 2·(y·z + w·x), ((w·w − x·x) − y·y) + z·z]]`.
//! * **Euler angles** `(roll φ, pitch θ, yaw ψ)` in radians, intrinsic
//!   Z-Y-X (yaw, then pitch, then roll; PX4's and MAVLink's order) become
//!   `E = Rz(ψ)·Ry(θ)·Rx(φ)` with `sφ = sinf(φ)`, `cφ = cosf(φ)`, … (libm
//!   0.2.16):
//!   `E = [[cθ·cψ, (sφ·sθ)·cψ − cφ·sψ, (cφ·sθ)·cψ + sφ·sψ],
//!   [cθ·sψ, (sφ·sθ)·sψ + cφ·cψ, (cφ·sθ)·sψ − sφ·cψ],
//!   [−sθ, sφ·cθ, cφ·cθ]]`.
//! * **Products**: `(M·N)ᵢⱼ = (Mᵢ₀·N₀ⱼ + Mᵢ₁·N₁ⱼ) + Mᵢ₂·N₂ⱼ`;
//!   `(M·v)ᵢ = (Mᵢ₀·v₀ + Mᵢ₁·v₁) + Mᵢ₂·v₂`; `Mᵀ·v` the same over the
//!   transposed matrix.

use nalgebra::{Matrix3, Vector3};

/// Roll, pitch and yaw in radians, applied yaw first (about z), then pitch
/// (about the new y), then roll (about the new x): the intrinsic Z-Y-X
/// Tait–Bryan angles of PX4's `vehicle_attitude` Euler view and of
/// MAVLink's `MOUNT_ORIENTATION` / gimbal messages. For a gimbal, pitch
/// −π/2 looks straight down (MAVLink's sign: positive pitch is up).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Euler {
    /// Rotation about x (forward), radians.
    pub roll: f32,
    /// Rotation about y (right), radians; negative is down.
    pub pitch: f32,
    /// Rotation about z (down), radians; positive turns right (clockwise
    /// seen from above).
    pub yaw: f32,
}

impl Euler {
    /// No rotation.
    pub const ZERO: Euler = Euler {
        roll: 0.0,
        pitch: 0.0,
        yaw: 0.0,
    };

    /// `true` when all three angles are finite.
    pub fn is_finite(&self) -> bool {
        self.roll.is_finite() && self.pitch.is_finite() && self.yaw.is_finite()
    }

    /// `E = Rz(yaw)·Ry(pitch)·Rx(roll)` (module docs).
    pub(crate) fn matrix(&self) -> Matrix3<f32> {
        let (sf, cf) = (libm::sinf(self.roll), libm::cosf(self.roll));
        let (st, ct) = (libm::sinf(self.pitch), libm::cosf(self.pitch));
        let (sp, cp) = (libm::sinf(self.yaw), libm::cosf(self.yaw));
        Matrix3::new(
            ct * cp,
            (sf * st) * cp - cf * sp,
            (cf * st) * cp + sf * sp,
            ct * sp,
            (sf * st) * sp + cf * cp,
            (cf * st) * sp - sf * cp,
            -st,
            sf * ct,
            cf * ct,
        )
    }
}

/// `|q|²` of `q = (w, x, y, z)`: `((w·w + x·x) + y·y) + z·z`.
pub(crate) fn norm2(q: [f32; 4]) -> f32 {
    let [w, x, y, z] = q;
    ((w * w + x * x) + y * y) + z * z
}

/// `A = |q|²·R(q)` for `q = (w, x, y, z)` (module docs).
pub(crate) fn attitude_matrix(q: [f32; 4]) -> Matrix3<f32> {
    let [w, x, y, z] = q;
    Matrix3::new(
        ((w * w + x * x) - y * y) - z * z,
        2.0 * (x * y - w * z),
        2.0 * (x * z + w * y),
        2.0 * (x * y + w * z),
        ((w * w - x * x) + y * y) - z * z,
        2.0 * (y * z - w * x),
        2.0 * (x * z - w * y),
        2.0 * (y * z + w * x),
        ((w * w - x * x) - y * y) + z * z,
    )
}

/// `M·N`, each entry `(Mᵢ₀·N₀ⱼ + Mᵢ₁·N₁ⱼ) + Mᵢ₂·N₂ⱼ`.
pub(crate) fn mul(m: &Matrix3<f32>, n: &Matrix3<f32>) -> Matrix3<f32> {
    let e = |i: usize, j: usize| {
        let (a, b) = (m.row(i), n.column(j));
        (a[0] * b[0] + a[1] * b[1]) + a[2] * b[2]
    };
    Matrix3::new(
        e(0, 0),
        e(0, 1),
        e(0, 2),
        e(1, 0),
        e(1, 1),
        e(1, 2),
        e(2, 0),
        e(2, 1),
        e(2, 2),
    )
}

/// `M·v`, each entry `(Mᵢ₀·v₀ + Mᵢ₁·v₁) + Mᵢ₂·v₂`.
pub(crate) fn apply(m: &Matrix3<f32>, v: &Vector3<f32>) -> Vector3<f32> {
    let e = |i: usize| {
        let a = m.row(i);
        (a[0] * v[0] + a[1] * v[1]) + a[2] * v[2]
    };
    Vector3::new(e(0), e(1), e(2))
}

/// The camera frame (x right, y down, z forward) in the frame of a gimbal
/// at zero angles (x forward, y right, z down; FRD): `(x, y, z)_cam =
/// (z, x, y)_gimbal`, a permutation (no arithmetic). `G·P` for a gimbal
/// matrix `G` is `G` with its columns reordered `(1, 2, 0)`.
pub(crate) fn camera_to_gimbal(g: &Matrix3<f32>) -> Matrix3<f32> {
    let (c0, c1, c2) = (g.column(0), g.column(1), g.column(2));
    Matrix3::from_columns(&[c1.into_owned(), c2.into_owned(), c0.into_owned()])
}

/// `1/√2` rounded to f32 (`0x3F3504F3`), for the ROS frame conversions.
const SQRT_HALF: f32 = core::f32::consts::FRAC_1_SQRT_2;

/// A ROS attitude (REP-103: body FLU — x forward, y left, z up — to world
/// ENU — x east, y north, z up; `geometry_msgs/Quaternion` as `(w, x, y,
/// z)`) as PX4's (body FRD → NED), what [`super::State::attitude`] takes:
/// `q_NED←FRD = q_NED←ENU ⊗ q_ENU←FLU ⊗ q_FLU←FRD` with `q_NED←ENU = (0,
/// √½, √½, 0)` and `q_FLU←FRD = (0, 1, 0, 0)`, which multiplies out to
/// `(√½·(w + z), √½·(x + y), √½·(x − y), √½·(w − z))` (each sum first,
/// then the product with `√½` rounded to f32). A vehicle level and facing
/// east (ROS identity) gets yaw +90° in NED. MAVROS applies the same
/// conversion.
pub fn attitude_from_ros(q_enu_flu: [f32; 4]) -> [f32; 4] {
    let [w, x, y, z] = q_enu_flu;
    [
        SQRT_HALF * (w + z),
        SQRT_HALF * (x + y),
        SQRT_HALF * (x - y),
        SQRT_HALF * (w - z),
    ]
}

/// A ROS ENU position (x east, y north, z up; metres) as NED `(north, east,
/// down) = (y, x, −z)`, exactly.
pub fn position_from_ros(enu: [f32; 3]) -> [f32; 3] {
    [enu[1], enu[0], -enu[2]]
}
