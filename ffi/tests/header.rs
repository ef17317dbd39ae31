//! `ffi/include/gpecnet.h` is what cbindgen generates from `ffi/src/lib.rs`
//! with `ffi/cbindgen.toml`: this test fails when the checked-in header is
//! stale. `UPDATE_HEADER=1 cargo test -p gpecnet-ffi --test it header::` rewrites it.
use std::path::Path;

#[test]
fn header_is_fresh() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"));
    let config = cbindgen::Config::from_file(dir.join("cbindgen.toml")).expect("cbindgen.toml");
    let mut generated = Vec::new();
    cbindgen::Builder::new()
        .with_config(config)
        .with_src(dir.join("src/lib.rs"))
        .generate()
        .expect("cbindgen generates the header")
        .write(&mut generated);
    let generated = String::from_utf8(generated).unwrap();
    let path = dir.join("include/gpecnet.h");
    if std::env::var_os("UPDATE_HEADER").is_some() {
        std::fs::write(&path, &generated).unwrap();
        return;
    }
    let checked_in = std::fs::read_to_string(&path).unwrap_or_default();
    assert!(
        checked_in == generated,
        "{} is stale: run `UPDATE_HEADER=1 cargo test -p gpecnet-ffi --test it header::` and commit it",
        path.display()
    );
}

#[test]
fn header_has_every_entry_point_and_cpp_guards() {
    let h = include_str!("../include/gpecnet.h");
    for f in [
        "gpecnet_init",
        "gpecnet_predict_point",
        "gpecnet_predict_endpoints",
        "gpecnet_model_info",
        "gpecnet_status_str",
        "gpecnet_predictor_size",
        "gpecnet_golden_info",
        "gpecnet_golden_case",
        "gpecnet_online_config_default",
        "gpecnet_forecaster_init",
        "gpecnet_forecaster_frame",
        "gpecnet_forecaster_state",
        "gpecnet_forecaster_restore",
        "gpecnet_forecaster_reset",
        "gpecnet_camera_pose",
        "gpecnet_image_to_ground",
        "gpecnet_ground_to_image",
        "gpecnet_ground_covariance",
        "gpecnet_boxes_to_detections",
        "gpecnet_attitude_from_ros",
        "gpecnet_position_from_ros",
    ] {
        assert!(h.contains(&format!("{f}(")), "{f} missing from the header");
    }
    assert!(h.contains("extern \"C\" {"), "C++ guard missing");
}
