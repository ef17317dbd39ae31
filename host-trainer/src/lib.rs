//! gpecnet-trainer: see the crate README and ARCHITECTURE.md.
pub mod data;
pub mod eval;
pub mod checkpoint;
pub mod config;
pub mod model;
pub mod optim;
pub mod rng;
pub mod train;
