//! Detections in the image → observations on the ground, in one call.
//!
//! A detector gives boxes; a tracker gives each an id. The point of a box
//! that lies on the ground is the pedestrian's **foot point**: for an
//! oblique camera (looking forward and down, the usual drone view) that is
//! the bottom centre of the box, [`BoundingBox::foot`]. Its centre would
//! be the ray through the pedestrian's hips, which meets the ground
//! *behind* them: about `0.85 m / tan(depression)` too far (1.5 m at 30°
//! below the horizon, 0.5 m at 60°). Looking straight down (nadir), a
//! standing person's height projects radially away from the image point
//! below the camera: the feet are the edge of the box nearest the
//! principal point, which is the bottom only in the image's upper half (in
//! the lower half the bottom is the head, `1.7 m · tan(off-nadir angle)`
//! beyond the feet: 1.4 m at 40°). There the box centre,
//! [`BoundingBox::centre`], is the steadier choice (`0.85 m · tan(off-nadir
//! angle)` beyond the feet, in every part of the image). The pedestrian's
//! motion, which is what the predictor uses, is the same for any fixed
//! point of the body; a consistent choice matters more than the point.

use super::pose::Pose;
use super::CameraError;
use crate::tracks::Observation;

/// An axis-aligned box in pixels (image x right, y down), as detectors
/// output it: `x_min ≤ x_max`, `y_min ≤ y_max` (top-left, bottom-right).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct BoundingBox {
    /// Left edge.
    pub x_min: f32,
    /// Top edge.
    pub y_min: f32,
    /// Right edge.
    pub x_max: f32,
    /// Bottom edge.
    pub y_max: f32,
}

impl BoundingBox {
    /// `Ok` for a box a detector can output: every edge finite
    /// ([`CameraError::NonFinite`]) and in order, `x_min ≤ x_max` and
    /// `y_min ≤ y_max` ([`CameraError::BadBox`]: a box given as `(x, y, w,
    /// h)` or with its corners swapped would otherwise give a foot point off
    /// the pedestrian, silently).
    pub fn check(&self) -> Result<(), CameraError> {
        let edges = [self.x_min, self.y_min, self.x_max, self.y_max];
        if !edges.iter().all(|v| v.is_finite()) {
            return Err(CameraError::NonFinite);
        }
        if self.x_min > self.x_max || self.y_min > self.y_max {
            return Err(CameraError::BadBox);
        }
        Ok(())
    }

    /// The bottom centre `((x_min + x_max)·0.5, y_max)`: where the feet
    /// touch the ground, for an oblique camera (module docs).
    pub fn foot(&self) -> [f32; 2] {
        [(self.x_min + self.x_max) * 0.5, self.y_max]
    }

    /// The centre `((x_min + x_max)·0.5, (y_min + y_max)·0.5)`: for a
    /// camera looking straight down (module docs).
    pub fn centre(&self) -> [f32; 2] {
        [
            (self.x_min + self.x_max) * 0.5,
            (self.y_min + self.y_max) * 0.5,
        ]
    }
}

/// One tracked detection in the image: which pedestrian, and the image
/// point (pixels) of their position on the ground.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Detection {
    /// The track id from the upstream tracker.
    pub id: u32,
    /// The image point, pixels (x right, y down).
    pub pixel: [f32; 2],
}

impl Detection {
    /// The detection at the foot point of `bbox` ([`BoundingBox::foot`]),
    /// unchecked: for boxes the caller has checked ([`Detection::try_from_box`]
    /// checks them).
    pub fn from_box(id: u32, bbox: &BoundingBox) -> Self {
        Detection {
            id,
            pixel: bbox.foot(),
        }
    }

    /// [`Detection::from_box`] for a box that passes [`BoundingBox::check`];
    /// its error otherwise.
    pub fn try_from_box(id: u32, bbox: &BoundingBox) -> Result<Self, CameraError> {
        bbox.check()?;
        Ok(Self::from_box(id, bbox))
    }
}

/// Every detection of one frame as a world-frame [`Observation`] (north,
/// east in metres: `pos = [north, east]`), ready for
/// [`TimedTrackTable::update`](crate::tracks::TimedTrackTable::update) or
/// [`Forecaster::frame`](crate::online::Forecaster::frame).
///
/// `detections[i]` is mapped by [`Pose::image_to_ground`] and written to
/// the next free slot of `out`, in detection order; a detection that
/// cannot be mapped, or finds `out` full ([`CameraError::OutputFull`]), is
/// handed to `refused(i, id, error)` instead. Every detection is either
/// written or refused, never dropped silently. Returns how many
/// observations were written: `out[..n]` is the frame.
///
/// ```
/// use gpecnet_core::camera::{
///     to_observations, BoundingBox, Camera, Detection, Distortion, Euler, Intrinsics, Pose, State,
/// };
/// use gpecnet_core::tracks::Observation;
///
/// let camera = Camera {
///     intrinsics: Intrinsics { fx: 1000.0, fy: 1000.0, cx: 960.0, cy: 540.0 },
///     distortion: Distortion::NONE,
///     mount: Euler::ZERO,
///     max_range: 150.0,
/// };
/// let state = State {
///     attitude: [1.0, 0.0, 0.0, 0.0],   // level, facing north
///     position: [0.0, 0.0, -30.0],      // 30 m above the origin
///     gimbal: Euler { roll: 0.0, pitch: -core::f32::consts::FRAC_PI_4, yaw: 0.0 },
///     ground_down: 0.0,
/// };
/// let pose = Pose::new(&camera, &state)?;
/// let boxes = [(3, BoundingBox { x_min: 940.0, y_min: 480.0, x_max: 980.0, y_max: 540.0 })];
/// let detections = boxes.map(|(id, b)| Detection::from_box(id, &b));
/// let mut out = [Observation { id: 0, pos: [0.0; 2] }; 16];
/// let n = to_observations(&pose, &detections, &mut out, |i, id, e| {
///     panic!("detection {i} (id {id}) refused: {e}");
/// });
/// // The image centre at 45° down from 30 m: 30 m north of the point below.
/// assert_eq!(n, 1);
/// assert!((out[0].pos[0] - 30.0).abs() < 1e-4 && out[0].pos[1].abs() < 1e-4);
/// # Ok::<(), gpecnet_core::camera::CameraError>(())
/// ```
pub fn to_observations(
    pose: &Pose,
    detections: &[Detection],
    out: &mut [Observation],
    mut refused: impl FnMut(usize, u32, CameraError),
) -> usize {
    let mut n = 0;
    for (i, det) in detections.iter().enumerate() {
        match pose.image_to_ground(det.pixel) {
            Ok(pos) => match out.get_mut(n) {
                Some(slot) => {
                    *slot = Observation { id: det.id, pos };
                    n += 1;
                }
                None => refused(i, det.id, CameraError::OutputFull),
            },
            Err(e) => refused(i, det.id, e),
        }
    }
    n
}
