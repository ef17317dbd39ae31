//! The sizes and limits the header publishes: the caller's storage for a
//! predictor and its alignment, the scratch width, the most samples,
//! observed steps, predicted steps, name bytes and golden endpoints one call
//! handles, and the online forecaster's fixed shape and storage (each
//! checked against the core's own limit where it has one).
use gpecnet_core::blob::{MAX_FUTURE, MAX_PAST};

#[cfg(doc)]
use crate::{gpecnet_golden_case, gpecnet_init, GpecnetModelInfo, GPECNET_E_CAPACITY_EXCEEDED};

/// Bytes of caller storage [`gpecnet_init`] needs on a 32-bit target
/// (Cortex-M: 4,456 B used today; the header picks the value by `UINTPTR_MAX`).
#[cfg(target_pointer_width = "32")]
pub const GPECNET_PREDICTOR_SIZE: usize = 4480;
/// Bytes of caller storage [`gpecnet_init`] needs on a 64-bit target
/// (x86-64: 6,216 B used today; the header picks the value by `UINTPTR_MAX`).
#[cfg(target_pointer_width = "64")]
pub const GPECNET_PREDICTOR_SIZE: usize = 6272;
/// Alignment of that storage, in bytes.
pub const GPECNET_PREDICTOR_ALIGN: usize = 8;
/// Scratch width of the predictor: models wider than this are refused.
pub const GPECNET_SCRATCH_WIDTH: usize = 128;
/// Most latent samples one endpoint set may draw (the endpoints of plain
/// sampling, or the blob's test-time samples): larger sets are refused with
/// [`GPECNET_E_CAPACITY_EXCEEDED`].
pub const GPECNET_MAX_SAMPLES: usize = 128;
/// Most observed steps a model may have.
pub const GPECNET_MAX_PAST: usize = 16;
/// Most predicted steps a model may have.
pub const GPECNET_MAX_FUTURE: usize = 32;
/// Bytes of [`GpecnetModelInfo::name`] (the name is cut to fit, NUL included).
pub const GPECNET_NAME_LEN: usize = 32;
/// Most endpoints per case a golden file may hold for [`gpecnet_golden_case`].
pub const GPECNET_GOLDEN_MAX_K: usize = 64;

/// Tracks one forecaster follows at once (the core's `Forecaster<N, P>`'s
/// `N`): a 17th new id in a frame is refused and counted, as in the track table.
pub const GPECNET_ONLINE_TRACKS: usize = 16;
/// Forecasts per track a forecaster keeps waiting for their truth (the
/// core's `P`): with 2, one forecast every 6 grid steps (2.4 s) per track is
/// scored, at every horizon.
pub const GPECNET_ONLINE_PENDING: usize = 2;
/// Most endpoints of one track's forecast (the core's `K`: the shipped
/// models' 20; a model that gives more is cut to 20).
pub const GPECNET_ONLINE_ENDPOINTS: usize = 20;
/// Steps of one forecast the online loop scores and calibrates (0.4 s each:
/// 4.8 s ahead).
pub const GPECNET_ONLINE_HORIZONS: usize = 12;
/// Experts of the online point forecast: the model's point head, then
/// constant velocity over the last 1, 2 and 4 steps.
pub const GPECNET_ONLINE_EXPERTS: usize = 4;
/// Motion states with calibrations of their own (`GPECNET_MOTION_*`).
pub const GPECNET_ONLINE_MOTION_STATES: usize = 4;
/// Bytes of a forecaster's calibration state (`gpecnet_forecaster_state`):
/// a header, the multipliers and losses, the feedback counts and a CRC-32.
pub const GPECNET_ONLINE_STATE_LEN: usize = 1184;
/// Most detections one `gpecnet_forecaster_frame` call applies in one
/// piece (more are applied in pieces of this many, each a continuation of
/// the frame at the same time).
pub const GPECNET_ONLINE_MAX_DETECTIONS: usize = 64;
/// Bytes of caller storage `gpecnet_forecaster_init` needs: an upper bound
/// on every target (x86-64: 11,056 B used today; 32-bit targets need less,
/// and a build where it does not fit fails to compile);
/// `gpecnet_forecaster_size` gives the exact size.
pub const GPECNET_FORECASTER_SIZE: usize = 11264;
/// Alignment of that storage, in bytes.
pub const GPECNET_FORECASTER_ALIGN: usize = 8;

// The header's literals are the core's limits.
const _: () = {
    assert!(GPECNET_MAX_PAST == MAX_PAST);
    assert!(GPECNET_MAX_FUTURE == MAX_FUTURE);
    assert!(GPECNET_MAX_SAMPLES <= gpecnet_core::blob::MAX_TTS_SAMPLES);
    assert!(GPECNET_ONLINE_HORIZONS == gpecnet_core::online::HORIZONS);
    assert!(GPECNET_ONLINE_EXPERTS == gpecnet_core::online::EXPERTS);
    assert!(GPECNET_ONLINE_MOTION_STATES == gpecnet_core::online::BINS);
    assert!(GPECNET_ONLINE_STATE_LEN == gpecnet_core::online::STATE_LEN);
    assert!(GPECNET_ONLINE_ENDPOINTS <= GPECNET_MAX_SAMPLES);
};
