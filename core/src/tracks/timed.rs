//! The timed track table: detections with timestamps, at any camera rate,
//! with jitter and dropped frames, in; histories on the model's period out.
//!
//! [`TimedTrackTable::update`]`(t_ms, observations)` takes one camera frame:
//! its timestamp in milliseconds (`u32`, wrapping, the frame counter's
//! rules) and its detections. The table resamples each track onto one grid
//! of times shared by every track, `g_k = t₀ + k·P` for the table's first
//! timestamp `t₀` and the model's period `P` ([`period_ms_of`]: 400 ms for
//! the shipped models), by linear interpolation between consecutive
//! detections of the track. It never extrapolates: a grid time gets its
//! position once a detection at or after it has arrived, so a history ends
//! at most one camera frame (plus the detector's latency) behind real time.
//!
//! # Rules
//!
//! `update(t, observations)` applies one camera frame, in this order:
//!
//! 1. **Time.** As [`TrackTable::update`](super::TrackTable::update)'s frame
//!    rule, in milliseconds: `step = t − last` (mod 2³²); 0 continues the
//!    last frame, `1 ≤ step < 2³¹` advances, `step ≥ 2³¹` (a timestamp before
//!    the last one) refuses the whole call ([`FrameDelta::stale`], every
//!    observation [`ObserveError::StaleFrame`]) and changes nothing. The
//!    first update after [`new`](TimedTrackTable::new) or
//!    [`clear`](TimedTrackTable::clear) accepts any `t` and makes it `t₀`.
//!    When time advances, every track's [`TimedTrack::fresh`] flag is reset.
//! 2. **Leaving.** A track whose last detection is more than `max_gap_ms`
//!    before `t` leaves (listed in [`FrameDelta::left`], its slot free for
//!    this frame's newcomers): no interpolation bridges a longer gap, and
//!    its id, seen again, enters as a new track.
//! 3. **Observations**, in slice order, each checked in this order:
//!    * a non-finite coordinate → [`ObserveError::NonFinite`] (not stored;
//!      it does not keep the track alive);
//!    * an id that already has a detection at `t` → [`ObserveError::Duplicate`]
//!      (the first position stands);
//!    * a known id, last detected at `t_a` with position `p_a`, now at `p_b`:
//!      every grid time `g` with `t_a < g ≤ t` is appended in time order,
//!      at most the last [`HISTORY`] of them, with the position `p_b` when
//!      `g = t`, else `lerp(p_a, p_b, a)` with
//!      `a = ((g − t_a) as f32) / ((t − t_a) as f32)` (one f32 division;
//!      `lerp` as in [`TrackTable`](super::TrackTable): `p_a + (p_b − p_a)·a`,
//!      overflow-safe). → [`Sampled::Continued`] with the number of grid
//!      points appended (0 when no grid time passed); the track is
//!      [`fresh`](TimedTrack::fresh) when it is more than 0;
//!    * a new id → [`Sampled::Entered`] if a slot is free (its history
//!      starts at `t` when `t` is a grid time, else at the next grid time a
//!      later detection reaches), else [`ObserveError::TableFull`]
//!      (counted in [`FrameDelta::rejected`]; tracks are never evicted).
//!
//! Times are kept on an unwrapped 64-bit millisecond line, so neither the
//! `u32` wrap (every 49.7 days) nor any product of them overflows. Every
//! step is integer or correctly rounded f32 arithmetic in a fixed order:
//! the histories are the same bits on every target (`cargo xtask qemu`
//! checks a resampled scene on the Cortex-M0, M4F and M7).
//!
//! # Predicting from it
//!
//! After each update, [`TimedTrackTable::fresh`] lists the tracks whose
//! history gained a grid point and is full: predict for those.
//! [`TimedTrack::end_ms`] is the time of the history's newest point, so
//! forecast step `k` (1-based) is at `end_ms + k·P`.
//!
//! ```
//! use core::num::NonZeroU32;
//! use gpecnet_core::tracks::{Observation, TimedTrackTable, HISTORY};
//!
//! const PERIOD: NonZeroU32 = NonZeroU32::new(400).unwrap(); // the model's 0.4 s
//! let mut table: TimedTrackTable<16> = TimedTrackTable::new(PERIOD, /* max gap */ 1_000);
//! let mut forecasts = 0;
//! for frame in 0..120u32 {
//!     // 30 Hz with ±5 ms of jitter; every tenth frame dropped.
//!     let t_ms = frame * 1000 / 30 + [0, 5, 2, 0, 4][frame as usize % 5];
//!     if frame % 10 == 9 { continue; }
//!     let x = 1.2 * t_ms as f32 / 1000.0; // walking at 1.2 m/s
//!     table.update(t_ms, &[Observation { id: 3, pos: [x, 0.5] }]);
//!     for track in table.fresh() {
//!         let past: [[f32; 2]; HISTORY] = track.past(); // predict from `past`
//!         assert!((past[HISTORY - 1][0] - 1.2 * track.end_ms() as f32 / 1000.0).abs() < 1e-4);
//!         forecasts += 1;
//!     }
//! }
//! assert_eq!(forecasts, 3); // grid points 7, 8, 9 (2.8 s, 3.2 s, 3.6 s)
//! ```
//!
//! # Memory and cost
//!
//! A [`TimedTrack`] is 104 bytes on a 32-bit target (the history, id, last
//! detection, grid end); a `TimedTrackTable<N>` is `104·N + 48` bytes and
//! can live in a `static` ([`TimedTrackTable::new`] is `const`). An update
//! costs O(N) per observation (lookup by id) plus O(N) per call (expiry),
//! and at most [`HISTORY`] interpolations per observation
//! (`cargo xtask profile` measures 16 tracks at 30 Hz on a Cortex-M4F).

use core::num::NonZeroU32;

use heapless::Vec;

use super::history::{lerp2, History};
use super::{advance, expire, FrameDelta, Observation, ObserveError, Pos, HISTORY};
use crate::blob::Model;

/// The model's period in whole milliseconds, for [`TimedTrackTable::new`]:
/// `None` when the blob does not record one (format < 4) or it is not
/// within 10⁻³ ms of a whole number of milliseconds.
pub fn period_ms_of(model: &Model<'_>) -> Option<NonZeroU32> {
    let ms = model.period_s()? * 1000.0;
    let whole = libm::roundf(ms);
    if (ms - whole).abs() > 1e-3 || !(1.0..=60_000.0).contains(&whole) {
        return None;
    }
    NonZeroU32::new(whole as u32)
}

/// What an accepted detection did.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Sampled {
    /// A new track entered the table with this detection.
    Entered,
    /// The detection extended a known track.
    Continued {
        /// Grid points this detection completed (0 when no grid time
        /// passed since the track's last detection); at most the last
        /// [`HISTORY`] of them were computed.
        points: u32,
    },
}

/// A tracked pedestrian of a [`TimedTrackTable`].
#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct TimedTrack {
    id: u32,
    /// Grid positions; empty until the first grid time is reached.
    hist: History,
    /// Whether the last update that advanced time appended grid points.
    fresh: bool,
    /// The last detection, on the table's unwrapped millisecond line.
    last_t: u64,
    /// Its position.
    last_pos: Pos,
    /// Grid time of the history's newest point (unwrapped ms; meaningless
    /// while the history is empty).
    end: u64,
}

impl TimedTrack {
    /// The track id.
    pub fn id(&self) -> u32 {
        self.id
    }

    /// Filled grid points, `0 ..= HISTORY`.
    pub fn len(&self) -> usize {
        self.hist.len()
    }

    /// `true` until the track's first grid point.
    pub fn is_empty(&self) -> bool {
        self.hist.len() == 0
    }

    /// `true` once [`HISTORY`] grid points are filled.
    pub fn ready(&self) -> bool {
        self.hist.len() == HISTORY
    }

    /// `true` when the last update that advanced time appended at least
    /// one grid point to this track.
    pub fn fresh(&self) -> bool {
        self.fresh
    }

    /// The grid history, oldest first, newest (at [`end_ms`](Self::end_ms))
    /// last; before the track is [`ready`](Self::ready) the missing older
    /// points are padded with the oldest one.
    pub fn past(&self) -> [Pos; HISTORY] {
        self.hist.past()
    }

    /// The time of the history's newest grid point, in the caller's
    /// milliseconds (wrapping like them).
    pub fn end_ms(&self) -> u32 {
        self.end as u32
    }

    /// The last detection's timestamp, in the caller's milliseconds.
    pub fn last_detection_ms(&self) -> u32 {
        self.last_t as u32
    }

    /// The last detection's position (measured, not resampled).
    pub fn last_detection(&self) -> Pos {
        self.last_pos
    }
}

/// A fixed-capacity table of at most `N` tracks resampled onto the model's
/// period (see the module's rules).
#[derive(Clone, Debug)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct TimedTrackTable<const N: usize> {
    tracks: Vec<TimedTrack, N>,
    period: u64,
    max_gap: u64,
    /// The grid origin `t₀` and the last update's time, unwrapped; `None`
    /// before the first update.
    clock: Option<(u64, u64)>,
}

impl<const N: usize> TimedTrackTable<N> {
    /// An empty table resampling onto `period_ms` ([`period_ms_of`] the
    /// model), bridging gaps between a track's detections of at most
    /// `max_gap_ms` (values of 2³¹ and more act as 2³¹ − 1).
    pub const fn new(period_ms: NonZeroU32, max_gap_ms: u32) -> Self {
        let max_gap = if max_gap_ms >= 1 << 31 {
            (1 << 31) - 1
        } else {
            max_gap_ms
        };
        TimedTrackTable {
            tracks: Vec::new(),
            period: period_ms.get() as u64,
            max_gap: max_gap as u64,
            clock: None,
        }
    }

    /// The grid period in milliseconds.
    pub const fn period_ms(&self) -> u32 {
        self.period as u32
    }

    /// The longest gap between two detections of a track that is bridged.
    pub const fn max_gap_ms(&self) -> u32 {
        self.max_gap as u32
    }

    table_views!(TimedTrack);

    /// The tracks with a full history that gained a grid point in the last
    /// update that advanced time: the ones to predict for now.
    pub fn fresh(&self) -> impl Iterator<Item = &TimedTrack> {
        self.tracks.iter().filter(|t| t.ready() && t.fresh)
    }

    /// The last accepted timestamp (`None` before the first update and
    /// after [`clear`](Self::clear)).
    pub fn time_ms(&self) -> Option<u32> {
        self.clock.map(|(_, now)| now as u32)
    }

    /// The grid origin `t₀`: the first accepted timestamp.
    pub fn origin_ms(&self) -> Option<u32> {
        self.clock.map(|(origin, _)| origin as u32)
    }

    /// Forgets every track, the grid origin and the last time (a new
    /// sequence, or a clock that restarted). Nothing is reported as left.
    pub fn clear(&mut self) {
        self.tracks.clear();
        self.clock = None;
    }

    /// Applies one camera frame (the module's rules 1–3) and reports what
    /// changed.
    pub fn update(&mut self, t_ms: u32, observations: &[Observation]) -> FrameDelta<N> {
        self.update_with(t_ms, observations, |_, _| {})
    }

    // The same call as `TrackTable::update_with`, with this table's clock
    // and outcome (`Sampled`): one way to feed either table.
    /// [`update`](Self::update), also calling `each(observation, outcome)`
    /// for every observation, in slice order, as it is applied.
    pub fn update_with(
        &mut self,
        t_ms: u32,
        observations: &[Observation],
        mut each: impl FnMut(&Observation, Result<Sampled, ObserveError>),
    ) -> FrameDelta<N> {
        let mut d = FrameDelta::default();
        let Some(now) = advance(self.clock.map(|(_, now)| now), t_ms) else {
            d.refuse(observations, |o| each(o, Err(ObserveError::StaleFrame)));
            return d;
        };
        let origin = match self.clock {
            Some((origin, last)) => {
                if now != last {
                    self.tracks.iter_mut().for_each(|t| t.fresh = false);
                }
                origin
            }
            None => now,
        };
        self.clock = Some((origin, now));
        let max_gap = self.max_gap;
        expire(&mut self.tracks, &mut d.left, |t| {
            (now.saturating_sub(t.last_t) > max_gap).then_some(t.id)
        });
        for o in observations {
            let r = self.observe(origin, now, o);
            d.record(o.id, r.map(|r| r == Sampled::Entered));
            each(o, r);
        }
        d
    }

    /// Rule 3 for one observation at unwrapped time `now`.
    fn observe(&mut self, origin: u64, now: u64, o: &Observation) -> Result<Sampled, ObserveError> {
        if !o.pos.iter().all(|v| v.is_finite()) {
            return Err(ObserveError::NonFinite);
        }
        let period = self.period;
        // Grid points up to `t`: g_k ≤ t for k < grid_count(t).
        let grid_count = |t: u64| t.saturating_sub(origin) / period + 1;
        if let Some(t) = self.tracks.iter_mut().find(|t| t.id == o.id) {
            if t.last_t == now {
                return Err(ObserveError::Duplicate);
            }
            let (first, end) = (grid_count(t.last_t), grid_count(now));
            let span = now.saturating_sub(t.last_t) as f32;
            for k in first.max(end.saturating_sub(HISTORY as u64))..end {
                let g = origin + k * period;
                let p = if g == now {
                    o.pos
                } else {
                    lerp2(t.last_pos, o.pos, (g - t.last_t) as f32 / span)
                };
                t.hist.push(p);
                t.end = g;
            }
            let points = end - first;
            t.fresh |= points > 0;
            t.last_t = now;
            t.last_pos = o.pos;
            Ok(Sampled::Continued {
                points: u32::try_from(points).unwrap_or(u32::MAX),
            })
        } else {
            let mut hist = History::EMPTY;
            let on_grid = now.saturating_sub(origin).is_multiple_of(period);
            if on_grid {
                hist.push(o.pos);
            }
            self.tracks
                .push(TimedTrack {
                    id: o.id,
                    hist,
                    fresh: on_grid,
                    last_t: now,
                    last_pos: o.pos,
                    end: now,
                })
                .map_err(|_| ObserveError::TableFull)?;
            Ok(Sampled::Entered)
        }
    }
}
