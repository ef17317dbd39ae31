//! gpecnet-trainer: see the crate README and ARCHITECTURE.md.
pub mod checkpoint;
pub mod config;
pub mod core_eval;
pub mod data;
pub mod draw;
pub mod eval;
pub mod export;
pub mod model;
pub mod optim;
pub mod quantize;
pub mod reference;
pub mod rng;
pub mod ship;
pub mod social;
pub mod synth;
pub mod train;
pub mod tts;
