//! An image-to-ground homography: a calibrated camera's pixels `(x, y)` to ground positions in
//! metres, as `dataset.toml`'s `[homography]` gives it per file (`super::folder_info`).
//!
//! `H` is 3 × 3, written row-major as nine numbers `[h11, h12, h13, h21, h22, h23, h31, h32,
//! h33]`, the convention of the ETH/UCY releases and of OpenCV's `findHomography`: with `(X, Y,
//! W) = H · (x, y, 1)`, the ground point is `(X / W, Y / W)`. Arithmetic in f64, the result
//! rounded to f32 once. Checked: nine finite numbers, `H` invertible (`|det H|` above `1e-12`
//! times the product of its rows' lengths, so a rank-deficient matrix that rounding made
//! non-zero is refused too);
//! at every point mapped, `W > 0` (the point is in front of the camera: a point with `W ≤ 0`
//! is on or beyond the horizon line, where the ground plane is behind the camera) and a finite
//! f32 result.

/// A checked homography (module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Homography {
    h: [f64; 9],
}

impl Homography {
    /// `h` (row-major) when it is a valid homography, else what is wrong.
    pub fn new(h: &[f64]) -> Result<Self, String> {
        let h: [f64; 9] = h
            .try_into()
            .map_err(|_| format!("{} numbers: expected 9 (3 x 3, row-major)", h.len()))?;
        if let Some(v) = h.iter().find(|v| !v.is_finite()) {
            return Err(format!("{v} is not a finite number"));
        }
        // Hadamard's bound: |det H| ≤ the product of its rows' lengths, with equality for
        // orthogonal rows; far below it, H is singular up to rounding.
        let rows: f64 = h
            .chunks(3)
            .map(|r| r.iter().map(|v| v * v).sum::<f64>().sqrt())
            .product();
        let det = h[0] * (h[4] * h[8] - h[5] * h[7]) - h[1] * (h[3] * h[8] - h[5] * h[6])
            + h[2] * (h[3] * h[7] - h[4] * h[6]);
        if rows == 0.0 || det.abs() <= 1e-12 * rows || det.is_nan() {
            return Err(format!(
                "not invertible (determinant {det:e}): a homography maps the image plane onto \
                 the ground plane one to one"
            ));
        }
        Ok(Self { h })
    }

    /// The ground point of pixel `p` in metres (module docs); `Err` when `p` is not in front
    /// of the camera or the result is not a finite f32.
    pub fn apply(&self, p: [f32; 2]) -> Result<[f32; 2], String> {
        let h = &self.h;
        let (x, y) = (f64::from(p[0]), f64::from(p[1]));
        let w = h[6] * x + h[7] * y + h[8];
        if w.is_nan() || w <= 0.0 {
            return Err(format!(
                "the homography puts pixel ({}, {}) behind the camera (w = {w:e} <= 0): beyond \
                 the horizon line, or the matrix maps ground to image (give image to ground)",
                p[0], p[1]
            ));
        }
        let gx = ((h[0] * x + h[1] * y + h[2]) / w) as f32;
        let gy = ((h[3] * x + h[4] * y + h[5]) / w) as f32;
        if !(gx.is_finite() && gy.is_finite()) {
            return Err(format!(
                "the homography maps pixel ({}, {}) to no finite ground point",
                p[0], p[1]
            ));
        }
        Ok([gx, gy])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn maps_as_written_and_refuses_what_is_not_a_homography() {
        // 2 cm per pixel, shifted, a little perspective.
        let h = Homography::new(&[0.02, 0.0, -5.0, 0.0, 0.02, 3.0, 0.0, 1e-4, 1.0]).unwrap();
        let g = h.apply([100.0, 200.0]).unwrap();
        let w = 1e-4 * 200.0 + 1.0;
        assert_eq!(g, [((2.0 - 5.0) / w) as f32, ((4.0 + 3.0) / w) as f32]);
        assert!(h
            .apply([0.0, -20_000.0])
            .unwrap_err()
            .contains("behind the camera"));
        assert!(Homography::new(&[1.0; 8]).unwrap_err().contains("9"));
        assert!(
            Homography::new(&[1.0, 2.0, 3.0, 2.0, 4.0, 6.0, 0.0, 0.0, 1.0])
                .unwrap_err()
                .contains("not invertible")
        );
        assert!(Homography::new(&[0.0; 9])
            .unwrap_err()
            .contains("not invertible"));
        let mut nan = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0];
        nan[4] = f64::NAN;
        assert!(Homography::new(&nan).unwrap_err().contains("finite"));
        let huge = Homography::new(&[1e30, 0.0, 0.0, 0.0, 1e30, 0.0, 0.0, 0.0, 1.0]).unwrap();
        assert!(huge.apply([1e10, 1.0]).unwrap_err().contains("finite"));
    }
}
