//! Which unit a blob works in, checked against a data set's before anything runs: a metre
//! model on pixel data (or the reverse) would give numbers with no meaning and no error.

use gpecnet_core::blob::{Meta, PositionUnit};

use crate::{DatasetSpec, Unit};

/// Why a blob may not be run on a data set: its positions are in another unit.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum UnitError {
    /// The blob states a unit (format version 4) other than the data set's.
    #[error(
        "model {model:?} takes and returns {} but the {dataset} data set is in {}: refusing \
         (every number would be meaningless); use a model in {} or a data set in {}",
        .blob.words(), .data.words(), .data.words(), .blob.words()
    )]
    Mismatch {
        /// The blob's model name.
        model: String,
        /// The blob's unit.
        blob: Unit,
        /// The data set.
        dataset: String,
        /// The data set's unit.
        data: Unit,
    },
    /// The blob's clock (seconds between positions, format version 4) is not the data's.
    #[error(
        "model {model:?} steps {blob_s} s between positions but the {dataset} data set is \
         windowed at {data_s} s: refusing (its forecast horizon and every velocity would be \
         wrong); use a model trained at {data_s} s"
    )]
    Clock {
        /// The blob's model name.
        model: String,
        /// The blob's period.
        blob_s: f32,
        /// The data set.
        dataset: String,
        /// The data's period ([`crate::PERIOD_S`]).
        data_s: f32,
    },
    /// A blob before format version 4 (no unit recorded) on a metre data set.
    #[error(
        "model {model:?} does not state its unit (blob format before version 4; every such \
         shipped model is in SDD image pixels) and the {dataset} data set is in metres: \
         refusing; pass --assume-unit m only if this blob was trained in metres"
    )]
    Unstated {
        /// The blob's model name.
        model: String,
        /// The data set.
        dataset: String,
    },
}

/// The unit `model` (whose blob says `meta`) works in, checked against `spec`'s: a stated unit must match; an
/// unstated one (blobs before format version 4) is taken from `assume`, else as pixels on a
/// pixel data set (what every such shipped blob is) and refused on a metre one. A stated
/// clock must be the data's too ([`check_clock`]).
pub fn check_unit(
    model: &gpecnet_core::Model<'_>,
    meta: &Meta<'_>,
    spec: &DatasetSpec,
    assume: Option<Unit>,
) -> std::result::Result<Unit, UnitError> {
    check_clock(model, meta, spec)?;
    let data = spec.unit();
    let stated = match meta.unit {
        PositionUnit::Metre => Some(Unit::Metres),
        PositionUnit::Pixel => Some(Unit::Pixels),
        _ => None,
    };
    let unit = match (stated, assume) {
        (Some(u), _) => u,
        (None, Some(a)) => a,
        (None, None) if data == Unit::Pixels => Unit::Pixels,
        (None, None) => {
            return Err(UnitError::Unstated {
                model: model.name().to_string(),
                dataset: spec.to_string(),
            })
        }
    };
    if unit != data || assume.is_some_and(|a| a != unit) {
        return Err(UnitError::Mismatch {
            model: model.name().to_string(),
            blob: if unit != data {
                unit
            } else {
                assume.unwrap_or(unit)
            },
            dataset: spec.to_string(),
            data,
        });
    }
    Ok(unit)
}

/// Every data set is windowed at [`crate::PERIOD_S`] (a folder's own clock must divide it):
/// a blob that states another period (format version 4) is refused. A blob that states none
/// (before version 4) was trained at that period, as every such shipped blob was.
pub fn check_clock(
    model: &gpecnet_core::Model<'_>,
    meta: &Meta<'_>,
    spec: &DatasetSpec,
) -> std::result::Result<(), UnitError> {
    let data_s = crate::PERIOD_S;
    let stated = meta.period_s;
    // The blob stores the period as f32: equal to the data's up to rounding, or refused.
    let differs = stated.is_nan() || (stated != 0.0 && (stated - data_s).abs() > 1e-6 * data_s);
    if differs {
        return Err(UnitError::Clock {
            model: model.name().to_string(),
            blob_s: stated,
            dataset: spec.to_string(),
            data_s,
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    static PIXEL_V3: &[u8] = include_bytes!("../../../weights/sdd-tiny-v2-qe.gpec");
    static METRE_V4: &[u8] = include_bytes!("../../../weights/sdd-m-tiny-qe.gpec");

    fn check(blob: &[u8], spec: &DatasetSpec, assume: Option<Unit>) -> Result<Unit, UnitError> {
        let m = gpecnet_core::Model::from_blob(blob).unwrap();
        check_unit(&m, &Meta::of_blob(blob).unwrap(), spec, assume)
    }

    #[test]
    fn units_must_match_before_anything_runs() {
        let zara1 = DatasetSpec::EthUcy("zara1".into());
        // The metric model on metre data, the pixel model on pixel data.
        assert_eq!(check(METRE_V4, &zara1, None), Ok(Unit::Metres));
        assert_eq!(
            check(METRE_V4, &DatasetSpec::SddMetres, None),
            Ok(Unit::Metres)
        );
        assert_eq!(check(PIXEL_V3, &DatasetSpec::Sdd, None), Ok(Unit::Pixels));
        // The pixel default (format 3, no unit recorded) on metre data: refused.
        let e = check(PIXEL_V3, &zara1, None).unwrap_err();
        assert!(matches!(e, UnitError::Unstated { .. }), "{e}");
        assert!(e.to_string().contains("--assume-unit"), "{e}");
        // ... unless the caller says it was trained in metres.
        assert_eq!(
            check(PIXEL_V3, &zara1, Some(Unit::Metres)),
            Ok(Unit::Metres)
        );
        // A stated unit always wins over the data and over an assumption.
        let e = check(METRE_V4, &DatasetSpec::Sdd, None).unwrap_err();
        assert!(matches!(e, UnitError::Mismatch { .. }), "{e}");
        assert!(
            e.to_string().contains("metres") && e.to_string().contains("pixels"),
            "{e}"
        );
        assert!(check(METRE_V4, &zara1, Some(Unit::Pixels)).is_err());
        assert!(check(PIXEL_V3, &DatasetSpec::Sdd, Some(Unit::Metres)).is_err());
    }
}
