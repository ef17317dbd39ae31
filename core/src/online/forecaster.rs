//! [`Forecaster`]: one call per camera frame, detections in, a
//! [`TrackForecast`] per track with a new grid point out, the loop fed.

use core::num::NonZeroU32;

use heapless::Vec;

use super::pending::TrackLoop;
use super::DEFAULT_MULTIPLIERS;
use super::{calibrate, model_outputs, Calibration, Config, OnlineError, TrackForecast};
use crate::output::PredictError;
use crate::sine::Sine;
use crate::tracks::{period_ms_of, FrameDelta, Observation, TimedTrackTable, HISTORY};
use crate::{Model, Predictor};

/// What one [`Forecaster::frame`] did.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FrameReport<const N: usize> {
    /// The track table's report of the frame (entered, left, refused).
    pub delta: FrameDelta<N>,
    /// Forecasts handed to the caller.
    pub forecasts: u32,
    /// Tracks whose forecast was refused (their input out of range, say).
    pub failed: u32,
    /// The first refusal's reason, when one was.
    pub error: Option<PredictError>,
    /// Feedback updates applied to the calibration.
    pub feedback: u32,
}

/// The track table, each track's pending forecasts and the calibration: a
/// drone's whole forecasting state, `N` tracks with `P` forecasts each
/// awaiting their truth (memory: the parent module). Can live in a `static`
/// once built.
#[derive(Clone, Debug)]
pub struct Forecaster<const N: usize, const P: usize> {
    table: TimedTrackTable<N>,
    loops: Vec<TrackLoop<P>, N>,
    calibration: Calibration,
    period_s: f32,
}

impl<const N: usize, const P: usize> Forecaster<N, P> {
    /// A forecaster for `model` (its period: 400 ms for the shipped models;
    /// its radius multipliers as the starting point, or
    /// [`DEFAULT_MULTIPLIERS`] for a model without learned radii), bridging
    /// gaps of at most `max_gap_ms` between a track's detections.
    /// [`OnlineError::ModelShape`] for a model that does not forecast 12
    /// steps from 8 on a whole-millisecond period; [`OnlineError::BadConfig`]
    /// for a config [`Config::validate`] refuses.
    pub fn new(model: &Model<'_>, config: Config, max_gap_ms: u32) -> Result<Self, OnlineError> {
        let shape = model.config();
        let period = period_ms_of(model).ok_or(OnlineError::ModelShape)?;
        if usize::from(shape.past_len) != HISTORY
            || usize::from(shape.future_len) != super::HORIZONS
        {
            return Err(OnlineError::ModelShape);
        }
        let initial = if model.has_probabilities() {
            model.radius_scales()
        } else {
            DEFAULT_MULTIPLIERS
        };
        Ok(Self::with_period(
            period,
            Calibration::new(config, initial)?,
            max_gap_ms,
        ))
    }

    /// A forecaster on a grid of `period_ms` with `calibration` (for models
    /// whose shape [`Forecaster::new`] has already checked, or a calibration
    /// restored from a previous flight).
    pub fn with_period(period_ms: NonZeroU32, calibration: Calibration, max_gap_ms: u32) -> Self {
        Forecaster {
            table: TimedTrackTable::new(period_ms, max_gap_ms),
            loops: Vec::new(),
            calibration,
            period_s: period_ms.get() as f32 / 1000.0,
        }
    }

    /// The track table.
    pub fn table(&self) -> &TimedTrackTable<N> {
        &self.table
    }

    /// What the loop has learned.
    pub fn calibration(&self) -> &Calibration {
        &self.calibration
    }

    /// What the loop has learned, to reset or restore.
    pub fn calibration_mut(&mut self) -> &mut Calibration {
        &mut self.calibration
    }

    /// Forgets every track and pending forecast (a new sequence, a clock
    /// that restarted); the calibration stays.
    pub fn clear(&mut self) {
        self.table.clear();
        self.loops.clear();
    }

    /// Applies one camera frame: the detections go into the track table
    /// (its rules: `crate::tracks::timed`), each track's new grid points are
    /// fed back to its pending forecasts, and every track that gained a grid
    /// point with a full history is forecast ([`super::forecast`], seed `id << 32 |
    /// end_ms`) and handed to `each`, up to `K` endpoints each. A refused
    /// forecast (out-of-range input) is counted in the report and the other
    /// tracks go on.
    pub fn frame<S: Sine, const W: usize, const K: usize>(
        &mut self,
        p: &mut Predictor<'_, S, W>,
        t_ms: u32,
        observations: &[Observation],
        each: impl FnMut(&TrackForecast<K>),
    ) -> FrameReport<N> {
        self.frame_with(
            t_ms,
            observations,
            |past, seed, out| model_outputs(p, past, seed, out),
            each,
        )
    }

    /// [`Forecaster::frame`] with the model's part of each forecast from
    /// `model` (called with the track's past, its seed and the forecast to
    /// fill, as [`model_outputs`]), the loop's part
    /// ([`calibrate`]) from this forecaster: for a host that runs several
    /// forecasters over the same detections (the loop off and on) and
    /// computes the model once, or replays recorded model outputs.
    pub fn frame_with<const K: usize>(
        &mut self,
        t_ms: u32,
        observations: &[Observation],
        mut model: impl FnMut(
            &[[f32; 2]; HISTORY],
            u64,
            &mut TrackForecast<K>,
        ) -> Result<(), PredictError>,
        mut each: impl FnMut(&TrackForecast<K>),
    ) -> FrameReport<N> {
        let delta = self.table.update(t_ms, observations);
        let Self {
            table,
            loops,
            calibration,
            period_s,
        } = self;
        // A track that left forgets its pending forecasts (the id may come
        // back as a new pedestrian).
        loops.retain(|l| !delta.left.contains(&l.id) && table.get(l.id).is_some());
        let mut report = FrameReport {
            delta,
            ..FrameReport::default()
        };
        if report.delta.stale {
            return report;
        }
        let period = table.period_ms();
        let mut fc = TrackForecast::<K>::new();
        for track in table.iter() {
            if track.is_empty() {
                continue;
            }
            let (id, end) = (track.id(), track.end_ms());
            let l = match loops.iter().position(|l| l.id == id) {
                Some(i) => loops.get_mut(i),
                None => {
                    // At most N tracks and N loops: the push cannot fail.
                    let _ = loops.push(TrackLoop::new(id, track.len(), end));
                    loops.last_mut()
                }
            };
            let Some(l) = l else { continue };
            let gained = l.advance(end, period);
            let past = track.past();
            for j in 1..=gained {
                // The j-th new point, when it is still in the history.
                let back = (gained - j) as usize;
                let y = HISTORY
                    .checked_sub(1 + back)
                    .and_then(|i| past.get(i).copied());
                report.feedback += l.feed(y, calibration);
            }
            if gained == 0 || !track.ready() {
                continue;
            }
            let seed = (u64::from(id) << 32) | u64::from(end);
            let made = model(&past, seed, &mut fc)
                .and_then(|()| calibrate(calibration, &past, *period_s, &mut fc));
            match made {
                Ok(()) => {
                    fc.id = id;
                    fc.end_ms = end;
                    l.keep(&fc);
                    report.forecasts += 1;
                    each(&fc);
                }
                Err(e) => {
                    report.failed += 1;
                    report.error.get_or_insert(e);
                }
            }
        }
        report
    }
}
