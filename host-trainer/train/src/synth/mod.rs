//! The synthetic-data commands (`gpecnet abscore`, `classify`, `synth`, `rl-train`: [`cli`])
//! and the augmentation sweep ([`sweep`]: training with the first K % of the pool for several
//! K, `gpecnet sweep`). See `docs/synthetic.md`.
//!
//! The trajectories themselves (generators, classification, Abruptness Score, the pool, the
//! pictures) are [`crate::synthetic`], below the training loop, which reads the pool; this
//! module sits above the loop and the export ([`crate::train`], [`crate::run_export`]) and
//! re-exports the data side under the paths it has always had (`synth::sample`, `synth::DT`, …).

pub mod cli;
pub mod sweep;

pub use crate::synthetic::{
    abscore, agent, classify, hmm, in_range, newtonian, plot, quantile_sorted, sample, start_stop,
    Stats, Traj, DT, SDD_RANGE,
};
