//! Training checkpoints: `<run_dir>/checkpoint.bin`, rewritten atomically after every epoch.
//!
//! File layout (little endian):
//! ```text
//! 0   8  magic  b"GPECCKPT"
//! 8   4  format version (u32)
//! 12  8  payload length (u64)
//! 20  8  FNV-1a 64 of the payload
//! 28  .. payload: postcard-encoded [`Checkpoint`]
//! ```
//! The write goes to a temporary file in the same directory, is fsynced, then renamed over the
//! old checkpoint (and the directory is fsynced), so a kill at any moment leaves either the
//! previous or the new checkpoint, never a torn one. The replaced checkpoint is kept as
//! `checkpoint.prev.bin`; `--resume` falls back to it, with a warning, when `checkpoint.bin`
//! is unusable ([`load_for_resume`]). A kill during a write can leave the temp file
//! `.checkpoint.bin.tmp.<pid>.<nonce>`; the next run into the folder deletes it
//! ([`crate::rundir::remove_stale_temp_files`]) and a failed write names any that remain. Truncated or corrupted files are reported
//! as [`CheckpointError`]s, never panics.

use std::fs;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::config::TrainConfig;
use crate::eval::Metrics;
use crate::model::Model;
use crate::optim::AdamState;
use crate::rng::{Rng, RngState};

/// File name of the checkpoint inside a run directory.
pub const CHECKPOINT_FILE: &str = "checkpoint.bin";
/// The checkpoint before the latest one (kept by [`save`], the fallback of
/// [`load_for_resume`]).
pub const PREV_FILE: &str = "checkpoint.prev.bin";
/// Where [`load_for_resume`] moves an unusable `checkpoint.bin` when it falls back.
pub const CORRUPT_FILE: &str = "checkpoint.corrupt.bin";
const MAGIC: &[u8; 8] = b"GPECCKPT";
/// 2: point head (`best_point`, per-epoch point metrics).
const VERSION: u32 = 2;
const HEADER: usize = 28;

/// Metrics of one finished epoch.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct EpochMetrics {
    /// 1-based epoch number.
    pub epoch: usize,
    /// Mean over minibatches of the total loss (scaled units).
    pub train_loss: f64,
    /// Mean endpoint reconstruction MSE.
    pub train_rcl: f64,
    /// Mean KLD (summed over each batch).
    pub train_kld: f64,
    /// Mean intermediate-points MSE.
    pub train_adl: f64,
    /// Validation metrics in raw units (pixels for SDD), when validated this epoch.
    pub val: Option<Metrics>,
    /// Wall-clock seconds of the epoch (training + validation).
    pub seconds: f64,
    /// Mean point-head loss (0 without a head).
    pub train_point: f64,
    /// Validation of the point head (K = 1), when the model has one and it was validated.
    pub val_point: Option<Metrics>,
}

/// The best epoch so far (by validation min FDE) and its weights.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BestModel {
    /// 1-based epoch.
    pub epoch: usize,
    /// Its validation metrics.
    pub val: Metrics,
    /// Weights in [`Model::vars`] order.
    pub weights: Vec<Vec<f32>>,
}

/// Everything needed to continue a run exactly.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Checkpoint {
    /// The run's configuration, as TOML.
    pub config_toml: String,
    /// Number of finished epochs.
    pub epochs_done: usize,
    /// Current weights in [`Model::vars`] order.
    pub weights: Vec<Vec<f32>>,
    /// Optimizer state.
    pub adam: AdamState,
    /// Training RNG (shuffling + noise) state.
    pub rng: RngState,
    /// Best epoch so far.
    pub best: Option<BestModel>,
    /// Per-epoch metrics of every finished epoch.
    pub history: Vec<EpochMetrics>,
    /// Best epoch of the point head (by validation FDE; its weights are taken from here).
    pub best_point: Option<BestModel>,
}

/// Why a checkpoint could not be read or written.
#[derive(Debug, thiserror::Error)]
pub enum CheckpointError {
    /// Filesystem error.
    #[error("checkpoint {path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The error.
        source: std::io::Error,
    },
    /// Not a checkpoint file.
    #[error("{path} is not a gpecnet checkpoint (bad magic bytes)")]
    BadMagic {
        /// The file.
        path: PathBuf,
    },
    /// Written by another format version.
    #[error("{path}: unsupported checkpoint version {found} (this build reads {VERSION})")]
    Version {
        /// The file.
        path: PathBuf,
        /// Version in the file.
        found: u32,
    },
    /// Shorter than its header says (e.g. the disk filled up).
    #[error("{path} is truncated: {got} bytes, expected {expected}")]
    Truncated {
        /// The file.
        path: PathBuf,
        /// Bytes expected.
        expected: u64,
        /// Bytes present.
        got: u64,
    },
    /// Payload checksum mismatch.
    #[error("{path} is corrupt (checksum mismatch)")]
    Checksum {
        /// The file.
        path: PathBuf,
    },
    /// Payload did not decode.
    #[error("{path}: cannot decode checkpoint: {source}")]
    Decode {
        /// The file.
        path: PathBuf,
        /// The error.
        source: postcard::Error,
    },
    /// The file could not be read (not a regular file, too large, missing, ...).
    #[error(transparent)]
    Read(#[from] crate::inpath::ReadError),
    /// The stored config or weights do not fit together.
    #[error("{path}: inconsistent checkpoint: {msg}")]
    Inconsistent {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        msg: String,
    },
}

/// FNV-1a, 64 bit.
fn fnv1a64(bytes: &[u8]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for &b in bytes {
        h ^= u64::from(b);
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    h
}

/// `p` itself if it is a file path, `p/checkpoint.bin` if it is a directory.
pub fn checkpoint_path(p: &Path) -> PathBuf {
    if p.is_dir() {
        p.join(CHECKPOINT_FILE)
    } else {
        p.to_path_buf()
    }
}

/// Serialise a checkpoint to bytes (header + payload).
pub fn to_bytes(ckpt: &Checkpoint) -> Result<Vec<u8>, postcard::Error> {
    let payload = postcard::to_stdvec(ckpt)?;
    let mut out = Vec::with_capacity(HEADER + payload.len());
    out.extend_from_slice(MAGIC);
    out.extend_from_slice(&VERSION.to_le_bytes());
    out.extend_from_slice(&(payload.len() as u64).to_le_bytes());
    out.extend_from_slice(&fnv1a64(&payload).to_le_bytes());
    out.extend_from_slice(&payload);
    Ok(out)
}

/// Parse bytes written by [`to_bytes`]; `path` is only used in error messages.
pub fn from_bytes(bytes: &[u8], path: &Path) -> Result<Checkpoint, CheckpointError> {
    let path = path.to_path_buf();
    if bytes.len() < 8 || &bytes[..8] != MAGIC {
        if bytes.len() < 8 && MAGIC.starts_with(bytes) {
            return Err(CheckpointError::Truncated {
                path,
                expected: HEADER as u64,
                got: bytes.len() as u64,
            });
        }
        return Err(CheckpointError::BadMagic { path });
    }
    if bytes.len() < HEADER {
        return Err(CheckpointError::Truncated {
            path,
            expected: HEADER as u64,
            got: bytes.len() as u64,
        });
    }
    let u32_at = |o: usize| u32::from_le_bytes(bytes[o..o + 4].try_into().expect("4 bytes"));
    let u64_at = |o: usize| u64::from_le_bytes(bytes[o..o + 8].try_into().expect("8 bytes"));
    let version = u32_at(8);
    if version != VERSION {
        return Err(CheckpointError::Version {
            path,
            found: version,
        });
    }
    let len = u64_at(12);
    let sum = u64_at(20);
    let expected = (HEADER as u64).saturating_add(len);
    if (bytes.len() as u64) < expected {
        return Err(CheckpointError::Truncated {
            path,
            expected,
            got: bytes.len() as u64,
        });
    }
    let payload = &bytes[HEADER..HEADER + len as usize];
    if fnv1a64(payload) != sum || bytes.len() as u64 != expected {
        return Err(CheckpointError::Checksum { path });
    }
    postcard::from_bytes(payload).map_err(|source| CheckpointError::Decode { path, source })
}

/// Save `ckpt` as `<run_dir>/checkpoint.bin` (atomically), keeping the checkpoint it
/// replaces as `checkpoint.prev.bin` (the fallback of [`load_for_resume`]).
pub fn save(run_dir: &Path, ckpt: &Checkpoint) -> Result<(), CheckpointError> {
    let path = run_dir.join(CHECKPOINT_FILE);
    let bytes = to_bytes(ckpt).map_err(|source| CheckpointError::Decode {
        path: path.clone(),
        source,
    })?;
    if path.is_file() {
        // checkpoint.bin stays in place throughout: a second name for it (hard link, else a
        // copy) is renamed over the previous fallback.
        let prev = run_dir.join(PREV_FILE);
        // Fresh temp names only (a hard link and an exclusive create both refuse an
        // existing name), so nothing planted in the folder is written through.
        let linked = crate::rundir::temp_path(run_dir, PREV_FILE);
        let staged = fs::hard_link(&path, &linked)
            .map(|()| linked)
            .or_else(|_| copy_to_temp(&path, run_dir));
        staged
            .and_then(|tmp| {
                fs::rename(&tmp, &prev).inspect_err(|_| {
                    let _ = fs::remove_file(&tmp);
                })
            })
            .map_err(|source| CheckpointError::Io {
                path: prev.clone(),
                source,
            })?;
    }
    crate::rundir::write_atomic(&path, &bytes)
        .map_err(|source| CheckpointError::Io { path, source })
}

/// A copy of `src` in a fresh temp file of `dir` ([`crate::rundir::create_temp`]), removed
/// again if the copy fails.
fn copy_to_temp(src: &Path, dir: &Path) -> std::io::Result<PathBuf> {
    let (tmp, mut f) = crate::rundir::create_temp(dir, PREV_FILE, 0o666)?;
    let copied = fs::File::open(src)
        .and_then(|mut from| std::io::copy(&mut from, &mut f))
        .and_then(|_| f.sync_all());
    match copied {
        Ok(()) => Ok(tmp),
        Err(e) => {
            let _ = fs::remove_file(&tmp);
            Err(e)
        }
    }
}

/// Load the checkpoint of a run directory for `--resume`: `checkpoint.bin`, or, when that is
/// missing or unreadable (truncated, corrupt, ...) and `checkpoint.prev.bin` is good, the
/// previous one, with a warning on stderr; the bad file is then kept as
/// `checkpoint.corrupt.bin` (so the next save does not rotate it into the fallback). Errors
/// name both files when neither can be used.
pub fn load_for_resume(run_dir: &Path) -> anyhow::Result<Checkpoint> {
    let path = run_dir.join(CHECKPOINT_FILE);
    let prev_path = run_dir.join(PREV_FILE);
    // A run killed before its first checkpoint was written has a folder (config, lock,
    // metrics) but nothing to continue from: say so rather than report a missing file.
    if fs::symlink_metadata(&path).is_err() && fs::symlink_metadata(&prev_path).is_err() {
        anyhow::bail!(
            "nothing to resume: {} holds no checkpoint ({CHECKPOINT_FILE} or {PREV_FILE}), \
             the run stopped before its first epoch was saved; start it again without \
             --resume: gpecnet train --config <TOML> --out {} --force (--force because the \
             folder already holds the stopped run's files)",
            run_dir.display(),
            run_dir.display()
        );
    }
    let newest = load(&path);
    let err = match newest {
        Ok(c) => return Ok(c),
        Err(e) => e,
    };
    if !prev_path.exists() {
        return Err(err.into());
    }
    match load(&prev_path) {
        Ok(c) => {
            let kept = if path.exists() {
                keep_corrupt(run_dir, &path)
            } else {
                None
            };
            eprintln!(
                "warning: {err}; resuming from the previous checkpoint {} (epoch {}){}",
                prev_path.display(),
                c.epochs_done,
                match kept {
                    Some(corrupt) =>
                        format!("; the unusable file is kept as {}", corrupt.display()),
                    None => String::new(),
                }
            );
            Ok(c)
        }
        Err(e2) => Err(anyhow::anyhow!(
            "no usable checkpoint in {}: {err}; and the previous one: {e2}",
            run_dir.display()
        )),
    }
}

/// Moves the unusable `path` to [`CORRUPT_FILE`], or `checkpoint.corrupt.<n>.bin` when an
/// earlier fallback kept one already: never over an existing file (a hard link refuses an
/// existing name; the original is removed only once linked). `None` when it stays put.
fn keep_corrupt(run_dir: &Path, path: &Path) -> Option<PathBuf> {
    const MOST_KEPT: u32 = 1000;
    for n in 0..MOST_KEPT {
        let corrupt = if n == 0 {
            run_dir.join(CORRUPT_FILE)
        } else {
            run_dir.join(format!("checkpoint.corrupt.{n}.bin"))
        };
        match fs::hard_link(path, &corrupt) {
            Ok(()) => {
                return fs::remove_file(path).is_ok().then_some(corrupt);
            }
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => continue,
            // No hard links here: a rename, to a name that is free.
            Err(_) if fs::symlink_metadata(&corrupt).is_err() => {
                return fs::rename(path, &corrupt).is_ok().then_some(corrupt);
            }
            Err(_) => continue,
        }
    }
    None
}

/// Load a checkpoint from a run directory or a checkpoint file.
pub fn load(run_dir_or_file: &Path) -> Result<Checkpoint, CheckpointError> {
    let path = checkpoint_path(run_dir_or_file);
    let bytes = crate::inpath::read_limited(&path, crate::inpath::FileKind::Checkpoint)?;
    let ckpt = from_bytes(&bytes, &path)?;
    ckpt.check_shapes(&path)?;
    Ok(ckpt)
}

impl Checkpoint {
    /// Checks that the weights, the Adam moments and the best epoch's weights have the
    /// tensors (count and sizes) of the model the stored config describes: a checkpoint that
    /// decodes but does not fit its config is [`CheckpointError::Inconsistent`], the same as
    /// other damage (so [`load_for_resume`] falls back to the previous checkpoint). `path`
    /// is only used in errors.
    pub fn check_shapes(&self, path: &Path) -> Result<(), CheckpointError> {
        let bad = |msg: String| CheckpointError::Inconsistent {
            path: path.to_path_buf(),
            msg,
        };
        let cfg = self
            .config()
            .map_err(|e| bad(format!("its config: {e:#}")))?;
        let model = Model::new(&cfg, &mut Rng::new(0))
            .map_err(|e| bad(format!("its config does not build a model: {e}")))?;
        let sizes: Vec<usize> = model.vars().iter().map(|v| v.elem_count()).collect();
        let check = |what: &str, w: &[Vec<f32>]| -> Result<(), CheckpointError> {
            if w.len() != sizes.len() {
                return Err(bad(format!(
                    "{what} has {} tensors, the model of its config {}",
                    w.len(),
                    sizes.len()
                )));
            }
            for (i, (t, &n)) in w.iter().zip(&sizes).enumerate() {
                if t.len() != n {
                    return Err(bad(format!(
                        "{what}: tensor {i} has {} values, the model of its config {n}",
                        t.len()
                    )));
                }
            }
            Ok(())
        };
        check("weights", &self.weights)?;
        check("Adam first moments", &self.adam.m)?;
        check("Adam second moments", &self.adam.v)?;
        if let Some(b) = &self.best {
            check("best-epoch weights", &b.weights)?;
        }
        Ok(())
    }

    /// Parse the stored config.
    pub fn config(&self) -> anyhow::Result<TrainConfig> {
        TrainConfig::from_toml_str(&self.config_toml)
    }

    /// The training RNG, restored.
    pub fn rng(&self) -> Rng {
        Rng::from_state(&self.rng)
    }
}

/// Which weights of a run to load.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Which {
    /// The best epoch by validation min FDE (falls back to the last epoch if never validated).
    Best,
    /// The last finished epoch.
    Last,
}

/// Load a trained model from a run directory (or checkpoint file): config + model with the
/// requested weights, plus the epoch those weights come from. For the exporter / evaluator.
pub fn load_model(
    run_dir_or_file: &Path,
    which: Which,
) -> anyhow::Result<(TrainConfig, Model, usize)> {
    let ckpt = load(run_dir_or_file)?;
    let cfg = ckpt.config()?;
    // Init values are irrelevant: every weight is overwritten below.
    let model = Model::new(&cfg, &mut Rng::new(0))?;
    let (weights, epoch) = match (which, &ckpt.best) {
        (Which::Best, Some(b)) => (&b.weights, b.epoch),
        _ => (&ckpt.weights, ckpt.epochs_done),
    };
    // With Which::Best the point head comes from its own best epoch (by validation FDE).
    let mut weights = weights.clone();
    let nh = model.point_head_tensors();
    if let (Which::Best, Some(bp)) = (which, &ckpt.best_point) {
        let n = weights.len();
        if nh > 0 && bp.weights.len() == n {
            weights[n - nh..].clone_from_slice(&bp.weights[n - nh..]);
        }
    }
    model
        .set_weights(&weights)
        .map_err(|e| CheckpointError::Inconsistent {
            path: checkpoint_path(run_dir_or_file),
            msg: e.to_string(),
        })?;
    Ok((cfg, model, epoch))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> Checkpoint {
        Checkpoint {
            config_toml: TrainConfig::default().to_toml_string().unwrap(),
            epochs_done: 2,
            weights: vec![vec![1.0, 2.0], vec![3.0]],
            adam: AdamState {
                step: 7,
                m: vec![vec![0.5, 0.25], vec![0.0]],
                v: vec![vec![0.1, 0.2], vec![0.3]],
            },
            rng: Rng::with_stream(3, 2).state(),
            best: None,
            history: vec![],
            best_point: None,
        }
    }

    #[test]
    fn roundtrip_and_corruption() {
        let c = sample();
        let bytes = to_bytes(&c).unwrap();
        let p = Path::new("x.bin");
        assert_eq!(from_bytes(&bytes, p).unwrap(), c);
        for cut in [0, 3, 8, 20, 27, bytes.len() - 1] {
            let e = from_bytes(&bytes[..cut], p).unwrap_err();
            assert!(
                matches!(e, CheckpointError::Truncated { .. }) || cut == 0,
                "{cut}: {e}"
            );
        }
        let mut bad = bytes.clone();
        let n = bad.len();
        bad[n - 2] ^= 0x40;
        assert!(matches!(
            from_bytes(&bad, p),
            Err(CheckpointError::Checksum { .. })
        ));
        assert!(matches!(
            from_bytes(b"hello world, not a checkpoint", p),
            Err(CheckpointError::BadMagic { .. })
        ));
    }
}
