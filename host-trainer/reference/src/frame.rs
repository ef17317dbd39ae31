//! The heading-canonical frame: every window is translated so its first observed
//! point is the origin and rotated so its recent heading points along +x, before the networks
//! see it; predictions are rotated back.
//!
//! This is the trainer's independent implementation of the rule that `gpecnet_core::frame`
//! specifies (the two are compared bit for bit by the workspace tests). With `steps = m`:
//!
//! 1. `v = p[P-1] - p[P-1-m]` per coordinate (f32).
//! 2. `n2 = v.x·v.x + v.y·v.y`. If `n2` is below `f32::MIN_POSITIVE` (stationary, or a
//!    motion so small its square underflows) the rotation is the identity `(c, s) = (1, 0)`;
//!    otherwise `n = sqrt(n2)` (correctly rounded), `c = v.x / n`, `s = v.y / n`.
//! 3. A point `p` becomes `q = p - p[0]`, then `(c·q.x + s·q.y, c·q.y - s·q.x)`.
//! 4. A canonical point `r` (relative to `p[0]`) maps back to
//!    `(c·r.x - s·r.y + p[0].x, s·r.x + c·r.y + p[0].y)`, evaluated left to right.

use crate::data::{Window, PAST};

/// A rotation about a window's first observed point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Heading {
    /// The first observed point (the origin of the canonical frame).
    pub origin: [f32; 2],
    /// Cosine of the heading.
    pub c: f32,
    /// Sine of the heading.
    pub s: f32,
}

impl Heading {
    /// The frame of the observed positions `obs` (length [`PAST`]) with heading from the last
    /// `steps` steps (`1 <= steps < PAST`; other values are clamped into that range).
    pub fn of(obs: &[[f32; 2]], steps: usize) -> Heading {
        let p = obs.len();
        let m = steps.clamp(1, p.saturating_sub(1).max(1));
        let a = obs[p - 1];
        let b = obs[p - 1 - m];
        let v = [a[0] - b[0], a[1] - b[1]];
        let n2 = v[0] * v[0] + v[1] * v[1];
        let (c, s) = if n2 < f32::MIN_POSITIVE || !n2.is_finite() {
            (1.0, 0.0)
        } else {
            let n = n2.sqrt();
            (v[0] / n, v[1] / n)
        };
        Heading {
            origin: obs[0],
            c,
            s,
        }
    }

    /// World point -> canonical point (relative to the origin).
    pub fn to_canonical(&self, p: [f32; 2]) -> [f32; 2] {
        let q = [p[0] - self.origin[0], p[1] - self.origin[1]];
        [self.c * q[0] + self.s * q[1], self.c * q[1] - self.s * q[0]]
    }

    /// Canonical point (relative to the origin) -> world point.
    pub fn to_world(&self, r: [f32; 2]) -> [f32; 2] {
        [
            self.c * r[0] - self.s * r[1] + self.origin[0],
            self.s * r[0] + self.c * r[1] + self.origin[1],
        ]
    }
}

/// `w` in its heading-canonical frame (every one of its 20 points), and the frame.
pub fn canonical_window(w: &Window, steps: usize) -> (Window, Heading) {
    let h = Heading::of(&w.pos[..PAST], steps);
    let mut out = w.clone();
    for p in out.pos.iter_mut() {
        *p = h.to_canonical(*p);
    }
    (out, h)
}

/// The reference's frame of one track (see `gpecnet_core::frame` for the rule).
pub enum RefFrame {
    /// Origin shift only.
    Raw([f32; 2]),
    /// Origin shift and heading rotation.
    Heading(Heading),
}

impl RefFrame {
    /// The frame of `past` with the heading over its last `heading_steps` steps (0 = none).
    pub fn of(past: &[[f32; 2]], heading_steps: usize) -> RefFrame {
        if heading_steps == 0 {
            RefFrame::Raw(past[0])
        } else {
            RefFrame::Heading(Heading::of(past, heading_steps))
        }
    }

    /// A caller point as the networks see it.
    pub fn input(&self, p: [f32; 2], ds: f32) -> [f32; 2] {
        match self {
            RefFrame::Raw(o) => [(p[0] - o[0]) * ds, (p[1] - o[1]) * ds],
            RefFrame::Heading(h) => {
                let r = h.to_canonical(p);
                [r[0] * ds, r[1] * ds]
            }
        }
    }

    /// A network output in the caller's units.
    pub fn output(&self, d: [f32; 2], ds: f32) -> [f32; 2] {
        match self {
            RefFrame::Raw(o) => [d[0] / ds + o[0], d[1] / ds + o[1]],
            RefFrame::Heading(h) => h.to_world([d[0] / ds, d[1] / ds]),
        }
    }

    /// The predictor's position input (before its divisor).
    pub fn predictor_position(&self, last: [f32; 2]) -> [f32; 2] {
        match self {
            RefFrame::Raw(_) => last,
            RefFrame::Heading(h) => h.to_canonical(last),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn heading_points_along_x_and_round_trips() {
        let obs: Vec<[f32; 2]> = (0..PAST)
            .map(|t| [100.0 + 3.0 * t as f32, 50.0 - 4.0 * t as f32])
            .collect();
        let h = Heading::of(&obs, 2);
        assert!((h.c - 0.6).abs() < 1e-6 && (h.s + 0.8).abs() < 1e-6);
        let last = h.to_canonical(obs[PAST - 1]);
        assert!(
            (last[0] - 35.0).abs() < 1e-4 && last[1].abs() < 1e-4,
            "{last:?}"
        );
        let back = h.to_world(last);
        assert!((back[0] - obs[PAST - 1][0]).abs() < 1e-3);
        assert!((back[1] - obs[PAST - 1][1]).abs() < 1e-3);
    }

    #[test]
    fn stationary_is_identity() {
        let obs = [[5.0f32, 7.0]; PAST];
        let h = Heading::of(&obs, 1);
        assert_eq!((h.c, h.s), (1.0, 0.0));
        assert_eq!(h.to_canonical([6.0, 9.0]), [1.0, 2.0]);
    }
}
