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
//! `run.rs` (new and resumed runs, the epoch loop), `fingerprint.rs` (the data fingerprint
//! `--resume` checks), `report.rs` (`metrics.csv`, `metrics.jsonl`, `curves.svg`).

mod fingerprint;
mod prepare;
mod report;
mod run;
mod trainer;
mod validate;

pub use fingerprint::DataFingerprint;
pub use prepare::{prepare_data, social_train_groups, synthetic_windows, PreparedData};
pub use report::{plot_curves, write_metrics};
pub use run::{
    config_diff, train_new, train_resume, train_resume_checked, TrainOptions, TrainSummary,
};
pub use trainer::{TrainLoss, Trainer};
pub use validate::{validate_model, validate_point};

/// Windows evaluated per validation forward pass (times K rows).
pub const VAL_CHUNK: usize = 512;

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

/// Asks the C allocator to keep freed memory in the process: no trimming of the heap and no
/// separately mapped blocks below 32 MiB (glibc's `mallopt`; elsewhere a no-op).
///
/// A training step allocates and frees about a hundred tensors of up to a few MiB (candle's
/// outputs and zero-filled gradient accumulators). With glibc's defaults the freed memory goes
/// back to the kernel and the next step faults it in again, page by page: before this setting a
/// paper-size epoch spent about 18 % of its time in page faults, `brk` and `munmap`. Memory
/// stays at the run's peak instead. Allocation never changes a computed bit.
pub fn keep_freed_memory() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    {
        // glibc's `mallopt` parameters (malloc.h).
        const M_TRIM_THRESHOLD: std::ffi::c_int = -1;
        const M_MMAP_THRESHOLD: std::ffi::c_int = -3;
        extern "C" {
            fn mallopt(param: std::ffi::c_int, value: std::ffi::c_int) -> std::ffi::c_int;
        }
        // SAFETY: `mallopt` only sets allocator parameters (it takes the allocator's own lock)
        // and reports an unsupported value by returning 0, which is ignored: the defaults then
        // stay, which is correct, only slower. 32 MiB is glibc's largest mmap threshold on
        // 64-bit targets.
        unsafe {
            mallopt(M_TRIM_THRESHOLD, 1 << 30);
            mallopt(M_MMAP_THRESHOLD, 32 << 20);
        }
    }
}
