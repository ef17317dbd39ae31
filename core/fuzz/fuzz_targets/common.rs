//! Shared by the blob fuzz targets: a valid track, every prediction entry point, and the
//! reader + both predictors on one byte string.
#![allow(dead_code)]

use gpecnet_core::{FastSine, LibmSine, Model, Predictor, Sine, Trajectory};

/// Eight observed positions (pixels, 0.4 s apart).
pub const PAST: [[f32; 2]; 8] = [
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
pub fn exercise<S: Sine>(p: &mut Predictor<'_, S, 256>, past: &[[f32; 2]]) {
    let mut ends = [[0.0f32; 2]; 4];
    let _ = p.predict_samples(past, 1, &mut ends);
    let _ = p.predict_endpoint_set::<64>(past, 1, &mut ends);
    let _ = p.predict_point(past);
    let mut t = [Trajectory::new(), Trajectory::new()];
    let _ = p.predict_trajectories(past, 1, &mut t);
    let _ = p.last_trajectory();
}

/// Reads `blob`; whatever the reader accepts goes through every entry point of the predictor
/// with both sines (the predictor picks the engine; the sine matters for f32 blobs only).
/// Returns whether the reader accepted it.
pub fn read_and_predict(blob: &[u8]) -> bool {
    let Ok(model) = Model::from_blob(blob) else {
        return false;
    };
    let past = &PAST[..(model.config().past_len as usize).min(8)];
    if let Ok(mut p) = Predictor::<LibmSine, 256>::new(model) {
        exercise(&mut p, past);
    }
    if let Ok(mut p) = Predictor::<FastSine, 256>::new(model) {
        exercise(&mut p, past);
    }
    true
}
