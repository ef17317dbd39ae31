//! Per track: the forecasts still waiting for their truth, and the feedback
//! that scores them (rules 1 and 2 of the parent module, through
//! [`Calibration::update`]).

use heapless::Vec;

use super::forecast::{distance, expert_at};
use super::{Calibration, MotionState, TrackForecast, EXPERTS, HORIZONS};
use crate::output::Trajectory;

/// A forecast waiting for its truth: what scoring it at each horizon needs.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct Pending {
    /// The track-local grid step it was issued at.
    step: u32,
    motion: MotionState,
    /// The scale at the endpoint horizon (rule 4).
    scale: f32,
    point: [[f32; 2]; HORIZONS],
    /// The head's forecast (meaningless without a head).
    head: [[f32; 2]; HORIZONS],
    has_head: bool,
    anchor: [f32; 2],
    velocities: [[f32; 2]; 3],
}

/// The loop's state of one track: its grid steps so far and its pending
/// forecasts (at most `P`).
#[derive(Clone, Debug, PartialEq)]
pub(super) struct TrackLoop<const P: usize> {
    pub(super) id: u32,
    /// Grid points this track has gained since the loop first saw it.
    steps: u32,
    /// The time of its newest grid point (caller's milliseconds).
    end_ms: u32,
    /// The step of the last stored forecast.
    last_stored: Option<u32>,
    pending: Vec<Pending, P>,
}

impl<const P: usize> TrackLoop<P> {
    /// The loop of a track first seen with `len` grid points, the newest at
    /// `end_ms`.
    pub(super) fn new(id: u32, len: usize, end_ms: u32) -> Self {
        TrackLoop {
            id,
            steps: len as u32,
            end_ms,
            last_stored: None,
            pending: Vec::new(),
        }
    }

    /// Grid points gained since the last call, for a track whose newest
    /// point is now at `end_ms` on a grid of `period_ms` (wrapping
    /// arithmetic: the `u32` wrap of the caller's clock is one step like
    /// any other).
    pub(super) fn advance(&mut self, end_ms: u32, period_ms: u32) -> u32 {
        let n = end_ms.wrapping_sub(self.end_ms) / period_ms.max(1);
        self.end_ms = end_ms;
        n
    }

    /// Feeds the truth `y` of the track's next grid step to every pending
    /// forecast, and drops those scored at their last horizon (or beyond,
    /// after a gap). Returns the updates applied.
    pub(super) fn feed(&mut self, y: Option<[f32; 2]>, calibration: &mut Calibration) -> u32 {
        self.steps = self.steps.wrapping_add(1);
        let now = self.steps;
        let mut applied = 0;
        for pd in self.pending.iter() {
            let h = now.wrapping_sub(pd.step) as usize;
            let Some(y) = y else { continue };
            if !(1..=HORIZONS).contains(&h) {
                continue;
            }
            let head = pd.has_head.then_some(&pd.head);
            let mut errors = [0.0f32; EXPERTS];
            for (e, err) in errors.iter_mut().enumerate() {
                let x = match (e, head) {
                    (0, Some(t)) => t.get(h - 1).copied(),
                    (0, None) => None,
                    _ => expert_at(None, pd.anchor, &pd.velocities, e, h),
                };
                *err = x.map_or(0.0, |x| distance(y, x));
            }
            let d = pd.point.get(h - 1).map_or(f32::NAN, |p| distance(y, *p));
            let scale = pd.scale * super::calibration::horizon_fraction(h);
            let available = [pd.has_head, true, true, true];
            if calibration.update(pd.motion, h, d, scale, errors, available) {
                applied += 1;
            }
        }
        self.pending
            .retain(|pd| (now.wrapping_sub(pd.step) as usize) < HORIZONS);
        applied
    }

    /// Keeps `f` (issued at the current step) for scoring when a slot is
    /// free and at least `⌈12/P⌉` steps passed since the last kept one.
    pub(super) fn keep<const K: usize>(&mut self, f: &TrackForecast<K>) {
        let stride = HORIZONS.div_ceil(P.max(1)) as u32;
        let due = self
            .last_stored
            .is_none_or(|s| self.steps.wrapping_sub(s) >= stride);
        if !due || self.pending.is_full() {
            return;
        }
        let mut head = [[0.0; 2]; HORIZONS];
        if let Some(t) = &f.head {
            copy_trajectory(t, &mut head);
        }
        let pd = Pending {
            step: self.steps,
            motion: f.motion,
            scale: f.scale,
            point: f.point,
            head,
            has_head: f.head.is_some(),
            anchor: f.anchor,
            velocities: f.velocities,
        };
        if self.pending.push(pd).is_ok() {
            self.last_stored = Some(self.steps);
        }
    }
}

/// The first [`HORIZONS`] points of `t` into `out`.
fn copy_trajectory(t: &Trajectory, out: &mut [[f32; 2]; HORIZONS]) {
    for (o, p) in out.iter_mut().zip(t.iter()) {
        *o = *p;
    }
}
