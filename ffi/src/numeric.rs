//! The numeric kinds of a blob, as [`GpecnetModelInfo::numeric`] reports them.
#[cfg(doc)]
use crate::GpecnetModelInfo;

/// [`GpecnetModelInfo::numeric`] of an f32 blob.
pub const GPECNET_NUMERIC_F32: u32 = 0;
/// [`GpecnetModelInfo::numeric`] of a fixed-point (int16/Q15) blob.
pub const GPECNET_NUMERIC_Q15: u32 = 1;
