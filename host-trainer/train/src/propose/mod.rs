//! `gpecnet propose`: a learned latent proposal for a **frozen** model.
//!
//! A CVAE's endpoint set is normally K latents drawn from the prior (or many more, reduced
//! by k-means, [`gpecnet_reference::tts`]). A proposal replaces the draw with K latents computed from
//! the past: a small network `f → K·zdim` (DLow, Yuan & Kitani, ECCV 2020) on the frozen
//! encoder's features, or, with `codebook`, K fixed latent vectors (its bias alone). It is
//! trained post hoc, the CVAE's networks untouched, against the soft minimum over the K
//! endpoint errors (a differentiable best-of-K) plus a small weight on the prior's
//! `½‖z‖²`. Every latent component is clamped to `±bound`, in training exactly as in
//! `gpecnet-core`, so the fixed-point decoder's input range is respected by construction.
//!
//! The run folder holds `checkpoint.json` (after every epoch, atomically: the current and
//! the best-validation weights, the optimiser and sampler state), `metrics.csv` and, at the
//! end, `proposal.json` (the best-validation proposal, exported layers). Selection uses the
//! validation windows only; the test set is never read here.
//!
//! Files: `file.rs` (settings, `proposal.json`, the card's record, the fingerprint),
//! `fit.rs` (tensors, loss, validation pass), `run.rs` (the loop and its files), this file
//! (the command line).

mod fit;
mod run;

use std::path::PathBuf;

use anyhow::{Context, Result};

use crate::data;
use crate::network::Act;
use crate::proposal_file::{ProposalFile, ProposeSettings};
pub use fit::{Encoded, LossSpec, ValScore};
pub use run::ProposeRun;

/// `gpecnet propose`'s options (the command's help text is in the CLI).
#[derive(clap::Args, Debug)]
pub struct ProposeArgs {
    /// The frozen f32 blob (its encoder and decoder are used as they are).
    #[arg(long, value_name = "FILE")]
    pub blob: PathBuf,
    /// Training and validation data (`sdd`, `sdd-m`, `eth_ucy:<scene>`, a folder); the test
    /// split is never read.
    #[arg(long, value_name = "SPEC", default_value = "sdd-m")]
    pub dataset: String,
    /// Data root holding sdd/ and eth_ucy/.
    #[arg(long, value_name = "DIR", default_value_os_t = data::default_data_root())]
    pub data: PathBuf,
    /// Run folder (created; refused when it holds a run unless --resume).
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// Continue the run in --out (the settings must be the same).
    #[arg(long)]
    pub resume: bool,
    /// Seed of the initialisation and batch order.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Latents per window (the endpoint count the model will return).
    #[arg(long, default_value_t = 20)]
    pub k: usize,
    /// Hidden widths of the proposal network, comma separated.
    #[arg(long, value_delimiter = ',', default_value = "64")]
    pub hidden: Vec<usize>,
    /// Hidden activation.
    #[arg(long, value_enum, default_value = "relu")]
    pub act: ActArg,
    /// K fixed latent vectors instead of a network (no hidden layer, weights 0).
    #[arg(long)]
    pub codebook: bool,
    /// Epochs.
    #[arg(long, default_value_t = 60)]
    pub epochs: usize,
    /// Windows per batch.
    #[arg(long, default_value_t = 256)]
    pub batch: usize,
    /// Adam learning rate.
    #[arg(long, default_value_t = 1e-3)]
    pub lr: f64,
    /// Weight of the prior term ½‖z‖².
    #[arg(long, default_value_t = 0.02)]
    pub prior_weight: f32,
    /// Soft-min temperature, in the blob's unit (metres for sdd-m).
    #[arg(long, default_value_t = 0.05)]
    pub temperature: f32,
    /// Each latent component is clamped to ±bound (as gpecnet-core does).
    #[arg(long, default_value_t = 8.0)]
    pub bound: f32,
    /// No time-reversed copies of the training windows.
    #[arg(long)]
    pub no_time_reversal: bool,
    /// No mirrored copies of the training windows.
    #[arg(long)]
    pub no_mirror: bool,
    /// Threads (0 = all cores).
    #[arg(long, default_value_t = 1)]
    pub threads: usize,
}

/// Hidden activation of a proposal network.
#[derive(Clone, Copy, Debug, clap::ValueEnum)]
pub enum ActArg {
    /// `max(x, 0)`.
    Relu,
    /// `sin(x)`.
    Sine,
}

impl ProposeArgs {
    /// Runs the command.
    pub fn run(&self) -> Result<ProposalFile> {
        crate::train::set_num_threads(if self.threads == 0 {
            std::thread::available_parallelism().map_or(1, |n| n.get())
        } else {
            self.threads
        });
        let bytes = crate::inpath::read_limited(&self.blob, crate::inpath::FileKind::Blob)?;
        let model = crate::export::read_blob(&bytes)
            .with_context(|| format!("reading {}", self.blob.display()))?;
        let crc = gpecnet_core::Model::from_blob(&bytes)
            .map_err(|e| anyhow::anyhow!("{}: {e}", self.blob.display()))?
            .crc();
        let settings = ProposeSettings {
            blob_crc: crc,
            dataset: self.dataset.clone(),
            val_scenes: data::default_sdd_val_scenes(),
            seed: self.seed,
            k: self.k,
            hidden: if self.codebook {
                Vec::new()
            } else {
                self.hidden.clone()
            },
            act: match self.act {
                ActArg::Relu => Act::Relu,
                ActArg::Sine => Act::Sine,
            },
            codebook: self.codebook,
            epochs: self.epochs,
            batch: self.batch,
            lr: self.lr,
            prior_weight: self.prior_weight,
            temperature: self.temperature,
            bound: self.bound,
            time_reversal: !self.no_time_reversal,
            mirror: !self.no_mirror,
        };
        ProposeRun {
            model: &model,
            settings,
            data_root: self.data.clone(),
            out: self.out.clone(),
            resume: self.resume,
            source: self.blob.clone(),
        }
        .run()
    }
}
