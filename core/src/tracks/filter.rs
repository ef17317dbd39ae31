//! A constant-velocity Kalman filter per track, for noisy detections: the
//! stage put in front of a track table (or the
//! [`online::Forecaster`](crate::online::Forecaster)) that replaces each
//! detection's position by the filter's estimate at the detection's time.
//!
//! A ground point from a drone's camera carries the detector's pixel error
//! and the attitude's error: about 0.1 m from 30 m up. The predictor reads
//! motion from the differences of its 8 history points, so that noise goes
//! straight into the forecast. [`TrackFilter::update`]`(t_ms, observations)`
//! takes one camera frame (the same timestamps and ids the table gets next)
//! and rewrites, in place, every detection it can filter; the table then
//! resamples the filtered positions onto the model's grid as it would raw
//! ones. The filter never delays a position: the estimate at `t` uses the
//! detections up to `t` only (no smoothing of older points).
//!
//! ```
//! use core::num::NonZeroU32;
//! use gpecnet_core::tracks::filter::{FilterConfig, TrackFilter};
//! use gpecnet_core::tracks::{Observation, TimedTrackTable};
//!
//! let mut filter: TrackFilter<16> = TrackFilter::new(FilterConfig::metres())?;
//! let mut table: TimedTrackTable<16> = TimedTrackTable::new(NonZeroU32::new(400).unwrap(), 1_000);
//! for frame in 0..90u32 {
//!     let t_ms = frame * 100;
//!     let wobble = if frame % 2 == 0 { 0.1 } else { -0.1 }; // ±0.1 m of detector noise
//!     let mut obs = [Observation { id: 1, pos: [1.2 * t_ms as f32 / 1000.0, wobble] }];
//!     filter.update(t_ms, &mut obs);
//!     table.update(t_ms, &obs);
//! }
//! let past = table.get(1).map(|t| t.past()).unwrap_or_default();
//! assert!(past.iter().all(|p| p[1].abs() < 0.05)); // the wobble is mostly gone
//! # Ok::<(), gpecnet_core::tracks::filter::FilterError>(())
//! ```
//!
//! # The model
//!
//! Per track the state is the position `x` and velocity `v` in the caller's
//! unit, both axes independent with the same covariance (isotropic noise
//! makes the two axes' covariances equal, so one symmetric 2 × 2 matrix
//! `[[p00, p01], [p01, p11]]`, three numbers, serves both). Motion: constant
//! velocity driven by white acceleration of spectral density `q = a²` (`a` =
//! [`FilterConfig::accel`], the acceleration's standard deviation over one
//! second; its unit is the caller's per s²), so over `dt` seconds
//! `Q = q·[[dt³/3, dt²/2], [dt²/2, dt]]` whatever the camera's rate.
//! Measurement: the position with isotropic Gaussian noise of standard
//! deviation `σ` (per detection, or [`FilterConfig::sigma`]).
//!
//! # Rules
//!
//! `update_with(t, observations, sigma)` applies one frame, in this order:
//!
//! 1. **Time**, as the track tables' (`crate::tracks`): `step = t − last`
//!    (mod 2³²) in milliseconds; 0 continues the last frame, `1 ≤ step <
//!    2³¹` advances, `step ≥ 2³¹` (a timestamp before the last) refuses the
//!    whole call ([`FilterReport::stale`]): nothing is rewritten and nothing
//!    changes (the table refuses the frame too). The first update after
//!    [`new`](TrackFilter::new) or [`clear`](TrackFilter::clear) accepts any
//!    `t`. Times are kept unwrapped on 64 bits.
//! 2. **Leaving.** A track whose last detection is more than
//!    [`FilterConfig::max_gap_ms`] before `t` is forgotten; its id, seen
//!    again, starts afresh.
//! 3. **Observations**, in slice order:
//!    * a non-finite coordinate: left as it is (the table refuses it), not
//!      used ([`FilterReport::non_finite`]);
//!    * `σ = sigma(index, observation)`; a `σ` that is not finite and
//!      positive is replaced by [`FilterConfig::sigma`]; `r = σ·σ`;
//!    * an id already updated at `t`: left as it is (the table refuses it as a
//!      duplicate) ([`FilterReport::duplicates`]);
//!    * an id the filter does not know: a new track, **started** at the
//!      detection (position left as it is), if a slot is free, else left as
//!      it is ([`FilterReport::untracked`]);
//!    * a known id: **predicted** to `t` and **updated** with the detection,
//!      whose position is replaced by the estimate; where the innovation's
//!      length exceeds [`FilterConfig::reset`] (a teleport, an id switch) or
//!      any result is not finite or the covariance is not positive definite,
//!      the track is **started** again at the detection instead
//!      ([`FilterReport::resets`]).
//!
//! So no input makes a position NaN or infinite: a filtered position is
//! either the detection itself or a finite estimate.
//!
//! # The arithmetic (f32, in this order; the same bits on every target)
//!
//! Per axis `i` (0, 1), `x_i` the position, `v_i` the velocity, `z_i` the
//! detection; `q = a·a` once per update.
//!
//! * **Start**: `x_i = z_i`, `v_i = 0`, `p00 = r`, `p01 = 0`, `p11 = s0·s0`
//!   with `s0` = [`FilterConfig::init_speed`].
//! * **Predict** over `dt = (step as f32) / 1000` seconds (`step` the
//!   milliseconds since the track's last detection, an exact integer):
//!   `x_i ← x_i + v_i·dt`; `d2 = dt·dt`, `d3 = d2·dt`; `a01 = p01 + dt·p11`;
//!   `p00 ← (p00 + dt·(p01 + a01)) + q·(d3/3)`; `p01 ← a01 + q·(d2·0.5)`;
//!   `p11 ← p11 + q·dt`.
//! * **Update**: `e_i = z_i − x_i`; reset when `e_0·e_0 + e_1·e_1 >
//!   reset·reset` or is NaN; `s = p00 + r`, `k0 = p00/s`, `k1 = p01/s`; `x_i ← x_i +
//!   k0·e_i`, `v_i ← v_i + k1·e_i`; `p11 ← p11 − k1·p01` (the predicted
//!   `p01`), then `p01 ← k1·r`, `p00 ← k0·r`.
//! * **Check**: every `x_i`, `v_i`, `p` finite, `p00 > 0`, `p11 > 0` and
//!   `p00·p11 > p01·p01`, else start again at `z`.
//!
//! The update's covariance is the standard `(I − K·H)·P` written so the
//! matrix stays symmetric by construction (one off-diagonal number) and its
//! determinant is `r/s` times the predicted one: positive in exact
//! arithmetic, checked in f32.
//!
//! # Memory and cost
//!
//! A [`FilteredTrack`] is 40 bytes; a `TrackFilter<N>` is about `40·N + 40`
//! bytes (`new` is not `const`: it checks the config). A detection costs a
//! lookup by id (O(N)) and about 30 flops, one of them a division.

use core::fmt;

use heapless::Vec;

use super::{advance, expire, Observation, Pos, HISTORY};

/// The filter's settings, in the caller's unit ([`FilterConfig::metres`]
/// for metres, [`FilterConfig::scaled`] for another unit).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FilterConfig {
    /// Process noise: the white acceleration's standard deviation over one
    /// second (caller units per s²; spectral density `accel²`).
    pub accel: f32,
    /// Measurement noise: a detection's standard deviation per axis, for
    /// detections without their own (caller units).
    pub sigma: f32,
    /// A new track's velocity standard deviation (caller units per s).
    pub init_speed: f32,
    /// An innovation longer than this restarts the track at the detection
    /// (caller units).
    pub reset: f32,
    /// A track not detected for longer than this is forgotten (ms).
    pub max_gap_ms: u32,
}

impl FilterConfig {
    /// The defaults in metres: `accel` 0.05 m/s² (the best of 0.03 … 1 for
    /// best-of-20 endpoint error under 0.1 m of detection noise on the
    /// ETH/UCY validation recordings at 2.5 Hz, `docs/camera.md`), `sigma`
    /// 0.1 m (a 2 px foot-point error from ~30 m altitude), `init_speed`
    /// 1.5 m/s (a walker), `reset` 3 m, `max_gap_ms` 1000.
    pub const fn metres() -> Self {
        FilterConfig {
            accel: 0.05,
            sigma: 0.1,
            init_speed: 1.5,
            reset: 3.0,
            max_gap_ms: 1_000,
        }
    }

    /// This config for positions in a unit of `per_metre` units per metre
    /// (`accel`, `sigma`, `init_speed` and `reset` multiplied by it).
    pub fn scaled(self, per_metre: f32) -> Self {
        FilterConfig {
            accel: self.accel * per_metre,
            sigma: self.sigma * per_metre,
            init_speed: self.init_speed * per_metre,
            reset: self.reset * per_metre,
            max_gap_ms: self.max_gap_ms,
        }
    }

    /// [`FilterError::BadConfig`] unless `accel`, `sigma`, `init_speed` and
    /// `reset` are finite and positive, `accel·accel`, `sigma·sigma` and
    /// `init_speed·init_speed` are finite and positive (no overflow or
    /// underflow), and `max_gap_ms` is in `1 ..= 60 000`.
    pub fn validate(&self) -> Result<(), FilterError> {
        let ok = |v: f32| v.is_finite() && v > 0.0 && (v * v).is_finite() && v * v > 0.0;
        if ok(self.accel)
            && ok(self.sigma)
            && ok(self.init_speed)
            && self.reset.is_finite()
            && self.reset > 0.0
            && (1..=60_000).contains(&self.max_gap_ms)
        {
            Ok(())
        } else {
            Err(FilterError::BadConfig)
        }
    }
}

impl Default for FilterConfig {
    fn default() -> Self {
        Self::metres()
    }
}

/// Why a filter could not be built.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum FilterError {
    /// A setting [`FilterConfig::validate`] refuses.
    BadConfig,
}

impl fmt::Display for FilterError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            FilterError::BadConfig => {
                "filter config: accel, sigma, init_speed and reset must be finite and \
                 positive, max_gap_ms within 1..=60000"
            }
        })
    }
}

impl core::error::Error for FilterError {}

/// What one [`TrackFilter::update`] did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FilterReport {
    /// Detections replaced by a filtered estimate.
    pub filtered: u32,
    /// Tracks started (new ids).
    pub started: u32,
    /// Tracks started again (absurd innovation or a non-finite result).
    pub resets: u32,
    /// Detections left as they are because a coordinate is not finite.
    pub non_finite: u32,
    /// Detections left as they are: their id was already updated at `t`.
    pub duplicates: u32,
    /// Detections of new ids left as they are because every slot is taken.
    pub untracked: u32,
    /// The timestamp is before the last one: nothing changed.
    pub stale: bool,
}

/// One track's filter state (see the module's arithmetic).
#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FilteredTrack {
    id: u32,
    pos: Pos,
    vel: Pos,
    /// `[p00, p01, p11]`: the per-axis covariance of (position, velocity).
    p: [f32; 3],
    /// The last detection's time (unwrapped ms).
    last_t: u64,
}

impl FilteredTrack {
    /// A track started at `z` (the module's **Start**).
    fn start(id: u32, z: Pos, r: f32, init_speed: f32, now: u64) -> Self {
        FilteredTrack {
            id,
            pos: z,
            vel: [0.0; 2],
            p: [r, 0.0, init_speed * init_speed],
            last_t: now,
        }
    }

    /// The track id.
    pub fn id(&self) -> u32 {
        self.id
    }

    /// The estimated position at the last detection.
    pub fn position(&self) -> Pos {
        self.pos
    }

    /// The estimated velocity (caller units per second).
    pub fn velocity(&self) -> Pos {
        self.vel
    }

    /// The per-axis covariance `[p00, p01, p11]` of position and velocity.
    pub fn covariance(&self) -> [f32; 3] {
        self.p
    }

    /// The last detection's timestamp, in the caller's milliseconds.
    pub fn last_detection_ms(&self) -> u32 {
        self.last_t as u32
    }

    /// Predict over `dt` s and update with `z` (variance `r`); `false` when
    /// the track must be started again (the module's rules).
    fn step(&mut self, dt: f32, z: Pos, r: f32, q: f32, reset: f32) -> bool {
        let [mut p00, mut p01, mut p11] = self.p;
        let mut x = self.pos;
        let mut v = self.vel;
        // Predict.
        x[0] += v[0] * dt;
        x[1] += v[1] * dt;
        let d2 = dt * dt;
        let d3 = d2 * dt;
        let a01 = p01 + dt * p11;
        p00 = (p00 + dt * (p01 + a01)) + q * (d3 / 3.0);
        p01 = a01 + q * (d2 * 0.5);
        p11 += q * dt;
        // Update.
        let e = [z[0] - x[0], z[1] - x[1]];
        let e2 = e[0] * e[0] + e[1] * e[1];
        if e2.is_nan() || e2 > reset * reset {
            return false;
        }
        let s = p00 + r;
        let k0 = p00 / s;
        let k1 = p01 / s;
        x[0] += k0 * e[0];
        x[1] += k0 * e[1];
        v[0] += k1 * e[0];
        v[1] += k1 * e[1];
        p11 -= k1 * p01;
        p01 = k1 * r;
        p00 = k0 * r;
        // Check.
        let finite = x
            .iter()
            .chain(&v)
            .chain(&[p00, p01, p11])
            .all(|a| a.is_finite());
        if !(finite && p00 > 0.0 && p11 > 0.0 && p00 * p11 > p01 * p01) {
            return false;
        }
        self.pos = x;
        self.vel = v;
        self.p = [p00, p01, p11];
        true
    }
}

/// A fixed-capacity bank of at most `N` per-track filters (the module's
/// rules).
#[derive(Clone, Debug)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct TrackFilter<const N: usize> {
    tracks: Vec<FilteredTrack, N>,
    config: FilterConfig,
    /// The last update's time, unwrapped; `None` before the first.
    now: Option<u64>,
}

impl<const N: usize> TrackFilter<N> {
    /// An empty filter bank; [`FilterError::BadConfig`] for a config
    /// [`FilterConfig::validate`] refuses.
    pub fn new(config: FilterConfig) -> Result<Self, FilterError> {
        config.validate()?;
        Ok(TrackFilter {
            tracks: Vec::new(),
            config,
            now: None,
        })
    }

    /// The settings.
    pub fn config(&self) -> &FilterConfig {
        &self.config
    }

    /// Tracks being filtered.
    pub fn len(&self) -> usize {
        self.tracks.len()
    }

    /// `true` when no track is being filtered.
    pub fn is_empty(&self) -> bool {
        self.tracks.is_empty()
    }

    /// The track with this id, if it is being filtered.
    pub fn get(&self, id: u32) -> Option<&FilteredTrack> {
        self.tracks.iter().find(|t| t.id == id)
    }

    /// Every track, in the order they started.
    pub fn iter(&self) -> impl Iterator<Item = &FilteredTrack> {
        self.tracks.iter()
    }

    /// Forgets every track and the last time (a new sequence).
    pub fn clear(&mut self) {
        self.tracks.clear();
        self.now = None;
    }

    /// Filters one camera frame in place with [`FilterConfig::sigma`] for
    /// every detection (the module's rules).
    pub fn update(&mut self, t_ms: u32, observations: &mut [Observation]) -> FilterReport {
        self.update_with(t_ms, observations, |_, _| f32::NAN)
    }

    /// [`update`](Self::update) with each detection's own standard
    /// deviation, `sigma(index, observation)` (caller units; a value that
    /// is not finite and positive means [`FilterConfig::sigma`]).
    pub fn update_with(
        &mut self,
        t_ms: u32,
        observations: &mut [Observation],
        mut sigma: impl FnMut(usize, &Observation) -> f32,
    ) -> FilterReport {
        let mut report = FilterReport::default();
        let Some(now) = advance(self.now, t_ms) else {
            report.stale = true;
            return report;
        };
        self.now = Some(now);
        let c = self.config;
        let max_gap = u64::from(c.max_gap_ms);
        let mut gone: Vec<u32, N> = Vec::new();
        expire(&mut self.tracks, &mut gone, |t| {
            (now.saturating_sub(t.last_t) > max_gap).then_some(t.id)
        });
        let q = c.accel * c.accel;
        for (i, o) in observations.iter_mut().enumerate() {
            if !o.pos.iter().all(|v| v.is_finite()) {
                report.non_finite = report.non_finite.saturating_add(1);
                continue;
            }
            let s = sigma(i, o);
            let s = if s.is_finite() && s > 0.0 && s * s > 0.0 && (s * s).is_finite() {
                s
            } else {
                c.sigma
            };
            let r = s * s;
            match self.tracks.iter_mut().find(|t| t.id == o.id) {
                Some(t) if t.last_t == now => {
                    report.duplicates = report.duplicates.saturating_add(1)
                }
                Some(t) => {
                    // At most `max_gap_ms` ≤ 60 000 ms: exact in f32.
                    let dt = (now - t.last_t) as f32 / 1000.0;
                    if t.step(dt, o.pos, r, q, c.reset) {
                        t.last_t = now;
                        o.pos = t.pos;
                        report.filtered = report.filtered.saturating_add(1);
                    } else {
                        *t = FilteredTrack::start(o.id, o.pos, r, c.init_speed, now);
                        report.resets = report.resets.saturating_add(1);
                    }
                }
                None => {
                    let t = FilteredTrack::start(o.id, o.pos, r, c.init_speed, now);
                    if self.tracks.push(t).is_ok() {
                        report.started = report.started.saturating_add(1);
                    } else {
                        report.untracked = report.untracked.saturating_add(1);
                    }
                }
            }
        }
        report
    }
}

/// A history smoothed by the same constant-velocity model: a
/// Rauch–Tung–Striebel smoother over the [`HISTORY`] equally spaced points
/// of `past` (oldest first, `period_s` apart), each taken as a measurement
/// of standard deviation `config.sigma`. The newest point is the filter's
/// estimate given all of them (no delay); older points also use the points
/// after them. For callers of [`crate::online::forecast`] with their own
/// track handling, before the forecast.
///
/// Arithmetic (f32, per axis, in this order): a forward pass as the
/// module's **Start** at `past[0]` and **Predict**/**Update** with `dt =
/// period_s` for `k = 1 … 7` (no reset: a restart would lose the history),
/// keeping each step's filtered `(x, v, p00, p01, p11)` and predicted
/// `(x, v, p00, p01, p11)`; then backwards for `k = 6 … 0`, with the rows
/// `b = (p00 + dt·p01, p01)`, `c = (p01 + dt·p11, p11)` of `P_k·Fᵀ` (`P_k`
/// the filtered one), the predicted `P_{k+1}` as `(a, m, d)`, `det = a·d −
/// m·m`: `C = [[(b0·d − b1·m)/det, (b1·a − b0·m)/det], [(c0·d − c1·m)/det,
/// (c1·a − c0·m)/det]]`, `dx = xs_{k+1} − xp_{k+1}`, `dv = vs_{k+1} −
/// vp_{k+1}`, `xs_k = x_k + (C00·dx + C01·dv)`, `vs_k = v_k + (C10·dx +
/// C11·dv)`. Where any value is not finite or `det` is not positive, `past`
/// is returned unchanged.
pub fn smooth_history(
    past: &[Pos; HISTORY],
    period_s: f32,
    config: &FilterConfig,
) -> [Pos; HISTORY] {
    let dt = period_s;
    let r = config.sigma * config.sigma;
    let q = config.accel * config.accel;
    // Filtered and predicted (x, v) per axis and the covariances (shared).
    let mut xf = [[0.0f32; 2]; HISTORY];
    let mut vf = [[0.0f32; 2]; HISTORY];
    let mut pf = [[0.0f32; 3]; HISTORY];
    let mut xp = [[0.0f32; 2]; HISTORY];
    let mut vp = [[0.0f32; 2]; HISTORY];
    let mut pp = [[0.0f32; 3]; HISTORY];
    let [first, ..] = *past;
    let mut t = FilteredTrack::start(0, first, r, config.init_speed, 0);
    xf[0] = t.pos;
    vf[0] = t.vel;
    pf[0] = t.p;
    for k in 1..HISTORY {
        let (Some(z), Some(out)) = (past.get(k), xp.get_mut(k)) else {
            return *past;
        };
        // The prediction, as in `step`, kept for the backward pass.
        let [p00, p01, p11] = t.p;
        let d2 = dt * dt;
        let d3 = d2 * dt;
        let a01 = p01 + dt * p11;
        *out = [t.pos[0] + t.vel[0] * dt, t.pos[1] + t.vel[1] * dt];
        vp[k] = t.vel;
        pp[k] = [
            (p00 + dt * (p01 + a01)) + q * (d3 / 3.0),
            a01 + q * (d2 * 0.5),
            p11 + q * dt,
        ];
        if !t.step(dt, *z, r, q, f32::INFINITY) {
            return *past;
        }
        xf[k] = t.pos;
        vf[k] = t.vel;
        pf[k] = t.p;
    }
    let mut xs = xf;
    let mut vs = vf;
    for k in (0..HISTORY - 1).rev() {
        let [p00, p01, p11] = pf[k];
        let [a, m, d] = pp[k + 1];
        let det = a * d - m * m;
        if !(det > 0.0 && det.is_finite()) {
            return *past;
        }
        let b = [p00 + dt * p01, p01];
        let c = [p01 + dt * p11, p11];
        let c00 = (b[0] * d - b[1] * m) / det;
        let c01 = (b[1] * a - b[0] * m) / det;
        let c10 = (c[0] * d - c[1] * m) / det;
        let c11 = (c[1] * a - c[0] * m) / det;
        for i in 0..2 {
            let dx = xs[k + 1][i] - xp[k + 1][i];
            let dv = vs[k + 1][i] - vp[k + 1][i];
            xs[k][i] = xf[k][i] + (c00 * dx + c01 * dv);
            vs[k][i] = vf[k][i] + (c10 * dx + c11 * dv);
        }
    }
    if xs
        .iter()
        .flatten()
        .chain(vs.iter().flatten())
        .all(|v| v.is_finite())
    {
        xs
    } else {
        *past
    }
}
