//! Trajectory data loading for the two standard benchmarks, and PECNet's preprocessing.
//!
//! * **SDD** (Stanford Drone Dataset, TrajNet split, **pixels**): [`load_sdd`]. The files are
//!   already cut into 20-step trajectories (one per ped id per file).
//! * **ETH/UCY** (Social-GAN leave-one-scene-out split, **metres**): [`load_eth_ucy`]. Windows
//!   are cut with the Social-GAN sliding-window rule.
//!
//! Both give a [`Dataset`] of [`Window`]s in raw dataset units. [`normalize`] turns a window
//! into PECNet's model-space [`Sample`]. The file formats and all counts are documented in
//! `shared/data/README.md`; the data is read from a path (CLI flag `--data`, default
//! [`default_data_root`]) and is never copied into this repository.
//!
//! Every parse problem is a [`DataError`] naming the file and the 1-based line; no file content
//! makes these functions panic. Coordinates must be finite and within
//! ±[`MAX_COORDINATE`] (10^6, `gpecnet_core::frame::MAX_COORDINATE`: the core refuses inputs
//! beyond it, and f32 arithmetic loses whole units there), else [`DataError::OutOfRange`].
//!
//! Files: `window.rs` (units, windows, data sets, the validation split, model-space samples),
//! `fraction.rs` (a fixed part of a split's tracks, [`track_fraction`]),
//! `error.rs` ([`DataError`]), `rows.rs` (the shared `frame ped_id x y` row reader and file
//! helpers), `sdd.rs` and `eth_ucy.rs` (one loader per benchmark), `scales.rs` (SDD's
//! metres-per-pixel table), `folder_info.rs` (a user's own data-set folder: `dataset.toml`, its keys, files and errors), `folder.rs` (its splits cut into windows), `detections.rs` (a
//! folder's files, plain text or with a header, read into detections), `resample.rs` (a
//! folder's tracks onto the 0.4 s grid through the core's timed track table), `spec.rs` (dataset names and their train/val/test splits: the one
//! entry point the commands use, [`load`]), `recording.rs` (a split's files frame by frame in time
//! order, for the streaming evaluation: [`recordings`]), `units.rs` (checks that a model's unit matches a
//! data set's).

pub mod units;

use gpecnet_files::{csvfile, inpath};

mod check;
mod detections;
mod error;
mod eth_ucy;
mod folder;
mod folder_info;
mod fraction;
mod homography;
mod recording;
mod resample;
mod rows;
mod scales;
mod sdd;
mod spec;
mod window;

pub use check::{
    check_folder, motion_change, observed_speed, speed_bin, FileCheck, FolderCheck, SplitCheck,
    MOTION_CHANGE_NAMES, SPEED_BINS_M_S, SPEED_BIN_NAMES,
};
pub use error::{Column, DataError};
pub use eth_ucy::{load_eth_ucy, parse_eth_ucy_file, EthUcySplit, ETH_UCY_FRAME_STEP};
pub use folder::{load_folder, parse_folder_file};
pub use folder_info::{Columns, FolderError, FolderInfo, TimeColumn, DATASET_TOML, MAX_GAP_S};
pub use fraction::track_fraction;
pub use homography::Homography;
pub use recording::{read_recording, recordings, RecordedFrame, Recording};
pub use rows::{default_data_root, read_rows, Row};
pub use scales::sdd_metres_per_pixel;
pub use sdd::{load_sdd, parse_sdd_file, SddSplit};
pub use spec::{load, sdd_in_metres, DatasetSpec, LoadError, Split, DATASET_NAMES};
pub use window::{
    default_sdd_val_scenes, denormalize_point, mirrored, normalize, split_by_scene, time_reversed,
    Dataset, Sample, Unit, Window,
};

/// Number of observed steps (3.2 s at 2.5 Hz).
pub const PAST: usize = 8;
/// Number of predicted steps (4.8 s at 2.5 Hz).
pub const FUTURE: usize = 12;
/// Total window length, [`PAST`] + [`FUTURE`].
pub const WINDOW: usize = PAST + FUTURE;

/// Seconds between consecutive positions of a window (2.5 Hz): the sample period of every
/// model trained on these data sets.
pub const PERIOD_S: f32 = 0.4;

/// Frame-index step between consecutive SDD annotations (12 frames at 30 fps = 0.4 s).
pub const SDD_FRAME_STEP: i64 = 12;

/// PECNet's default `data_scale` (`config/optimal.yaml`).
pub const PECNET_DATA_SCALE: f32 = 1.86;

/// The five ETH/UCY leave-one-out scene names (folder names under `eth_ucy/`).
pub const ETH_UCY_SCENES: [&str; 5] = ["eth", "hotel", "univ", "zara1", "zara2"];

/// Largest coordinate magnitude accepted in a data file (raw units):
/// `gpecnet_core::frame::MAX_COORDINATE`, the bound the core enforces on its inputs.
pub const MAX_COORDINATE: f32 = gpecnet_core::frame::MAX_COORDINATE;

/// Hint appended to "missing path" errors.
pub const DATA_HINT: &str =
    "the benchmark data is not part of the repository: see shared/data/README.md \
     for the expected layout, and point the trainer at it with `--data <dir>` \
     (default ../shared/data)";
