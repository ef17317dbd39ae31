//! gpecnet-trainer: the `gpecnet` command line (`src/main.rs`: argument parsing and printing)
//! over the trainer's crates, one per pipeline stage (ARCHITECTURE.md, "The trainer's
//! crates"), and one import path to all of them for the trainer's integration tests, benches
//! and examples. Each module below is the crate or module of the stage that owns it.

pub use gpecnet_data as data;
pub use gpecnet_data::units;
pub use gpecnet_files::{csvfile, inpath, outpath, rundir};
pub use gpecnet_metrics::{
    baseline, card, core_eval, dist, draw, eval, fixed_eval, flight, planner_metrics,
    proposal_file, score_file, stream,
};
pub use gpecnet_nn::{mlp, ops, optim, pool, rng};
pub use gpecnet_onnx as onnx;
pub use gpecnet_reference::{export, frame, network, quantize, reference, signing, tts};
pub use gpecnet_ship::{blob_eval, eval_report, quantize_blob, score, stream_eval};
pub use gpecnet_train::{
    checkpoint, config, model, propose, run_export, select, social, synth, train,
};
