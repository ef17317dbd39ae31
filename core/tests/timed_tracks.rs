//! The timed track table against its rules (`gpecnet_core::tracks::timed`):
//! the shared grid, interpolation between detections (exact at grid times),
//! fresh histories, gaps, stale and duplicate timestamps, non-finite input,
//! a full table, the `u32` wrap and coordinates near `f32::MAX`.
use core::num::NonZeroU32;

use gpecnet_core::tracks::{
    FrameDelta, Observation, ObserveError, Sampled, TimedTrack, TimedTrackTable, HISTORY,
};

const P: NonZeroU32 = NonZeroU32::new(400).unwrap();

fn ob(id: u32, x: f32, y: f32) -> Observation {
    Observation { id, pos: [x, y] }
}

type Log = Vec<(u32, Result<Sampled, ObserveError>)>;

fn update_log<const N: usize>(
    t: &mut TimedTrackTable<N>,
    ms: u32,
    obs: &[Observation],
) -> (FrameDelta<N>, Log) {
    let mut log = Vec::new();
    let d = t.update_with(ms, obs, |o, r| log.push((o.id, r)));
    (d, log)
}

fn track<const N: usize>(t: &TimedTrackTable<N>, id: u32) -> &TimedTrack {
    t.get(id).unwrap_or_else(|| panic!("track {id} missing"))
}

/// Linear motion at irregular camera times gives the grid positions exactly
/// (up to f32 rounding), every track on the same grid, fresh once per period.
#[test]
fn linear_motion_resamples_onto_the_grid() {
    let mut t: TimedTrackTable<4> = TimedTrackTable::new(P, 1_000);
    let pos = |id: u32, ms: u32| {
        let s = ms as f32 / 1000.0;
        [10.0 * id as f32 + 1.5 * s, -0.75 * s]
    };
    let mut fresh_at = Vec::new();
    let mut ms = 0;
    while ms <= 4_100 {
        let seen = [
            ob(1, pos(1, ms)[0], pos(1, ms)[1]),
            ob(2, pos(2, ms)[0], pos(2, ms)[1]),
        ];
        let d = t.update(ms, &seen);
        assert_eq!(
            (d.rejected, d.duplicates, d.non_finite, d.stale),
            (0, 0, 0, false)
        );
        for tr in t.fresh() {
            assert_eq!(tr.end_ms() % 400, 0);
            for (k, p) in tr.past().iter().enumerate() {
                let g = tr.end_ms() - 400 * (HISTORY - 1 - k) as u32;
                let want = pos(tr.id(), g);
                assert!((p[0] - want[0]).abs() < 2e-5 && (p[1] - want[1]).abs() < 2e-5);
            }
            fresh_at.push((ms, tr.id(), tr.end_ms()));
        }
        ms += 29 + ms % 11; // 29..39 ms: jittery ~30 Hz
    }
    // Both tracks share the grid: full from 2.8 s on, once per period.
    let ends: Vec<u32> = fresh_at.iter().filter(|f| f.1 == 1).map(|f| f.2).collect();
    assert_eq!(ends, [2_800, 3_200, 3_600, 4_000]);
    let ends2: Vec<u32> = fresh_at.iter().filter(|f| f.1 == 2).map(|f| f.2).collect();
    assert_eq!(ends, ends2);
    // A grid point is computed by the first detection at or after it.
    for (ms, _, end) in fresh_at {
        assert!(ms >= end && ms - end < 40, "{ms} {end}");
    }
}

#[test]
fn grid_times_get_the_detection_itself_and_entries_start_on_the_grid() {
    let mut t: TimedTrackTable<4> = TimedTrackTable::new(P, 1_000);
    // The first timestamp is the grid origin.
    let (d, log) = update_log(&mut t, 100, &[ob(1, 1.0, 1.0)]);
    assert_eq!(d.entered.as_slice(), [1]);
    assert_eq!(log, [(1, Ok(Sampled::Entered))]);
    assert_eq!(track(&t, 1).len(), 1); // on the grid: its first point
    assert_eq!(t.origin_ms(), Some(100));
    // Off the grid: no point until the next grid time is passed.
    t.update(300, &[ob(2, 5.0, 5.0)]);
    assert_eq!(track(&t, 2).len(), 0);
    assert!(track(&t, 2).is_empty());
    // 500 is the grid time 100 + 400: both get exactly the detection's bits.
    let (_, log) = update_log(&mut t, 500, &[ob(1, 0.1, 0.2), ob(2, 0.3, 0.7)]);
    assert_eq!(log[0].1, Ok(Sampled::Continued { points: 1 }));
    assert_eq!(log[1].1, Ok(Sampled::Continued { points: 1 }));
    assert_eq!(track(&t, 1).past()[HISTORY - 1], [0.1, 0.2]);
    assert_eq!(track(&t, 2).past()[HISTORY - 1], [0.3, 0.7]);
    assert_eq!(track(&t, 2).end_ms(), 500);
    // Padding: before the history is full, older slots repeat the oldest point.
    assert_eq!(track(&t, 2).past()[0], [0.3, 0.7]);
    assert_eq!(track(&t, 1).past()[0], [1.0, 1.0]);
}

#[test]
fn interpolation_weights_are_the_documented_division() {
    let mut t: TimedTrackTable<2> = TimedTrackTable::new(P, 1_000);
    t.update(0, &[ob(1, 0.0, 0.0)]);
    t.update(130, &[ob(1, 1.3, 13.0)]);
    t.update(530, &[ob(1, 7.1, -3.3)]);
    let (p0, p1, a) = ([1.3f32, 13.0f32], [7.1f32, -3.3f32], 270.0f32 / 400.0);
    let want = [p0[0] + (p1[0] - p0[0]) * a, p0[1] + (p1[1] - p0[1]) * a];
    assert_eq!(track(&t, 1).past()[HISTORY - 1], want);
    assert_eq!(track(&t, 1).end_ms(), 400);
    assert_eq!(track(&t, 1).last_detection(), [7.1, -3.3]);
    assert_eq!(track(&t, 1).last_detection_ms(), 530);
}

#[test]
fn fresh_is_reset_when_time_advances_and_kept_within_a_frame() {
    let mut t: TimedTrackTable<4> = TimedTrackTable::new(P, 1_000);
    for k in 0..HISTORY as u32 {
        t.update(400 * k, &[ob(1, k as f32, 0.0)]);
    }
    assert_eq!(t.fresh().count(), 1);
    // Same timestamp again (the frame continued in a second call): kept.
    t.update(400 * 7, &[ob(2, 0.0, 0.0)]);
    assert_eq!(t.fresh().count(), 1);
    // Time advanced without a grid point for track 1: not fresh.
    t.update(400 * 7 + 10, &[ob(1, 7.1, 0.0)]);
    assert_eq!(t.fresh().count(), 0);
    assert!(track(&t, 1).ready());
}

#[test]
fn stale_timestamps_refuse_the_whole_call() {
    let mut t: TimedTrackTable<4> = TimedTrackTable::new(P, 1_000);
    t.update(1_000, &[ob(1, 0.0, 0.0)]);
    let before = track(&t, 1).clone();
    let (d, log) = update_log(&mut t, 999, &[ob(1, 1.0, 1.0), ob(2, 2.0, 2.0)]);
    assert!(d.stale);
    assert!(log.iter().all(|(_, r)| *r == Err(ObserveError::StaleFrame)));
    assert_eq!(t.len(), 1);
    assert_eq!(track(&t, 1), &before);
    assert_eq!(t.time_ms(), Some(1_000));
}

#[test]
fn duplicates_in_a_frame_keep_the_first_detection() {
    let mut t: TimedTrackTable<4> = TimedTrackTable::new(P, 1_000);
    t.update(0, &[ob(1, 0.0, 0.0)]);
    let (d, log) = update_log(&mut t, 400, &[ob(1, 4.0, 0.0), ob(1, 9.0, 9.0)]);
    assert_eq!(d.duplicates, 1);
    assert_eq!(log[1].1, Err(ObserveError::Duplicate));
    // A second call at the same time is the same frame.
    let (d, _) = update_log(&mut t, 400, &[ob(1, 8.0, 8.0)]);
    assert_eq!(d.duplicates, 1);
    assert_eq!(track(&t, 1).past()[HISTORY - 1], [4.0, 0.0]);
}

#[test]
fn non_finite_detections_are_refused_and_do_not_keep_a_track() {
    let mut t: TimedTrackTable<4> = TimedTrackTable::new(P, 500);
    t.update(0, &[ob(1, 0.0, 0.0)]);
    for (i, bad) in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY]
        .into_iter()
        .enumerate()
    {
        let ms = 200 * (i as u32 + 1);
        let (d, log) = update_log(&mut t, ms, &[ob(1, bad, 0.0), ob(9, 0.0, bad)]);
        assert_eq!(d.non_finite, 2);
        assert!(log.iter().all(|(_, r)| *r == Err(ObserveError::NonFinite)));
        assert!(t.get(9).is_none());
    }
    // Last real detection at 0, now 600 > 500: it left.
    assert!(t.get(1).is_none());
}

#[test]
fn gaps_up_to_max_gap_are_bridged_longer_ones_end_the_track() {
    let mut t: TimedTrackTable<4> = TimedTrackTable::new(P, 1_200);
    t.update(0, &[ob(1, 0.0, 0.0)]);
    // 1.2 s later: bridged, three grid points (400, 800, 1200).
    let (_, log) = update_log(&mut t, 1_200, &[ob(1, 1.2, 0.0)]);
    assert_eq!(log[0].1, Ok(Sampled::Continued { points: 3 }));
    let past = track(&t, 1).past();
    for (p, want) in past[HISTORY - 4..].iter().zip([0.0, 0.4, 0.8, 1.2]) {
        assert!((p[0] - want).abs() < 1e-6 && p[1] == 0.0, "{past:?}");
    }
    // 1.201 s later: it left first, and enters anew.
    let (d, log) = update_log(&mut t, 2_401, &[ob(1, 5.0, 0.0)]);
    assert_eq!(d.left.as_slice(), [1]);
    assert_eq!(d.entered.as_slice(), [1]);
    assert_eq!(log[0].1, Ok(Sampled::Entered));
    assert_eq!(track(&t, 1).len(), 0);
    // Leaving also happens in calls without the track's id.
    t.update(2_500, &[]);
    let d = t.update(3_702, &[]);
    assert_eq!(d.left.as_slice(), [1]);
    assert!(t.is_empty());
}

#[test]
fn a_long_gap_computes_only_the_last_history() {
    let mut t: TimedTrackTable<2> = TimedTrackTable::new(P, 10_000);
    t.update(0, &[ob(1, 0.0, 0.0)]);
    let (_, log) = update_log(&mut t, 8_000, &[ob(1, 80.0, 0.0)]);
    assert_eq!(log[0].1, Ok(Sampled::Continued { points: 20 }));
    let tr = track(&t, 1);
    assert!(tr.ready() && tr.fresh());
    for (k, p) in tr.past().iter().enumerate() {
        let g = 8_000 - 400 * (HISTORY - 1 - k) as u32;
        assert!((p[0] - g as f32 / 100.0).abs() < 1e-4, "{k}: {p:?}");
    }
}

#[test]
fn a_full_table_rejects_newcomers_until_a_slot_frees() {
    let mut t: TimedTrackTable<2> = TimedTrackTable::new(P, 300);
    t.update(0, &[ob(1, 0.0, 0.0), ob(2, 0.0, 0.0)]);
    let (d, log) = update_log(&mut t, 100, &[ob(3, 0.0, 0.0), ob(1, 0.1, 0.0)]);
    assert_eq!(d.rejected, 1);
    assert_eq!(log[0].1, Err(ObserveError::TableFull));
    // Track 2 (last seen at 0) leaves at 301; 3 takes its slot.
    let (d, _) = update_log(&mut t, 301, &[ob(3, 0.0, 0.0), ob(1, 0.2, 0.0)]);
    assert_eq!(d.left.as_slice(), [2]);
    assert_eq!(d.entered.as_slice(), [3]);
    assert_eq!(t.iter().map(TimedTrack::id).collect::<Vec<_>>(), [1, 3]);
}

#[test]
fn the_u32_clock_wraps() {
    let mut t: TimedTrackTable<2> = TimedTrackTable::new(P, 1_000);
    let start = u32::MAX - 1_000;
    let mut ms = start;
    for k in 0..=30u32 {
        t.update(ms, &[ob(1, k as f32, 0.0)]);
        ms = ms.wrapping_add(100);
    }
    let tr = track(&t, 1);
    assert!(tr.ready());
    assert_eq!(tr.end_ms(), start.wrapping_add(2_800));
    assert_eq!(tr.past()[HISTORY - 1], [28.0, 0.0]);
    assert_eq!(t.time_ms(), Some(start.wrapping_add(3_000)));
    // Half the u32 range back is "before": refused.
    assert!(t.update(ms.wrapping_sub(1 << 31), &[]).stale);
}

#[test]
fn huge_coordinates_stay_finite() {
    let mut t: TimedTrackTable<2> = TimedTrackTable::new(P, 1_000);
    t.update(0, &[ob(1, -f32::MAX, f32::MAX)]);
    t.update(1_000, &[ob(1, f32::MAX, -f32::MAX)]);
    for p in track(&t, 1).past() {
        assert!(p.iter().all(|v| v.is_finite()), "{p:?}");
    }
}

#[test]
fn clear_forgets_the_origin() {
    let mut t: TimedTrackTable<2> = TimedTrackTable::new(P, 1_000);
    t.update(5_000, &[ob(1, 0.0, 0.0)]);
    t.clear();
    assert_eq!((t.time_ms(), t.origin_ms(), t.len()), (None, None, 0));
    assert!(!t.update(10, &[ob(1, 0.0, 0.0)]).stale);
    assert_eq!(t.origin_ms(), Some(10));
}

#[test]
fn max_gap_is_capped_below_the_serial_range() {
    let t: TimedTrackTable<2> = TimedTrackTable::new(P, u32::MAX);
    assert_eq!(t.max_gap_ms(), (1 << 31) - 1);
    assert_eq!(t.period_ms(), 400);
    assert_eq!(t.capacity(), 2);
}
