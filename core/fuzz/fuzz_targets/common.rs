//! Shared by the blob fuzz targets: a valid track and every prediction entry point.
use gpecnet_core::{Predictor, Sine, Trajectory};

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
