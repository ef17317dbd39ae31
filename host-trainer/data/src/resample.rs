//! A folder's tracks resampled onto the models' 0.4 s grid by the core's own timed track
//! table ([`gpecnet_core::tracks::TimedTrackTable`]), so the windows a model is trained and
//! scored on are the histories a drone running the core would build from the same
//! detections: the same linear interpolation, the same gap rule, the same f32 bits.
//!
//! Each pedestrian of a file goes through a table of its own (capacity 1, period 400 ms, the
//! folder's `max_gap`), its detections in time order, with timestamps in whole milliseconds
//! from the pedestrian's first detection (`round((t − t_first) · ms_per_unit)` in f64). So the
//! grid of a pedestrian is its first detection plus whole periods, as the frame grid of a
//! track always was: on a clock that divides 0.4 s every grid time is one of its frames and
//! the window positions are its detections, bit for bit. Between grid-time detections the
//! table interpolates; a gap of more than `max_gap` ends the track, and the pedestrian seen
//! again starts a new run of grid points on the same grid. Every run of `n ≥ 20` consecutive
//! grid points gives `n − 19` windows (stride one grid step), in time order.
//!
//! Two detections of one pedestrian in the same millisecond are an error naming both lines;
//! so is a track longer than 2³¹ ms (24.8 days), the table's clock range.

use core::num::NonZeroU32;
use std::path::Path;

use gpecnet_core::tracks::{Observation, Sampled, TimedTrackTable, HISTORY};

use super::detections::Detection;
use super::folder_info::FolderError;
use super::*;

/// The models' period in milliseconds (400).
pub(super) const PERIOD_MS: u32 = 400;

/// How one pedestrian's detections become windows.
pub(super) struct TrackClock {
    /// Milliseconds per unit of the time column.
    pub ms_per_unit: f64,
    /// Whether the time column holds frame numbers (else timestamps).
    pub frames: bool,
    /// The table's `max_gap_ms`.
    pub max_gap_ms: u32,
}

/// Appends the windows of one pedestrian to `out`. `dets` are its detections sorted by time
/// (ties in file order).
pub(super) fn track_windows(
    path: &Path,
    scene: &str,
    ped_id: f64,
    dets: &[Detection],
    clock: &TrackClock,
    out: &mut Vec<Window>,
) -> Result<(), FolderError> {
    let Some(first) = dets.first() else {
        return Ok(());
    };
    let period = NonZeroU32::new(PERIOD_MS).unwrap_or(NonZeroU32::MIN);
    let mut table: TimedTrackTable<1> = TimedTrackTable::new(period, clock.max_gap_ms);
    // The time of a grid point in the file's frame numbers (rounded to the nearest frame)
    // or, for timestamps, in milliseconds of the file's clock.
    let frame_of = |g_ms: u32| -> i64 {
        if clock.frames {
            (first.t + f64::from(g_ms) / clock.ms_per_unit).round() as i64
        } else {
            (first.t * clock.ms_per_unit).round() as i64 + i64::from(g_ms)
        }
    };
    let mut run: Vec<(u32, [f32; 2])> = Vec::new();
    let mut last: Option<(u32, usize)> = None;
    for d in dets {
        let ms = ((d.t - first.t) * clock.ms_per_unit).round();
        if !(0.0..f64::from(1u32 << 31)).contains(&ms) {
            return Err(FolderError::TimeRange {
                path: path.to_path_buf(),
                line: d.line,
                first_line: first.line,
                ped_id,
            });
        }
        let ms = ms as u32;
        if let Some((prev, line)) = last.filter(|(prev, _)| *prev == ms) {
            return Err(if clock.frames {
                DataError::DuplicateRow {
                    path: path.to_path_buf(),
                    line: d.line,
                    ped_id,
                    frame: d.t as i64,
                }
                .into()
            } else {
                FolderError::SameTime {
                    path: path.to_path_buf(),
                    line: d.line,
                    first_line: line,
                    ped_id,
                    ms: prev,
                }
            });
        }
        last = Some((ms, d.line));
        let mut outcome = None;
        table.update_with(ms, &[Observation { id: 0, pos: d.pos }], |_, r| {
            outcome = Some(r)
        });
        let refused = |why: String| FolderError::Track {
            path: path.to_path_buf(),
            line: d.line,
            ped_id,
            why,
        };
        let track = table.get(0);
        match outcome {
            Some(Ok(Sampled::Entered)) => {
                flush(&mut run, scene, ped_id, &frame_of, out);
                if let Some(t) = track.filter(|t| t.len() == 1) {
                    run.push((t.end_ms(), t.past()[HISTORY - 1]));
                }
            }
            Some(Ok(Sampled::Continued { points })) if points > 0 => {
                let Some(t) = track else {
                    return Err(refused("the track is not in the table".into()));
                };
                // A gap of at most `max_gap` (≤ 8 periods) completes at most HISTORY grid
                // points, all of which the table computed; more would have left a hole.
                let n = points as usize;
                if n > HISTORY {
                    return Err(refused(format!(
                        "{n} grid points in one gap (max_gap allows at most {HISTORY})"
                    )));
                }
                let past = t.past();
                for (i, p) in past[HISTORY - n..].iter().enumerate() {
                    let back = (n - 1 - i) as u32 * PERIOD_MS;
                    run.push((t.end_ms().wrapping_sub(back), *p));
                }
            }
            Some(Ok(Sampled::Continued { .. })) => {}
            Some(Err(e)) => return Err(refused(format!("{e:?}"))),
            None => return Err(refused("no outcome".into())),
        }
    }
    flush(&mut run, scene, ped_id, &frame_of, out);
    Ok(())
}

/// Cuts a run of consecutive grid points into windows and empties it.
fn flush(
    run: &mut Vec<(u32, [f32; 2])>,
    scene: &str,
    ped_id: f64,
    frame_of: &impl Fn(u32) -> i64,
    out: &mut Vec<Window>,
) {
    for w in run.windows(WINDOW) {
        let mut win = Window {
            scene: scene.to_string(),
            ped_id,
            frames: [0; WINDOW],
            pos: [[0.0; 2]; WINDOW],
        };
        for (i, (g, p)) in w.iter().enumerate() {
            win.frames[i] = frame_of(*g);
            win.pos[i] = *p;
        }
        out.push(win);
    }
    run.clear();
}
