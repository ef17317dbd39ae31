//! Blob-level commands of the gpecnet trainer, everything that starts from a blob rather than
//! from a training run: `gpecnet quantize` ([`quantize_blob`]), `gpecnet score` ([`score`],
//! endpoint probabilities and radii fitted on validation) `gpecnet eval` ([`blob_eval`]) and `gpecnet stream`
//! ([`stream_eval`]: recordings streamed through the track table and the online loop).
//!
//! Depends on `gpecnet-metrics` and below; no candle.
pub mod blob_eval;
pub mod eval_report;
pub mod quantize_blob;
pub mod score;
pub mod stream_eval;

// The lower crates' modules under the names the code uses (`crate::data::Window`).
use gpecnet_data as data;
use gpecnet_data::units;
use gpecnet_files::{inpath, outpath, rundir};
use gpecnet_metrics::{
    baseline, card, core_eval, dist, draw, eval, fixed_eval, flight, planner_metrics,
    proposal_file, score_file, stream,
};
use gpecnet_reference::{export, network, quantize, reference, signing};
