//! gpecnet-ffi's integration tests, one binary (`autotests = false` in Cargo.toml): each
//! file of this folder is a module here, so the dependencies are linked once, not once
//! per file. Run one file's tests with `cargo test -p gpecnet-ffi --test it <file>::`;
//! `cargo xtask check-modules` fails when a file of this folder is missing below.
mod c_abi;
mod c_camera;
mod c_examples;
mod c_online;
mod c_signed;
mod c_units_tracks;
mod common;
mod header;
