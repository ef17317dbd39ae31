//! The online calibration loop through the C ABI: the core's
//! `Forecaster<16, 2>` (`gpecnet_core::online`: the rules, what the numbers
//! guarantee) in caller-owned storage. One call per camera frame takes the
//! detections, feeds each track's new grid points back to its pending
//! forecasts (per-horizon radii by quantile tracking, the point forecast as
//! a weighted aggregate of the point head and three constant-velocity
//! experts) and writes a [`GpecnetTrackForecast`] per track with a new grid
//! point; the calibration survives a power cycle as
//! [`GPECNET_ONLINE_STATE_LEN`] bytes.
//!
//! ```c
//! static _Alignas(GPECNET_FORECASTER_ALIGN) uint8_t fc_mem[GPECNET_FORECASTER_SIZE];
//! GpecnetOnlineConfig cfg;
//! gpecnet_online_config_default(&cfg);           /* metres */
//! gpecnet_forecaster_init(fc_mem, sizeof fc_mem, p, &cfg, /* max gap */ 1000);
//! GpecnetForecaster *f = (GpecnetForecaster *)fc_mem;
//! // each camera frame:
//! static GpecnetTrackForecast out[GPECNET_ONLINE_TRACKS];
//! size_t n;
//! gpecnet_forecaster_frame(f, p, t_ms, dets, n_dets, out, GPECNET_ONLINE_TRACKS, &n, NULL);
//! // out[i].point[h], out[i].r90[h]: where track out[i].id is at end_ms + (h + 1) * 400 ms
//! ```
use core::ffi::c_void;
use core::mem::{align_of, size_of};

use gpecnet_core::online::{Config, Forecaster, FrameReport, MotionState, TrackForecast};
use gpecnet_core::tracks::Observation;

use crate::boundary::{guard, non_null};
use crate::limits::{GPECNET_FORECASTER_ALIGN, GPECNET_FORECASTER_SIZE};
use crate::limits::{GPECNET_ONLINE_ENDPOINTS, GPECNET_ONLINE_EXPERTS, GPECNET_ONLINE_HORIZONS};
use crate::limits::{GPECNET_ONLINE_MAX_DETECTIONS, GPECNET_ONLINE_MOTION_STATES};
use crate::limits::{GPECNET_ONLINE_PENDING, GPECNET_ONLINE_STATE_LEN, GPECNET_ONLINE_TRACKS};
use crate::status::GPECNET_E_ONLINE_OTHER_MODEL;
use crate::status::{online_status, predict_status, GPECNET_E_BAD_LENGTH, GPECNET_E_MISALIGNED};
use crate::status::{GPECNET_E_NOT_INITIALISED, GPECNET_E_NULL_POINTER, GPECNET_OK};
use crate::status::{GPECNET_E_ONLINE_BUFFER_TOO_SMALL, GPECNET_E_ONLINE_FORECASTS_DROPPED};
use crate::status::{GPECNET_E_ONLINE_STATE_LENGTH, GPECNET_E_TRACKS_STALE_TIME};
use crate::storage::{state, GpecnetPredictor, Inner};
use crate::tracks::GpecnetDetection;

#[cfg(doc)]
use crate::{
    gpecnet_init_units, GPECNET_E_ONLINE_BAD_CONFIG, GPECNET_E_ONLINE_MODEL_SHAPE,
    GPECNET_E_ONLINE_STATE_CRC,
};

/// [`GpecnetTrackForecast::motion`]: below the first speed threshold.
pub const GPECNET_MOTION_STANDING: u8 = 0;
/// [`GpecnetTrackForecast::motion`]: below the second.
pub const GPECNET_MOTION_SLOW: u8 = 1;
/// [`GpecnetTrackForecast::motion`]: below the third.
pub const GPECNET_MOTION_WALKING: u8 = 2;
/// [`GpecnetTrackForecast::motion`]: at or above the third.
pub const GPECNET_MOTION_FAST: u8 = 3;

// The header's literals are the core's motion states.
const _: () = {
    assert!(GPECNET_MOTION_STANDING == MotionState::Standing as u8);
    assert!(GPECNET_MOTION_SLOW == MotionState::Slow as u8);
    assert!(GPECNET_MOTION_WALKING == MotionState::Walking as u8);
    assert!(GPECNET_MOTION_FAST == MotionState::Fast as u8);
};

/// The loop's settings, `gpecnet_core::online::Config` field for field (its
/// docs give each default value and the rule it enters). Distances are in
/// the caller's unit (the one the predictor was initialised with,
/// [`gpecnet_init_units`]): start from [`gpecnet_online_config_default`]
/// (metres) or [`gpecnet_online_config_scaled`] (another unit).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GpecnetOnlineConfig {
    /// 1: learn from feedback; 0: the blob's static multipliers and the
    /// head's point forecast, as without the loop.
    pub adapt: u8,
    /// Target miss rates of `r50` and `r90` (`0 < alpha[1] < alpha[0] < 1`).
    pub alpha: [f32; 2],
    /// Step of the multipliers' logarithm per update, `γ` (`0 < γ ≤ 1`).
    pub gamma: f32,
    /// Learning rate of the expert weights per caller unit of discounted
    /// error at the endpoint horizon, `η` (`> 0`).
    pub eta: f32,
    /// Forgetting factor of the expert losses per update, `λ` (`0 < λ < 1`).
    pub forgetting: f32,
    /// The constant-velocity experts' initial loss at the endpoint horizon
    /// (caller unit; `h/12` of it at horizon `h`, the point head's is 0).
    pub expert_prior: f32,
    /// Observed speeds (caller units per second, ascending) separating
    /// standing, slow, walking and fast.
    pub speed_thresholds: [f32; 3],
    /// 1: one calibration per motion state; 0: one for all.
    pub motion_bins: u8,
    /// The smallest scale of the radii (caller unit).
    pub min_scale: f32,
    /// The largest error one update counts (caller unit).
    pub loss_cap: f32,
    /// `{c_min, c_max}`, the range of every radius multiplier.
    pub multiplier_bounds: [f32; 2],
}

/// The configuration `$c` as a `$to`: the fields the two structs share by
/// name and type copied as they are, the two flags (`bool` in the core, `u8`
/// in C) converted by `$flag`. Both directions list the fields here once; a
/// field added to either struct fails to compile until it is mapped.
macro_rules! convert_config {
    ($c:ident => $to:ident, $flag:expr) => {
        $to {
            adapt: $flag($c.adapt),
            alpha: $c.alpha,
            gamma: $c.gamma,
            eta: $c.eta,
            forgetting: $c.forgetting,
            expert_prior: $c.expert_prior,
            speed_thresholds: $c.speed_thresholds,
            motion_bins: $flag($c.motion_bins),
            min_scale: $c.min_scale,
            loss_cap: $c.loss_cap,
            multiplier_bounds: $c.multiplier_bounds,
        }
    };
}

impl From<Config> for GpecnetOnlineConfig {
    fn from(c: Config) -> Self {
        convert_config!(c => GpecnetOnlineConfig, u8::from)
    }
}

impl From<GpecnetOnlineConfig> for Config {
    fn from(c: GpecnetOnlineConfig) -> Self {
        convert_config!(c => Config, |flag: u8| flag != 0)
    }
}

/// One track's forecast from [`gpecnet_forecaster_frame`], in the caller's
/// unit: the model's endpoints and their probabilities, the point head,
/// and what the loop issues, the aggregate point forecast with its radii
/// per horizon (`gpecnet_core::online::TrackForecast`).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GpecnetTrackForecast {
    /// The track id (the detections' id).
    pub id: u32,
    /// The time of the history's newest point (caller's milliseconds):
    /// horizon index `h` (0-based) is at `end_ms + (h + 1) · period`.
    pub end_ms: u32,
    /// The observed speed over the history (caller units per second).
    pub speed: f32,
    /// Its motion state (`GPECNET_MOTION_*`): the calibration it used.
    pub motion: u8,
    /// 1 when `probabilities` are the model's learned ones (else `1/n` each).
    pub learned: u8,
    /// 1 when `head` holds the model's point head, else 0 (and `head` is 0).
    pub has_head: u8,
    /// Endpoints in `endpoints` and `probabilities` (the model's, at most
    /// [`GPECNET_ONLINE_ENDPOINTS`]; the rest of both arrays is 0).
    pub n_endpoints: u32,
    /// The model's endpoint set 4.8 s ahead, (x, y) each.
    pub endpoints: [[f32; 2]; GPECNET_ONLINE_ENDPOINTS],
    /// One probability per endpoint (summing to 1).
    pub probabilities: [f32; GPECNET_ONLINE_ENDPOINTS],
    /// The model's point head, step 1 first (the first expert).
    pub head: [[f32; 2]; GPECNET_ONLINE_HORIZONS],
    /// The point forecast the loop issues (the experts' aggregate; the head
    /// itself with `adapt` = 0), step 1 first.
    pub point: [[f32; 2]; GPECNET_ONLINE_HORIZONS],
    /// The median radius around `point` at each step.
    pub r50: [f32; GPECNET_ONLINE_HORIZONS],
    /// The 90 % radius around `point` at each step.
    pub r90: [f32; GPECNET_ONLINE_HORIZONS],
    /// The scale of the radii at the endpoint horizon.
    pub scale: f32,
    /// The experts' weights at the endpoint horizon (head, constant velocity
    /// over 1, 2 and 4 steps).
    pub weights: [f32; GPECNET_ONLINE_EXPERTS],
    /// The planner's static radii around the head's endpoint (the blob's
    /// multipliers, as `gpecnet_predict_forecast` gives them): `r50`, then
    /// `r90`; 0 for a model without learned radii.
    pub static_radii: [f32; 2],
}

impl GpecnetTrackForecast {
    /// The C form of the core's forecast.
    fn of(fc: &TrackForecast<GPECNET_ONLINE_ENDPOINTS>) -> Self {
        let mut c = GpecnetTrackForecast {
            id: fc.id,
            end_ms: fc.end_ms,
            speed: fc.speed,
            motion: fc.motion as u8,
            learned: fc.learned.into(),
            has_head: fc.head.is_some().into(),
            n_endpoints: fc.endpoints.len() as u32,
            endpoints: [[0.0; 2]; GPECNET_ONLINE_ENDPOINTS],
            probabilities: [0.0; GPECNET_ONLINE_ENDPOINTS],
            head: [[0.0; 2]; GPECNET_ONLINE_HORIZONS],
            point: fc.point,
            r50: [0.0; GPECNET_ONLINE_HORIZONS],
            r90: [0.0; GPECNET_ONLINE_HORIZONS],
            scale: fc.scale,
            weights: fc.weights,
            static_radii: fc.static_radii.map_or([0.0; 2], |r| [r.r50, r.r90]),
        };
        for (o, e) in c.endpoints.iter_mut().zip(&fc.endpoints) {
            *o = *e;
        }
        for (o, p) in c.probabilities.iter_mut().zip(&fc.probabilities) {
            *o = *p;
        }
        if let Some(t) = &fc.head {
            for (o, p) in c.head.iter_mut().zip(t.iter()) {
                *o = *p;
            }
        }
        for ((r50, r90), r) in c.r50.iter_mut().zip(c.r90.iter_mut()).zip(&fc.radii) {
            *r50 = r.r50;
            *r90 = r.r90;
        }
        c
    }
}

/// What one [`gpecnet_forecaster_frame`] did, counted.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct GpecnetOnlineReport {
    /// Tracks that entered.
    pub entered: u32,
    /// Tracks that left (their last detection more than `max_gap_ms` ago).
    pub left: u32,
    /// Detections of new ids refused because the table was full.
    pub rejected: u32,
    /// Detections refused because their id already had one at this time.
    pub duplicates: u32,
    /// Detections refused because a coordinate was not finite.
    pub non_finite: u32,
    /// Forecasts the frame made (written, or dropped when `out` was full).
    pub forecasts: u32,
    /// Forecasts dropped because `out` was full (`forecasts − out_cap`).
    pub dropped: u32,
    /// Tracks whose forecast was refused (their input out of range, say):
    /// no forecast for them in this frame, the other tracks went on.
    pub failed: u32,
    /// The status code of the first refusal ([`GPECNET_OK`] when none).
    pub first_error: i32,
    /// Feedback updates applied to the calibration.
    pub feedback: u32,
}

impl GpecnetOnlineReport {
    /// Adds the core's report of one piece of the frame.
    fn add(&mut self, r: &FrameReport<GPECNET_ONLINE_TRACKS>) {
        self.entered += r.delta.entered.len() as u32;
        self.left += r.delta.left.len() as u32;
        self.rejected = self.rejected.saturating_add(r.delta.rejected);
        self.duplicates = self.duplicates.saturating_add(r.delta.duplicates);
        self.non_finite = self.non_finite.saturating_add(r.delta.non_finite);
        self.failed = self.failed.saturating_add(r.failed);
        self.feedback = self.feedback.saturating_add(r.feedback);
        if let (GPECNET_OK, Some(e)) = (self.first_error, r.error) {
            self.first_error = predict_status(e);
        }
    }
}

/// An initialised forecaster in caller-owned storage:
/// `(GpecnetForecaster *)storage` after [`gpecnet_forecaster_init`]. Opaque to C.
pub struct GpecnetForecaster {
    _opaque: [u8; 0],
}

type Inner16 = Forecaster<GPECNET_ONLINE_TRACKS, GPECNET_ONLINE_PENDING>;

/// Tag of an initialised forecaster storage ("GPOF").
const LIVE: u32 = 0x464f_5047;

/// What the caller's storage holds: a tag, which predictor it was built
/// for, then the core's forecaster.
#[repr(C)]
struct ForecasterState {
    tag: u32,
    /// The CRC-32 of the predictor's blob at init.
    model_crc: u32,
    /// The bits of the predictor's unit factor at init (its distances are
    /// the config's unit).
    unit_factor: u32,
    forecaster: Inner16,
}

const _: () = {
    assert!(size_of::<ForecasterState>() <= GPECNET_FORECASTER_SIZE);
    assert!(align_of::<ForecasterState>() <= GPECNET_FORECASTER_ALIGN);
    assert!(GPECNET_FORECASTER_ALIGN.is_power_of_two());
};

impl ForecasterState {
    /// [`GPECNET_E_ONLINE_OTHER_MODEL`] unless `pred` holds the blob and
    /// unit this forecaster was built for.
    fn check(&self, pred: &Inner) -> Result<(), i32> {
        if pred.model().crc() == self.model_crc
            && pred.units().factor().to_bits() == self.unit_factor
        {
            Ok(())
        } else {
            Err(GPECNET_E_ONLINE_OTHER_MODEL)
        }
    }
}

/// The size the forecaster storage actually needs on this target (at most
/// [`GPECNET_FORECASTER_SIZE`]).
#[no_mangle]
pub extern "C" fn gpecnet_forecaster_size() -> usize {
    size_of::<ForecasterState>()
}

/// The forecaster in `f`, or why there is none.
///
/// # Safety
/// `f` is NULL or a storage passed to [`gpecnet_forecaster_init`], not in
/// use by another call.
unsafe fn forecaster<'a>(f: *mut GpecnetForecaster) -> Result<&'a mut ForecasterState, i32> {
    if f.is_null() {
        return Err(GPECNET_E_NULL_POINTER);
    }
    if (f as usize) & (GPECNET_FORECASTER_ALIGN - 1) != 0 {
        return Err(GPECNET_E_MISALIGNED);
    }
    let s = f.cast::<ForecasterState>();
    // SAFETY: non-null and aligned (checked above); the caller guarantees a
    // storage gpecnet_forecaster_init wrote (its tag at least).
    let tag = unsafe { core::ptr::addr_of!((*s).tag).read() };
    if tag != LIVE {
        return Err(GPECNET_E_NOT_INITIALISED);
    }
    // SAFETY: the tag is LIVE only after gpecnet_forecaster_init wrote a
    // whole ForecasterState; the caller guarantees exclusive use for this call.
    Ok(unsafe { &mut *s })
}

/// Fills `*out` with the loop's defaults for a caller in metres
/// (`gpecnet_core::online::Config::metres`).
///
/// # Safety
/// `out` is NULL or valid for a write.
#[no_mangle]
pub unsafe extern "C" fn gpecnet_online_config_default(out: *mut GpecnetOnlineConfig) -> i32 {
    guard(|| {
        non_null(out)?;
        // SAFETY: non-null, writable (caller's contract); any alignment.
        unsafe { out.write_unaligned(Config::metres().into()) };
        Ok(())
    })
}

/// Writes to `*out` the config `*cfg` for a caller whose unit is
/// `units_per_metre` of its unit per metre (pixels per metre for a
/// camera): every distance and speed multiplied by it, `eta` divided by it.
/// The result is checked when a forecaster is built from it
/// ([`GPECNET_E_ONLINE_BAD_CONFIG`]). `cfg` and `out` may be the same.
///
/// # Safety
/// `cfg` is NULL or valid for a read; `out` is NULL or valid for a write.
#[no_mangle]
pub unsafe extern "C" fn gpecnet_online_config_scaled(
    cfg: *const GpecnetOnlineConfig,
    units_per_metre: f32,
    out: *mut GpecnetOnlineConfig,
) -> i32 {
    guard(|| {
        non_null(cfg)?;
        non_null(out)?;
        // SAFETY: non-null, readable (caller's contract); any alignment.
        let c: Config = unsafe { cfg.read_unaligned() }.into();
        // SAFETY: non-null, writable (caller's contract); `cfg` was read first.
        unsafe { out.write_unaligned(c.scaled(units_per_metre).into()) };
        Ok(())
    })
}

/// Builds a forecaster in `storage` (`storage_len >=
/// GPECNET_FORECASTER_SIZE` bytes aligned to [`GPECNET_FORECASTER_ALIGN`])
/// for the model of the initialised predictor `p` (its period, and its
/// radius multipliers as the starting calibration), under `*cfg` (in the
/// predictor's caller unit), bridging gaps of at most `max_gap_ms` between
/// a track's detections. [`GPECNET_E_ONLINE_MODEL_SHAPE`] for a model that
/// does not forecast 12 steps from 8 on a whole-millisecond period,
/// [`GPECNET_E_ONLINE_BAD_CONFIG`] for a config out of range. On failure the
/// storage is marked not initialised (when it is usable at all). Only `p`'s
/// blob and unit are kept: every [`gpecnet_forecaster_frame`] must pass a
/// predictor of the same blob and unit.
///
/// # Safety
/// `storage` is NULL or valid for writes of `storage_len` bytes; `p` is NULL
/// or a storage passed to `gpecnet_init*`, not in use by another call; `cfg`
/// is NULL or valid for a read.
#[no_mangle]
pub unsafe extern "C" fn gpecnet_forecaster_init(
    storage: *mut c_void,
    storage_len: usize,
    p: *const GpecnetPredictor,
    cfg: *const GpecnetOnlineConfig,
    max_gap_ms: u32,
) -> i32 {
    guard(|| {
        non_null(storage)?;
        if (storage as usize) & (GPECNET_FORECASTER_ALIGN - 1) != 0 {
            return Err(GPECNET_E_MISALIGNED);
        }
        if storage_len < size_of::<ForecasterState>() {
            return Err(GPECNET_E_BAD_LENGTH);
        }
        let s = storage.cast::<ForecasterState>();
        // SAFETY: non-null, aligned, at least size_of::<ForecasterState>()
        // writable bytes (checked above; the caller guarantees storage_len).
        unsafe { core::ptr::addr_of_mut!((*s).tag).write(0) };
        non_null(cfg)?;
        // SAFETY: the caller's contract on `p`; the predictor is only read
        // (its storage is writable memory: gpecnet_init wrote it).
        let pred: &Inner = unsafe { state(p.cast_mut()) }?;
        // SAFETY: non-null, readable (caller's contract); any alignment.
        let config: Config = unsafe { cfg.read_unaligned() }.into();
        let forecaster = Inner16::new(pred.model(), config, max_gap_ms).map_err(online_status)?;
        let state = ForecasterState {
            tag: LIVE,
            model_crc: pred.model().crc(),
            unit_factor: pred.units().factor().to_bits(),
            forecaster,
        };
        // SAFETY: as above; the forecaster holds no heap memory, so
        // overwriting a previous one leaks nothing.
        unsafe { s.write(state) };
        Ok(())
    })
}

/// Applies one camera frame: `n` detections at `dets` (caller's unit, the
/// predictor's), all at timestamp `t_ms` (milliseconds, wrapping `u32`),
/// through the core's `Forecaster::frame`: the detections go into the
/// forecaster's track table (the rules of `gpecnet_tracks_update`), each
/// track's new grid points are fed back to its pending forecasts, and every
/// track that gained a grid point with a full history is forecast (seed
/// `id << 32 | end_ms`) with `p`, which must hold the blob and unit the
/// forecaster was built for ([`GPECNET_E_ONLINE_OTHER_MODEL`] otherwise).
///
/// The forecasts go to `out` (room for `out_cap`) in table order, and
/// `*n_out` receives how many the frame made. When there are more than
/// `out_cap`, the first `out_cap` are written, the rest are dropped and the
/// status is [`GPECNET_E_ONLINE_FORECASTS_DROPPED`]: the frame was applied
/// all the same (a 16-entry array never drops: one forecast per track).
/// A timestamp before the last one refuses the whole call
/// ([`GPECNET_E_TRACKS_STALE_TIME`], nothing changes). A track whose
/// forecast is refused (its input out of range, say) gets none this frame;
/// it is counted in `*report` (when `report` is not NULL) and the status
/// stays [`GPECNET_OK`]. Up to [`GPECNET_ONLINE_MAX_DETECTIONS`] detections
/// are applied in one piece, the same bits as the core's `frame` with the
/// same slice; more are applied in pieces of that many, each a continuation
/// of the frame at the same `t_ms`.
///
/// # Safety
/// `f` is NULL or a storage passed to [`gpecnet_forecaster_init`] and `p`
/// NULL or one passed to `gpecnet_init*`, neither in use by another call;
/// `dets` is NULL (only with `n` = 0) or valid for reads of `n` detections;
/// `out` is NULL (only with `out_cap` = 0) or valid for writes of `out_cap`
/// forecasts, not overlapping `dets` (later pieces of a frame of more than
/// [`GPECNET_ONLINE_MAX_DETECTIONS`] are read after forecasts are written);
/// `n_out` is NULL or valid for a write; `report` is NULL or valid for a
/// write. The same storage as both `f` and `p` is refused by their tags.
#[no_mangle]
pub unsafe extern "C" fn gpecnet_forecaster_frame(
    f: *mut GpecnetForecaster,
    p: *mut GpecnetPredictor,
    t_ms: u32,
    dets: *const GpecnetDetection,
    n: usize,
    out: *mut GpecnetTrackForecast,
    out_cap: usize,
    n_out: *mut usize,
    report: *mut GpecnetOnlineReport,
) -> i32 {
    guard(|| {
        non_null(n_out)?;
        // SAFETY: non-null, writable (caller's contract): 0 until the frame is applied.
        unsafe { n_out.write_unaligned(0) };
        if n > 0 {
            non_null(dets)?;
        }
        if out_cap > 0 {
            non_null(out)?;
        }
        // SAFETY: the caller's contract on `f`.
        let fs = unsafe { forecaster(f) }?;
        // SAFETY: the caller's contract on `p` (a storage distinct from `f`'s).
        let pred = unsafe { state(p) }?;
        fs.check(pred)?;
        let mut rep = GpecnetOnlineReport::default();
        let mut made = 0usize;
        let mut chunk = [Observation {
            id: 0,
            pos: [0.0; 2],
        }; GPECNET_ONLINE_MAX_DETECTIONS];
        let mut done = 0;
        loop {
            let m = (n - done).min(GPECNET_ONLINE_MAX_DETECTIONS);
            for (i, o) in chunk.iter_mut().take(m).enumerate() {
                // SAFETY: done + i < n, and the caller guarantees n readable detections.
                let d = unsafe { dets.add(done + i).read_unaligned() };
                *o = Observation {
                    id: d.id,
                    pos: [d.x, d.y],
                };
            }
            let r = fs.forecaster.frame::<_, _, GPECNET_ONLINE_ENDPOINTS>(
                pred,
                t_ms,
                chunk.get(..m).unwrap_or(&[]),
                |fc| {
                    if made < out_cap {
                        // SAFETY: made < out_cap, and the caller guarantees room
                        // for out_cap forecasts at the non-null `out`; any alignment.
                        unsafe { out.add(made).write_unaligned(GpecnetTrackForecast::of(fc)) };
                    }
                    made += 1;
                },
            );
            if r.delta.stale {
                return Err(GPECNET_E_TRACKS_STALE_TIME);
            }
            rep.add(&r);
            done += m;
            if done >= n {
                break;
            }
        }
        rep.forecasts = made as u32;
        rep.dropped = made.saturating_sub(out_cap) as u32;
        // SAFETY: non-null, writable (caller's contract).
        unsafe { n_out.write_unaligned(made) };
        if !report.is_null() {
            // SAFETY: non-null, writable (caller's contract).
            unsafe { report.write_unaligned(rep) };
        }
        if made > out_cap {
            return Err(GPECNET_E_ONLINE_FORECASTS_DROPPED);
        }
        Ok(())
    })
}

/// Writes the forecaster's calibration (what the loop has learned: every
/// multiplier, loss and feedback count, with a CRC-32) into `out`, which has
/// room for `cap` bytes, at least [`GPECNET_ONLINE_STATE_LEN`]
/// ([`GPECNET_E_ONLINE_BUFFER_TOO_SMALL`] otherwise, nothing written);
/// `*written` receives the bytes written. Keep it across flights and give
/// it back with [`gpecnet_forecaster_restore`].
///
/// # Safety
/// `f` as in [`gpecnet_forecaster_frame`]; `out` is NULL or valid for
/// writes of `cap` bytes; `written` is NULL or valid for a write.
#[no_mangle]
pub unsafe extern "C" fn gpecnet_forecaster_state(
    f: *const GpecnetForecaster,
    out: *mut u8,
    cap: usize,
    written: *mut usize,
) -> i32 {
    guard(|| {
        non_null(out)?;
        non_null(written)?;
        // SAFETY: the caller's contract on `f`; the forecaster is only read
        // (its storage is writable memory: gpecnet_forecaster_init wrote it).
        let fs: &ForecasterState = unsafe { forecaster(f.cast_mut()) }?;
        let mut bytes = [0u8; GPECNET_ONLINE_STATE_LEN];
        let len = fs
            .forecaster
            .calibration()
            .state(&mut bytes)
            .map_err(online_status)?;
        // The core writes at most GPECNET_ONLINE_STATE_LEN bytes; a longer
        // answer would be a core fault, refused rather than cut.
        let bytes = bytes.get(..len).ok_or(GPECNET_E_ONLINE_BUFFER_TOO_SMALL)?;
        if len > cap {
            return Err(GPECNET_E_ONLINE_BUFFER_TOO_SMALL);
        }
        // SAFETY: non-null, room for cap >= len bytes (caller's contract);
        // a local copy, so no overlap.
        unsafe {
            core::ptr::copy_nonoverlapping(bytes.as_ptr(), out, len);
            written.write_unaligned(len);
        }
        Ok(())
    })
}

/// Replaces the forecaster's calibration by `len` bytes from
/// [`gpecnet_forecaster_state`], after checking all of it: length
/// ([`GPECNET_E_ONLINE_STATE_LENGTH`]), magic, version, shape, CRC
/// ([`GPECNET_E_ONLINE_STATE_CRC`] for a damaged state) and every value
/// within this forecaster's config bounds. On any error nothing changes.
/// Tracks and pending forecasts are kept.
///
/// # Safety
/// `f` as in [`gpecnet_forecaster_frame`]; `bytes` is NULL or valid for
/// reads of `len` bytes.
#[no_mangle]
pub unsafe extern "C" fn gpecnet_forecaster_restore(
    f: *mut GpecnetForecaster,
    bytes: *const u8,
    len: usize,
) -> i32 {
    guard(|| {
        non_null(bytes)?;
        // SAFETY: the caller's contract on `f`.
        let fs = unsafe { forecaster(f) }?;
        if len != GPECNET_ONLINE_STATE_LEN {
            return Err(GPECNET_E_ONLINE_STATE_LENGTH);
        }
        let mut copy = [0u8; GPECNET_ONLINE_STATE_LEN];
        // SAFETY: non-null, `len` = GPECNET_ONLINE_STATE_LEN readable bytes
        // (caller's contract), copied into a local array.
        unsafe { core::ptr::copy_nonoverlapping(bytes, copy.as_mut_ptr(), len) };
        fs.forecaster
            .calibration_mut()
            .restore(&copy)
            .map_err(online_status)
    })
}

/// Forgets what the loop has learned: every multiplier back to the blob's,
/// every expert loss back to its prior, the feedback counts to 0. Tracks
/// and pending forecasts are kept.
///
/// # Safety
/// `f` as in [`gpecnet_forecaster_frame`].
#[no_mangle]
pub unsafe extern "C" fn gpecnet_forecaster_reset(f: *mut GpecnetForecaster) -> i32 {
    guard(|| {
        // SAFETY: the caller's contract on `f`.
        let fs = unsafe { forecaster(f) }?;
        fs.forecaster.calibration_mut().reset();
        Ok(())
    })
}

/// Forgets every track and pending forecast (a new sequence, a clock that
/// restarted); the calibration stays.
///
/// # Safety
/// `f` as in [`gpecnet_forecaster_frame`].
#[no_mangle]
pub unsafe extern "C" fn gpecnet_forecaster_clear(f: *mut GpecnetForecaster) -> i32 {
    guard(|| {
        // SAFETY: the caller's contract on `f`.
        let fs = unsafe { forecaster(f) }?;
        fs.forecaster.clear();
        Ok(())
    })
}

/// Writes the feedback updates applied so far to each motion state's
/// calibration (saturating) to `out[GPECNET_MOTION_*]`, which has room for
/// `cap` counts, at least [`GPECNET_ONLINE_MOTION_STATES`]
/// ([`GPECNET_E_BAD_LENGTH`] otherwise). With `motion_bins` = 0 every state
/// shares one calibration and reports its count.
///
/// # Safety
/// `f` as in [`gpecnet_forecaster_state`]; `out` is NULL or valid for
/// writes of `cap` counts.
#[no_mangle]
pub unsafe extern "C" fn gpecnet_forecaster_feedback(
    f: *const GpecnetForecaster,
    out: *mut u32,
    cap: usize,
) -> i32 {
    guard(|| {
        non_null(out)?;
        // SAFETY: the caller's contract on `f`; only read (see gpecnet_forecaster_state).
        let fs: &ForecasterState = unsafe { forecaster(f.cast_mut()) }?;
        if cap < GPECNET_ONLINE_MOTION_STATES {
            return Err(GPECNET_E_BAD_LENGTH);
        }
        for (i, s) in MotionState::ALL.iter().enumerate() {
            let n = fs.forecaster.calibration().feedback_count(*s);
            // SAFETY: i < GPECNET_ONLINE_MOTION_STATES <= cap counts (caller's contract).
            unsafe { out.add(i).write_unaligned(n) };
        }
        Ok(())
    })
}
