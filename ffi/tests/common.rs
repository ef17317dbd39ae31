//! What the test files of this folder share: where the repository and its
//! shipped weights are, and the camera of `examples/c/drone_camera.c`.
use std::path::PathBuf;

use gpecnet_ffi::{GpecnetCamera, GpecnetEuler};

/// The repository's root (this crate's parent folder).
pub fn root() -> PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .unwrap()
        .to_path_buf()
}

/// The shipped file `weights/<name>`, whole.
pub fn weights(name: &str) -> Vec<u8> {
    std::fs::read(root().join("weights").join(name)).unwrap()
}

/// The shipped file `weights/<name>` for the rest of the test run: the C
/// functions that read a blob in place may keep pointing into it.
pub fn weights_static(name: &str) -> &'static [u8] {
    weights(name).leak()
}

/// A gimbal camera of 1920 × 1080 px with a calibrated lens, mounted along
/// the body's axes, ground points up to 150 m away: `drone_camera.c`'s.
pub fn camera() -> GpecnetCamera {
    GpecnetCamera {
        fx: 1100.0,
        fy: 1100.0,
        cx: 960.0,
        cy: 540.0,
        k1: -0.12,
        k2: 0.03,
        p1: 0.0,
        p2: 0.0,
        mount: GpecnetEuler::default(),
        max_range: 150.0,
    }
}
