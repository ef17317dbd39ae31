//! Evaluation for the gpecnet trainer: ADE/FDE, KDE and hit rates ([`eval`]), the planner's
//! probability and radius metrics ([`planner_metrics`]), evaluation through `gpecnet-core`
//! and the reference, bit for bit ([`core_eval`], [`fixed_eval`]), model cards and baselines
//! ([`card`]), the proposal and score files a card records ([`proposal_file`],
//! [`score_file`]), SVG drawings ([`draw`]), the streaming evaluation ([`stream`]) and the
//! simulated drone it can see a recording through ([`flight`]).
//!
//! Depends on `gpecnet-reference`, `gpecnet-data` and `gpecnet-files`; no candle.
pub mod baseline;
pub mod card;
pub mod core_eval;
pub mod dist;
pub mod draw;
pub mod eval;
pub mod fixed_eval;
pub mod flight;
pub mod planner_metrics;
pub mod proposal_file;
pub mod score_file;
pub mod stream;

// The lower crates' modules under the names the code uses (`crate::data::Window`).
use gpecnet_data as data;
use gpecnet_files::inpath;
use gpecnet_reference::{network, quantize, reference};
