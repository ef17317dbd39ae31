//! gpecnet-trainer: see the crate README and ARCHITECTURE.md.
pub mod data;
pub mod eval;
pub mod reference;
pub mod export;
pub mod checkpoint;
pub mod config;
pub mod model;
pub mod social;
pub mod optim;
pub mod rng;
pub mod train;
pub mod core_eval;
pub mod draw;
pub mod ship;
pub mod synth;
pub mod quantize;
