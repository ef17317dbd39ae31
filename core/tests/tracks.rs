//! The track table against its rules (`gpecnet_core::tracks` module docs):
//! enter, leave, timeouts, missed detections and interpolation, a full
//! table, duplicate ids, non-finite input, stale and wrapping frame numbers.
use gpecnet_core::tracks::{
    FrameDelta, Observation, ObserveError, Observed, Pos, Track, TrackTable, HISTORY,
};

fn ob(id: u32, x: f32, y: f32) -> Observation {
    Observation { id, pos: [x, y] }
}

fn track<const N: usize>(t: &TrackTable<N>, id: u32) -> &Track {
    t.get(id).unwrap_or_else(|| panic!("track {id} missing"))
}

/// The per-observation outcomes of one update, in order.
type Log = Vec<(u32, Result<Observed, ObserveError>)>;

/// `update_with`, collecting the per-observation outcomes.
fn update_log<const N: usize>(
    t: &mut TrackTable<N>,
    frame: u32,
    obs: &[Observation],
) -> (FrameDelta<N>, Log) {
    let mut log = Vec::new();
    let d = t.update_with(frame, obs, |o, r| log.push((o.id, r)));
    (d, log)
}

fn ids<'a>(it: impl Iterator<Item = &'a Track>) -> Vec<u32> {
    it.map(Track::id).collect()
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
        assert_eq!(track(&t, 7).ready(), f as usize == HISTORY - 1);
    }
    assert_eq!(t.ready().count(), 1);
    let past = track(&t, 7).past();
    for (i, p) in past.iter().enumerate() {
        assert_eq!(*p, [i as f32, 0.0]);
    }
}

#[test]
fn history_keeps_last_steps_in_order() {
    let mut t: TrackTable<2> = TrackTable::new(0);
    for f in 0..20u32 {
        t.update(f, &[ob(1, f as f32, -(f as f32))]);
    }
    let tr = track(&t, 1);
    let want: Vec<Pos> = (12..20).map(|f| [f as f32, -(f as f32)]).collect();
    assert_eq!(tr.past().to_vec(), want);
    assert_eq!(tr.latest(), [19.0, -19.0]);
    assert_eq!(tr.len(), HISTORY);
    assert_eq!(tr.last_seen(), 19);
}

#[test]
fn past_pads_with_oldest_before_ready() {
    let mut t: TrackTable<2> = TrackTable::new(0);
    t.update(0, &[ob(1, 5.0, 5.0)]);
    t.update(1, &[ob(1, 6.0, 5.0)]);
    let tr = track(&t, 1);
    assert!(!tr.ready());
    assert!(!tr.is_empty());
    assert_eq!(tr.len(), 2);
    let past = tr.past();
    assert_eq!(&past[..7], &[[5.0, 5.0]; 7]);
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
fn max_missed_zero_leaves_at_first_missed_frame() {
    let mut t: TrackTable<2> = TrackTable::new(0);
    assert_eq!(t.max_missed(), 0);
    t.update(0, &[ob(1, 0.0, 0.0)]);
    assert_eq!(t.update(1, &[]).left.as_slice(), &[1]);
    assert!(t.is_empty());
}

#[test]
fn gap_is_interpolated_to_keep_equal_spacing() {
    let mut t: TrackTable<1> = TrackTable::new(3);
    t.update(0, &[ob(9, 0.0, 0.0)]);
    t.update(1, &[ob(9, 1.0, 10.0)]);
    t.update(2, &[]);
    t.update(3, &[]);
    // 3-frame gap from frame 1: 2 missed frames, filled
    let (d, log) = update_log(&mut t, 4, &[ob(9, 4.0, 40.0)]);
    assert!(d.left.is_empty() && d.entered.is_empty());
    assert_eq!(log, vec![(9, Ok(Observed::Continued { missed: 2 }))]);
    let tr = track(&t, 9);
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
fn gap_of_exactly_max_missed_survives_one_more_leaves() {
    // max_missed = 2: last seen at 0, frames 1 and 2 missed, seen at 3: kept.
    let mut t: TrackTable<2> = TrackTable::new(2);
    t.update(0, &[ob(1, 0.0, 0.0), ob(2, 0.0, 0.0)]);
    t.update(1, &[]);
    t.update(2, &[]);
    let (d, log) = update_log(&mut t, 3, &[ob(1, 3.0, 0.0)]);
    assert_eq!(log, vec![(1, Ok(Observed::Continued { missed: 2 }))]);
    assert_eq!(d.left.as_slice(), &[2]); // 3 frames missed
    assert_eq!(
        track(&t, 1).past()[4..],
        [[0.0, 0.0], [1.0, 0.0], [2.0, 0.0], [3.0, 0.0]]
    );
}

#[test]
fn long_gap_fills_at_most_history() {
    let mut t: TrackTable<1> = TrackTable::new(100);
    t.update(0, &[ob(1, 0.0, 0.0)]);
    let (_, log) = update_log(&mut t, 50, &[ob(1, 50.0, 0.0)]);
    assert_eq!(log, vec![(1, Ok(Observed::Continued { missed: 49 }))]);
    let tr = track(&t, 1);
    assert!(tr.ready());
    assert_eq!(tr.latest(), [50.0, 0.0]);
    // equally spaced, slope 1 per frame
    let p = tr.past();
    for w in p.windows(2) {
        assert!((w[1][0] - w[0][0] - 1.0).abs() < 1e-4);
    }
}

#[test]
fn huge_max_missed_and_gap() {
    let mut t: TrackTable<1> = TrackTable::new(u32::MAX);
    t.update(0, &[ob(1, 0.0, 0.0)]);
    // the longest forward step there is
    let f = (1u32 << 31) - 1;
    let (d, log) = update_log(&mut t, f, &[ob(1, 1.0, -1.0)]);
    assert!(d.left.is_empty() && !d.stale);
    assert_eq!(log, vec![(1, Ok(Observed::Continued { missed: f - 1 }))]);
    let tr = track(&t, 1);
    assert!(tr.ready());
    assert_eq!(tr.latest(), [1.0, -1.0]);
    assert!(tr.past().iter().flatten().all(|v| v.is_finite()));
    // and again: the track's last position is now 2^31 - 1 frames back
    t.update(f.wrapping_add(f), &[]);
    assert_eq!(t.len(), 1);
}

#[test]
fn interpolation_between_extreme_coordinates_stays_finite() {
    let mut t: TrackTable<1> = TrackTable::new(8);
    t.update(0, &[ob(1, -3.0e38, f32::MAX)]);
    t.update(2, &[ob(1, 3.0e38, -f32::MAX)]);
    let past = track(&t, 1).past();
    assert!(past.iter().flatten().all(|v| v.is_finite()), "{past:?}");
    assert_eq!(past[6], [0.0, 0.0]);
    assert_eq!(past[7], [3.0e38, -f32::MAX]);
}

#[test]
fn full_table_rejects_newcomers_and_readmits_after_drop() {
    let mut t: TrackTable<2> = TrackTable::new(0);
    let (d, log) = update_log(
        &mut t,
        0,
        &[ob(1, 0.0, 0.0), ob(2, 0.0, 0.0), ob(3, 0.0, 0.0)],
    );
    assert_eq!(d.entered.as_slice(), &[1, 2]);
    assert_eq!(d.rejected, 1);
    assert!(d.left.is_empty());
    assert_eq!(log[2], (3, Err(ObserveError::TableFull)));
    // frame 1: id 3 still rejected (the slot of 2 frees at the end of the frame)
    let d = t.update(1, &[ob(1, 1.0, 0.0), ob(3, 0.0, 0.0)]);
    assert_eq!(d.rejected, 1);
    assert_eq!(d.left.as_slice(), &[2]);
    let d = t.update(2, &[ob(3, 0.0, 0.0), ob(1, 2.0, 0.0)]);
    assert!(d.left.is_empty());
    assert_eq!(d.entered.as_slice(), &[3]);
    assert_eq!(d.rejected, 0);
    assert_eq!(track(&t, 1).len(), 3);
    assert_eq!(t.len(), t.capacity());
}

#[test]
fn zero_capacity_table_rejects_everything() {
    let mut t: TrackTable<0> = TrackTable::new(5);
    let d = t.update(0, &[ob(1, 0.0, 0.0), ob(2, 0.0, 0.0)]);
    assert_eq!(d.rejected, 2);
    assert!(t.is_empty());
}

#[test]
fn reentry_of_dropped_id_starts_fresh() {
    let mut t: TrackTable<2> = TrackTable::new(1);
    for f in 0..8 {
        t.update(f, &[ob(5, f as f32, 0.0)]);
    }
    assert!(track(&t, 5).ready());
    t.update(8, &[]);
    assert_eq!(t.update(9, &[]).left.as_slice(), &[5]);
    assert!(t.get(5).is_none());
    let d = t.update(10, &[ob(5, 100.0, 0.0)]);
    assert_eq!(d.entered.as_slice(), &[5]);
    assert_eq!(track(&t, 5).len(), 1);
    assert_eq!(track(&t, 5).past(), [[100.0, 0.0]; HISTORY]);
}

#[test]
fn skipped_frames_beyond_max_missed_leave_then_reenter() {
    // Frames 1..9 never passed to update: the track had left at frame 3.
    let mut t: TrackTable<2> = TrackTable::new(2);
    t.update(0, &[ob(1, 0.0, 0.0), ob(2, 0.0, 0.0)]);
    let (d, log) = update_log(&mut t, 10, &[ob(1, 10.0, 0.0)]);
    assert_eq!(d.left.as_slice(), &[1, 2]);
    assert_eq!(d.entered.as_slice(), &[1]);
    assert_eq!(log, vec![(1, Ok(Observed::Entered))]);
    assert_eq!(track(&t, 1).len(), 1);
    assert_eq!(track(&t, 1).past(), [[10.0, 0.0]; HISTORY]);
}

#[test]
fn slots_freed_during_skipped_frames_serve_this_frame() {
    let mut t: TrackTable<1> = TrackTable::new(0);
    t.update(0, &[ob(1, 0.0, 0.0)]);
    // Frame 1 skipped: id 1 left at the end of it, so id 2 fits at frame 2.
    let d = t.update(2, &[ob(2, 0.0, 0.0)]);
    assert_eq!(d.left.as_slice(), &[1]);
    assert_eq!(d.entered.as_slice(), &[2]);
    assert_eq!(d.rejected, 0);
}

#[test]
fn skipped_frames_within_max_missed_are_interpolated() {
    let mut t: TrackTable<1> = TrackTable::new(3);
    t.update(0, &[ob(1, 0.0, 0.0)]);
    let (d, log) = update_log(&mut t, 4, &[ob(1, 8.0, 4.0)]);
    assert!(d.left.is_empty());
    assert_eq!(log, vec![(1, Ok(Observed::Continued { missed: 3 }))]);
    assert_eq!(
        track(&t, 1).past()[3..],
        [[0.0, 0.0], [2.0, 1.0], [4.0, 2.0], [6.0, 3.0], [8.0, 4.0]]
    );
}

#[test]
fn duplicate_id_in_one_frame_first_position_stands() {
    let mut t: TrackTable<2> = TrackTable::new(1);
    // a new id twice: enters once
    let (d, log) = update_log(&mut t, 0, &[ob(1, 0.0, 0.0), ob(1, 3.0, 3.0)]);
    assert_eq!(d.entered.as_slice(), &[1]);
    assert_eq!(d.duplicates, 1);
    assert_eq!(
        log,
        vec![
            (1, Ok(Observed::Entered)),
            (1, Err(ObserveError::Duplicate))
        ]
    );
    assert_eq!(track(&t, 1).len(), 1);
    assert_eq!(track(&t, 1).latest(), [0.0, 0.0]);
    // a known id twice after a gap: the interpolation uses the first position
    t.update(1, &[]);
    let d = t.update(2, &[ob(1, 2.0, 2.0), ob(1, 9.0, 9.0), ob(2, 5.0, 5.0)]);
    assert_eq!(d.duplicates, 1);
    assert_eq!(d.entered.as_slice(), &[2]);
    assert_eq!(
        track(&t, 1).past()[5..],
        [[0.0, 0.0], [1.0, 1.0], [2.0, 2.0]]
    );
    // a frame given in two calls: the second position of id 1 is a duplicate,
    // a new id in the second call enters
    let d = t.update(2, &[ob(1, 7.0, 7.0)]);
    assert_eq!(d.duplicates, 1);
    assert!(d.entered.is_empty() && d.left.is_empty());
    assert_eq!(track(&t, 1).latest(), [2.0, 2.0]);
    assert_eq!(t.frame(), Some(2));
}

#[test]
fn duplicates_do_not_take_slots() {
    let mut t: TrackTable<2> = TrackTable::new(1);
    let d = t.update(0, &[ob(1, 0.0, 0.0), ob(1, 0.0, 0.0), ob(2, 0.0, 0.0)]);
    assert_eq!(d.entered.as_slice(), &[1, 2]);
    assert_eq!((d.duplicates, d.rejected), (1, 0));
}

#[test]
fn non_finite_positions_are_refused_and_not_stored() {
    let bad = [
        [f32::NAN, 0.0],
        [0.0, f32::NAN],
        [f32::INFINITY, 0.0],
        [0.0, f32::NEG_INFINITY],
    ];
    for pos in bad {
        let mut t: TrackTable<2> = TrackTable::new(1);
        // a new id with a bad position does not enter
        let (d, log) = update_log(&mut t, 0, &[Observation { id: 1, pos }]);
        assert_eq!(log, vec![(1, Err(ObserveError::NonFinite))]);
        assert_eq!(d.non_finite, 1);
        assert!(d.entered.is_empty() && t.is_empty());
        // a known id with a bad position: a missed frame (not stored, no keep-alive)
        t.update(1, &[ob(2, 0.0, 0.0)]);
        let d = t.update(2, &[Observation { id: 2, pos }]);
        assert_eq!(d.non_finite, 1);
        assert_eq!(track(&t, 2).len(), 1);
        assert_eq!(track(&t, 2).last_seen(), 1);
        let d = t.update(3, &[Observation { id: 2, pos }]);
        assert_eq!(d.left.as_slice(), &[2]);
    }
}

#[test]
fn non_finite_then_finite_in_one_frame_takes_the_finite() {
    let mut t: TrackTable<1> = TrackTable::new(1);
    t.update(0, &[ob(1, 0.0, 0.0)]);
    let d = t.update(1, &[ob(1, f32::NAN, 1.0), ob(1, 1.0, 1.0)]);
    assert_eq!((d.non_finite, d.duplicates), (1, 0));
    assert_eq!(track(&t, 1).latest(), [1.0, 1.0]);
    assert!(track(&t, 1).past().iter().flatten().all(|v| v.is_finite()));
}

#[test]
fn stale_frame_is_refused_and_changes_nothing() {
    let mut t: TrackTable<2> = TrackTable::new(1);
    t.update(10, &[ob(1, 0.0, 0.0)]);
    t.update(11, &[ob(1, 1.0, 0.0)]);
    let before = track(&t, 1).clone();
    let (d, log) = update_log(&mut t, 9, &[ob(1, 5.0, 5.0), ob(2, 0.0, 0.0)]);
    assert!(d.stale);
    assert!(d.entered.is_empty() && d.left.is_empty());
    assert_eq!((d.rejected, d.duplicates, d.non_finite), (0, 0, 0));
    assert_eq!(
        log,
        vec![
            (1, Err(ObserveError::StaleFrame)),
            (2, Err(ObserveError::StaleFrame))
        ]
    );
    assert_eq!(t.frame(), Some(11));
    assert_eq!(t.len(), 1);
    assert_eq!(*track(&t, 1), before);
    // a step of 2^31 or more reads as backwards too
    assert!(t.update(11u32.wrapping_add(1 << 31), &[]).stale);
    // an empty stale frame is refused as well (no expiry)
    assert!(t.update(0, &[]).stale);
    assert_eq!(t.len(), 1);
    // clear() restarts the numbering
    t.clear();
    assert_eq!(t.frame(), None);
    assert!(t.is_empty());
    let d = t.update(0, &[ob(1, 5.0, 5.0)]);
    assert!(!d.stale);
    assert_eq!(d.entered.as_slice(), &[1]);
}

#[test]
fn frame_counter_wraps() {
    let mut t: TrackTable<2> = TrackTable::new(2);
    let start = u32::MAX - 3;
    for i in 0..8u32 {
        let f = start.wrapping_add(i);
        let d = t.update(f, &[ob(1, i as f32, 0.0)]);
        assert!(!d.stale && d.left.is_empty(), "frame {f}");
    }
    assert_eq!(t.frame(), Some(3));
    let tr = track(&t, 1);
    assert!(tr.ready());
    assert_eq!(tr.last_seen(), 3);
    assert_eq!(
        tr.past().map(|p| p[0]),
        [0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0]
    );
    // a gap across the wrap is interpolated, a timeout across it expires
    let mut t: TrackTable<2> = TrackTable::new(2);
    t.update(u32::MAX - 1, &[ob(1, 0.0, 0.0), ob(2, 0.0, 0.0)]);
    let (d, log) = update_log(&mut t, 1, &[ob(1, 3.0, 0.0)]);
    assert_eq!(log, vec![(1, Ok(Observed::Continued { missed: 2 }))]);
    assert_eq!(d.left.as_slice(), &[2]);
    assert_eq!(
        track(&t, 1).past()[4..]
            .iter()
            .map(|p| p[0])
            .collect::<Vec<_>>(),
        [0.0, 1.0, 2.0, 3.0]
    );
}

#[test]
fn iteration_and_ready_keep_entry_order() {
    let mut t: TrackTable<4> = TrackTable::new(0);
    t.update(
        0,
        &[
            ob(4, 0.0, 0.0),
            ob(2, 0.0, 0.0),
            ob(9, 0.0, 0.0),
            ob(1, 0.0, 0.0),
        ],
    );
    // 2 leaves; 7 takes a slot next frame
    t.update(1, &[ob(4, 0.0, 0.0), ob(9, 0.0, 0.0), ob(1, 0.0, 0.0)]);
    assert_eq!(ids(t.iter()), [4, 9, 1]);
    t.update(
        2,
        &[
            ob(7, 0.0, 0.0),
            ob(1, 0.0, 0.0),
            ob(9, 0.0, 0.0),
            ob(4, 0.0, 0.0),
        ],
    );
    assert_eq!(ids(t.iter()), [4, 9, 1, 7]);
    for f in 3..9 {
        t.update(
            f,
            &[
                ob(1, 0.0, 0.0),
                ob(9, 0.0, 0.0),
                ob(4, 0.0, 0.0),
                ob(7, 0.0, 0.0),
            ],
        );
    }
    // 4, 9, 1 have 9 steps, 7 has 7
    assert_eq!(ids(t.ready()), [4, 9, 1]);
    let d = t.update(9, &[ob(7, 0.0, 0.0)]);
    assert_eq!(d.left.as_slice(), &[4, 9, 1]);
    assert_eq!(ids(t.iter()), [7]);
}

#[test]
fn table_is_const_constructible_and_reports_capacity() {
    static EMPTY: TrackTable<16> = TrackTable::new(3);
    assert_eq!(EMPTY.capacity(), 16);
    assert_eq!(EMPTY.max_missed(), 3);
    assert_eq!(EMPTY.frame(), None);
    assert!(EMPTY.is_empty());
    assert_eq!(EMPTY.len(), 0);
}

#[test]
fn errors_display() {
    for e in [
        ObserveError::StaleFrame,
        ObserveError::NonFinite,
        ObserveError::Duplicate,
        ObserveError::TableFull,
    ] {
        assert!(!e.to_string().is_empty());
        let _: &dyn core::error::Error = &e;
    }
}
