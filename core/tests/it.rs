//! gpecnet-core's integration tests, one binary (`autotests = false` in Cargo.toml): each
//! file of this folder is a module here, so the dependencies are linked once, not once
//! per file. Run one file's tests with `cargo test -p gpecnet-core --test it <file>::`;
//! `cargo xtask check-modules` fails when a file of this folder is missing below.
mod blob_corruption;
mod camera;
mod common;
mod endpoint_bound;
mod fixed_blob;
mod fixed_sine;
mod guards;
mod online;
mod planner;
mod predictor;
mod proposal;
mod public_api;
mod signed;
mod timed_tracks;
mod track_filter;
mod tracks;
mod units;
