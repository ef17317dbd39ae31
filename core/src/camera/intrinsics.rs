//! The pinhole camera with Brown–Conrady lens distortion (OpenCV's
//! `k1, k2, p1, p2` model): pixels ↔ normalised image coordinates.
//!
//! A normalised image point `(x, y)` is the direction `(x, y, 1)` in the
//! camera frame (x right, y down, z forward along the optical axis). The
//! lens moves it to the distorted point `(x_d, y_d)` (rule D below), which
//! the sensor records at pixel `(u, v) = (fx·x_d + cx, fy·y_d + cy)`.
//!
//! # The arithmetic (f32, in this order)
//!
//! **D, distortion** of `(x, y)`: `a = x·y`, `r2 = x·x + y·y`,
//! `rad = 1 + (k1 + k2·r2)·r2`,
//! `x_d = (x·rad + (2·p1)·a) + p2·(r2 + (2·x)·x)`,
//! `y_d = (y·rad + p1·(r2 + (2·y)·y)) + (2·p2)·a`.
//!
//! **U, undistortion** of a distorted `(x_d, y_d)`: Newton's method from
//! `(x, y) = (x_d, y_d)`, exactly [`UNDISTORT_ITERATIONS`] steps (no early
//! exit, so the cost and the bits never depend on the data). One step: the
//! residual `(e_x, e_y) = D(x, y) − (x_d, y_d)`; the Jacobian of D at
//! `(x, y)` with `g = k1 + (2·k2)·r2` (`a`, `r2`, `rad` as in D):
//! `j_xx = ((rad + (2·x)·(x·g)) + (2·p1)·y) + (6·p2)·x`,
//! `j_xy = ((2·x)·(y·g) + (2·p1)·x) + (2·p2)·y` (`= j_yx`),
//! `j_yy = ((rad + (2·y)·(y·g)) + (6·p1)·y) + (2·p2)·x`;
//! `det = j_xx·j_yy − j_xy·j_xy`; `x ← x − (j_yy·e_x − j_xy·e_y)/det`,
//! `y ← y − (j_xx·e_y − j_xy·e_x)/det`. A step with `det` not positive and
//! finite, or a final residual (D of the result, once more) with
//! `|e_x|` or `|e_y|` above [`UNDISTORT_TOLERANCE`], is
//! [`CameraError::Undistortion`]: the lens model is not invertible there
//! (far outside the calibrated field of view), and no point is guessed.
//! With all four coefficients zero, D and U are the identity and are not
//! computed.
//!
//! **Pixels**: `x_d = (u − cx)/fx`, `y_d = (v − cy)/fy`; back,
//! `u = fx·x_d + cx`, `v = fy·y_d + cy`.

use super::CameraError;

/// Newton steps of the undistortion (rule U). Newton's method converges
/// quadratically from the distorted point for any lens whose model is
/// invertible over the image; 6 steps leave a residual at f32 rounding
/// level for distortions far stronger than a calibrated gimbal camera's
/// (`tests/camera.rs` checks a strong barrel lens over the whole image).
pub const UNDISTORT_ITERATIONS: usize = 6;

/// The largest residual `|D(x, y) − (x_d, y_d)|` per coordinate, in
/// normalised image units, that the undistortion accepts: 2·10⁻⁶, 0.002 px
/// at a focal length of 1,000 px (a few f32 roundings of a coordinate near 1).
pub const UNDISTORT_TOLERANCE: f32 = 2e-6;

/// The smallest focal length accepted, in pixels.
pub const MIN_FOCAL_PX: f32 = 1.0;

/// The pinhole camera's intrinsics, in pixels (OpenCV's camera matrix, or
/// ROS `CameraInfo.K = [fx, 0, cx, 0, fy, cy, 0, 0, 1]`).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Intrinsics {
    /// Focal length along the image's x axis (right), pixels, at least
    /// [`MIN_FOCAL_PX`].
    pub fx: f32,
    /// Focal length along the image's y axis (down), pixels, at least
    /// [`MIN_FOCAL_PX`].
    pub fy: f32,
    /// Principal point's x, pixels (0 = the left edge of the first pixel
    /// column, as OpenCV).
    pub cx: f32,
    /// Principal point's y, pixels (0 = the top edge of the first row).
    pub cy: f32,
}

/// Lens distortion, OpenCV's first four coefficients `k1, k2, p1, p2` (ROS
/// `CameraInfo.D` with `distortion_model = "plumb_bob"`, its first four
/// values; a fifth `k3` is not supported and must be zero there).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Distortion {
    /// Radial coefficient of `r²`.
    pub k1: f32,
    /// Radial coefficient of `r⁴`.
    pub k2: f32,
    /// First tangential coefficient.
    pub p1: f32,
    /// Second tangential coefficient.
    pub p2: f32,
}

impl Distortion {
    /// No distortion (a rectified image).
    pub const NONE: Distortion = Distortion {
        k1: 0.0,
        k2: 0.0,
        p1: 0.0,
        p2: 0.0,
    };

    /// `true` when every coefficient is zero: rules D and U are skipped.
    pub fn is_none(&self) -> bool {
        self.k1 == 0.0 && self.k2 == 0.0 && self.p1 == 0.0 && self.p2 == 0.0
    }

    /// Rule D: the distorted point of the normalised point `p`.
    pub fn distort(&self, p: [f32; 2]) -> [f32; 2] {
        if self.is_none() {
            return p;
        }
        self.apply(p[0], p[1])
    }

    /// Rule D without the shortcut.
    fn apply(&self, x: f32, y: f32) -> [f32; 2] {
        let Distortion { k1, k2, p1, p2 } = *self;
        let a = x * y;
        let r2 = x * x + y * y;
        let rad = 1.0 + (k1 + k2 * r2) * r2;
        let xd = (x * rad + (2.0 * p1) * a) + p2 * (r2 + (2.0 * x) * x);
        let yd = (y * rad + p1 * (r2 + (2.0 * y) * y)) + (2.0 * p2) * a;
        [xd, yd]
    }

    /// Rule U: the normalised point whose distortion is `d`, or
    /// [`CameraError::Undistortion`].
    pub fn undistort(&self, d: [f32; 2]) -> Result<[f32; 2], CameraError> {
        if self.is_none() {
            return Ok(d);
        }
        let Distortion { k1, k2, p1, p2 } = *self;
        let [xd, yd] = d;
        let (mut x, mut y) = (xd, yd);
        for _ in 0..UNDISTORT_ITERATIONS {
            let [fx, fy] = self.apply(x, y);
            let (ex, ey) = (fx - xd, fy - yd);
            let r2 = x * x + y * y;
            let rad = 1.0 + (k1 + k2 * r2) * r2;
            let g = k1 + (2.0 * k2) * r2;
            let jxx = ((rad + (2.0 * x) * (x * g)) + (2.0 * p1) * y) + (6.0 * p2) * x;
            let jxy = ((2.0 * x) * (y * g) + (2.0 * p1) * x) + (2.0 * p2) * y;
            let jyy = ((rad + (2.0 * y) * (y * g)) + (6.0 * p1) * y) + (2.0 * p2) * x;
            let det = jxx * jyy - jxy * jxy;
            // `!(det > 0)` also catches NaN.
            if !(det > 0.0 && det.is_finite()) {
                return Err(CameraError::Undistortion);
            }
            x -= (jyy * ex - jxy * ey) / det;
            y -= (jxx * ey - jxy * ex) / det;
        }
        let [fx, fy] = self.apply(x, y);
        let ok = |e: f32| e.abs() <= UNDISTORT_TOLERANCE;
        if ok(fx - xd) && ok(fy - yd) {
            Ok([x, y])
        } else {
            Err(CameraError::Undistortion)
        }
    }
}

impl Intrinsics {
    /// Checks the intrinsics: all finite ([`CameraError::NonFinite`]) and
    /// both focal lengths at least [`MIN_FOCAL_PX`]
    /// ([`CameraError::FocalLength`]: zero, negative, or under a pixel).
    pub fn validate(&self) -> Result<(), CameraError> {
        let Intrinsics { fx, fy, cx, cy } = *self;
        if !(fx.is_finite() && fy.is_finite() && cx.is_finite() && cy.is_finite()) {
            return Err(CameraError::NonFinite);
        }
        if !(fx >= MIN_FOCAL_PX && fy >= MIN_FOCAL_PX) {
            return Err(CameraError::FocalLength);
        }
        Ok(())
    }

    /// The distorted normalised point of pixel `uv`: `((u − cx)/fx, (v − cy)/fy)`.
    pub fn normalise(&self, uv: [f32; 2]) -> [f32; 2] {
        [(uv[0] - self.cx) / self.fx, (uv[1] - self.cy) / self.fy]
    }

    /// The pixel of the distorted normalised point `d`: `(fx·x_d + cx, fy·y_d + cy)`.
    pub fn to_pixel(&self, d: [f32; 2]) -> [f32; 2] {
        [self.fx * d[0] + self.cx, self.fy * d[1] + self.cy]
    }
}
