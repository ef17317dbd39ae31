//! The fixed-length position history both track tables keep per track, and
//! the interpolation they fill missing steps with.

use super::{Pos, HISTORY};

/// The last [`HISTORY`] positions of a track, equally spaced in time,
/// oldest first. Slots not yet filled hold the oldest position (padding,
/// see [`History::past`]).
#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub(crate) struct History {
    hist: [Pos; HISTORY],
    /// Filled steps, 0..=HISTORY.
    len: u8,
}

impl History {
    /// No position yet.
    pub(crate) const EMPTY: History = History {
        hist: [[0.0; 2]; HISTORY],
        len: 0,
    };

    /// Appends `pos` as the newest step (the first one also pads every slot).
    pub(crate) fn push(&mut self, pos: Pos) {
        if self.len == 0 {
            self.hist = [pos; HISTORY];
            self.len = 1;
            return;
        }
        self.hist.rotate_left(1);
        if let Some(newest) = self.hist.last_mut() {
            *newest = pos;
        }
        if usize::from(self.len) < HISTORY {
            self.len += 1;
        }
    }

    /// Filled steps, `0 ..= HISTORY`.
    pub(crate) fn len(&self) -> usize {
        usize::from(self.len)
    }

    /// The newest step (meaningless while [`len`](Self::len) is 0).
    pub(crate) fn latest(&self) -> Pos {
        let [.., newest] = self.hist;
        newest
    }

    /// Oldest first, newest last; missing older steps padded with the oldest.
    pub(crate) fn past(&self) -> [Pos; HISTORY] {
        self.hist
    }
}

/// `p0 + (p1 − p0)·a`, finite for finite inputs: when `p1 − p0` overflows
/// (coordinates of opposite signs near `f32::MAX`) the equivalent
/// `p0·(1 − a) + p1·a` is used, and the result is clamped to ±`f32::MAX`.
pub(crate) fn lerp(p0: f32, p1: f32, a: f32) -> f32 {
    let d = p1 - p0;
    let v = if d.is_finite() {
        p0 + d * a
    } else {
        p0 * (1.0 - a) + p1 * a
    };
    v.clamp(-f32::MAX, f32::MAX)
}

/// [`lerp`] of both coordinates.
pub(crate) fn lerp2(p0: Pos, p1: Pos, a: f32) -> Pos {
    [lerp(p0[0], p1[0], a), lerp(p0[1], p1[1], a)]
}
