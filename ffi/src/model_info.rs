//! Model information: [`gpecnet_model_info`] fills a [`GpecnetModelInfo`]
//! with what the predictor's blob holds and how the predictor converts units.
use core::ffi::c_char;

use gpecnet_core::blob::PositionUnit;

use crate::boundary::{c_name, guard, non_null};
use crate::limits::{GPECNET_MAX_SAMPLES, GPECNET_NAME_LEN};
use crate::numeric::{GPECNET_NUMERIC_F32, GPECNET_NUMERIC_Q15};
use crate::storage::{state, GpecnetPredictor};
use crate::units::{GPECNET_POSITION_METRE, GPECNET_POSITION_PIXEL, GPECNET_POSITION_UNKNOWN};

#[cfg(doc)]
use crate::GPECNET_SCRATCH_WIDTH;
#[cfg(doc)]
use crate::{gpecnet_predict_endpoints, gpecnet_predict_forecast, gpecnet_predict_point};

/// What a blob holds, for [`gpecnet_model_info`].
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GpecnetModelInfo {
    /// [`GPECNET_NUMERIC_F32`] or [`GPECNET_NUMERIC_Q15`].
    pub numeric: u32,
    /// Observed steps `gpecnet_predict_*` expect (`past_len`).
    pub past_len: u32,
    /// Points of a point forecast (the last is the endpoint).
    pub future_len: u32,
    /// Scratch width the model needs (at most [`GPECNET_SCRATCH_WIDTH`] here).
    pub scratch_width: u32,
    /// Test-time samples of the endpoint protocol (0: plain latent samples).
    pub tts_samples: u32,
    /// Most endpoints [`gpecnet_predict_endpoints`] gives (every `k` in
    /// `1..=max_endpoints` is accepted): `min(tts_samples, 64)` with test-time
    /// sampling (k-means gives at most 64 centres), `min(K, GPECNET_MAX_SAMPLES)`
    /// for a model with a learned proposal of K latents, [`GPECNET_MAX_SAMPLES`]
    /// for plain sampling.
    pub max_endpoints: u32,
    /// 1 when [`gpecnet_predict_point`] is available, else 0.
    pub has_point_head: u32,
    /// 1 when the model has a trajectory predictor network, else 0.
    pub has_predictor: u32,
    /// CRC-32 of the blob (as golden files record it).
    pub crc: u32,
    /// The model's name, NUL-terminated, cut to fit.
    pub name: [c_char; GPECNET_NAME_LEN],
    /// The unit of the model's positions (`GPECNET_POSITION_*`).
    pub unit: u32,
    /// Seconds between consecutive history and forecast positions (0.4 for
    /// the shipped models); 0 when the blob does not record it (format < 4).
    pub period_s: f32,
    /// For a pixel model of one ground scale, its metres per pixel; else 0.
    pub metres_per_pixel: f32,
    /// The factor this predictor converts the caller's positions with
    /// (model = caller · factor; 1 when none).
    pub unit_factor: f32,
    /// 1 when the model gives learned endpoint probabilities and radii
    /// ([`gpecnet_predict_forecast`]), else 0.
    pub has_probabilities: u32,
}

/// Fills `*out` with what the predictor's blob holds.
///
/// # Safety
/// `p` as in [`gpecnet_predict_point`]; `out` is NULL or valid for a write.
#[no_mangle]
pub unsafe extern "C" fn gpecnet_model_info(
    p: *mut GpecnetPredictor,
    out: *mut GpecnetModelInfo,
) -> i32 {
    guard(|| {
        non_null(out)?;
        // SAFETY: the caller's contract on `p`.
        let pred = unsafe { state(p) }?;
        let m = pred.model();
        let ext = m.extensions();
        let max_endpoints = gpecnet_core::sampling::max_endpoints_of(m, GPECNET_MAX_SAMPLES) as u32;
        let info = GpecnetModelInfo {
            numeric: match m.numeric() {
                gpecnet_core::NumericKind::F32 => GPECNET_NUMERIC_F32,
                gpecnet_core::NumericKind::Int16Q15 => GPECNET_NUMERIC_Q15,
            },
            past_len: m.config().past_len.into(),
            future_len: m.config().future_len.into(),
            scratch_width: u32::try_from(m.scratch_width()).unwrap_or(u32::MAX),
            tts_samples: ext.tts_samples.into(),
            max_endpoints,
            has_point_head: m.has_point_head().into(),
            has_predictor: m.has_predictor().into(),
            crc: m.crc(),
            name: c_name(m.name()),
            unit: match m.unit() {
                PositionUnit::Metre => GPECNET_POSITION_METRE,
                PositionUnit::Pixel => GPECNET_POSITION_PIXEL,
                _ => GPECNET_POSITION_UNKNOWN,
            },
            period_s: m.period_s().unwrap_or(0.0),
            metres_per_pixel: m.metres_per_pixel().unwrap_or(0.0),
            unit_factor: pred.units().factor(),
            has_probabilities: m.has_probabilities().into(),
        };
        // SAFETY: non-null, writable (caller's contract).
        unsafe { out.write_unaligned(info) };
        Ok(())
    })
}
