//! Training-epoch timing: tiny, small and paper-size G-PECNet on SDD (data loaded once per
//! config, outside the timed loop), at one thread count per process.
//!
//! ```text
//! cargo bench -p gpecnet-trainer --bench train_epoch                       # 1 thread
//! GPECNET_BENCH_THREADS=2 cargo bench -p gpecnet-trainer --bench train_epoch
//! ```
//!
//! Environment (all optional):
//! * `GPECNET_BENCH_THREADS`: the run's `threads` (default 1). One count per process: rayon's
//!   global pool is sized once, at the first parallel call.
//! * `GPECNET_BENCH_CONFIGS`: comma-separated config names from `host-trainer/configs`
//!   (default `sdd-tiny,sdd-small,sdd-paper`).
//! * `GPECNET_BENCH_EPOCHS`: timed epochs per config after one untimed warm-up epoch
//!   (default 3).
//!
//! Prints one line per config: every epoch's seconds, their median and an FNV-1a hash of the
//! weights' bits after the last epoch (equal hashes: bit-identical training). Wall-clock numbers
//! live here and in `docs/host-speed.md`, never in tests.

use std::path::Path;
use std::time::Instant;

use gpecnet_trainer::config::TrainConfig;
use gpecnet_trainer::data;
use gpecnet_trainer::train::{prepare_data, Trainer};

fn env_or(name: &str, default: &str) -> String {
    std::env::var(name).unwrap_or_else(|_| default.to_string())
}

/// FNV-1a over the little-endian bytes of every weight.
fn fnv1a(weights: &[Vec<f32>]) -> u64 {
    let mut h = 0xcbf2_9ce4_8422_2325u64;
    for b in weights.iter().flatten().flat_map(|w| w.to_le_bytes()) {
        h = (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3);
    }
    h
}

fn main() {
    let threads: usize = env_or("GPECNET_BENCH_THREADS", "1").parse().unwrap_or(1);
    let epochs: usize = env_or("GPECNET_BENCH_EPOCHS", "3").parse().unwrap_or(3);
    let configs = env_or("GPECNET_BENCH_CONFIGS", "sdd-tiny,sdd-small,sdd-paper");
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("configs");
    for name in configs.split(',').map(str::trim).filter(|s| !s.is_empty()) {
        let path = dir.join(format!("{name}.toml"));
        let mut cfg = match TrainConfig::from_file(&path) {
            Ok(c) => c,
            Err(e) => {
                eprintln!("{name}: {e:#}");
                continue;
            }
        };
        cfg.threads = threads;
        let data = match prepare_data(&cfg, &data::default_data_root()) {
            Ok(d) => d,
            Err(e) => {
                eprintln!("{name}: SDD data (see shared/data): {e:#}");
                continue;
            }
        };
        let mut trainer = match Trainer::new(cfg, data) {
            Ok(t) => t,
            Err(e) => {
                eprintln!("{name}: {e:#}");
                continue;
            }
        };
        let mut times = Vec::with_capacity(epochs);
        for i in 0..=epochs {
            let t0 = Instant::now();
            if let Err(e) = trainer.train_epoch(None) {
                eprintln!("{name}: {e:#}");
                break;
            }
            if i > 0 {
                times.push(t0.elapsed().as_secs_f64());
            }
        }
        if times.is_empty() {
            continue;
        }
        let mut sorted = times.clone();
        sorted.sort_by(f64::total_cmp);
        let median = sorted[sorted.len() / 2];
        let list: Vec<String> = times.iter().map(|t| format!("{t:.3}")).collect();
        let hash = match trainer.model().weights() {
            Ok(w) => format!("{:016x}", fnv1a(&w)),
            Err(e) => format!("({e})"),
        };
        println!(
            "train_epoch {name} threads={threads} epochs=[{}] median={median:.3} s weights={hash}",
            list.join(", ")
        );
    }
}
