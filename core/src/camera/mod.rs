//! Camera geometry: a detection in the image of a gimballed camera on a
//! moving drone → a point on the ground in a world-fixed frame (north,
//! east in metres), and a ground point (a forecast) → the image.
//!
//! The predictor wants positions in a world-fixed frame: in the image, the
//! drone's own translation, rotation and altitude changes look like
//! pedestrian motion. [`Pose::new`] combines the fixed [`Camera`] (lens,
//! mounting, range limit) with the flight stack's [`State`] at the frame's
//! timestamp (attitude, position, gimbal angles, ground height);
//! [`Pose::image_to_ground`] casts the ray through a pixel onto the ground
//! plane, [`Pose::ground_to_image`] projects back, and [`to_observations`]
//! turns a frame's [`Detection`]s into the
//! [`Observation`](crate::tracks::Observation)s that
//! [`TimedTrackTable`](crate::tracks::TimedTrackTable) and
//! [`Forecaster`](crate::online::Forecaster) take, reporting every
//! detection it cannot map. No heap, no panics, every input checked.
//!
//! ```
//! use gpecnet_core::camera::{Camera, Distortion, Euler, Intrinsics, Pose, State};
//!
//! let camera = Camera {
//!     intrinsics: Intrinsics { fx: 1100.0, fy: 1100.0, cx: 960.0, cy: 540.0 },
//!     distortion: Distortion { k1: -0.12, k2: 0.03, p1: 0.0, p2: 0.0 },
//!     mount: Euler::ZERO,
//!     max_range: 150.0,
//! };
//! let h = core::f32::consts::FRAC_1_SQRT_2;
//! let state = State {
//!     attitude: [h, 0.0, 0.0, h],           // PX4 vehicle_attitude.q: yawed 90°, facing east
//!     position: [10.0, -4.0, -30.0],        // NED metres: 30 m up
//!     gimbal: Euler { roll: 0.0, pitch: -0.7, yaw: 0.0 }, // 40° below the horizon
//!     ground_down: 0.0,
//! };
//! let pose = Pose::new(&camera, &state)?;
//! let [north, east] = pose.image_to_ground([1000.0, 700.0])?; // a foot point
//! assert!(east > -4.0 + 20.0);                                  // ahead of the drone, to the east
//! let back = pose.ground_to_image([north, east])?;              // e.g. a forecast, drawn
//! assert!((back[0] - 1000.0).abs() < 0.01 && (back[1] - 700.0).abs() < 0.01);
//! # Ok::<(), gpecnet_core::camera::CameraError>(())
//! ```
//!
//! # Conventions
//!
//! * **World**: the flight stack's local NED frame (x north, y east, z
//!   down; metres), PX4's `vehicle_local_position` and MAVLink's
//!   `LOCAL_POSITION_NED`. Ground points are `[north, east]`; the ground is
//!   the plane `down = State::ground_down`.
//! * **Body**: FRD (x forward, y right, z down). The attitude quaternion
//!   rotates body vectors into NED, stored `(w, x, y, z)` as PX4's
//!   `vehicle_attitude.q` and MAVLink's `ATTITUDE_QUATERNION` (Hamilton
//!   convention, scalar first).
//! * **Gimbal**: [`Camera::mount`] rotates the gimbal's base relative to
//!   the body, [`State::gimbal`] the camera relative to that base, each
//!   [`Euler`] angles (roll, pitch, yaw; intrinsic Z-Y-X; radians; pitch
//!   negative looks down, MAVLink's gimbal convention). At all-zero angles
//!   the camera looks forward along the body's x axis with the image's
//!   right along the body's right.
//! * **Camera**: x right, y down, z forward along the optical axis
//!   (OpenCV, ROS `optical_frame`); pixels `(u, v)` with `u` right and `v`
//!   down from the top-left corner; [`Intrinsics`] and [`Distortion`] as
//!   OpenCV's (`k1, k2, p1, p2`).
//! * **ROS** (REP-103: world ENU, body FLU): [`attitude_from_ros`] and
//!   [`position_from_ros`] convert to the above (`(n, e, d) = (y, x, −z)`).
//! * **Which image point**: the foot point of a box for an oblique camera,
//!   [`BoundingBox::foot`]; see `detections`' docs for a camera looking
//!   straight down.
//!
//! # Arithmetic
//!
//! Every step is f32 `+ − × ÷`, libm 0.2.16's `sinf`/`cosf`/`sqrtf` and
//! comparisons in the order each submodule writes down (`intrinsics`: the
//! lens; `rotation`: the matrices; `pose`: the ray and its intersection;
//! `uncertainty`: the ground point's first-order covariance,
//! [`Pose::ground_covariance`]).
//! Rust never fuses a multiply and an add, so the host, the Cortex-M and C
//! callers of the same code get the same bits. The error against a
//! double-precision reference is measured in `docs/camera.md` (under
//! 0.01 px for the image → ground → image round trip; under 1 mm at 100 m
//! range).
//!
//! # Cost
//!
//! [`Pose::new`] is six `sinf`/`cosf`, two 3×3 products and the attitude
//! matrix (about 120 flops); a pixel → ground point is one 3×3 product,
//! one `sqrtf` and one division, plus 6 Newton steps of undistortion (about
//! 50 flops each) with a distorted lens. A [`Pose`] is 84 bytes (21 `f32`s).

mod detections;
mod intrinsics;
mod pose;
mod rotation;
mod uncertainty;

pub use detections::{to_observations, BoundingBox, Detection};
pub use intrinsics::{
    Distortion, Intrinsics, MIN_FOCAL_PX, UNDISTORT_ITERATIONS, UNDISTORT_TOLERANCE,
};
pub use pose::{Camera, Pose, State, QUATERNION_TOLERANCE};
pub use rotation::{attitude_from_ros, position_from_ros, Euler};
pub use uncertainty::{GroundCovariance, MeasurementNoise};

/// Why a camera input or a point was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum CameraError {
    /// An input is NaN or infinite (intrinsics, distortion, angles,
    /// attitude, position, ground height, a pixel or a ground point).
    NonFinite,
    /// A focal length is zero, negative or under [`MIN_FOCAL_PX`].
    FocalLength,
    /// [`Camera::max_range`] is not positive.
    MaxRange,
    /// The attitude's `|q|²` is outside `1 ±` [`QUATERNION_TOLERANCE`]
    /// (not normalised, all zero, or not a quaternion at all).
    Quaternion,
    /// The camera is at or below the ground plane.
    BelowGround,
    /// The pixel's ray points at or above the horizon: it never meets the
    /// ground.
    AboveHorizon,
    /// The ray meets the ground farther than [`Camera::max_range`] from the
    /// point below the camera.
    BeyondRange,
    /// The ground point is at or behind the camera's image plane: it has
    /// no pixel.
    BehindCamera,
    /// The lens model cannot be inverted at this pixel (far outside the
    /// calibrated field of view; `intrinsics`' rule U).
    Undistortion,
    /// A result overflowed f32 (a pixel or a point absurdly far outside
    /// the image).
    Overflow,
    /// [`to_observations`]: the output slice is full.
    OutputFull,
    /// A bounding box whose edges are out of order (`x_min > x_max` or
    /// `y_min > y_max`: [`BoundingBox::check`]).
    BadBox,
    /// A [`MeasurementNoise`] standard deviation that is negative or not
    /// finite ([`Pose::ground_covariance`]).
    Noise,
}

impl core::fmt::Display for CameraError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            CameraError::NonFinite => "camera input not finite",
            CameraError::FocalLength => "focal length under one pixel",
            CameraError::MaxRange => "maximum range not positive",
            CameraError::Quaternion => "attitude quaternion not normalised",
            CameraError::BelowGround => "camera at or below the ground plane",
            CameraError::AboveHorizon => "ray at or above the horizon",
            CameraError::BeyondRange => "ground point beyond the maximum range",
            CameraError::BehindCamera => "point behind the camera",
            CameraError::Undistortion => "lens distortion not invertible at this pixel",
            CameraError::Overflow => "camera arithmetic overflowed",
            CameraError::OutputFull => "observation buffer full",
            CameraError::BadBox => "bounding box edges out of order",
            CameraError::Noise => "measurement noise negative or not finite",
        })
    }
}

impl core::error::Error for CameraError {}
