//! The track table: detections, frame by frame, in; per-pedestrian histories
//! of [`HISTORY`] equally spaced positions, ready for a prediction, out.
//! Fixed capacity (`N` tracks, a const generic), no heap, no panics.
//!
//! Two tables. [`TimedTrackTable`] ([`timed`]) takes detections with
//! millisecond timestamps at the camera's rate, jitter and misses included,
//! and resamples them onto the model's period: the one a flight computer
//! wants. [`TrackTable`], described below, takes frames that are already
//! one model period apart.
//!
//! For noisy detections (a drone's camera), [`filter::TrackFilter`] is an
//! optional stage in front of either table: a constant-velocity Kalman filter
//! per track that replaces each detection by its filtered position. The
//! tables themselves never filter.
//!
//! The integrator's detector/tracker delivers, once per *frame*, a list of
//! [`Observation`]s `(track id, position)`. Association is by id only: run
//! your own data association / re-identification upstream. A frame of
//! [`TrackTable`] is one step of the model's sampling period (0.4 s, 2.5 Hz,
//! for the shipped models): feed it at that rate, not at the camera's. Positions are
//! kept in the caller's raw units (the ones the model was trained on: pixels
//! or metres) and must be finite; the predictor checks its own input range.
//!
//! # Rules
//!
//! [`TrackTable::update`]`(frame, observations)` applies one frame, in this
//! order:
//!
//! 1. **Frame.** Frame numbers are `u32` and compared with wrapping (serial
//!    number) arithmetic, so a counter that wraps from `u32::MAX` to `0` just
//!    advances by one. Let `step = frame − last frame` (mod 2³²). `step = 0`
//!    continues the last frame (a frame may be given in several calls);
//!    `1 ≤ step < 2³¹` advances by `step` frames (the skipped frames are frames
//!    without observations); `step ≥ 2³¹` is a frame *before* the last one:
//!    the whole call is refused ([`FrameDelta::stale`], every observation
//!    gets [`ObserveError::StaleFrame`]) and nothing changes. The first call
//!    after [`TrackTable::new`] or [`TrackTable::clear`] accepts any frame.
//!    A detector whose counter restarts (a new sequence) must call
//!    [`TrackTable::clear`] first.
//! 2. **Leaving during skipped frames.** A track whose last observation is
//!    more than `max_missed + 1` frames before `frame` had already gone more
//!    than `max_missed` frames unobserved before this frame: it leaves now
//!    (listed in [`FrameDelta::left`]), and its slot is free for this frame's
//!    newcomers. Never happens when every frame is passed to `update`.
//! 3. **Observations**, in slice order, each checked in this order:
//!    * a non-finite coordinate → [`ObserveError::NonFinite`]: not stored,
//!      and it does not keep the track alive (the frame counts as missed);
//!    * an id that already has a position for this frame (an earlier
//!      observation in the same frame, in this or an earlier call) →
//!      [`ObserveError::Duplicate`]: the first position of a frame stands;
//!    * a known id → [`Observed::Continued`]: the position is appended. If
//!      `g` frames passed since the track's last position (`g − 1 ≤
//!      max_missed` missed frames, by rule 2), the missed steps are filled by
//!      linear interpolation, `p₀ + (p₁ − p₀)·a` with `a = s · (1/g)` in f32
//!      for `s = 1 .. g−1` (only the last `HISTORY − 1` of them, the ones
//!      that can still be in the history), so the history stays equally
//!      spaced in time, as the predictor requires (where `p₁ − p₀`
//!      overflows, for coordinates near ±`f32::MAX`, `p₀·(1 − a) + p₁·a` is
//!      used instead, so the history stays finite);
//!    * a new id → [`Observed::Entered`] if the table has a free slot, else
//!      [`ObserveError::TableFull`] (counted in [`FrameDelta::rejected`];
//!      existing tracks are never evicted for newcomers).
//! 4. **Leaving at the end of the frame.** A track not observed for more than
//!    `max_missed` consecutive frames (its last position is more than
//!    `max_missed` frames before `frame`) leaves. Its slot is free from the
//!    next frame on, so a newcomer rejected in this frame gets it next frame.
//!
//! An id that left is forgotten: seen again, it enters as a new track, its
//! history starting afresh. When frames were skipped (rule 2), one call can list the
//! same id in both [`FrameDelta::left`] (the old track) and
//! [`FrameDelta::entered`] (the new one).
//!
//! A track is [`Track::ready`] once [`HISTORY`] steps are filled (measured or
//! interpolated); [`Track::past`] returns them oldest first, the input of a
//! prediction. Tracks are kept, and iterated, in the order they entered.
//!
//! ```
//! use gpecnet_core::tracks::{Observation, TrackTable, HISTORY};
//!
//! let mut table: TrackTable<16> = TrackTable::new(/* max_missed */ 3);
//! for frame in 0..10u32 {
//!     let seen = [Observation { id: 7, pos: [100.0 + 4.0 * frame as f32, 50.0] }];
//!     let delta = table.update(frame, &seen);
//!     assert_eq!(delta.rejected, 0);
//!     for track in table.ready() {
//!         let past: [[f32; 2]; HISTORY] = track.past(); // predict from `past`
//!         assert_eq!(past[HISTORY - 1], track.latest());
//!     }
//! }
//! assert_eq!(table.get(7).map(|t| t.len()), Some(HISTORY));
//! ```
//!
//! # Memory
//!
//! A [`Track`] is 80 bytes (`HISTORY` positions, id, length, last frame); a
//! `TrackTable<N>` is `80·N + 32` bytes and can live in a `static`
//! ([`TrackTable::new`] is `const`). A [`FrameDelta<N>`] (two id lists of
//! capacity `N`) is about `8·N + 32` bytes. `update` costs O(N) per
//! observation (lookup by id) plus O(N) per call (expiry).

/// The read-only views both track tables ([`TrackTable`],
/// [`TimedTrackTable`]) offer over their `tracks` (a `heapless::Vec` of
/// `$track`, each with an `id` and `ready()`), written once.
/// `tests/public_api.rs` expands it for the snapshot.
macro_rules! table_views {
    ($track:ty) => {
        /// Tracks in the table.
        pub fn len(&self) -> usize {
            self.tracks.len()
        }

        /// `true` when no track is in the table.
        pub fn is_empty(&self) -> bool {
            self.tracks.is_empty()
        }

        /// The most tracks the table holds (`N`).
        pub const fn capacity(&self) -> usize {
            N
        }

        /// The track with this id, if it is in the table.
        pub fn get(&self, id: u32) -> Option<&$track> {
            self.tracks.iter().find(|t| t.id == id)
        }

        /// Every track, in the order they entered.
        pub fn iter(&self) -> impl Iterator<Item = &$track> {
            self.tracks.iter()
        }

        /// The tracks with a full history (`ready`), in the order they
        /// entered.
        pub fn ready(&self) -> impl Iterator<Item = &$track> {
            self.tracks.iter().filter(|t| t.ready())
        }
    };
}

pub mod filter;
mod history;
pub mod timed;

use core::fmt;

use heapless::Vec;

use history::{lerp2, History};
pub use timed::{period_ms_of, Sampled, TimedTrack, TimedTrackTable};

/// Steps of history a prediction consumes: the shipped models' `past_len`
/// (8 × 0.4 s = 3.2 s). A model with another `past_len` cannot take
/// [`Track::past`] directly; check `model.config().past_len` at start-up.
pub const HISTORY: usize = 8;

/// A 2-D position in the model's raw units.
pub type Pos = [f32; 2];

/// One detection in a frame: which pedestrian, and where.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Observation {
    /// The track id from the upstream tracker (any value).
    pub id: u32,
    /// The position; both coordinates must be finite.
    pub pos: Pos,
}

/// What an accepted observation did.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Observed {
    /// A new track entered the table with this position.
    Entered,
    /// The position was appended to an existing track.
    Continued {
        /// Frames missed since the track's previous position (0 = observed
        /// in the previous frame); the last `min(missed, HISTORY − 1)` of
        /// them were filled by interpolation.
        missed: u32,
    },
}

/// Why an observation was not stored (see the module's rules for the order
/// of the checks).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum ObserveError {
    /// The frame is before the table's last frame; the whole update was refused.
    StaleFrame,
    /// A coordinate is NaN or infinite.
    NonFinite,
    /// The id already has a position for this frame.
    Duplicate,
    /// A new id, and every slot is taken.
    TableFull,
}

impl fmt::Display for ObserveError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            ObserveError::StaleFrame => "frame is before the track table's last frame",
            ObserveError::NonFinite => "non-finite observed position",
            ObserveError::Duplicate => "track id observed twice in one frame",
            ObserveError::TableFull => "track table full",
        })
    }
}

impl core::error::Error for ObserveError {}

/// A tracked pedestrian: its id and its last [`HISTORY`] positions.
#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Track {
    id: u32,
    /// At least one step: the position the track entered with.
    hist: History,
    /// Frame of the last position, on the table's unwrapped time line.
    last_seen: u64,
}

impl Track {
    fn new(id: u32, pos: Pos, now: u64) -> Self {
        let mut hist = History::EMPTY;
        hist.push(pos);
        Track {
            id,
            hist,
            last_seen: now,
        }
    }

    /// Appends `pos`, observed `gap ≥ 1` frames after the last position,
    /// interpolating the `gap − 1` missed steps (the last HISTORY − 1 at most).
    fn extend(&mut self, pos: Pos, gap: u64) {
        let p0 = self.latest();
        let inv = 1.0 / gap as f32;
        let first = gap.saturating_sub(HISTORY as u64 - 1).max(1);
        for s in first..gap {
            self.hist.push(lerp2(p0, pos, s as f32 * inv));
        }
        self.hist.push(pos);
    }

    /// The track id.
    pub fn id(&self) -> u32 {
        self.id
    }

    /// The frame of the last stored observation (the caller's numbering).
    pub fn last_seen(&self) -> u32 {
        self.last_seen as u32
    }

    /// Filled history steps, `1 ..= HISTORY` (interpolated steps count).
    pub fn len(&self) -> usize {
        self.hist.len()
    }

    /// Always `false`: a track holds at least the position it entered with.
    pub fn is_empty(&self) -> bool {
        self.hist.len() == 0
    }

    /// `true` once [`HISTORY`] steps are filled.
    pub fn ready(&self) -> bool {
        self.hist.len() == HISTORY
    }

    /// The most recent position (always a measured one).
    pub fn latest(&self) -> Pos {
        self.hist.latest()
    }

    /// The history, oldest first, newest last. Before the track is
    /// [`ready`](Self::ready), the missing older steps are padded with the
    /// oldest known position (the one the track entered with).
    pub fn past(&self) -> [Pos; HISTORY] {
        self.hist.past()
    }
}

/// What one [`TrackTable::update`] changed and refused.
///
/// `entered` and `left` cannot overflow: at most `N` tracks can leave (the
/// table held at most `N`) and at most `N` can enter in one call.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FrameDelta<const N: usize> {
    /// Ids that entered, in observation order.
    pub entered: Vec<u32, N>,
    /// Ids that left: first those gone during skipped frames, then those
    /// gone at the end of this frame, each group in table order.
    pub left: Vec<u32, N>,
    /// Observations of new ids refused because the table was full.
    pub rejected: u32,
    /// Observations refused because their id already had a position for this frame.
    pub duplicates: u32,
    /// Observations refused because a coordinate was not finite.
    pub non_finite: u32,
    /// The frame was before the table's last frame: the call changed nothing.
    pub stale: bool,
}

impl<const N: usize> FrameDelta<N> {
    /// Counts one observation's outcome (`Ok(true)`: its id entered).
    fn record(&mut self, id: u32, r: Result<bool, ObserveError>) {
        match r {
            // At most N entries per call: cannot overflow.
            Ok(true) => {
                let _ = self.entered.push(id);
            }
            Ok(false) | Err(ObserveError::StaleFrame) => {}
            Err(ObserveError::NonFinite) => self.non_finite = self.non_finite.saturating_add(1),
            Err(ObserveError::Duplicate) => self.duplicates = self.duplicates.saturating_add(1),
            Err(ObserveError::TableFull) => self.rejected = self.rejected.saturating_add(1),
        }
    }

    /// Marks the call stale, telling `each` of every observation.
    fn refuse(&mut self, observations: &[Observation], each: impl FnMut(&Observation)) {
        self.stale = true;
        observations.iter().for_each(each);
    }
}

/// The unwrapped time of the caller's `t` (a wrapping `u32` counter) after
/// the unwrapped `last`: `None` when `t` is before it (a serial-number
/// difference of 2³¹ or more); any `t` when there is no `last`.
fn advance(last: Option<u64>, t: u32) -> Option<u64> {
    match last {
        None => Some(u64::from(t)),
        Some(last) => {
            let step = t.wrapping_sub(last as u32);
            (step < 1 << 31).then(|| last.wrapping_add(u64::from(step)))
        }
    }
}

/// Removes from `tracks` (keeping the order of the others) those `gone`
/// says have left, listing their ids in `left`.
fn expire<T, const N: usize>(
    tracks: &mut Vec<T, N>,
    left: &mut Vec<u32, N>,
    gone: impl Fn(&T) -> Option<u32>,
) {
    tracks.retain(|t| match gone(t) {
        Some(id) => {
            // At most the N tracks present at the start of a call leave.
            let _ = left.push(id);
            false
        }
        None => true,
    });
}

/// A fixed-capacity table of at most `N` tracks (see the module's rules).
#[derive(Clone, Debug)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct TrackTable<const N: usize> {
    tracks: Vec<Track, N>,
    max_missed: u32,
    /// The last frame on an unwrapped time line (its low 32 bits are the
    /// caller's frame number); `None` before the first update.
    now: Option<u64>,
}

impl<const N: usize> TrackTable<N> {
    /// An empty table. `max_missed`: a track survives up to this many
    /// consecutive frames without an observation, and leaves at the end of
    /// the next one (0: it leaves at the end of the first frame it is missed).
    pub const fn new(max_missed: u32) -> Self {
        TrackTable {
            tracks: Vec::new(),
            max_missed,
            now: None,
        }
    }

    /// The `max_missed` the table was made with.
    pub const fn max_missed(&self) -> u32 {
        self.max_missed
    }

    table_views!(Track);

    /// The last frame an update accepted (`None` before the first one and
    /// after [`clear`](Self::clear)).
    pub fn frame(&self) -> Option<u32> {
        self.now.map(|n| n as u32)
    }

    /// Forgets every track and the last frame (for a new sequence, or a
    /// detector whose frame counter restarted). Nothing is reported as left.
    pub fn clear(&mut self) {
        self.tracks.clear();
        self.now = None;
    }

    /// Applies one frame of observations (the module's rules 1–4) and
    /// reports what changed.
    pub fn update(&mut self, frame: u32, observations: &[Observation]) -> FrameDelta<N> {
        self.update_with(frame, observations, |_, _| {})
    }

    /// [`update`](Self::update), also calling `each(observation, outcome)`
    /// for every observation, in slice order, as it is applied.
    pub fn update_with(
        &mut self,
        frame: u32,
        observations: &[Observation],
        mut each: impl FnMut(&Observation, Result<Observed, ObserveError>),
    ) -> FrameDelta<N> {
        let mut d = FrameDelta::default();
        let Some(now) = advance(self.now, frame) else {
            d.refuse(observations, |o| each(o, Err(ObserveError::StaleFrame)));
            return d;
        };
        self.now = Some(now);
        let max_missed = u64::from(self.max_missed);
        self.expire(now, max_missed + 1, &mut d.left);
        for o in observations {
            let r = self.observe(now, o);
            d.record(o.id, r.map(|r| r == Observed::Entered));
            each(o, r);
        }
        self.expire(now, max_missed, &mut d.left);
        d
    }

    /// Rule 3 for one observation at (unwrapped) frame `now`.
    fn observe(&mut self, now: u64, o: &Observation) -> Result<Observed, ObserveError> {
        if !o.pos.iter().all(|v| v.is_finite()) {
            return Err(ObserveError::NonFinite);
        }
        if let Some(t) = self.tracks.iter_mut().find(|t| t.id == o.id) {
            let gap = now.wrapping_sub(t.last_seen);
            if gap == 0 {
                return Err(ObserveError::Duplicate);
            }
            t.extend(o.pos, gap);
            t.last_seen = now;
            let missed = u32::try_from(gap - 1).unwrap_or(u32::MAX);
            Ok(Observed::Continued { missed })
        } else {
            self.tracks
                .push(Track::new(o.id, o.pos, now))
                .map_err(|_| ObserveError::TableFull)?;
            Ok(Observed::Entered)
        }
    }

    /// Removes (keeping the order of the others) the tracks whose last
    /// position is more than `max_age` frames before `now`, listing their ids.
    fn expire(&mut self, now: u64, max_age: u64, left: &mut Vec<u32, N>) {
        expire(&mut self.tracks, left, |t| {
            (now.wrapping_sub(t.last_seen) > max_age).then_some(t.id)
        });
    }
}
