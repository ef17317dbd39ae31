//! The training loop (`gpecnet train`).
//!
//! * Data: SDD `train` minus the validation scenes (or ETH/UCY `<scene>/train`), plus, with
//!   `augment_pct > 0`, the first `augment_pct` % (of the real count) of the synthetic pool;
//!   every window plus its time-reversed copy (PECNet), normalised with [`crate::data::normalize`].
//! * Each epoch: seeded shuffle, minibatches of `batch_size`, Adam on PECNet's loss, then
//!   (every `eval_every` epochs and at the last) best-of-K validation in raw units with latents
//!   `z ~ N(0, sigma^2)` drawn from a validation RNG re-seeded identically every time, so
//!   epochs are compared on the same draws. The best epoch is chosen by validation min FDE;
//!   the test set is never read.
//! * After every epoch: `checkpoint.bin` (atomic; the one before kept as
//!   `checkpoint.prev.bin`), `metrics.csv`, `metrics.jsonl`, `curves.svg` in the run
//!   directory; `config.toml` and `data-fingerprint.json` once at the start.
//! * Run-folder safety ([`crate::rundir`]): one run per folder (lock file), no silent
//!   overwrite of a non-empty folder, `--resume` checks config and data.
//!
//! Determinism: all randomness comes from [`crate::rng`]; candle's CPU matmul thread count is
//! pinned from `TrainConfig::threads` via `RAYON_NUM_THREADS` (read by candle for every
//! matmul) before the first tensor operation. Two runs with the same config, data and thread
//! count produce bit-identical weights, and `--resume` continues bit-exactly. The variable, not
//! a local `rayon::ThreadPool`, is the knob on purpose: candle 0.11 sizes every CPU matmul from
//! `candle_core::utils::get_num_threads()`, which reads `RAYON_NUM_THREADS` itself (falling back
//! to the machine's core count), whatever pool the call runs in. The elementwise passes the
//! crate runs itself (the fused sine and bias add of [`crate::model`], the Adam update of
//! [`crate::optim`]) split their work over the same number of threads, but compute every
//! element on its own, so only the matmuls make results depend on the thread count; the fused
//! ops compute the very f32 operations of the unfused candle graph, so the shipped weights keep
//! their bits.
//!
//! Files: `prepare.rs` (the data a run trains and validates on), `trainer.rs` (the model,
//! optimizer and RNG of a run and its epochs), `validate.rs` (validation metrics),
//! `run.rs` (new and resumed runs, the epoch loop), `init.rs` (the weights a fine-tuning run
//! starts from), `fingerprint.rs` (the data fingerprint
//! `--resume` checks), `report.rs` (`metrics.csv`, `metrics.jsonl`, `curves.svg`).

mod fingerprint;
pub mod init;
mod memory;
mod prepare;
mod report;
mod run;
mod trainer;
mod validate;

pub use fingerprint::DataFingerprint;
pub use memory::keep_freed_memory;
pub use prepare::{
    auto_data_scale, data_scale_of, load_train_split, noisy_samples, prepare_data, prepare_loaded,
    social_train_groups, synthetic_windows, with_obs_noise, PreparedData, OBS_NOISE_STREAMS,
};
pub use report::{plot_curves, write_metrics};
pub use run::{
    config_diff, train_new, train_resume, train_resume_checked, TrainOptions, TrainSummary,
};
pub use trainer::{TrainLoss, Trainer};
pub use validate::{validate_model, validate_point};

// Defined with the config limits it bounds (`MAX_VAL_ACTIVATION_BYTES`), which sit below the
// loop.
pub use crate::config::VAL_CHUNK;

/// Pin candle's CPU matmul parallelism to `n` threads (see the module docs). Must be called
/// before the first tensor operation of the process to also size rayon's global pool.
///
/// Unless the caller set it, `CANDLE_NUM_THREADS` is set to 1: candle's own pool for its
/// elementwise ops (the gradient accumulators' adds) then stays serial. Its workers and its
/// barrier spin, which on a busy 2-core machine cost more than they save (a paper-size epoch
/// at 2 threads: 8.8 s serial against 10.4 s pooled, `docs/host-speed.md`); every element is
/// computed on its own, so the bits do not change.
pub fn set_num_threads(n: usize) {
    let n = n.max(1).to_string();
    if std::env::var("RAYON_NUM_THREADS").ok().as_deref() != Some(n.as_str()) {
        std::env::set_var("RAYON_NUM_THREADS", n);
    }
    if std::env::var_os("CANDLE_NUM_THREADS").is_none() {
        std::env::set_var("CANDLE_NUM_THREADS", "1");
    }
}
