//! The sizes and limits the header publishes: the caller's storage for a
//! predictor and its alignment, the scratch width, and the most samples,
//! observed steps, predicted steps, name bytes and golden endpoints one call
//! handles (each checked against the core's own limit where it has one).
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

// The header's literals are the core's limits.
const _: () = {
    assert!(GPECNET_MAX_PAST == MAX_PAST);
    assert!(GPECNET_MAX_FUTURE == MAX_FUTURE);
    assert!(GPECNET_MAX_SAMPLES <= gpecnet_core::blob::MAX_TTS_SAMPLES);
};
