//! Newtonian trajectory generators at the dataset's 0.4 s step, in the SDD pixel range.
//!
//! Each generator integrates its motion from the origin, then the whole trajectory is translated
//! to a start drawn uniformly among the positions that keep every point inside
//! `[0, SDD_RANGE]` (speeds and accelerations are bounded so that the extent is always smaller
//! than the range: no rejection loop, always in range). Parameters (px, px/s, px/s², rad/s):
//!
//! | motion | parameters drawn uniformly |
//! |---|---|
//! | constant velocity | speed `[5, 100]` px/s, heading `[0, 2π)` |
//! | constant acceleration | initial speed `[5, 100]`, heading, acceleration `[0, 25]` px/s² in direction `[0, 2π)` |
//! | turn (constant speed, constant turn rate) | speed `[5, 100]`, heading, turn rate `±[0.1, 0.6]` rad/s |
//!
//! 100 px/s is about 1.3–4 m/s depending on the SDD scene's scale, i.e. the walking-to-cycling
//! range of SDD agents.

use crate::data::WINDOW;
use crate::rng::Rng;

use super::{Traj, DT, SDD_RANGE};

/// A Newtonian motion model with its parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Motion {
    /// `x(t) = v t`.
    ConstVel {
        /// Velocity, px/s.
        v: [f32; 2],
    },
    /// `x(t) = v t + a t² / 2`.
    ConstAcc {
        /// Initial velocity, px/s.
        v: [f32; 2],
        /// Acceleration, px/s².
        a: [f32; 2],
    },
    /// Constant speed, heading changing at a constant rate (integrated per step).
    Turn {
        /// Speed, px/s.
        speed: f32,
        /// Initial heading, rad.
        heading: f32,
        /// Turn rate, rad/s.
        omega: f32,
    },
}

/// Which generator to draw from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// [`Motion::ConstVel`].
    ConstVel,
    /// [`Motion::ConstAcc`].
    ConstAcc,
    /// [`Motion::Turn`].
    Turn,
}

const TAU: f32 = std::f32::consts::TAU;

fn unit(rng: &mut Rng) -> [f32; 2] {
    let h = rng.uniform(0.0, TAU);
    [h.cos(), h.sin()]
}

impl Motion {
    /// Draw a motion of `kind` with the parameter ranges in the module docs.
    pub fn random(kind: Kind, rng: &mut Rng) -> Motion {
        let speed = rng.uniform(5.0, 100.0);
        let u = unit(rng);
        let v = [u[0] * speed, u[1] * speed];
        match kind {
            Kind::ConstVel => Motion::ConstVel { v },
            Kind::ConstAcc => {
                let am = rng.uniform(0.0, 25.0);
                let ua = unit(rng);
                Motion::ConstAcc {
                    v,
                    a: [ua[0] * am, ua[1] * am],
                }
            }
            Kind::Turn => {
                let w = rng.uniform(0.1, 0.6);
                let sign = if rng.unit_f32() < 0.5 { -1.0 } else { 1.0 };
                Motion::Turn {
                    speed,
                    heading: u[1].atan2(u[0]),
                    omega: sign * w,
                }
            }
        }
    }

    /// The 20 positions relative to the start (the first is the origin).
    pub fn integrate(&self) -> Traj {
        let mut out = [[0.0f32; 2]; WINDOW];
        match *self {
            Motion::ConstVel { v } => {
                for (k, p) in out.iter_mut().enumerate() {
                    let t = k as f32 * DT;
                    *p = [v[0] * t, v[1] * t];
                }
            }
            Motion::ConstAcc { v, a } => {
                for (k, p) in out.iter_mut().enumerate() {
                    let t = k as f32 * DT;
                    *p = [v[0] * t + 0.5 * a[0] * t * t, v[1] * t + 0.5 * a[1] * t * t];
                }
            }
            Motion::Turn {
                speed,
                heading,
                omega,
            } => {
                let mut h = heading;
                for k in 1..WINDOW {
                    out[k] = [
                        out[k - 1][0] + speed * DT * h.cos(),
                        out[k - 1][1] + speed * DT * h.sin(),
                    ];
                    h += omega * DT;
                }
            }
        }
        out
    }
}

/// Translate a trajectory to a uniformly drawn start keeping it inside `[0, SDD_RANGE]`
/// (if it is larger than the range it is placed at the low corner and clamped).
pub fn place(rel: &Traj, rng: &mut Rng) -> Traj {
    let mut out = *rel;
    for c in 0..2 {
        let lo = rel.iter().map(|p| p[c]).fold(f32::MAX, f32::min);
        let hi = rel.iter().map(|p| p[c]).fold(f32::MIN, f32::max);
        let free = (SDD_RANGE[c] - (hi - lo)).max(0.0);
        let off = rng.uniform(0.0, free) - lo;
        for p in out.iter_mut() {
            p[c] = (p[c] + off).clamp(0.0, SDD_RANGE[c]);
        }
    }
    out
}

/// One Newtonian trajectory of `kind`, placed in the SDD range.
pub fn generate(kind: Kind, rng: &mut Rng) -> Traj {
    let m = Motion::random(kind, rng);
    place(&m.integrate(), rng)
}
