//! Units at the integration surface: the unit a caller's positions are in,
//! checked against the model's, and the one conversion between them.
//!
//! A model takes and returns positions in the unit it was trained in
//! ([`Model::unit`]: metres, or the image pixels of its cameras). Numbers in
//! another unit give numbers out, not an error, so a predictor built with
//! [`Predictor::with_units`](crate::Predictor::with_units) is told the
//! caller's unit ([`CallerUnit`]) and refuses, at construction, any pairing
//! it cannot convert ([`UnitError`]).
//!
//! # The rules
//!
//! | model \ caller | `Metres` | `Pixels` | `ScaledPixels { s }` | `ModelUnit` |
//! |---|---|---|---|---|
//! | metre | as is | [`UnitError::Mismatch`] | factor `s` | as is |
//! | pixel, one scale `m` | factor `1 / m` | as is | factor `s / m` | as is |
//! | pixel, several scales | [`UnitError::NoModelScale`] | as is | [`UnitError::NoModelScale`] | as is |
//! | unknown (format < 4) | [`UnitError::UnknownModelUnit`] | the same | the same | as is |
//!
//! `CallerUnit::ModelUnit` is the explicit opt-in: "my positions are in
//! whatever the model takes"; it is the only way to use a blob that does
//! not record its unit (format versions 1–3), and what
//! [`Predictor::new`](crate::Predictor::new) assumes.
//!
//! # The conversion, exactly
//!
//! A factor `f` (an f32) is computed once, at construction, as the table
//! says (`1 / m` and `s / m` are one correctly rounded f32 division each).
//! `s`, `m` and `f` must be finite and within [[`MIN_SCALE`],
//! [`MAX_SCALE`]], else [`UnitError::BadScale`]. When `f` is exactly 1 the
//! positions pass untouched (the bits of [`Predictor::new`](crate::Predictor::new)).
//! Otherwise every input coordinate `x` becomes `x · f` (one f32 product)
//! before the model sees it, and every output coordinate `y` (endpoints,
//! trajectories, the point forecast) becomes `y / f` (one f32 division)
//! before the caller sees it. An input whose product is not finite is
//! [`crate::PredictError::InputOutOfRange`]; outputs stay finite (the model's
//! outputs are bounded by [`crate::frame::MAX_OUTPUT`] and `f ≥ MIN_SCALE`).
//! The endpoint set's k-means reduction runs in the model's unit, before the
//! conversion.
//!
//! A downward-looking camera at altitude `h` (metres) with focal length `F`
//! and pixel pitch `p` (both in metres, or `F` in pixels and `p = 1`) sees
//! `s = h · p / F` metres per pixel on flat ground.
//!
//! ```
//! # let blob = include_bytes!("../../weights/sdd-m-tiny-qe.gpec");
//! use gpecnet_core::units::{CallerUnit, UnitError};
//! use gpecnet_core::{Error, LibmSine, Model, Predictor};
//!
//! let model = Model::from_blob(blob)?; // a metric model
//! // Metres in, metres out.
//! let _p = Predictor::<LibmSine, 128>::with_units(model, CallerUnit::Metres)?;
//! // Pixels of a camera 40 m up with a 1,000-pixel focal length: 0.04 m/px.
//! let cam = CallerUnit::ScaledPixels { metres_per_pixel: 0.04 };
//! let _p = Predictor::<LibmSine, 128>::with_units(model, cam)?;
//! // Pixels of an unknown camera: refused.
//! let e = Predictor::<LibmSine, 128>::with_units(model, CallerUnit::Pixels).err();
//! assert!(matches!(e, Some(Error::Unit(UnitError::Mismatch { .. }))));
//! # Ok::<(), Error>(())
//! ```

use core::fmt;

use crate::blob::{Model, PositionUnit};

/// The smallest scale or conversion factor accepted (1 µm per pixel).
pub const MIN_SCALE: f32 = 1e-6;
/// The largest scale or conversion factor accepted.
pub const MAX_SCALE: f32 = 1e6;

/// The unit of the positions a caller passes to a predictor and gets back.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum CallerUnit {
    /// Metres in a ground-plane frame (any origin and orientation).
    Metres,
    /// Image pixels of the camera(s) a pixel model was trained on.
    Pixels,
    /// Image pixels of a camera whose ground scale is known, e.g. a
    /// downward-looking camera at a known altitude.
    ScaledPixels {
        /// Metres per pixel on the ground (finite, in
        /// [[`MIN_SCALE`], [`MAX_SCALE`]]).
        metres_per_pixel: f32,
    },
    /// Whatever the model takes, unchecked: the explicit opt-in for blobs
    /// that do not record their unit.
    ModelUnit,
}

/// Why a caller's unit cannot be used with a model.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum UnitError {
    /// The blob does not record its unit (format version < 4): declare
    /// [`CallerUnit::ModelUnit`] to use it as it is.
    UnknownModelUnit,
    /// The caller's unit is not the model's and there is no scale to
    /// convert with: metres into a pixel model of unstated scale or, for a
    /// metre model, pixels without [`CallerUnit::ScaledPixels`].
    Mismatch {
        /// The model's unit.
        model: PositionUnit,
        /// The caller's unit.
        caller: PositionUnit,
    },
    /// A pixel model trained on cameras of several ground scales (the SDD
    /// pixel models) takes only its own pixels: metres or another camera's
    /// pixels have no single conversion into them.
    NoModelScale,
    /// A metres-per-pixel value, or the conversion factor made of it, is
    /// not finite or outside [[`MIN_SCALE`], [`MAX_SCALE`]].
    BadScale,
}

impl fmt::Display for UnitError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            UnitError::UnknownModelUnit => f.write_str(
                "the model does not record its unit (blob format < 4): declare the model's own unit to use it",
            ),
            UnitError::Mismatch { model, caller } => write!(
                f,
                "positions in {} cannot go into a model in {} (state the camera's metres per pixel)",
                caller.suffix(),
                model.suffix()
            ),
            UnitError::NoModelScale => f.write_str(
                "the pixel model has no single ground scale: it takes only its own cameras' pixels",
            ),
            UnitError::BadScale => f.write_str(
                "metres per pixel (or the conversion factor) not finite or outside [1e-6, 1e6]",
            ),
        }
    }
}

impl core::error::Error for UnitError {}

/// The conversion between a caller's positions and a model's (the module's
/// rules): a factor `f`, 1 for none.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Conversion {
    factor: f32,
}

/// `v` when finite and within [[`MIN_SCALE`], [`MAX_SCALE`]].
fn scale(v: f32) -> Result<f32, UnitError> {
    if (MIN_SCALE..=MAX_SCALE).contains(&v) {
        Ok(v)
    } else {
        Err(UnitError::BadScale)
    }
}

impl Conversion {
    /// No conversion: the caller's positions are the model's.
    pub const IDENTITY: Conversion = Conversion { factor: 1.0 };

    /// The conversion for a caller in `caller` units to `model` (the
    /// module's table), or why there is none.
    pub fn new(model: &Model<'_>, caller: CallerUnit) -> Result<Self, UnitError> {
        let factor = match (model.unit(), caller) {
            (_, CallerUnit::ModelUnit) => 1.0,
            (PositionUnit::Metre, CallerUnit::Metres)
            | (PositionUnit::Pixel, CallerUnit::Pixels) => 1.0,
            (PositionUnit::Metre, CallerUnit::ScaledPixels { metres_per_pixel }) => {
                scale(metres_per_pixel)?
            }
            (PositionUnit::Metre, CallerUnit::Pixels) => {
                return Err(UnitError::Mismatch {
                    model: PositionUnit::Metre,
                    caller: PositionUnit::Pixel,
                })
            }
            (PositionUnit::Pixel, CallerUnit::Metres) => {
                let m = model.metres_per_pixel().ok_or(UnitError::NoModelScale)?;
                scale(1.0 / scale(m)?)?
            }
            (PositionUnit::Pixel, CallerUnit::ScaledPixels { metres_per_pixel }) => {
                let s = scale(metres_per_pixel)?;
                let m = model.metres_per_pixel().ok_or(UnitError::NoModelScale)?;
                scale(s / scale(m)?)?
            }
            _ => return Err(UnitError::UnknownModelUnit),
        };
        Ok(Conversion { factor })
    }

    /// The factor `f`: model position = caller position · `f`.
    pub fn factor(&self) -> f32 {
        self.factor
    }

    /// `true` when positions pass untouched (`f` = 1).
    pub fn is_identity(&self) -> bool {
        self.factor == 1.0
    }
}
