//! The gpecnet trainer's reference side: the network description every stage shares
//! ([`network`]), the independent f32 reference inference ([`mod@reference`], written from
//! `weights/FORMAT.md`, not from `gpecnet-core`), its frames ([`frame`]) and test-time sampling
//! ([`tts`]), blob reading and writing with golden vectors ([`export`]), the quantisation
//! arithmetic and integer reference ([`quantize`]) and Ed25519 signing ([`signing`]).
//!
//! Depends on `gpecnet-data` and `gpecnet-files`; no candle.
pub mod export;
pub mod frame;
pub mod network;
pub mod quantize;
pub mod reference;
pub mod signing;
pub mod tts;

// The lower crates' modules under the names the code uses (`crate::data::Window`).
use gpecnet_data as data;
use gpecnet_files::{inpath, outpath, rundir};
