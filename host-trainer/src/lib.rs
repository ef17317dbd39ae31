//! gpecnet-trainer: see the crate README and ARCHITECTURE.md.
pub mod data;
pub mod eval;
