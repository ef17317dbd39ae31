//! The measurement model: how uncertain a ground point from the camera is,
//! to first order, given the detector's pixel error and the error of the
//! camera's orientation (attitude estimate, gimbal encoder, mounting).
//!
//! A ground point is `g = o + t·(d_n, d_e)` with `d = R·(x, y, 1)` the ray
//! through the undistorted normalised image point and `t = h / d_d`
//! ([`Pose::image_to_ground`]). Its Jacobian with respect to the ray is
//!
//! ```text
//! J = [[t, 0, −a_n],      a_n = t·d_n / d_d
//!      [0, t, −a_e]]      a_e = t·d_e / d_d
//! ```
//!
//! and the two error sources move the ray as follows:
//!
//! * **Pixels**: an error `(δu, δv)` moves `(x, y)` by `(δu / f_x, δv / f_y)`
//!   and the ray by `R[:,0]·δu / f_x + R[:,1]·δv / f_y`. The lens
//!   distortion's own slope is left out (the pixel term is that of the
//!   rectified image; with OpenCV-sized `k1` it changes it by a few per
//!   cent at the image's edge, docs/camera.md "Measurement model").
//! * **Orientation**: a small rotation `δθ` of the camera about the world
//!   axes (north, east, down) moves the ray by `δθ × d`, so by
//!   `e_k × d` per radian about axis `k`: `(0, −d_d, d_e)`,
//!   `(d_d, 0, −d_n)`, `(−d_e, d_n, 0)`. About the vertical this moves the
//!   point sideways by `t·|(d_n, d_e)|`·δψ (its horizontal distance times
//!   the yaw error); about a horizontal axis it moves it by about
//!   `range² / h`·δθ along the line of sight (0.5° at 30 m range from 30 m
//!   up: 0.52 m).
//!
//! With i.i.d. errors of standard deviation `σ_p` on `u` and `v` and `σ_a`
//! about each axis, the covariance is
//! `Σ = σ_p²·Σ_c (J·r_c)(J·r_c)ᵀ + σ_a²·Σ_k (J·(e_k × d))(J·(e_k × d))ᵀ`.
//! The first order holds while the errors are small against the depression
//! angle (a ray near the horizon turns the covariance into a long streak
//! whose true distribution is skewed; `max_range` bounds it).
//!
//! # The arithmetic (f32, in this order)
//!
//! 1. `σ_p`, `σ_a` finite and `≥ 0`, else [`CameraError::Noise`]; the pixel
//!    through [`Pose::image_to_ground`]'s checks and ray `d` (the same bits,
//!    the same refusals).
//! 2. `t = h / d_d`; `a_n = (t·d_n) / d_d`; `a_e = (t·d_e) / d_d`.
//! 3. For each term vector `v` (in order `r_0 = R[:,0] / f_x`,
//!    `r_1 = R[:,1] / f_y` with weight `s_p = σ_p·σ_p`, then the three
//!    `e_k × d` with weight `s_a = σ_a·σ_a`): `g_n = t·v_0 − a_n·v_2`,
//!    `g_e = t·v_1 − a_e·v_2`; the sums start at 0 and add, per group,
//!    `g_n·g_n`, `g_n·g_e`, `g_e·g_e` in the term order.
//! 4. `nn = s_p·P_nn + s_a·A_nn` (likewise `ne`, `ee`), `P` and `A` the two
//!    groups' sums. A result that is not finite is [`CameraError::Overflow`].
//!
//! (`R`, hence `d`, carries the attitude's `|q|²`; every product above is a
//! ratio in it, so it cancels.)

use super::pose::Pose;
use super::CameraError;

/// The two error sources' standard deviations (i.i.d. per coordinate).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct MeasurementNoise {
    /// The detector's error on each pixel coordinate (`u` and `v`), pixels:
    /// about 1–2 px for a good detector's foot point.
    pub pixel: f32,
    /// The camera orientation's error about each world axis, radians: the
    /// attitude estimate, the gimbal's encoders and the mounting together
    /// (0.5° = 0.0087 rad is a good flight controller with a calibrated
    /// gimbal).
    pub attitude: f32,
}

/// A ground point's covariance, metres² (north, east).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct GroundCovariance {
    /// Variance of north.
    pub nn: f32,
    /// Covariance of north and east.
    pub ne: f32,
    /// Variance of east.
    pub ee: f32,
}

impl GroundCovariance {
    /// The isotropic standard deviation with the same total variance,
    /// `sqrtf((nn + ee) · 0.5)`, metres: the per-detection σ that
    /// [`crate::tracks::filter::TrackFilter::update_with`] takes (its model
    /// is isotropic).
    pub fn sigma(&self) -> f32 {
        libm::sqrtf((self.nn + self.ee) * 0.5)
    }
}

impl Pose {
    /// The first-order covariance of the ground point seen at pixel `uv`
    /// under `noise` (the module's rules), or why there is none (the
    /// refusals of [`Pose::image_to_ground`], and [`CameraError::Noise`]).
    pub fn ground_covariance(
        &self,
        uv: [f32; 2],
        noise: &MeasurementNoise,
    ) -> Result<GroundCovariance, CameraError> {
        let ok = |s: f32| s.is_finite() && s >= 0.0;
        if !(ok(noise.pixel) && ok(noise.attitude)) {
            return Err(CameraError::Noise);
        }
        let (_, [dn, de, dd]) = self.ground_and_ray(uv)?;
        let t = self.height() / dd;
        let an = (t * dn) / dd;
        let ae = (t * de) / dd;
        let (fx, fy) = (self.intrinsics().fx, self.intrinsics().fy);
        let r = self.rotation();
        let pixel_terms = [
            [r[(0, 0)] / fx, r[(1, 0)] / fx, r[(2, 0)] / fx],
            [r[(0, 1)] / fy, r[(1, 1)] / fy, r[(2, 1)] / fy],
        ];
        let attitude_terms = [[0.0, -dd, de], [dd, 0.0, -dn], [-de, dn, 0.0]];
        let sums = |terms: &[[f32; 3]]| {
            let (mut nn, mut ne, mut ee) = (0.0f32, 0.0f32, 0.0f32);
            for v in terms {
                let gn = t * v[0] - an * v[2];
                let ge = t * v[1] - ae * v[2];
                nn += gn * gn;
                ne += gn * ge;
                ee += ge * ge;
            }
            (nn, ne, ee)
        };
        let (pn, pne, pe) = sums(&pixel_terms);
        let (a_n, a_ne, a_e) = sums(&attitude_terms);
        let sp = noise.pixel * noise.pixel;
        let sa = noise.attitude * noise.attitude;
        let c = GroundCovariance {
            nn: sp * pn + sa * a_n,
            ne: sp * pne + sa * a_ne,
            ee: sp * pe + sa * a_e,
        };
        if c.nn.is_finite() && c.ne.is_finite() && c.ee.is_finite() {
            Ok(c)
        } else {
            Err(CameraError::Overflow)
        }
    }
}
