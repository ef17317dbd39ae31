//! The coordinate frame the networks see: the observed track shifted so its
//! first point is the origin and, for models trained that way, rotated so its
//! recent heading points along +x (the *heading-canonical frame*); and the way
//! back to the caller's coordinates.
//!
//! # Specification (f32, each operation rounded once, left to right)
//!
//! With observed points `p_0 .. p_{P-1}`, origin `o = p_0` and `m` =
//! [`crate::blob::Extensions::heading_steps`]:
//!
//! * `m = 0` (raw orientation, every format-1 blob): a point `p` enters the
//!   networks as `x = ((p.x − o.x) · s, (p.y − o.y) · s)` with `s` =
//!   `data_scale`; a network output `d` leaves as `(d.x / s + o.x, d.y / s + o.y)`;
//!   the trajectory predictor's position input is the raw last point `p_{P-1}`.
//! * `m ≥ 1`: `v = p_{P-1} − p_{P-1−m}` (per coordinate), `n2 = v.x·v.x + v.y·v.y`.
//!   If `n2 < f32::MIN_POSITIVE` (a pedestrian standing still, or moving so
//!   little that the square underflows) the rotation is the identity
//!   `(c, s_) = (1, 0)`; if `n2` is infinite the input is refused
//!   ([`PredictError::NonFiniteInput`]); otherwise `n = sqrt(n2)` (correctly
//!   rounded, `libm::sqrtf`), `c = v.x / n`, `s_ = v.y / n`. A point `p` becomes
//!   `q = p − o`, `r = (c·q.x + s_·q.y, c·q.y − s_·q.x)` and enters as
//!   `(r.x · s, r.y · s)`. An output `d` gives `u = (d.x / s, d.y / s)` and leaves
//!   as `(c·u.x − s_·u.y + o.x, s_·u.x + c·u.y + o.y)`. The predictor's position
//!   input is the rotated last point `r_{P-1}`.
//!
//! No trigonometry is involved, so the f32 and the fixed-point engines apply
//! the same rule, bit for bit, on every target.

use crate::backend::in_exp;
use crate::blob::{pow2, Model, NumericKind, MAX_PAST};
use crate::output::{PredictError, Trajectory};

/// The largest accepted magnitude of an input coordinate (caller's units).
///
/// At 10^6 an f32 resolves 1/16 of a unit, so the first step of the
/// computation (`p − p_0`) loses at most 1/32 of a unit (a pixel or a metre)
/// to rounding; beyond it the loss grows to whole units (1 at 1.7·10^7, 8 at
/// 10^8) and the forecast would shift silently, so such inputs are refused
/// with [`PredictError::InputOutOfRange`]. Shift your coordinates to a
/// nearby origin first.
pub const MAX_COORDINATE: f32 = 1.0e6;

/// The largest magnitude of an output coordinate (endpoint, trajectory or
/// point-forecast point): twice [`MAX_COORDINATE`]. A real forecast lies a
/// few hundred units at most from an input inside ±[`MAX_COORDINATE`]; an
/// output beyond this bound comes from a model that is not a forecaster
/// (e.g. a doctored blob whose weights are valid but absurd) and is refused
/// with [`PredictError::OutputOutOfRange`] instead of being returned.
pub const MAX_OUTPUT: f32 = 2.0 * MAX_COORDINATE;

/// An output point as a predictor may return it: finite
/// ([`PredictError::NonFiniteOutput`] otherwise) and within ±[`MAX_OUTPUT`]
/// ([`PredictError::OutputOutOfRange`] otherwise). The same check on every
/// numeric path.
#[inline]
pub fn check_output(p: [f32; 2]) -> Result<[f32; 2], PredictError> {
    if !(p[0].is_finite() && p[1].is_finite()) {
        Err(PredictError::NonFiniteOutput)
    } else if p[0].abs() > MAX_OUTPUT || p[1].abs() > MAX_OUTPUT {
        Err(PredictError::OutputOutOfRange)
    } else {
        Ok(p)
    }
}

/// The largest accepted magnitude of a network input (`(p_t − p_0) ·
/// data_scale`, normalised units) for every model; fixed-point models may
/// accept less ([`crate::blob::Model::input_limit`]).
///
/// 2^12. The shipped SDD models (`data_scale` 1.86 per pixel) see at most
/// 1,834 in their training data (a 986 px displacement in 3.2 s; the test set's
/// largest is 1,297), so 4,096 (2,202 px; 57 m for the ETH/UCY recipe's
/// `data_scale` of 72 per metre) leaves room for fast movers while a
/// corrupted track (a teleporting detection, a coordinate in the wrong unit) is
/// refused instead of forecast from.
pub const MAX_INPUT: f32 = 4096.0;

// A method of the model view, defined here because it is the frame's input
// guard applied to the model: the blob below knows neither.
impl Model<'_> {
    /// The largest accepted magnitude of a normalised network input
    /// ([`Frame::inputs`]): [`MAX_INPUT`], or less
    /// for a fixed-point model whose input exponent `e` cannot represent it:
    /// `2^(15−e)`, beyond which quantisation would saturate by more than one
    /// step (up to it, the error is at most one step, `2^−e`).
    pub fn input_limit(&self) -> f32 {
        let limit = MAX_INPUT;
        match self.numeric() {
            NumericKind::F32 => limit,
            NumericKind::Int16Q15 => {
                let e = in_exp(self.encoder_past());
                limit.min(pow2(15 - e as i32))
            }
        }
    }
}

/// A track's frame: its origin and, when the model asks, its heading.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Frame {
    origin: [f32; 2],
    /// `(c, s)`: cosine and sine of the heading; `None` = raw orientation.
    rot: Option<[f32; 2]>,
}

impl Frame {
    /// The raw frame at the origin (placeholder before the first prediction).
    pub const fn raw() -> Frame {
        Frame {
            origin: [0.0; 2],
            rot: None,
        }
    }

    /// Checks `past` against `model` (length `past_len`, every coordinate
    /// finite and within ±[`MAX_COORDINATE`]) and returns its frame under the
    /// model's `heading_steps`.
    pub fn checked(
        past: &[[f32; 2]],
        model: &crate::blob::Model<'_>,
    ) -> Result<Frame, PredictError> {
        let p = model.config().past_len as usize;
        if past.len() != p {
            return Err(PredictError::WrongPastLength {
                expected: p,
                got: past.len(),
            });
        }
        if past.iter().flatten().any(|v| !v.is_finite()) {
            return Err(PredictError::NonFiniteInput);
        }
        if past.iter().flatten().any(|v| v.abs() > MAX_COORDINATE) {
            return Err(PredictError::InputOutOfRange);
        }
        Frame::new(past, model.extensions().heading_steps)
    }

    /// [`Frame::checked`], then every point as the networks see it
    /// ([`Frame::input`]), each coordinate within ±[`Model::input_limit`]
    /// ([`PredictError::InputOutOfRange`] otherwise). The guard every engine
    /// runs before touching a network, so both numeric kinds refuse the same
    /// inputs with the same error.
    ///
    /// [`Model::input_limit`]: crate::blob::Model::input_limit
    pub fn inputs(
        past: &[[f32; 2]],
        model: &crate::blob::Model<'_>,
    ) -> Result<(Frame, [[f32; 2]; MAX_PAST]), PredictError> {
        let frame = Frame::checked(past, model)?;
        let (scale, limit) = (model.config().data_scale, model.input_limit());
        let mut x = [[0.0f32; 2]; MAX_PAST];
        for (dst, p) in x.iter_mut().zip(past) {
            *dst = frame.input(*p, scale);
            // `!(a <= b)` also refuses NaN.
            if !(dst[0].abs() <= limit && dst[1].abs() <= limit) {
                return Err(PredictError::InputOutOfRange);
            }
        }
        Ok((frame, x))
    }

    /// The frame of `past` (already checked finite and at least 2 long) with
    /// the heading over its last `heading_steps` steps (0 = none).
    pub fn new(past: &[[f32; 2]], heading_steps: u8) -> Result<Frame, PredictError> {
        let origin = past.first().copied().unwrap_or([0.0; 2]);
        let m = heading_steps as usize;
        if m == 0 {
            return Ok(Frame { origin, rot: None });
        }
        let p = past.len();
        let (Some(a), Some(b)) = (p.checked_sub(1), p.checked_sub(1 + m)) else {
            return Err(PredictError::WrongPastLength {
                expected: m + 1,
                got: p,
            });
        };
        let (a, b) = (past.get(a).copied(), past.get(b).copied());
        let (Some(a), Some(b)) = (a, b) else {
            return Err(PredictError::NonFiniteInput);
        };
        let v = [a[0] - b[0], a[1] - b[1]];
        let n2 = v[0] * v[0] + v[1] * v[1];
        if !n2.is_finite() {
            return Err(PredictError::NonFiniteInput);
        }
        let rot = if n2 < f32::MIN_POSITIVE {
            [1.0, 0.0]
        } else {
            let n = libm::sqrtf(n2);
            [v[0] / n, v[1] / n]
        };
        Ok(Frame {
            origin,
            rot: Some(rot),
        })
    }

    /// The origin (the first observed point).
    pub fn origin(&self) -> [f32; 2] {
        self.origin
    }

    /// `(cos, sin)` of the heading, or `None` for the raw orientation.
    pub fn rotation(&self) -> Option<[f32; 2]> {
        self.rot
    }

    /// `p` relative to the origin, rotated (not yet scaled).
    #[inline]
    pub fn relative(&self, p: [f32; 2]) -> [f32; 2] {
        let q = [p[0] - self.origin[0], p[1] - self.origin[1]];
        match self.rot {
            None => q,
            Some([c, s]) => [c * q[0] + s * q[1], c * q[1] - s * q[0]],
        }
    }

    /// A caller point as the networks see it: `relative(p) · data_scale`.
    #[inline]
    pub fn input(&self, p: [f32; 2], data_scale: f32) -> [f32; 2] {
        let r = self.relative(p);
        [r[0] * data_scale, r[1] * data_scale]
    }

    /// A network output (model space) in the caller's coordinates.
    #[inline]
    pub fn output(&self, d: [f32; 2], data_scale: f32) -> [f32; 2] {
        let u = [d[0] / data_scale, d[1] / data_scale];
        match self.rot {
            None => [u[0] + self.origin[0], u[1] + self.origin[1]],
            Some([c, s]) => [
                c * u[0] - s * u[1] + self.origin[0],
                s * u[0] + c * u[1] + self.origin[1],
            ],
        }
    }

    /// Network output pairs (model space) as caller points, in order: the
    /// shared tail of every trajectory and point forecast. Refuses a point
    /// that fails [`check_output`] and more than [`crate::blob::MAX_FUTURE`]
    /// points ([`PredictError::NonFiniteOutput`]).
    pub fn points(
        &self,
        pairs: impl IntoIterator<Item = [f32; 2]>,
        data_scale: f32,
    ) -> Result<Trajectory, PredictError> {
        let mut t = Trajectory::new();
        for d in pairs {
            let pt = check_output(self.output(d, data_scale))?;
            if t.push(pt).is_err() {
                return Err(PredictError::NonFiniteOutput);
            }
        }
        Ok(t)
    }

    /// The trajectory predictor's position input before its divisor: the raw
    /// last point, or the rotated one in the heading-canonical frame.
    #[inline]
    pub fn predictor_position(&self, last: [f32; 2]) -> [f32; 2] {
        match self.rot {
            None => last,
            Some(_) => self.relative(last),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn raw_frame_is_the_old_arithmetic() {
        let past = [[10.0f32, 20.0], [11.5, 19.0], [13.0, 18.25]];
        let f = Frame::new(&past, 0).unwrap();
        let x = f.input(past[2], 1.86);
        assert_eq!(x, [(13.0 - 10.0) * 1.86, (18.25 - 20.0) * 1.86]);
        assert_eq!(
            f.output([5.58, -3.72], 1.86),
            [5.58 / 1.86 + 10.0, -3.72 / 1.86 + 20.0]
        );
        assert_eq!(f.predictor_position(past[2]), past[2]);
    }

    #[test]
    fn heading_rotates_onto_x_and_back() {
        let past = [[0.0f32, 0.0], [3.0, 4.0], [6.0, 8.0]];
        let f = Frame::new(&past, 1).unwrap();
        assert_eq!(f.rotation(), Some([0.6, 0.8]));
        let r = f.relative(past[2]);
        assert!((r[0] - 10.0).abs() < 1e-5 && r[1].abs() < 1e-5);
        let back = f.output(f.input([7.0, -2.0], 2.0), 2.0);
        assert!((back[0] - 7.0).abs() < 1e-5 && (back[1] + 2.0).abs() < 1e-5);
    }

    #[test]
    fn standing_still_is_identity_and_overflow_is_refused() {
        let still = [[5.0f32, 5.0]; 4];
        assert_eq!(Frame::new(&still, 2).unwrap().rotation(), Some([1.0, 0.0]));
        let huge = [[0.0f32, 0.0], [3e38, 0.0]];
        assert_eq!(Frame::new(&huge, 1), Err(PredictError::NonFiniteInput));
        assert!(matches!(
            Frame::new(&still, 4),
            Err(PredictError::WrongPastLength { .. })
        ));
    }
}
