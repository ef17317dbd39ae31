//! Units: the `GPECNET_UNIT_*` values a caller declares for its positions
//! (`gpecnet_init_units`) and the `GPECNET_POSITION_*` values a blob records
//! for its model ([`GpecnetModelInfo::unit`]).
#[cfg(doc)]
use crate::GpecnetModelInfo;

/// Declared unit: whatever the model takes, unchecked (the only choice for
/// blobs before format 4).
pub const GPECNET_UNIT_MODEL: u32 = 0;
/// Declared unit: metres in a ground-plane frame.
pub const GPECNET_UNIT_METRES: u32 = 1;
/// Declared unit: the pixels of the camera(s) a pixel model was trained on.
pub const GPECNET_UNIT_PIXELS: u32 = 2;
/// Declared unit: pixels of a camera whose metres per pixel are given.
pub const GPECNET_UNIT_SCALED_PIXELS: u32 = 3;

/// A model's recorded unit ([`GpecnetModelInfo::unit`]): not recorded.
pub const GPECNET_POSITION_UNKNOWN: u32 = 0;
/// A model's recorded unit: metres.
pub const GPECNET_POSITION_METRE: u32 = 1;
/// A model's recorded unit: image pixels.
pub const GPECNET_POSITION_PIXEL: u32 = 2;
