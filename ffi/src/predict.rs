//! Predictions: the point forecast, the endpoint set, and the endpoint set
//! with its probabilities and the point forecast's radii for a planner
//! ([`GpecnetPlanner`]); each entry point first copies the observed track
//! out of C memory.
use gpecnet_core::blob::MAX_PAST;

use crate::boundary::{guard, non_null, read_points, write_points};
use crate::limits::GPECNET_MAX_SAMPLES;
use crate::status::{predict_status, GPECNET_E_BAD_LENGTH, GPECNET_E_CAPACITY_EXCEEDED};
use crate::status::{GPECNET_E_NULL_POINTER, GPECNET_E_WRONG_PAST_LENGTH};
use crate::storage::{state, GpecnetPredictor, Inner};

#[cfg(doc)]
use crate::{gpecnet_init, GpecnetModelInfo, GPECNET_E_NO_POINT_HEAD};

/// The model's past, copied out of C memory, after the length check.
///
/// # Safety
/// `past_xy` is NULL or valid for reads of `2·past_len` floats.
unsafe fn past(
    pred: &Inner,
    past_xy: *const f32,
    past_len: usize,
) -> Result<[[f32; 2]; MAX_PAST], i32> {
    if past_xy.is_null() {
        return Err(GPECNET_E_NULL_POINTER);
    }
    let expected = pred.model().config().past_len as usize;
    if past_len != expected || past_len > MAX_PAST {
        return Err(GPECNET_E_WRONG_PAST_LENGTH);
    }
    // SAFETY: non-null, past_len <= MAX_PAST, and the caller guarantees the floats.
    Ok(unsafe { read_points::<MAX_PAST>(past_xy, past_len) })
}

/// The predictor in `p` and the observed track at `past_xy`: the preamble of
/// every prediction entry point.
///
/// # Safety
/// As [`state`] for `p` and [`past`] for `past_xy`.
unsafe fn track<'a>(
    p: *mut GpecnetPredictor,
    past_xy: *const f32,
    past_len: usize,
) -> Result<(&'a mut Inner, [[f32; 2]; MAX_PAST]), i32> {
    // SAFETY: the caller's contract on `p`.
    let pred = unsafe { state(p) }?;
    // SAFETY: the caller's contract on `past_xy`.
    let past = unsafe { past(pred, past_xy, past_len) }?;
    Ok((pred, past))
}

/// The model's deterministic point forecast: `future_len` points (x, y
/// interleaved, the last one the endpoint) into `out_xy`, which has room for
/// `out_cap` points; `*out_len` receives the number written.
///
/// `past_xy` holds `past_len` observed (x, y) points, oldest first, in any
/// units (the model's training units; SDD: pixels). Fails with
/// [`GPECNET_E_NO_POINT_HEAD`] for a model without a point head,
/// [`GPECNET_E_BAD_LENGTH`] when `out_cap < future_len`. Nothing is written to
/// `out_xy` on failure.
///
/// # Safety
/// `p` is NULL or a storage passed to [`gpecnet_init`]; `past_xy` is NULL or
/// valid for `2·past_len` floats; `out_xy` is NULL or valid for `2·out_cap`
/// floats; `out_len` is NULL or valid for a write. Buffers may overlap.
#[no_mangle]
pub unsafe extern "C" fn gpecnet_predict_point(
    p: *mut GpecnetPredictor,
    past_xy: *const f32,
    past_len: usize,
    out_xy: *mut f32,
    out_cap: usize,
    out_len: *mut usize,
) -> i32 {
    guard(|| {
        non_null(out_xy)?;
        non_null(out_len)?;
        // SAFETY: the caller's contract on `p` and `past_xy`.
        let (pred, past) = unsafe { track(p, past_xy, past_len) }?;
        let t = pred
            .predict_point(past.get(..past_len).unwrap_or(&[]))
            .map_err(predict_status)?;
        if t.len() > out_cap {
            return Err(GPECNET_E_BAD_LENGTH);
        }
        // SAFETY: non-null, room for out_cap >= t.len() points; out_len is
        // non-null and writable (caller's contract).
        unsafe {
            write_points(out_xy, &t);
            out_len.write_unaligned(t.len());
        }
        Ok(())
    })
}

/// The model's endpoint set: `k` endpoints (x, y interleaved) into `out_xy`
/// (room for `k` points), from the latent stream seeded with `seed`. Plain
/// latent samples, or — when the blob asks for test-time sampling — the
/// k-means reduction of its `tts_samples` samples (`weights/FORMAT.md`).
/// Identical, bit for bit, to the core's `Predictor::predict_endpoint_set`
/// and to the trainer's golden files. Needs at most [`GPECNET_MAX_SAMPLES`]
/// samples ([`GpecnetModelInfo::max_endpoints`]). Nothing is written on failure.
///
/// # Safety
/// As [`gpecnet_predict_point`]; `out_xy` is NULL or valid for `2·k` floats.
#[no_mangle]
pub unsafe extern "C" fn gpecnet_predict_endpoints(
    p: *mut GpecnetPredictor,
    past_xy: *const f32,
    past_len: usize,
    seed: u64,
    out_xy: *mut f32,
    k: usize,
) -> i32 {
    guard(|| {
        non_null(out_xy)?;
        // SAFETY: the caller's contract on `p` and `past_xy`.
        let (pred, past) = unsafe { track(p, past_xy, past_len) }?;
        let mut ends = [[0.0f32; 2]; GPECNET_MAX_SAMPLES];
        // k endpoints never need fewer than k samples: k > the buffer is a capacity error.
        let out = ends.get_mut(..k).ok_or(GPECNET_E_CAPACITY_EXCEEDED)?;
        pred.predict_endpoint_set::<GPECNET_MAX_SAMPLES>(
            past.get(..past_len).unwrap_or(&[]),
            seed,
            out,
        )
        .map_err(predict_status)?;
        // SAFETY: non-null, room for k points (caller's contract).
        unsafe { write_points(out_xy, out) };
        Ok(())
    })
}

/// What a planner gets besides the endpoints, for [`gpecnet_predict_forecast`].
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GpecnetPlanner {
    /// 1 when the probabilities are the model's own (a model with endpoint
    /// probabilities, format version 6); 0 when they are `1/k` each and there
    /// are no radii.
    pub learned: u32,
    /// 1 when `point_xy` holds the point forecast's endpoint, else 0.
    pub has_point: u32,
    /// The point forecast's endpoint (x, y), the centre of the radii.
    pub point_xy: [f32; 2],
    /// The true endpoint lies within `r50` of `point_xy` in about half of the
    /// windows (0 when `learned` is 0).
    pub r50: f32,
    /// ... and within `r90` in about nine of ten (0 when `learned` is 0).
    pub r90: f32,
}

/// What a planner needs in one call: the model's endpoint set of `k`
/// endpoints (as [`gpecnet_predict_endpoints`]) into `out_xy`, their
/// probabilities into `out_probs` (`k` floats summing to 1), and the point
/// forecast's endpoint with its radii `r50` / `r90` into `*out_planner`
/// (`gpecnet_core::planner`, `weights/FORMAT.md` "Format version 6"). A model
/// without probabilities gives `1/k` each and `learned = 0`. Identical, bit
/// for bit, to the core's `Predictor::predict_planner`. Nothing is written on
/// failure.
///
/// # Safety
/// As [`gpecnet_predict_endpoints`]; `out_probs` is NULL or valid for `k`
/// floats; `out_planner` is NULL or valid for a write.
#[no_mangle]
pub unsafe extern "C" fn gpecnet_predict_forecast(
    p: *mut GpecnetPredictor,
    past_xy: *const f32,
    past_len: usize,
    seed: u64,
    out_xy: *mut f32,
    out_probs: *mut f32,
    k: usize,
    out_planner: *mut GpecnetPlanner,
) -> i32 {
    guard(|| {
        non_null(out_xy)?;
        non_null(out_probs)?;
        non_null(out_planner)?;
        // SAFETY: the caller's contract on `p` and `past_xy`.
        let (pred, past) = unsafe { track(p, past_xy, past_len) }?;
        let past = past.get(..past_len).unwrap_or(&[]);
        let mut ends = [[0.0f32; 2]; GPECNET_MAX_SAMPLES];
        let out = ends.get_mut(..k).ok_or(GPECNET_E_CAPACITY_EXCEEDED)?;
        let mut probs = [0.0f32; GPECNET_MAX_SAMPLES];
        let probs = probs.get_mut(..k).ok_or(GPECNET_E_CAPACITY_EXCEEDED)?;
        let got = pred
            .predict_planner::<GPECNET_MAX_SAMPLES>(past, seed, out, probs)
            .map_err(predict_status)?;
        let (learned, radii) = (got.learned, got.radii);
        let point = got.point.and_then(|t| t.last().copied());
        let planner = GpecnetPlanner {
            learned: learned.into(),
            has_point: point.is_some().into(),
            point_xy: point.unwrap_or([0.0; 2]),
            r50: radii.map_or(0.0, |r| r.r50),
            r90: radii.map_or(0.0, |r| r.r90),
        };
        // SAFETY: non-null; room for k points, k floats and one struct (caller's contract).
        unsafe {
            write_points(out_xy, out);
            for (i, &v) in probs.iter().enumerate() {
                out_probs.add(i).write_unaligned(v);
            }
            out_planner.write_unaligned(planner);
        }
        Ok(())
    })
}
