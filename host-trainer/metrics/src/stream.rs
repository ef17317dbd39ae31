//! Streaming evaluation: a recording played frame by frame through the timed track table, the
//! predictor and the online loop (`gpecnet_core::online::Forecaster`), exactly as a drone runs
//! them, each forecast scored against the track's grid positions 0.4 s … 4.8 s later.
//!
//! Per recording and per mode (loop off: the blob's static multipliers and the point head; loop
//! on: the loop adapting), [`StreamReport`] gives: r50/r90 coverage at the endpoint and per
//! horizon, by motion state and for *starters* (standing when forecast, more than 1 m from
//! the anchor at the endpoint), the mean radius against an oracle multiplier fitted on the
//! recording itself (a calibrated but uselessly wide radius is no win), the endpoint error of
//! the point head, of each constant-velocity expert and of the issued point, and the burn-in
//! (coverage over the first N forecasts).
//!
//! A forecast is scored when the track's grid positions at all 12 horizons are known (the
//! track table's resampled positions: the truth the drone itself sees); forecasts of tracks
//! that leave earlier are counted as unscored. Every distance is in metres when the
//! recording's scale is known (`Recording::metres_per_unit`), else in its unit.
//!
//! **Noise and filtering** ([`StreamSettings::noise_m`], [`StreamSettings::filter`]): every
//! detection the forecaster gets may carry i.i.d. Gaussian noise (a seeded PRNG, the same
//! draws with the loop off and on) and may go through the core's per-track Kalman filter
//! (`gpecnet_core::tracks::filter`) first. The truth stays the clean recording's: a second
//! timed track table is fed the clean detections alongside, and forecasts are scored against
//! its grid positions. Without noise and filter that table holds exactly the forecaster's
//! positions, so the report is the same as scoring against the forecaster's own table.

use std::collections::{BTreeMap, HashMap};

use anyhow::{anyhow, bail, Result};
use gpecnet_core::online::{
    model_outputs, Config, Forecaster, MotionState, TrackForecast, EXPERTS, HORIZONS,
};
use gpecnet_core::planner::Radii;
use gpecnet_core::prng::Gaussian;
use gpecnet_core::tracks::filter::{FilterConfig, TrackFilter};
use gpecnet_core::tracks::{Observation, TimedTrackTable, HISTORY};
use gpecnet_core::units::CallerUnit;
use gpecnet_core::{LibmSine, Model, Predictor};
use serde::Serialize;

use crate::data::Recording;
use crate::flight::{Flight, FlightSettings, FlightStats};

/// Endpoints per forecast (the shipped models' K).
pub const K: usize = 20;
/// Tracks the host's table holds at once.
pub const TRACKS: usize = 256;
/// Scratch width of the host's predictor.
const WIDTH: usize = 1024;
/// The burn-in points reported: coverage over the first N scored forecasts.
pub const BURN_IN: [usize; 5] = [25, 50, 100, 200, 500];
/// Forecasts per point of the rolling coverage in [`StreamReport::rolling_r90`].
pub const ROLLING: usize = 100;

/// How the loop runs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StreamSettings {
    /// The loop's config in metres (scaled to each recording's unit).
    pub config: Config,
    /// Longest gap bridged between a track's detections.
    pub max_gap_ms: u32,
    /// Forecasts per track awaiting their truth: 2 (the device default) or 12 (every forecast
    /// scored by the loop).
    pub pending: usize,
    /// Standard deviation of the i.i.d. Gaussian noise added to each coordinate of every
    /// detection, in metres (0: none). Scoring stays against the clean positions.
    pub noise_m: f32,
    /// Seed of the noise (the same draws with the loop off and on).
    pub noise_seed: u64,
    /// The core's per-track Kalman filter in front of the forecaster, its config in metres
    /// (scaled to each recording's unit); `None`: detections go in as they are.
    pub filter: Option<FilterConfig>,
    /// A simulated drone's camera between the recording and the forecaster
    /// ([`crate::flight`]): each detection is projected into its image, detected with pixel
    /// noise and misses, and mapped back to the ground through a pose with attitude error;
    /// the filter then takes each detection's σ from the measurement model. Metre recordings
    /// only. `None`: the recording's positions (with [`StreamSettings::noise_m`]) go in.
    pub flight: Option<FlightSettings>,
}

impl Default for StreamSettings {
    fn default() -> Self {
        StreamSettings {
            config: Config::metres(),
            max_gap_ms: 1_000,
            pending: 2,
            noise_m: 0.0,
            noise_seed: 0,
            filter: None,
            flight: None,
        }
    }
}

/// Coverage of a set of scored forecasts.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct Coverage {
    /// Forecasts.
    pub n: usize,
    /// Fraction of them whose truth was within r50.
    pub r50: f64,
    /// Fraction within r90.
    pub r90: f64,
}

/// Endpoint errors (4.8 s ahead) averaged over the scored forecasts.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct Fde {
    /// The model's point head (`None` without one).
    pub head: Option<f64>,
    /// Constant velocity over the last 1, 2 and 4 steps.
    pub cv: [f64; 3],
    /// The point the loop issued (the head's with the loop off).
    pub point: f64,
    /// The issued point's average displacement error over the 12 steps.
    pub point_ade: f64,
    /// Best-of-K endpoint error: the model's endpoint nearest the truth (K = 20 for the
    /// shipped models).
    pub min_k: f64,
}

impl Fde {
    /// The best of the head and the three constant-velocity experts.
    pub fn best_expert(&self) -> f64 {
        self.cv
            .iter()
            .copied()
            .chain(self.head)
            .fold(f64::INFINITY, f64::min)
    }
}

/// One recording streamed in one mode (module docs).
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct StreamReport {
    /// The recording's scene.
    pub scene: String,
    /// Whether the loop adapted.
    pub adapt: bool,
    /// The unit of every distance (`m`, or the recording's unit where its scale is unknown).
    pub unit: String,
    /// Forecasts issued.
    pub forecasts: usize,
    /// Forecasts scored (all 12 horizons seen).
    pub scored: usize,
    /// Tracks whose forecast the predictor refused.
    pub failed: usize,
    /// Coverage at the endpoint (4.8 s).
    pub endpoint: Coverage,
    /// Coverage at each horizon, 0.4 s first.
    pub per_horizon: Vec<Coverage>,
    /// Endpoint coverage per motion state when forecast (standing, slow, walking, fast).
    pub by_motion: BTreeMap<String, Coverage>,
    /// Endpoint coverage of starters (standing when forecast, > 1 m away at the endpoint).
    pub starters: Coverage,
    /// Mean r50 at the endpoint.
    pub mean_r50: f64,
    /// Mean r90 at the endpoint.
    pub mean_r90: f64,
    /// Mean r90 of an oracle: one multiplier fitted on this recording's scored forecasts so
    /// that 90 % are covered, times each forecast's scale.
    pub oracle_r90: f64,
    /// Endpoint errors.
    pub fde: Fde,
    /// `(N, r90 coverage of the first N scored forecasts)` for N in [`BURN_IN`] (where N
    /// forecasts were scored).
    pub burn_in: Vec<(usize, f64)>,
    /// r90 endpoint coverage of consecutive blocks of [`ROLLING`] scored forecasts, in issue
    /// order (the picture of coverage over time).
    pub rolling_r90: Vec<f64>,
    /// The endpoint's multipliers `[c50, c90]` per motion state at the end.
    pub final_multipliers: BTreeMap<String, [f32; 2]>,
    /// What the simulated drone's camera and detector did ([`StreamSettings::flight`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub flight: Option<FlightStats>,
}

/// A forecast waiting for its truth.
struct Issued {
    order: usize,
    end_ms: u32,
    motion: MotionState,
    point: [[f32; 2]; HORIZONS],
    radii: [Radii; HORIZONS],
    experts: [Option<[f32; 2]>; EXPERTS],
    anchor: [f32; 2],
    scale: f32,
    endpoints: Vec<[f32; 2]>,
}

/// One scored forecast.
struct Scored {
    order: usize,
    motion: MotionState,
    starter: bool,
    /// Per horizon: the distance to the issued point and its radii.
    d: [f64; HORIZONS],
    radii: [Radii; HORIZONS],
    experts: [Option<f64>; EXPERTS],
    scale: f64,
    /// The nearest endpoint's distance to the truth.
    min_k: f64,
}

/// Streams `rec` through `blob` with the loop off and on (module docs); `(off, on)`. Both
/// forecasters see the same detections, so the model runs once per forecast and the loop-on
/// forecaster takes its outputs ([`gpecnet_core::online::Forecaster::frame_with`]): the same
/// numbers as two separate streams, at half the model's cost.
pub fn stream_both(
    blob: &[u8],
    rec: &Recording,
    s: &StreamSettings,
) -> Result<(StreamReport, StreamReport)> {
    let mut off = *s;
    off.config.adapt = false;
    let mut on = *s;
    on.config.adapt = true;
    let mut both = stream_modes(blob, rec, &[off, on])?.into_iter();
    match (both.next(), both.next()) {
        (Some(off), Some(on)) => Ok((off, on)),
        _ => bail!("{}: the streaming gave no report", rec.scene),
    }
}

/// Streams `rec` through `blob` under `s` (module docs).
pub fn stream(blob: &[u8], rec: &Recording, s: &StreamSettings) -> Result<StreamReport> {
    stream_modes(blob, rec, std::slice::from_ref(s))?
        .pop()
        .ok_or_else(|| anyhow!("{}: the streaming gave no report", rec.scene))
}

/// Streams `rec` through `blob` once per entry of `modes`, side by side over the same
/// detections (one report each, in order). The modes may differ only in their loop config;
/// the detections' noise, filter, gap and pending count are the first mode's.
pub fn stream_modes(
    blob: &[u8],
    rec: &Recording,
    modes: &[StreamSettings],
) -> Result<Vec<StreamReport>> {
    let Some(first) = modes.first() else {
        return Ok(Vec::new());
    };
    let run = || match first.pending {
        2 => stream_with::<2>(blob, rec, modes),
        12 => stream_with::<12>(blob, rec, modes),
        n => bail!("--pending {n}: expected 2 (the device default) or 12"),
    };
    // The forecaster is the device's fixed-capacity state sized for a crowd (TRACKS tracks, up
    // to 12 pending forecasts each: about 0.8 MB), built by value before it is boxed: on a
    // thread of its own with room for it, whatever the caller's stack (a test thread has 2 MiB).
    std::thread::scope(|scope| {
        std::thread::Builder::new()
            .name("stream".into())
            .stack_size(STACK_BYTES)
            .spawn_scoped(scope, run)
            .map_err(|e| anyhow!("cannot start the streaming thread: {e}"))?
            .join()
            .map_err(|_| anyhow!("the streaming thread panicked"))?
    })
}

/// Stack of the thread a recording is streamed on (see [`stream`]).
const STACK_BYTES: usize = 64 << 20;

/// One mode of [`stream_modes`]: its forecaster and what it issued and scored.
struct Mode<const P: usize> {
    settings: StreamSettings,
    f: Box<Forecaster<TRACKS, P>>,
    pending: HashMap<u32, Vec<Issued>>,
    scored: Vec<Scored>,
    issued_n: usize,
    failed: usize,
}

fn stream_with<const P: usize>(
    blob: &[u8],
    rec: &Recording,
    modes: &[StreamSettings],
) -> Result<Vec<StreamReport>> {
    let Some(s) = modes.first() else {
        return Ok(Vec::new());
    };
    let model = Model::from_blob(blob).map_err(|e| anyhow!("{e}"))?;
    // The loop's distances are the caller's: the recording's unit.
    let per_metre = rec.metres_per_unit.map_or(1.0, |m| 1.0 / m);
    let mut p: Predictor<'_, LibmSine, WIDTH> =
        Predictor::with_units(model, CallerUnit::ModelUnit).map_err(|e| anyhow!("{e}"))?;
    let mut runs: Vec<Mode<P>> = Vec::with_capacity(modes.len());
    for m in modes {
        runs.push(Mode {
            settings: *m,
            f: Box::new(
                Forecaster::new(&model, m.config.scaled(per_metre), s.max_gap_ms)
                    .map_err(|e| anyhow!("{}: {e}", model.name()))?,
            ),
            pending: HashMap::new(),
            scored: Vec::new(),
            issued_n: 0,
            failed: 0,
        });
    }
    let period = runs[0].f.table().period_ms();
    let metres = rec.metres_per_unit.unwrap_or(1.0) as f64;
    // The clean recording's grid positions: the truth forecasts are scored against.
    let mut clean: Box<TimedTrackTable<TRACKS>> = Box::new(TimedTrackTable::new(
        core::num::NonZeroU32::new(period).ok_or_else(|| anyhow!("zero period"))?,
        s.max_gap_ms,
    ));
    let mut filter: Option<Box<TrackFilter<TRACKS>>> = match s.filter {
        Some(c) => Some(Box::new(
            TrackFilter::new(c.scaled(per_metre)).map_err(|e| anyhow!("{e}"))?,
        )),
        None => None,
    };
    let noise = s.noise_m * per_metre;
    if !(noise.is_finite() && noise >= 0.0) {
        bail!("noise of {} m: expected a finite value >= 0", s.noise_m);
    }
    let mut normal = Gaussian::new(s.noise_seed);
    let mut flight = match s.flight {
        Some(fs) => {
            if rec.metres_per_unit != Some(1.0) {
                bail!(
                    "{}: a synthetic flight needs a recording in metres (--dataset sdd-m, \
                     eth_ucy:<scene> or a metre folder)",
                    rec.scene
                );
            }
            if noise > 0.0 {
                bail!("a synthetic flight makes its own detection noise: drop --noise-m");
            }
            Some(Flight::over(fs, rec).map_err(|e| anyhow!("{e}"))?)
        }
        None => None,
    };
    let mut seen: Vec<(u32, [f32; 2], f32)> = Vec::new();
    let mut sigmas: Vec<f32> = Vec::new();
    let mut clean_obs: Vec<Observation> = Vec::new();
    let mut truth: HashMap<u32, BTreeMap<u32, [f32; 2]>> = HashMap::new();
    let mut obs: Vec<Observation> = Vec::new();
    // This frame's model outputs by seed (one forecast per track and frame), with the past they
    // were computed on: the first mode computes them, the others copy.
    let mut made: HashMap<u64, ([[f32; 2]; HISTORY], Box<TrackForecast<K>>)> = HashMap::new();
    for frame in &rec.frames {
        obs.clear();
        obs.extend(
            frame
                .detections
                .iter()
                .map(|&(id, pos)| Observation { id, pos }),
        );
        clean_obs.clone_from(&obs);
        clean.update(frame.t_ms, &clean_obs);
        if noise > 0.0 {
            for o in obs.iter_mut() {
                o.pos[0] += noise * normal.next();
                o.pos[1] += noise * normal.next();
            }
        }
        sigmas.clear();
        if let Some(fl) = flight.as_mut() {
            seen.clear();
            fl.detect(frame.t_ms, &frame.detections, &mut seen)
                .map_err(|e| {
                    anyhow!(
                        "{}: the simulated drone at {} ms: {e}",
                        rec.scene,
                        frame.t_ms
                    )
                })?;
            obs.clear();
            obs.extend(seen.iter().map(|&(id, pos, _)| Observation { id, pos }));
            sigmas.extend(seen.iter().map(|d| d.2));
        }
        if let Some(fl) = filter.as_mut() {
            // With a flight, each detection's σ is the measurement model's.
            fl.update_with(frame.t_ms, &mut obs, |i, _| {
                sigmas.get(i).copied().unwrap_or(f32::NAN)
            });
        }
        made.clear();
        let mut left: Vec<u32> = Vec::new();
        for (mi, m) in runs.iter_mut().enumerate() {
            let mut new: Vec<(u32, Issued)> = Vec::new();
            let issued_n = m.issued_n;
            let report = m.f.frame_with::<K>(
                frame.t_ms,
                &obs,
                |past, seed, out| match made.get(&seed).filter(|(at, _)| at == past) {
                    Some((_, done)) if mi > 0 => {
                        out.copy_model_outputs(done);
                        Ok(())
                    }
                    _ => {
                        model_outputs(&mut p, past, seed, out)?;
                        made.insert(seed, (*past, Box::new(out.clone())));
                        Ok(())
                    }
                },
                |fc| new.push((fc.id, issued(fc, issued_n + new.len()))),
            );
            if report.delta.stale {
                bail!(
                    "{}: frame at {} ms is before the last one",
                    rec.scene,
                    frame.t_ms
                );
            }
            m.failed += report.failed as usize;
            for id in &report.delta.left {
                m.pending.remove(id);
                left.push(*id);
            }
            m.issued_n += new.len();
            for (id, i) in new {
                m.pending.entry(id).or_default().push(i);
            }
        }
        for id in &left {
            truth.remove(id);
        }
        // The clean grid positions (without noise or filter, the forecaster's table's).
        for t in clean.iter() {
            let past = t.past();
            let known = t.len().min(HISTORY);
            let m = truth.entry(t.id()).or_default();
            for k in 0..known {
                let at = t.end_ms().wrapping_sub(period * k as u32);
                m.insert(at, past[HISTORY - 1 - k]);
            }
        }
        // Score every forecast whose endpoint time has a grid position.
        for run in runs.iter_mut() {
            let scored = &mut run.scored;
            for (id, list) in run.pending.iter_mut() {
                let Some(m) = truth.get(id) else { continue };
                list.retain(|i| {
                    let end = i.end_ms.wrapping_add(period * HORIZONS as u32);
                    if !m.contains_key(&end) {
                        return true;
                    }
                    let ys: Option<Vec<[f32; 2]>> = (1..=HORIZONS as u32)
                        .map(|h| m.get(&i.end_ms.wrapping_add(period * h)).copied())
                        .collect();
                    if let Some(ys) = ys {
                        scored.push(score(i, &ys, metres));
                    }
                    false
                });
            }
        }
    }
    let mut out = Vec::with_capacity(runs.len());
    for mut run in runs {
        run.scored.sort_by_key(|s| s.order);
        let mut r = summarise(&run.scored, metres);
        r.scene = rec.scene.clone();
        r.adapt = run.settings.config.adapt;
        r.unit = if rec.metres_per_unit.is_some() {
            "m".into()
        } else {
            rec.unit.suffix().into()
        };
        r.forecasts = run.issued_n;
        r.failed = run.failed;
        r.flight = flight.as_ref().map(Flight::stats);
        let cal = run.f.calibration();
        r.final_multipliers = MotionState::ALL
            .iter()
            .map(|&m| (m.name().to_string(), cal.multipliers(m, HORIZONS)))
            .collect();
        out.push(r);
    }
    Ok(out)
}

fn issued(fc: &TrackForecast<K>, order: usize) -> Issued {
    let mut experts = [None; EXPERTS];
    for (e, x) in experts.iter_mut().enumerate() {
        *x = fc.expert(e, HORIZONS);
    }
    Issued {
        order,
        end_ms: fc.end_ms,
        motion: fc.motion,
        point: fc.point,
        radii: fc.radii,
        experts,
        anchor: fc.anchor,
        scale: fc.scale,
        endpoints: fc.endpoints.to_vec(),
    }
}

fn dist(a: [f32; 2], b: [f32; 2]) -> f64 {
    let (dx, dy) = (a[0] as f64 - b[0] as f64, a[1] as f64 - b[1] as f64);
    (dx * dx + dy * dy).sqrt()
}

fn score(i: &Issued, ys: &[[f32; 2]], metres: f64) -> Scored {
    let mut d = [0.0; HORIZONS];
    for ((d, y), p) in d.iter_mut().zip(ys).zip(&i.point) {
        *d = dist(*y, *p);
    }
    let end = ys.last().copied().unwrap_or([0.0; 2]);
    let mut experts = [None; EXPERTS];
    for (o, x) in experts.iter_mut().zip(&i.experts) {
        *o = x.map(|x| dist(end, x) * metres);
    }
    Scored {
        order: i.order,
        motion: i.motion,
        starter: i.motion == MotionState::Standing && dist(end, i.anchor) * metres > 1.0,
        d,
        radii: i.radii,
        experts,
        scale: i.scale as f64,
        min_k: i
            .endpoints
            .iter()
            .map(|&e| dist(end, e) * metres)
            .fold(f64::INFINITY, f64::min),
    }
}

fn covered(s: &Scored, h: usize) -> (bool, bool) {
    let r = s.radii[h];
    (s.d[h] <= r.r50 as f64, s.d[h] <= r.r90 as f64)
}

fn coverage<'a>(it: impl Iterator<Item = &'a Scored>, h: usize) -> Coverage {
    let (mut n, mut c50, mut c90) = (0usize, 0usize, 0usize);
    for s in it {
        let (a, b) = covered(s, h);
        n += 1;
        c50 += a as usize;
        c90 += b as usize;
    }
    let f = |c: usize| if n == 0 { 0.0 } else { c as f64 / n as f64 };
    Coverage {
        n,
        r50: f(c50),
        r90: f(c90),
    }
}

fn mean(it: impl Iterator<Item = f64>) -> f64 {
    let (mut s, mut n) = (0.0, 0usize);
    for v in it {
        s += v;
        n += 1;
    }
    if n == 0 {
        0.0
    } else {
        s / n as f64
    }
}

fn summarise(scored: &[Scored], metres: f64) -> StreamReport {
    let end = HORIZONS - 1;
    let per_horizon = (0..HORIZONS).map(|h| coverage(scored.iter(), h)).collect();
    let by_motion = MotionState::ALL
        .iter()
        .map(|&m| {
            let c = coverage(scored.iter().filter(|s| s.motion == m), end);
            (m.name().to_string(), c)
        })
        .collect();
    // The oracle: the 90 % quantile of d / scale (nearest rank), times the mean scale.
    let mut ratios: Vec<f64> = scored
        .iter()
        .map(|s| s.d[end] / s.scale.max(f64::MIN_POSITIVE))
        .collect();
    ratios.sort_by(f64::total_cmp);
    let c_star = ratios
        .get(((ratios.len() as f64 * 0.9).ceil() as usize).saturating_sub(1))
        .copied()
        .unwrap_or(0.0);
    let head = scored.iter().all(|s| s.experts[0].is_some());
    let fde = Fde {
        head: (head && !scored.is_empty())
            .then(|| mean(scored.iter().filter_map(|s| s.experts[0]))),
        cv: [1, 2, 3].map(|e| mean(scored.iter().filter_map(|s| s.experts[e]))),
        point: mean(scored.iter().map(|s| s.d[end] * metres)),
        point_ade: mean(scored.iter().map(|s| mean(s.d.iter().copied()) * metres)),
        min_k: mean(scored.iter().map(|s| s.min_k)),
    };
    let hits: Vec<bool> = scored.iter().map(|s| covered(s, end).1).collect();
    let burn_in = BURN_IN
        .iter()
        .filter(|&&n| n <= hits.len())
        .map(|&n| {
            (
                n,
                hits[..n].iter().filter(|&&h| h).count() as f64 / n as f64,
            )
        })
        .collect();
    let rolling_r90 = hits
        .chunks(ROLLING)
        .filter(|c| c.len() == ROLLING)
        .map(|c| c.iter().filter(|&&h| h).count() as f64 / ROLLING as f64)
        .collect();
    StreamReport {
        scored: scored.len(),
        endpoint: coverage(scored.iter(), end),
        per_horizon,
        by_motion,
        starters: coverage(scored.iter().filter(|s| s.starter), end),
        mean_r50: mean(scored.iter().map(|s| s.radii[end].r50 as f64 * metres)),
        mean_r90: mean(scored.iter().map(|s| s.radii[end].r90 as f64 * metres)),
        oracle_r90: c_star * mean(scored.iter().map(|s| s.scale)) * metres,
        fde,
        burn_in,
        rolling_r90,
        ..StreamReport::default()
    }
}

/// Pools several reports of one mode (the recordings of a data set) into one: coverages and
/// errors weighted by scored forecasts; the oracle radius is the pooled reports' weighted mean
/// (each recording's own oracle), burn-in and rolling curves are left empty.
pub fn pool(name: &str, reports: &[StreamReport]) -> StreamReport {
    let n: usize = reports.iter().map(|r| r.scored).sum();
    let w = |f: &dyn Fn(&StreamReport) -> f64| -> f64 {
        if n == 0 {
            return 0.0;
        }
        reports.iter().map(|r| f(r) * r.scored as f64).sum::<f64>() / n as f64
    };
    let cov = |f: &dyn Fn(&StreamReport) -> Coverage| -> Coverage {
        let m: usize = reports.iter().map(|r| f(r).n).sum();
        let avg = |g: &dyn Fn(&Coverage) -> f64| {
            if m == 0 {
                0.0
            } else {
                reports
                    .iter()
                    .map(|r| g(&f(r)) * f(r).n as f64)
                    .sum::<f64>()
                    / m as f64
            }
        };
        Coverage {
            n: m,
            r50: avg(&|c| c.r50),
            r90: avg(&|c| c.r90),
        }
    };
    let by_motion = MotionState::ALL
        .iter()
        .map(|m| {
            let k = m.name().to_string();
            let c = cov(&|r| r.by_motion.get(&k).copied().unwrap_or_default());
            (k, c)
        })
        .collect();
    StreamReport {
        scene: name.to_string(),
        adapt: reports.first().is_some_and(|r| r.adapt),
        unit: reports.first().map(|r| r.unit.clone()).unwrap_or_default(),
        forecasts: reports.iter().map(|r| r.forecasts).sum(),
        scored: n,
        failed: reports.iter().map(|r| r.failed).sum(),
        endpoint: cov(&|r| r.endpoint),
        per_horizon: (0..HORIZONS)
            .map(|h| cov(&|r| r.per_horizon.get(h).copied().unwrap_or_default()))
            .collect(),
        by_motion,
        starters: cov(&|r| r.starters),
        mean_r50: w(&|r| r.mean_r50),
        mean_r90: w(&|r| r.mean_r90),
        oracle_r90: w(&|r| r.oracle_r90),
        fde: Fde {
            head: reports
                .iter()
                .all(|r| r.fde.head.is_some())
                .then(|| w(&|r| r.fde.head.unwrap_or(0.0))),
            cv: [0, 1, 2].map(|i| w(&|r| r.fde.cv[i])),
            point: w(&|r| r.fde.point),
            point_ade: w(&|r| r.fde.point_ade),
            min_k: w(&|r| r.fde.min_k),
        },
        flight: reports.iter().all(|r| r.flight.is_some()).then(|| {
            let parts: Vec<FlightStats> = reports.iter().filter_map(|r| r.flight).collect();
            FlightStats::pooled(&parts)
        }),
        ..StreamReport::default()
    }
}
