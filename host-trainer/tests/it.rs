//! gpecnet-trainer's integration tests, one binary (`autotests = false` in Cargo.toml): each
//! file of this folder is a module here, so the dependencies are linked once, not once
//! per file. Run one file's tests with `cargo test -p gpecnet-trainer --test it <file>::`;
//! `cargo xtask check-modules` fails when a file of this folder is missing below.
mod cli_safety;
mod cli_safety_surfaces;
mod cli_snapshots;
mod common;
mod config_validation;
mod data_errors;
mod data_loading;
mod data_range_eval;
mod eval_metrics;
mod eval_once;
mod finetune;
mod obs_noise;
mod own_data;
mod propose;
mod run_folder;
mod score;
mod signing;
mod social;
mod stream;
mod synth_abscore;
mod synth_agent;
mod synth_augment;
mod synth_classify;
mod synth_generators;
mod synth_sample;
mod train_resume;
