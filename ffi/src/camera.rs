//! The camera geometry through the C ABI (`gpecnet_core::camera`: the
//! conventions, the f32 arithmetic, the errors): bounding boxes in the
//! image of a gimballed camera on a moving drone, and the flight stack's
//! state at the frame's timestamp, become the ground-frame
//! [`GpecnetDetection`]s (north, east in NED metres) that
//! `gpecnet_forecaster_frame` and `gpecnet_tracks_update` take; a ground
//! point (a forecast) maps back into the image.
//!
//! ```c
//! GpecnetCamera cam = { .fx = 1100, .fy = 1100, .cx = 960, .cy = 540,
//!                       .k1 = -0.12f, .k2 = 0.03f, .max_range = 150 };
//! // each camera frame, with PX4's vehicle_attitude.q and vehicle_local_position:
//! GpecnetCameraState st = { .attitude = { q[0], q[1], q[2], q[3] },
//!                           .position = { x, y, z }, .gimbal = { 0, -1.22f, 0 } };
//! GpecnetPose pose;
//! if (gpecnet_camera_pose(&cam, &st, &pose) != GPECNET_OK) { /* skip the frame */ }
//! GpecnetDetection dets[GPECNET_ONLINE_MAX_DETECTIONS];
//! int32_t why[GPECNET_ONLINE_MAX_DETECTIONS];
//! size_t n_dets;
//! gpecnet_boxes_to_detections(&pose, boxes, n_boxes, dets, GPECNET_ONLINE_MAX_DETECTIONS,
//!                             why, &n_dets);
//! gpecnet_forecaster_frame(f, p, t_ms, dets, n_dets, out, GPECNET_ONLINE_TRACKS, &n, NULL);
//! ```
//!
//! Every result is the core's, bit for bit: the pose is the core's `Pose`
//! (built once per frame by [`gpecnet_camera_pose`] and kept, opaque, in a
//! [`GpecnetPose`] the caller declares), and each box goes through the
//! core's `to_observations`.
use gpecnet_core::camera::{
    attitude_from_ros, position_from_ros, to_observations, BoundingBox, Camera, CameraError,
    Detection, Distortion, Euler, Intrinsics, MeasurementNoise, Pose, State,
};
use gpecnet_core::tracks::Observation;

use crate::boundary::{guard, non_null};
#[cfg(doc)]
use crate::status::GPECNET_E_CAMERA_BAD_BOX;
use crate::status::GPECNET_OK;
use crate::status::{camera_status, GPECNET_E_CAMERA_OUTPUT_FULL, GPECNET_E_NOT_INITIALISED};
use crate::tracks::GpecnetDetection;

#[cfg(doc)]
use crate::status::{
    GPECNET_E_CAMERA_ABOVE_HORIZON, GPECNET_E_CAMERA_BELOW_GROUND, GPECNET_E_CAMERA_FOCAL_LENGTH,
    GPECNET_E_CAMERA_NON_FINITE, GPECNET_E_CAMERA_QUATERNION,
};

/// 32-bit words of [`GpecnetPose::opaque`]: room for the core's `Pose`
/// (21 words today) and for its growth without changing the C struct.
pub const GPECNET_POSE_WORDS: usize = 31;

/// Roll, pitch and yaw in radians, applied yaw first, then pitch, then roll
/// (intrinsic Z-Y-X; PX4's and MAVLink's order): `gpecnet_core::camera::Euler`.
/// For a gimbal, pitch −π/2 looks straight down (MAVLink's sign).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct GpecnetEuler {
    /// Rotation about x (forward), radians.
    pub roll: f32,
    /// Rotation about y (right), radians; negative looks down.
    pub pitch: f32,
    /// Rotation about z (down), radians; positive turns right (clockwise
    /// seen from above).
    pub yaw: f32,
}

/// What does not change during a flight (`gpecnet_core::camera::Camera`):
/// the pinhole intrinsics and OpenCV lens coefficients in pixels (ROS
/// `CameraInfo.K`, the first four of `CameraInfo.D`), how the gimbal's base
/// (or a fixed camera) is mounted on the body, and the farthest ground
/// point accepted.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct GpecnetCamera {
    /// Focal length along the image's x axis (right), pixels, at least 1.
    pub fx: f32,
    /// Focal length along the image's y axis (down), pixels, at least 1.
    pub fy: f32,
    /// Principal point's x, pixels from the left edge.
    pub cx: f32,
    /// Principal point's y, pixels from the top edge.
    pub cy: f32,
    /// Radial distortion coefficient of `r²` (0 for a rectified image).
    pub k1: f32,
    /// Radial distortion coefficient of `r⁴`.
    pub k2: f32,
    /// First tangential distortion coefficient.
    pub p1: f32,
    /// Second tangential distortion coefficient.
    pub p2: f32,
    /// The gimbal's base relative to the body (FRD); all zero when the
    /// gimbal's zero looks forward along the body's x axis.
    pub mount: GpecnetEuler,
    /// The farthest ground point, horizontal metres from the point below
    /// the camera (> 0; 100–200 m from 30 m altitude).
    pub max_range: f32,
}

/// The flight stack's state at a frame's timestamp (the camera's exposure
/// time): `gpecnet_core::camera::State`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct GpecnetCameraState {
    /// The vehicle's attitude quaternion `(w, x, y, z)`, body (FRD) → NED:
    /// PX4's `vehicle_attitude.q`, MAVLink's `ATTITUDE_QUATERNION (q1, q2,
    /// q3, q4)`, in that order; `|q|²` within `1 ± 10⁻³`.
    pub attitude: [f32; 4],
    /// The camera's position `(north, east, down)`, NED metres (PX4's
    /// `vehicle_local_position x, y, z`).
    pub position: [f32; 3],
    /// The gimbal's angles relative to its base ([`GpecnetCamera::mount`]);
    /// all zero for a fixed camera. A gimbal reporting its yaw in the world
    /// frame must subtract the vehicle's yaw first.
    pub gimbal: GpecnetEuler,
    /// The ground plane's down coordinate in the same NED frame, metres (0
    /// at the local origin's height); the camera must be above it
    /// (`position[2] < ground_down`).
    pub ground_down: f32,
}

/// A detector's box in pixels (x right, y down), with the upstream
/// tracker's id: `x_min ≤ x_max`, `y_min ≤ y_max`. Its ground point is the
/// foot point, the bottom centre `((x_min + x_max)·0.5, y_max)`
/// (`gpecnet_core::camera::BoundingBox::foot`: right for an oblique
/// camera; for one looking straight down, map the box centre with
/// [`gpecnet_image_to_ground`] instead).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct GpecnetBox {
    /// Track id from the upstream tracker (any value).
    pub id: u32,
    /// Left edge, pixels.
    pub x_min: f32,
    /// Top edge, pixels.
    pub y_min: f32,
    /// Right edge, pixels.
    pub x_max: f32,
    /// Bottom edge, pixels.
    pub y_max: f32,
}

/// A camera at one frame, the core's validated and precomputed `Pose`,
/// written by [`gpecnet_camera_pose`]: declare one (stack, static, struct
/// member; any alignment), fill it once per frame and pass it to the
/// mapping functions. Copying it (assignment, `memcpy`) copies the pose.
/// Its fields are opaque: a pose that [`gpecnet_camera_pose`] refused, or
/// zero-filled memory, is [`GPECNET_E_NOT_INITIALISED`].
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct GpecnetPose {
    /// Opaque: a tag saying whether the rest holds a pose.
    pub tag: u32,
    /// Opaque: the core's pose.
    pub opaque: [u32; GPECNET_POSE_WORDS],
}

/// Tag of a pose written by a successful [`gpecnet_camera_pose`] ("GPCP").
const LIVE: u32 = 0x5043_5047;

// The core's pose is 21 f32s: any bit pattern is a valid `Pose`, it fits in
// the opaque words, and it needs no more than their alignment.
const _: () = {
    assert!(core::mem::size_of::<Pose>() <= 4 * GPECNET_POSE_WORDS);
    assert!(core::mem::align_of::<Pose>() <= core::mem::align_of::<u32>());
};

impl From<GpecnetEuler> for Euler {
    fn from(e: GpecnetEuler) -> Self {
        Euler {
            roll: e.roll,
            pitch: e.pitch,
            yaw: e.yaw,
        }
    }
}

impl From<GpecnetCamera> for Camera {
    fn from(c: GpecnetCamera) -> Self {
        Camera {
            intrinsics: Intrinsics {
                fx: c.fx,
                fy: c.fy,
                cx: c.cx,
                cy: c.cy,
            },
            distortion: Distortion {
                k1: c.k1,
                k2: c.k2,
                p1: c.p1,
                p2: c.p2,
            },
            mount: c.mount.into(),
            max_range: c.max_range,
        }
    }
}

impl From<GpecnetCameraState> for State {
    fn from(s: GpecnetCameraState) -> Self {
        State {
            attitude: s.attitude,
            position: s.position,
            gimbal: s.gimbal.into(),
            ground_down: s.ground_down,
        }
    }
}

impl From<GpecnetBox> for BoundingBox {
    fn from(b: GpecnetBox) -> Self {
        BoundingBox {
            x_min: b.x_min,
            y_min: b.y_min,
            x_max: b.x_max,
            y_max: b.y_max,
        }
    }
}

impl GpecnetPose {
    /// A pose that holds nothing (what a refused [`gpecnet_camera_pose`] writes).
    const EMPTY: GpecnetPose = GpecnetPose {
        tag: 0,
        opaque: [0; GPECNET_POSE_WORDS],
    };

    /// The C form of the core's `pose`.
    fn of(pose: Pose) -> Self {
        let mut c = GpecnetPose {
            tag: LIVE,
            ..GpecnetPose::EMPTY
        };
        // SAFETY: `opaque` has room for a Pose at its start (size asserted
        // above); the write is unaligned, so the array's alignment is moot.
        unsafe { c.opaque.as_mut_ptr().cast::<Pose>().write_unaligned(pose) };
        c
    }

    /// The core's pose, or [`GPECNET_E_NOT_INITIALISED`] when this holds none.
    fn pose(&self) -> Result<Pose, i32> {
        if self.tag != LIVE {
            return Err(GPECNET_E_NOT_INITIALISED);
        }
        // SAFETY: `opaque` holds size_of::<Pose>() initialised bytes at its
        // start (asserted above), read unaligned; a Pose is only f32s, so
        // these bytes are a valid Pose whatever they are (the tag says
        // `of` wrote them, or a copy of what it wrote).
        Ok(unsafe { self.opaque.as_ptr().cast::<Pose>().read_unaligned() })
    }
}

/// The pose in `*pose`, or why there is none.
///
/// # Safety
/// `pose` is NULL or valid for a read of a [`GpecnetPose`] (any alignment).
unsafe fn read_pose(pose: *const GpecnetPose) -> Result<Pose, i32> {
    non_null(pose)?;
    // SAFETY: non-null, readable (caller's contract); any alignment; every
    // bit pattern of the struct's u32s is a value.
    unsafe { pose.read_unaligned() }.pose()
}

/// Builds the camera's geometry at one frame from the fixed `*camera` and
/// the flight stack's `*state` (the core's `Pose::new`) into `*out`.
/// Checks, in this order: every number finite
/// ([`GPECNET_E_CAMERA_NON_FINITE`], a NaN quaternion among them), the
/// focal lengths at least 1 px ([`GPECNET_E_CAMERA_FOCAL_LENGTH`]),
/// `max_range > 0`, `|q|²` within `1 ± 10⁻³`
/// ([`GPECNET_E_CAMERA_QUATERNION`]) and the camera above the ground plane
/// ([`GPECNET_E_CAMERA_BELOW_GROUND`]). On any failure `*out` (when not
/// NULL) is marked as holding no pose: the mapping functions then return
/// [`GPECNET_E_NOT_INITIALISED`]. The three structs may have any alignment.
///
/// # Safety
/// `camera` and `state` are NULL or valid for a read; `out` is NULL or
/// valid for a write of a [`GpecnetPose`].
#[no_mangle]
pub unsafe extern "C" fn gpecnet_camera_pose(
    camera: *const GpecnetCamera,
    state: *const GpecnetCameraState,
    out: *mut GpecnetPose,
) -> i32 {
    guard(|| {
        non_null(out)?;
        // SAFETY: non-null, writable (caller's contract); any alignment.
        unsafe { out.write_unaligned(GpecnetPose::EMPTY) };
        non_null(camera)?;
        non_null(state)?;
        // SAFETY: non-null, readable (caller's contract); any alignment.
        let (camera, state) = unsafe { (camera.read_unaligned(), state.read_unaligned()) };
        let pose = Pose::new(&camera.into(), &state.into()).map_err(camera_status)?;
        // SAFETY: as above.
        unsafe { out.write_unaligned(GpecnetPose::of(pose)) };
        Ok(())
    })
}

/// The ground point seen at pixel `(u, v)` (the core's
/// `Pose::image_to_ground`): `out_ne[0]` = north, `out_ne[1]` = east, NED
/// metres. A ray at or above the horizon is
/// [`GPECNET_E_CAMERA_ABOVE_HORIZON`], a ground point beyond the camera's
/// `max_range` `GPECNET_E_CAMERA_BEYOND_RANGE`, a pixel the lens model
/// cannot invert `GPECNET_E_CAMERA_UNDISTORTION`, a NaN or infinite pixel
/// [`GPECNET_E_CAMERA_NON_FINITE`]; nothing is written on failure.
///
/// # Safety
/// `pose` is NULL or valid for a read of a [`GpecnetPose`]; `out_ne` is
/// NULL or valid for writes of 2 floats (any alignment).
#[no_mangle]
pub unsafe extern "C" fn gpecnet_image_to_ground(
    pose: *const GpecnetPose,
    u: f32,
    v: f32,
    out_ne: *mut f32,
) -> i32 {
    guard(|| {
        non_null(out_ne)?;
        // SAFETY: the caller's contract on `pose`.
        let pose = unsafe { read_pose(pose) }?;
        let ne = pose.image_to_ground([u, v]).map_err(camera_status)?;
        // SAFETY: non-null, room for 2 floats (caller's contract); any alignment.
        unsafe { crate::boundary::write_points(out_ne, &[ne]) };
        Ok(())
    })
}

/// The pixel at which the ground point `(north, east)` (NED metres) is
/// seen (the core's `Pose::ground_to_image`): `out_uv[0]` = u (right),
/// `out_uv[1]` = v (down), e.g. to draw a forecast into the image. Any
/// range is accepted; a point at or behind the image plane is
/// `GPECNET_E_CAMERA_BEHIND_CAMERA`, a NaN or infinite one
/// [`GPECNET_E_CAMERA_NON_FINITE`]; nothing is written on failure.
///
/// # Safety
/// `pose` is NULL or valid for a read of a [`GpecnetPose`]; `out_uv` is
/// NULL or valid for writes of 2 floats (any alignment).
#[no_mangle]
pub unsafe extern "C" fn gpecnet_ground_to_image(
    pose: *const GpecnetPose,
    north: f32,
    east: f32,
    out_uv: *mut f32,
) -> i32 {
    guard(|| {
        non_null(out_uv)?;
        // SAFETY: the caller's contract on `pose`.
        let pose = unsafe { read_pose(pose) }?;
        let uv = pose.ground_to_image([north, east]).map_err(camera_status)?;
        // SAFETY: non-null, room for 2 floats (caller's contract); any alignment.
        unsafe { crate::boundary::write_points(out_uv, &[uv]) };
        Ok(())
    })
}

/// The first-order covariance of the ground point seen at pixel `(u, v)`
/// (the core's `Pose::ground_covariance`) under i.i.d. detector noise of
/// `sigma_px` pixels on `u` and `v` and camera-orientation noise of
/// `sigma_att` radians about each world axis: `out_cov` = `{nn, ne, ee}`,
/// metres². Its isotropic `sqrtf((nn + ee) / 2)` is the per-detection
/// sigma a Kalman filter takes. The refusals of [`gpecnet_image_to_ground`]
/// come after `GPECNET_E_CAMERA_NOISE` (a noise negative or not finite);
/// nothing is written on failure.
///
/// # Safety
/// `pose` is NULL or valid for a read of a [`GpecnetPose`]; `out_cov` is
/// NULL or valid for writes of 3 floats (any alignment).
#[no_mangle]
pub unsafe extern "C" fn gpecnet_ground_covariance(
    pose: *const GpecnetPose,
    u: f32,
    v: f32,
    sigma_px: f32,
    sigma_att: f32,
    out_cov: *mut f32,
) -> i32 {
    guard(|| {
        non_null(out_cov)?;
        // SAFETY: the caller's contract on `pose`.
        let pose = unsafe { read_pose(pose) }?;
        let noise = MeasurementNoise {
            pixel: sigma_px,
            attitude: sigma_att,
        };
        let c = pose
            .ground_covariance([u, v], &noise)
            .map_err(camera_status)?;
        let out = [c.nn, c.ne, c.ee];
        for (i, x) in out.iter().enumerate() {
            // SAFETY: non-null, room for 3 floats (caller's contract); an
            // unaligned write, as the caller may pass any alignment.
            unsafe { out_cov.add(i).write_unaligned(*x) };
        }
        Ok(())
    })
}

/// Maps one frame's `n` boxes at `boxes` onto the ground, each at its foot
/// point ([`GpecnetBox`]), through the core's `to_observations`: box `i`'s
/// detection `{id, x = north, y = east}` (NED metres) goes to the next free
/// entry of `out` (room for `cap`), in box order, and `statuses[i]`
/// receives [`GPECNET_OK`], or the `GPECNET_E_CAMERA_*` code of why it has
/// no detection (above the horizon, beyond range, not finite, edges out of
/// order: [`GPECNET_E_CAMERA_BAD_BOX`], ...; or
/// [`GPECNET_E_CAMERA_OUTPUT_FULL`] when `out` was already full). Every box
/// gets a status: none is dropped silently. `*n_out` receives the
/// detections written: `out[0 .. *n_out]` is the frame for
/// `gpecnet_forecaster_frame` or `gpecnet_tracks_update`.
///
/// Returns [`GPECNET_OK`] when every box that maps found room (boxes
/// refused for their geometry are normal: a pedestrian near the horizon),
/// [`GPECNET_E_CAMERA_OUTPUT_FULL`] when some did not (the first `cap` were
/// written), or an argument's status (NULL pointers, a pose that holds
/// none), with nothing written but `*n_out` = 0.
///
/// # Safety
/// `pose` is NULL or valid for a read of a [`GpecnetPose`]; `boxes` is NULL
/// (only with `n` = 0) or valid for reads of `n` boxes; `statuses` is NULL
/// (only with `n` = 0) or valid for writes of `n` codes; `out` is NULL
/// (only with `cap` = 0) or valid for writes of `cap` detections; `n_out`
/// is NULL or valid for a write. Any alignment; `out` and `statuses` must
/// not overlap `boxes`.
#[no_mangle]
pub unsafe extern "C" fn gpecnet_boxes_to_detections(
    pose: *const GpecnetPose,
    boxes: *const GpecnetBox,
    n: usize,
    out: *mut GpecnetDetection,
    cap: usize,
    statuses: *mut i32,
    n_out: *mut usize,
) -> i32 {
    guard(|| {
        non_null(n_out)?;
        // SAFETY: non-null, writable (caller's contract): 0 until boxes are mapped.
        unsafe { n_out.write_unaligned(0) };
        if n > 0 {
            non_null(boxes)?;
            non_null(statuses)?;
        }
        if cap > 0 {
            non_null(out)?;
        }
        // SAFETY: the caller's contract on `pose`.
        let pose = unsafe { read_pose(pose) }?;
        let mut written = 0usize;
        let mut full = false;
        for i in 0..n {
            // SAFETY: i < n, and the caller guarantees n readable boxes; any alignment.
            let b = unsafe { boxes.add(i).read_unaligned() };
            let det = match Detection::try_from_box(b.id, &b.into()) {
                Ok(d) => [d],
                Err(e) => {
                    // SAFETY: i < n, and the caller guarantees n writable statuses.
                    unsafe { statuses.add(i).write_unaligned(camera_status(e)) };
                    continue;
                }
            };
            // The core's call on this one box, with the one free slot of
            // `out`, or none when `out` is full (the core then refuses the
            // box with OutputFull).
            let mut slot = [Observation {
                id: 0,
                pos: [0.0; 2],
            }];
            let room: &mut [Observation] = if written < cap {
                slot.as_mut_slice()
            } else {
                &mut []
            };
            let mut status = GPECNET_OK;
            let made = to_observations(&pose, &det, room, |_, _, e: CameraError| {
                status = camera_status(e);
            });
            if made == 1 {
                let [o] = slot;
                let d = GpecnetDetection {
                    id: o.id,
                    x: o.pos[0],
                    y: o.pos[1],
                };
                // SAFETY: written < cap (a slot was offered), and the caller
                // guarantees room for cap detections; any alignment.
                unsafe { out.add(written).write_unaligned(d) };
                written += 1;
            }
            full |= status == GPECNET_E_CAMERA_OUTPUT_FULL;
            // SAFETY: i < n, and the caller guarantees room for n codes; any alignment.
            unsafe { statuses.add(i).write_unaligned(status) };
        }
        // SAFETY: non-null, writable (caller's contract).
        unsafe { n_out.write_unaligned(written) };
        if full {
            return Err(GPECNET_E_CAMERA_OUTPUT_FULL);
        }
        Ok(())
    })
}

/// A ROS attitude (REP-103: body FLU → world ENU, `geometry_msgs/Quaternion`
/// as `(w, x, y, z)`) at `q_enu_flu` as the `(w, x, y, z)` body FRD → NED
/// quaternion [`GpecnetCameraState::attitude`] takes, at `out_q` (the
/// core's `attitude_from_ros`: `(√½(w + z), √½(x + y), √½(x − y), √½(w − z))`,
/// MAVROS's conversion). `out_q` may be `q_enu_flu`.
///
/// # Safety
/// `q_enu_flu` is NULL or valid for reads of 4 floats; `out_q` is NULL or
/// valid for writes of 4 floats (any alignment).
#[no_mangle]
pub unsafe extern "C" fn gpecnet_attitude_from_ros(q_enu_flu: *const f32, out_q: *mut f32) -> i32 {
    guard(|| {
        non_null(q_enu_flu)?;
        non_null(out_q)?;
        // SAFETY: non-null, 4 readable floats (caller's contract); any alignment.
        let q = unsafe { [0, 1, 2, 3].map(|i| q_enu_flu.add(i).read_unaligned()) };
        let out = attitude_from_ros(q);
        for (i, v) in out.into_iter().enumerate() {
            // SAFETY: i < 4, room for 4 floats (caller's contract); the input was read first.
            unsafe { out_q.add(i).write_unaligned(v) };
        }
        Ok(())
    })
}

/// A ROS ENU position `(x east, y north, z up)` at `enu` as the NED
/// `(north, east, down)` = `(y, x, −z)` [`GpecnetCameraState::position`]
/// takes, at `out_ned` (the core's `position_from_ros`). `out_ned` may be
/// `enu`.
///
/// # Safety
/// `enu` is NULL or valid for reads of 3 floats; `out_ned` is NULL or valid
/// for writes of 3 floats (any alignment).
#[no_mangle]
pub unsafe extern "C" fn gpecnet_position_from_ros(enu: *const f32, out_ned: *mut f32) -> i32 {
    guard(|| {
        non_null(enu)?;
        non_null(out_ned)?;
        // SAFETY: non-null, 3 readable floats (caller's contract); any alignment.
        let p = unsafe { [0, 1, 2].map(|i| enu.add(i).read_unaligned()) };
        let ned = position_from_ros(p);
        for (i, v) in ned.into_iter().enumerate() {
            // SAFETY: i < 3, room for 3 floats (caller's contract); the input was read first.
            unsafe { out_ned.add(i).write_unaligned(v) };
        }
        Ok(())
    })
}
