//! Training for the gpecnet trainer: the run's configuration ([`config`]), the CVAE
//! ([`model`]) with optional social pooling ([`social`]), the training loop ([`train`]),
//! checkpoints ([`checkpoint`]), synthetic trajectories ([`synthetic`]) and the commands and
//! sweep over them ([`synth`]), learned latent proposals ([`propose`]), model selection over
//! runs ([`select`]) and the export of a run as shipped artefacts ([`run_export`]).
//!
//! Its modules are layers, each importing only the ones below it (`cargo xtask check-modules`
//! refuses a cycle): `config` and `synthetic` at the bottom; `social`, then `model`, then
//! `checkpoint`; the loop (`train`); `run_export`, `propose`; `select` and `synth` on top.
//!
//! The top of the library crates: it depends on all of them but `gpecnet-onnx`.
pub mod checkpoint;
pub mod config;
pub mod model;
pub mod propose;
pub mod run_export;
pub mod select;
pub mod social;
pub mod synth;
pub mod synthetic;
pub mod train;

// The lower crates' modules under the names the code uses (`crate::data::Window`).
use gpecnet_data as data;
use gpecnet_files::{csvfile, inpath, outpath, rundir};
use gpecnet_metrics::{baseline, card, core_eval, dist, draw, eval, proposal_file, score_file};
use gpecnet_nn::{mlp, optim, rng};
use gpecnet_reference::{export, frame, network, reference, signing};
use gpecnet_ship::score;
