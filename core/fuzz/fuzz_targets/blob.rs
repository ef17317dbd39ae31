//! Any byte string given to the blob reader: `Ok` or a typed error, never a
//! panic; whatever is accepted must predict without panicking.
//!
//! `cd core/fuzz && RUSTC_BOOTSTRAP=1 cargo fuzz run blob -- -max_total_time=60`
#![no_main]

use gpecnet_core::{FastSine, LibmSine, Model, Predictor, Sine, Trajectory};
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

/// Every prediction entry point of `p` (errors are fine, panics are not).
fn exercise<S: Sine>(p: &mut Predictor<'_, S, 256>, past: &[[f32; 2]]) {
    let mut ends = [[0.0f32; 2]; 4];
    let _ = p.predict_samples(past, 1, &mut ends);
    let _ = p.predict_endpoint_set::<64>(past, 1, &mut ends);
    let _ = p.predict_point(past);
    let mut t = [Trajectory::new(), Trajectory::new()];
    let _ = p.predict_trajectories(past, 1, &mut t);
    let _ = p.last_trajectory();
}

fuzz_target!(|data: &[u8]| {
    let Ok(model) = Model::from_blob(data) else {
        return;
    };
    let past = &PAST[..(model.config().past_len as usize).min(8)];
    // Any kind: the predictor picks the engine (the sine matters for f32 blobs only).
    if let Ok(mut p) = Predictor::<LibmSine, 256>::new(model) {
        exercise(&mut p, past);
    }
    if let Ok(mut p) = Predictor::<FastSine, 256>::new(model) {
        exercise(&mut p, past);
    }
});
