//! Any byte string given to the blob reader: `Ok` or a typed error, never a
//! panic; whatever is accepted must predict without panicking.
//!
//! `cd core/fuzz && RUSTC_BOOTSTRAP=1 cargo fuzz run blob -- -max_total_time=60`
#![no_main]

use gpecnet_core::fixed::FixedPredictor;
use gpecnet_core::{FastSine, LibmSine, Model, NumericKind, Predictor};
use libfuzzer_sys::fuzz_target;

const PAST: [[f32; 2]; 8] = [
    [10.0, 20.0],
    [11.0, 21.0],
    [12.5, 22.0],
    [14.0, 23.5],
    [15.0, 25.0],
    [16.5, 26.0],
    [18.0, 27.5],
    [19.0, 29.0],
];

fuzz_target!(|data: &[u8]| {
    let Ok(model) = Model::from_blob(data) else { return };
    let past = &PAST[..(model.config().past_len as usize).min(8)];
    match model.numeric() {
        NumericKind::F32 => {
            if let Ok(mut p) = Predictor::<LibmSine, 256>::new(&model) {
                let _ = p.predict_endpoints::<4>(past, 1, 4);
                let _ = p.predict_trajectories::<2>(past, 1, 2);
            }
            if let Ok(mut p) = Predictor::<FastSine, 256>::new(&model) {
                let _ = p.predict_endpoints::<4>(past, 1, 4);
            }
        }
        _ => {
            if let Ok(mut p) = FixedPredictor::<256>::new(&model) {
                let _ = p.predict_endpoints::<4>(past, 1, 4);
            }
        }
    }
});
