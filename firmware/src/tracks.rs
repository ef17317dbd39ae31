//! Fixed-capacity table of tracked pedestrians (target-independent, heap-free).
//!
//! Each frame (2.5 Hz, one step = 0.4 s) the integrator's detector/tracker
//! delivers observations `(track id, position)`; association is by id (run
//! your own data association / re-identification upstream). The table keeps,
//! per track, the last [`HISTORY`] positions in a ring buffer, in the raw
//! units the model was trained on (pixels or metres).
//!
//! * A new id **enters** the table if there is room (else it is rejected and
//!   counted; existing tracks are never evicted for newcomers).
//! * A track that has not been observed for more than `max_missed`
//!   consecutive frames **leaves** (is dropped) at the end of that update.
//! * A track observed again after a short gap (≤ `max_missed` frames) gets the
//!   missing steps filled by linear interpolation, so the history stays
//!   equally spaced in time, as the predictor requires.
//! * A track is [`Track::ready`] once [`HISTORY`] steps are filled; then
//!   [`Track::past`] returns them oldest first, ready for `predict_endpoints`.
//!
//! This file is compiled twice: into the firmware (thumbv7em, no_std) and into
//! `firmware/host` (stable toolchain, std test harness), where the unit tests
//! below run: `cargo xtask fw-test`.

use heapless::Vec;

/// Steps of history the predictor consumes (8 × 0.4 s = 3.2 s).
pub const HISTORY: usize = 8;

/// A 2-D position in the model's raw units.
pub type Pos = [f32; 2];

/// One detection in a frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Observation {
    pub id: u32,
    pub pos: Pos,
}

/// A tracked pedestrian: id + ring buffer of the last [`HISTORY`] positions.
#[derive(Clone, Debug)]
pub struct Track {
    id: u32,
    ring: [Pos; HISTORY],
    /// Index of the next slot to write (the oldest entry once full).
    head: u8,
    /// Filled slots, saturating at HISTORY.
    len: u8,
    /// Frame of the last observation.
    last_seen: u32,
}

impl Track {
    fn new(id: u32, pos: Pos, frame: u32) -> Self {
        let mut t = Track {
            id,
            ring: [[0.0; 2]; HISTORY],
            head: 0,
            len: 0,
            last_seen: frame,
        };
        t.push(pos);
        t
    }

    fn push(&mut self, pos: Pos) {
        self.ring[self.head as usize] = pos;
        self.head = ((self.head as usize + 1) % HISTORY) as u8;
        if (self.len as usize) < HISTORY {
            self.len += 1;
        }
    }

    /// Most recent position.
    pub fn latest(&self) -> Pos {
        self.ring[(self.head as usize + HISTORY - 1) % HISTORY]
    }

    fn set_latest(&mut self, pos: Pos) {
        self.ring[(self.head as usize + HISTORY - 1) % HISTORY] = pos;
    }

    pub fn id(&self) -> u32 {
        self.id
    }

    pub fn last_seen(&self) -> u32 {
        self.last_seen
    }

    /// Number of filled history steps (0..=HISTORY).
    pub fn len(&self) -> usize {
        self.len as usize
    }

    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// True once HISTORY steps are filled.
    pub fn ready(&self) -> bool {
        self.len as usize == HISTORY
    }

    /// The history, oldest first. Slots not yet filled (len < HISTORY) are
    /// padded with the oldest known position.
    pub fn past(&self) -> [Pos; HISTORY] {
        let len = self.len as usize;
        let mut out = [[0.0; 2]; HISTORY];
        // oldest filled entry
        let start = (self.head as usize + HISTORY - len) % HISTORY;
        for (i, o) in out.iter_mut().enumerate() {
            let k = if i + len < HISTORY {
                0
            } else {
                i + len - HISTORY
            };
            *o = self.ring[(start + k) % HISTORY];
        }
        out
    }
}

/// Rejected observation: the table is full.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TableFull;

/// What one [`TrackTable::update`] changed. `entered`/`left` are bounded by
/// the table capacity (an update can drop at most N and admit at most N).
#[derive(Clone, Debug, Default)]
pub struct FrameDelta<const N: usize> {
    pub entered: Vec<u32, N>,
    pub left: Vec<u32, N>,
    /// Observations of new ids that did not fit.
    pub rejected: u32,
}

/// Fixed-capacity track table (N tracks).
pub struct TrackTable<const N: usize> {
    tracks: Vec<Track, N>,
    max_missed: u32,
    frame: Option<u32>,
}

impl<const N: usize> TrackTable<N> {
    /// `max_missed`: a track survives up to this many frames without an
    /// observation and is dropped at the update after that.
    pub const fn new(max_missed: u32) -> Self {
        TrackTable {
            tracks: Vec::new(),
            max_missed,
            frame: None,
        }
    }

    pub fn len(&self) -> usize {
        self.tracks.len()
    }

    pub fn is_empty(&self) -> bool {
        self.tracks.is_empty()
    }

    pub const fn capacity(&self) -> usize {
        N
    }

    pub fn get(&self, id: u32) -> Option<&Track> {
        self.tracks.iter().find(|t| t.id == id)
    }

    pub fn iter(&self) -> impl Iterator<Item = &Track> {
        self.tracks.iter()
    }

    /// Tracks with a full history.
    pub fn ready(&self) -> impl Iterator<Item = &Track> {
        self.tracks.iter().filter(|t| t.ready())
    }

    /// Drop tracks not seen for more than `max_missed` frames as of `frame`.
    fn expire(&mut self, frame: u32, left: &mut Vec<u32, N>) {
        let max = self.max_missed;
        let mut i = 0;
        while i < self.tracks.len() {
            if frame.wrapping_sub(self.tracks[i].last_seen) > max {
                let t = self.tracks.swap_remove(i);
                // capacity N: cannot overflow
                let _ = left.push(t.id);
            } else {
                i += 1;
            }
        }
    }

    /// Add one observation for `frame`. Re-observing an id twice in the same
    /// frame overwrites that step. Frames must not go backwards.
    pub fn observe(&mut self, frame: u32, obs: Observation) -> Result<bool, TableFull> {
        if let Some(t) = self.tracks.iter_mut().find(|t| t.id == obs.id) {
            let gap = frame.wrapping_sub(t.last_seen);
            if gap == 0 {
                t.set_latest(obs.pos);
            } else {
                // fill missed steps (gap-1 of them) by linear interpolation
                let p0 = t.latest();
                let inv = 1.0 / gap as f32;
                // only the last HISTORY-1 missed steps can still be in the ring
                let first = if gap > HISTORY as u32 {
                    gap - (HISTORY as u32 - 1)
                } else {
                    1
                };
                for s in first..gap {
                    let a = s as f32 * inv;
                    t.push([
                        p0[0] + (obs.pos[0] - p0[0]) * a,
                        p0[1] + (obs.pos[1] - p0[1]) * a,
                    ]);
                }
                t.push(obs.pos);
                t.last_seen = frame;
            }
            Ok(false)
        } else {
            self.tracks
                .push(Track::new(obs.id, obs.pos, frame))
                .map_err(|_| TableFull)?;
            Ok(true)
        }
    }

    /// One frame: apply the observations, then drop the tracks that have now
    /// gone more than `max_missed` frames without one. A full table frees its
    /// slots at the end of a frame, so newcomers get them from the next frame on.
    pub fn update(&mut self, frame: u32, observations: &[Observation]) -> FrameDelta<N> {
        let mut d = FrameDelta {
            entered: Vec::new(),
            left: Vec::new(),
            rejected: 0,
        };
        self.frame = Some(frame);
        for o in observations {
            match self.observe(frame, *o) {
                Ok(true) => {
                    let _ = d.entered.push(o.id);
                }
                Ok(false) => {}
                Err(TableFull) => d.rejected += 1,
            }
        }
        self.expire(frame, &mut d.left);
        d
    }

    /// The last frame passed to [`update`](Self::update).
    pub fn frame(&self) -> Option<u32> {
        self.frame
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use std::vec::Vec as StdVec;

    fn ob(id: u32, x: f32, y: f32) -> Observation {
        Observation { id, pos: [x, y] }
    }

    #[test]
    fn enters_and_becomes_ready_after_history_steps() {
        let mut t: TrackTable<4> = TrackTable::new(2);
        for f in 0..HISTORY as u32 {
            let d = t.update(f, &[ob(7, f as f32, 0.0)]);
            assert_eq!(
                d.entered.as_slice(),
                if f == 0 { &[7][..] } else { &[][..] }
            );
            assert_eq!(t.get(7).unwrap().ready(), f as usize == HISTORY - 1);
        }
        assert_eq!(t.ready().count(), 1);
        let past = t.get(7).unwrap().past();
        for (i, p) in past.iter().enumerate() {
            assert_eq!(*p, [i as f32, 0.0]);
        }
    }

    #[test]
    fn ring_keeps_last_history_in_order() {
        let mut t: TrackTable<2> = TrackTable::new(0);
        for f in 0..20u32 {
            t.update(f, &[ob(1, f as f32, -(f as f32))]);
        }
        let past = t.get(1).unwrap().past();
        let want: StdVec<Pos> = (12..20).map(|f| [f as f32, -(f as f32)]).collect();
        assert_eq!(past.to_vec(), want);
        assert_eq!(t.get(1).unwrap().latest(), [19.0, -19.0]);
    }

    #[test]
    fn past_pads_with_oldest_before_ready() {
        let mut t: TrackTable<2> = TrackTable::new(0);
        t.update(0, &[ob(1, 5.0, 5.0)]);
        t.update(1, &[ob(1, 6.0, 5.0)]);
        let tr = t.get(1).unwrap();
        assert!(!tr.ready());
        assert_eq!(tr.len(), 2);
        let past = tr.past();
        assert_eq!(&past[..6], &[[5.0, 5.0]; 6]);
        assert_eq!(past[6], [5.0, 5.0]);
        assert_eq!(past[7], [6.0, 5.0]);
    }

    #[test]
    fn dropped_after_max_missed_frames() {
        let mut t: TrackTable<4> = TrackTable::new(2);
        t.update(0, &[ob(1, 0.0, 0.0), ob(2, 0.0, 0.0)]);
        // id 2 missing from frame 1 on: survives 2 missed frames, gone at the 3rd
        for f in 1..=2 {
            let d = t.update(f, &[ob(1, f as f32, 0.0)]);
            assert!(d.left.is_empty(), "frame {f}");
        }
        let d = t.update(3, &[ob(1, 3.0, 0.0)]);
        assert_eq!(d.left.as_slice(), &[2]);
        assert!(t.get(2).is_none());
        assert_eq!(t.len(), 1);
        // empty frames drop the rest too
        for f in 4..=5 {
            assert!(t.update(f, &[]).left.is_empty());
        }
        assert_eq!(t.update(6, &[]).left.as_slice(), &[1]);
        assert!(t.is_empty());
    }

    #[test]
    fn gap_is_interpolated_to_keep_equal_spacing() {
        let mut t: TrackTable<1> = TrackTable::new(3);
        t.update(0, &[ob(9, 0.0, 0.0)]);
        t.update(1, &[ob(9, 1.0, 10.0)]);
        t.update(2, &[]);
        t.update(3, &[]);
        t.update(4, &[ob(9, 4.0, 40.0)]); // 3-frame gap from frame 1
        let tr = t.get(9).unwrap();
        assert_eq!(tr.len(), 5);
        assert_eq!(tr.last_seen(), 4);
        let past = tr.past();
        assert_eq!(
            &past[3..],
            &[
                [0.0, 0.0],
                [1.0, 10.0],
                [2.0, 20.0],
                [3.0, 30.0],
                [4.0, 40.0]
            ]
        );
    }

    #[test]
    fn full_table_rejects_newcomers_and_readmits_after_drop() {
        let mut t: TrackTable<2> = TrackTable::new(0);
        let d = t.update(0, &[ob(1, 0.0, 0.0), ob(2, 0.0, 0.0), ob(3, 0.0, 0.0)]);
        assert_eq!(d.entered.as_slice(), &[1, 2]);
        assert_eq!(d.rejected, 1);
        assert!(d.left.is_empty());
        // frame 1: id 3 still rejected (the slot of 2 frees at the end of the frame)
        let d = t.update(1, &[ob(1, 1.0, 0.0), ob(3, 0.0, 0.0)]);
        assert_eq!(d.rejected, 1);
        assert_eq!(d.left.as_slice(), &[2]);
        let d = t.update(2, &[ob(3, 0.0, 0.0), ob(1, 2.0, 0.0)]);
        assert!(d.left.is_empty());
        assert_eq!(d.entered.as_slice(), &[3]);
        assert_eq!(d.rejected, 0);
        assert_eq!(t.get(1).unwrap().len(), 3);
        assert_eq!(t.len(), t.capacity());
    }

    #[test]
    fn reentry_of_dropped_id_starts_fresh() {
        let mut t: TrackTable<2> = TrackTable::new(1);
        for f in 0..8 {
            t.update(f, &[ob(5, f as f32, 0.0)]);
        }
        assert!(t.get(5).unwrap().ready());
        t.update(8, &[]);
        t.update(9, &[]);
        assert!(t.get(5).is_none());
        let d = t.update(10, &[ob(5, 100.0, 0.0)]);
        assert_eq!(d.entered.as_slice(), &[5]);
        assert_eq!(t.get(5).unwrap().len(), 1);
        assert_eq!(t.get(5).unwrap().past(), [[100.0, 0.0]; HISTORY]);
    }

    #[test]
    fn same_frame_reobservation_overwrites() {
        let mut t: TrackTable<1> = TrackTable::new(1);
        t.update(0, &[ob(1, 0.0, 0.0), ob(1, 3.0, 3.0)]);
        assert_eq!(t.get(1).unwrap().len(), 1);
        assert_eq!(t.get(1).unwrap().latest(), [3.0, 3.0]);
    }

    #[test]
    fn long_gap_fills_at_most_history() {
        let mut t: TrackTable<1> = TrackTable::new(100);
        t.update(0, &[ob(1, 0.0, 0.0)]);
        t.update(50, &[ob(1, 50.0, 0.0)]);
        let tr = t.get(1).unwrap();
        assert!(tr.ready());
        assert_eq!(tr.latest(), [50.0, 0.0]);
        // equally spaced, slope 1 per frame
        let p = tr.past();
        for w in p.windows(2) {
            assert!((w[1][0] - w[0][0] - 1.0).abs() < 1e-4);
        }
    }
}
