//! Units at the predictor's surface (`gpecnet_core::units`): every pairing of
//! a model's recorded unit with a caller's declared one, on shipped blobs of
//! both numeric kinds and on written test blobs, and the conversion's exact
//! arithmetic (`x · f` in, `y / f` out) bit for bit.
use crate::common;

use gpecnet_core::blob::{Meta, PositionUnit};
use gpecnet_core::tracks::period_ms_of;
use gpecnet_core::units::{CallerUnit, Conversion, UnitError, MAX_SCALE, MIN_SCALE};
use gpecnet_core::{Error, LibmSine, Model, PredictError, Predictor};

const METRIC_Q: &[u8] = include_bytes!("../../weights/sdd-m-tiny-qe.gpec");
const METRIC_F: &[u8] = include_bytes!("../../weights/sdd-m-tiny.gpec");
const PIXEL_OLD: &[u8] = include_bytes!("../../weights/sdd-tiny-v2-qe.gpec");

type P = Predictor<'static, LibmSine, 128>;

fn unit_err(blob: &'static [u8], unit: CallerUnit) -> Option<UnitError> {
    match P::with_units(Model::from_blob(blob).unwrap(), unit) {
        Ok(_) => None,
        Err(Error::Unit(e)) => Some(e),
        Err(other) => panic!("not a unit error: {other}"),
    }
}

/// A walk in metres (about 1.3 m/s, turning).
fn walk_m() -> [[f32; 2]; 8] {
    core::array::from_fn(|i| {
        let t = i as f32 * 0.4;
        [3.0 + 1.2 * t, -2.0 + 0.5 * t + 0.05 * t * t]
    })
}

#[test]
fn models_report_unit_and_period() {
    for blob in [METRIC_Q, METRIC_F] {
        let m = Model::from_blob(blob).unwrap();
        assert_eq!(m.unit(), PositionUnit::Metre);
        assert_eq!(m.period_s(), Some(0.4));
        assert_eq!(m.metres_per_pixel(), None);
        assert_eq!(period_ms_of(&m).map(|p| p.get()), Some(400));
        let meta = Meta::of_blob(blob).unwrap();
        assert_eq!((meta.unit, meta.period_s), (m.unit(), 0.4));
    }
    let old = Model::from_blob(PIXEL_OLD).unwrap();
    assert_eq!(old.unit(), PositionUnit::Unknown);
    assert_eq!((old.period_s(), period_ms_of(&old)), (None, None));
}

#[test]
fn metric_model_takes_metres_and_scaled_pixels_only() {
    for blob in [METRIC_Q, METRIC_F] {
        assert_eq!(unit_err(blob, CallerUnit::Metres), None);
        assert_eq!(unit_err(blob, CallerUnit::ModelUnit), None);
        assert_eq!(
            unit_err(blob, CallerUnit::Pixels),
            Some(UnitError::Mismatch {
                model: PositionUnit::Metre,
                caller: PositionUnit::Pixel
            })
        );
        let scaled = |s| CallerUnit::ScaledPixels {
            metres_per_pixel: s,
        };
        assert_eq!(unit_err(blob, scaled(0.04)), None);
        for bad in [
            0.0,
            -0.04,
            f32::NAN,
            f32::INFINITY,
            MIN_SCALE / 2.0,
            MAX_SCALE * 2.0,
        ] {
            assert_eq!(
                unit_err(blob, scaled(bad)),
                Some(UnitError::BadScale),
                "{bad}"
            );
        }
    }
}

#[test]
fn blob_without_unit_needs_the_explicit_opt_in() {
    for unit in [
        CallerUnit::Metres,
        CallerUnit::Pixels,
        CallerUnit::ScaledPixels {
            metres_per_pixel: 0.04,
        },
    ] {
        assert_eq!(unit_err(PIXEL_OLD, unit), Some(UnitError::UnknownModelUnit));
    }
    assert_eq!(unit_err(PIXEL_OLD, CallerUnit::ModelUnit), None);
}

/// Metres and another camera's pixels into pixel models: a pixel model with
/// one recorded scale converts both; one without (several cameras) refuses.
#[test]
fn pixel_models_convert_only_with_a_recorded_scale() {
    let meta = |mpp| Meta {
        unit: PositionUnit::Pixel,
        metres_per_pixel: mpp,
        period_s: 0.4,
        data: "test",
        licence: "",
    };
    let one: &'static [u8] = common::small_blob_with_meta(meta(0.05)).leak();
    let several: &'static [u8] = common::small_blob_with_meta(meta(0.0)).leak();
    let factor = |blob: &'static [u8], unit| {
        Conversion::new(&Model::from_blob(blob).unwrap(), unit).map(|c| c.factor())
    };
    assert_eq!(factor(one, CallerUnit::Pixels), Ok(1.0));
    assert_eq!(factor(one, CallerUnit::Metres), Ok(1.0 / 0.05f32));
    let scaled = CallerUnit::ScaledPixels {
        metres_per_pixel: 0.02,
    };
    assert_eq!(factor(one, scaled), Ok(0.02f32 / 0.05));
    assert_eq!(factor(several, CallerUnit::Pixels), Ok(1.0));
    assert_eq!(
        factor(several, CallerUnit::Metres),
        Err(UnitError::NoModelScale)
    );
    assert_eq!(factor(several, scaled), Err(UnitError::NoModelScale));
    // The same camera's pixels are no conversion at all.
    let same = CallerUnit::ScaledPixels {
        metres_per_pixel: 0.05,
    };
    assert!(Conversion::new(&Model::from_blob(one).unwrap(), same)
        .unwrap()
        .is_identity());
}

/// The conversion is exactly `x · f` before the model and `y / f` after it,
/// on every output path, for both numeric kinds.
#[test]
fn conversion_is_exact_on_every_path() {
    let s = 0.037f32;
    let px: [[f32; 2]; 8] = walk_m().map(|p| p.map(|v| v / s));
    let model_in: [[f32; 2]; 8] = px.map(|p| p.map(|v| v * s));
    let back = |p: [f32; 2]| p.map(|v| (v / s).to_bits());
    for blob in [METRIC_Q, METRIC_F] {
        let model = Model::from_blob(blob).unwrap();
        let unit = CallerUnit::ScaledPixels {
            metres_per_pixel: s,
        };
        let mut conv = P::with_units(model, unit).unwrap();
        let mut plain = P::new(model).unwrap();
        assert_eq!(conv.units().factor(), s);

        let (a, b) = (
            conv.predict_point(&px).unwrap(),
            plain.predict_point(&model_in).unwrap(),
        );
        assert_eq!(a.len(), b.len());
        for (a, b) in a.iter().zip(&b) {
            assert_eq!(a.map(f32::to_bits), back(*b));
        }

        let (mut ea, mut eb) = ([[0.0f32; 2]; 20], [[0.0f32; 2]; 20]);
        conv.predict_endpoint_set::<128>(&px, 5, &mut ea).unwrap();
        plain
            .predict_endpoint_set::<128>(&model_in, 5, &mut eb)
            .unwrap();
        for (a, b) in ea.iter().zip(&eb) {
            assert_eq!(a.map(f32::to_bits), back(*b));
        }

        let (mut sa, mut sb) = ([[0.0f32; 2]; 7], [[0.0f32; 2]; 7]);
        conv.predict_samples(&px, 9, &mut sa).unwrap();
        plain.predict_samples(&model_in, 9, &mut sb).unwrap();
        for (a, b) in sa.iter().zip(&sb) {
            assert_eq!(a.map(f32::to_bits), back(*b));
        }

        conv.start(&px, 11).unwrap();
        plain.start(&model_in, 11).unwrap();
        for _ in 0..3 {
            let (a, b) = (
                conv.next_endpoint().unwrap(),
                plain.next_endpoint().unwrap(),
            );
            assert_eq!(a.map(f32::to_bits), back(b));
        }
    }
}

#[test]
fn metres_into_the_metric_model_are_untouched() {
    let model = Model::from_blob(METRIC_Q).unwrap();
    let mut a = P::with_units(model, CallerUnit::Metres).unwrap();
    let mut b = P::new(model).unwrap();
    assert!(a.units().is_identity());
    let past = walk_m();
    assert_eq!(
        a.predict_point(&past).unwrap(),
        b.predict_point(&past).unwrap()
    );
}

#[test]
fn converted_inputs_are_still_checked() {
    let model = Model::from_blob(METRIC_Q).unwrap();
    let unit = CallerUnit::ScaledPixels {
        metres_per_pixel: MAX_SCALE,
    };
    let mut p = P::with_units(model, unit).unwrap();
    let mut past = walk_m();
    past[3] = [1e35, 0.0]; // finite, but not after scaling
    assert_eq!(p.predict_point(&past), Err(PredictError::InputOutOfRange));
    past[3] = [f32::NAN, 0.0];
    assert_eq!(p.predict_point(&past), Err(PredictError::NonFiniteInput));
    assert!(matches!(
        p.predict_point(&past[..5]),
        Err(PredictError::WrongPastLength { got: 5, .. })
    ));
    let long = [[0.0f32; 2]; 40];
    assert!(matches!(
        p.predict_point(&long),
        Err(PredictError::WrongPastLength { got: 40, .. })
    ));
}
