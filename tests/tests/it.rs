//! gpecnet-tests's integration tests, one binary (`autotests = false` in Cargo.toml): each
//! file of this folder is a module here, so the dependencies are linked once, not once
//! per file. Run one file's tests with `cargo test -p gpecnet-tests --test it <file>::`;
//! `cargo xtask check-modules` fails when a file of this folder is missing below.
mod batch_vs_scalar;
mod core_vs_trainer;
mod fixed_shipped;
mod fixed_vs_trainer;
mod kmeans_vs_core;
mod resample_real;
mod shipped_blobs;
mod sine_spec;
mod v2_vs_trainer;
