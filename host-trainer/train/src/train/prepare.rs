//! The data a run trains and validates on.

use std::path::Path;

use anyhow::{bail, Context, Result};

use crate::config::TrainConfig;
use crate::data::{self, Sample, Unit, Window, PAST};
use crate::rng::Rng;

use super::*;

/// Training and validation data, ready for the loop.
#[derive(Clone, Debug)]
pub struct PreparedData {
    /// Normalised training samples: the real windows, then the synthetic ones, then (when
    /// enabled) the time-reversed copies of both in the same order.
    pub train: Vec<Sample>,
    /// Real training windows (before time reversal).
    pub n_real: usize,
    /// Synthetic windows added by `augment_pct` (before time reversal).
    pub n_synthetic: usize,
    /// Validation windows (raw, or in the heading-canonical frame when the config asks).
    pub val: Vec<Window>,
    /// Unit of the raw coordinates.
    pub unit: Unit,
    /// Social groups of `train` (indices; [`social_train_groups`]); empty without
    /// `social_pooling`.
    pub groups: Vec<Vec<u32>>,
    /// Fingerprint of the raw windows (checked by `--resume`).
    pub fingerprint: DataFingerprint,
    /// The windows [`PreparedData::train`] was normalised from (heading frame, mirrored and
    /// scaled copies included, same order), kept only when `obs_noise > 0`: every epoch
    /// normalises them again with fresh noise on their observed positions
    /// ([`noisy_samples`]). Empty otherwise.
    pub train_windows: Vec<Window>,
}

/// The noise of epoch `e` (0-based) of a run with `obs_noise > 0` comes from stream
/// `OBS_NOISE_STREAMS + e` of the run's seed: one stream per epoch, apart from the
/// [`crate::rng::streams`] (1 to 3), so that a resumed run draws exactly what an uninterrupted
/// one draws without any state in the checkpoint.
pub const OBS_NOISE_STREAMS: u64 = 1 << 32;

/// `w` with i.i.d. Gaussian noise of standard deviation `sigma` added to each coordinate of
/// its [`PAST`] observed positions, drawn from `rng` point by point (x, then y); the future is
/// left as it is.
pub fn with_obs_noise(w: &Window, sigma: f32, rng: &mut Rng) -> Window {
    let mut out = w.clone();
    for p in out.pos[..PAST].iter_mut() {
        p[0] += sigma * rng.normal();
        p[1] += sigma * rng.normal();
    }
    out
}

/// The training samples of one epoch with observation noise: every window of `windows`
/// (a [`PreparedData::train_windows`]) through [`with_obs_noise`] with `cfg.obs_noise`, then
/// through the heading frame again (the frame of the noisy observations, as the core computes
/// it from noisy detections; a window already in the frame is only turned by the noise's
/// heading error) and [`data::normalize`], so every offset, the future's included, is taken
/// from the noisy observations.
pub fn noisy_samples(cfg: &TrainConfig, windows: &[Window], rng: &mut Rng) -> Vec<Sample> {
    windows
        .iter()
        .map(|w| {
            let noisy = with_obs_noise(w, cfg.obs_noise, rng);
            let framed = if cfg.heading_steps == 0 {
                noisy
            } else {
                crate::frame::canonical_window(&noisy, cfg.heading_steps).0
            };
            data::normalize(&framed, cfg.data_scale)
        })
        .collect()
}

/// Social groups of the training windows (`social_pooling`): PECNet's star grouping
/// ([`crate::social::group_windows`]) of the real windows, file by file; synthetic windows
/// are singletons; the time-reversed copies (the second half of `train` when `reversed`) form
/// the same groups as their originals (PECNet reuses each batch's mask).
pub fn social_train_groups(
    cfg: &TrainConfig,
    train: &[Window],
    n_real: usize,
    reversed: bool,
) -> Vec<Vec<u32>> {
    let n_fwd = if reversed {
        train.len() / 2
    } else {
        train.len()
    };
    let mut groups: Vec<Vec<u32>> =
        crate::social::group_windows(&train[..n_real], cfg.time_thresh, cfg.dist_thresh)
            .into_iter()
            .map(|g| g.into_iter().map(|i| i as u32).collect())
            .collect();
    groups.extend((n_real..n_fwd).map(|i| vec![i as u32]));
    if reversed {
        let rev: Vec<Vec<u32>> = groups
            .iter()
            .map(|g| g.iter().map(|&i| i + n_fwd as u32).collect())
            .collect();
        groups.extend(rev);
    }
    groups
}

/// The synthetic windows `cfg` adds to `n_real` real training windows: the first
/// `round(augment_pct / 100 × n_real)` trajectories of `cfg.synthetic_pool`
/// ([`crate::synthetic::sample::take_first_pct`]); none when `augment_pct` is 0.
pub fn synthetic_windows(cfg: &TrainConfig, n_real: usize) -> Result<Vec<Window>> {
    if cfg.augment_pct <= 0.0 {
        return Ok(Vec::new());
    }
    let Some(path) = cfg.synthetic_pool.as_deref() else {
        bail!("augment_pct = {} needs synthetic_pool", cfg.augment_pct);
    };
    let pool = crate::synthetic::sample::read_pool(Path::new(path))?;
    let mut windows =
        crate::synthetic::sample::take_first_pct(&pool, f64::from(cfg.augment_pct), n_real)
            .with_context(|| format!("augmenting from {path}"))?;
    let s = cfg.synthetic_metres_per_pixel;
    if s > 0.0 {
        for w in windows.iter_mut() {
            w.scale(s);
        }
    }
    Ok(windows)
}

/// The real training windows a run of `cfg` sees: the training split, cut to
/// [`TrainConfig::train_fraction`] of its tracks (before `train_extra`, synthetic windows
/// and every augmentation).
pub fn load_train_split(cfg: &TrainConfig, data_root: &Path) -> Result<data::Dataset> {
    let spec = cfg.dataset_spec()?;
    let mut train = data::load(data_root, &spec, data::Split::Train, &cfg.val_scenes)?;
    train.windows = data::track_fraction(std::mem::take(&mut train.windows), cfg.train_fraction);
    Ok(train)
}

/// The data scale of a config that leaves it to the data ([`crate::config::AUTO_DATA_SCALE`]):
/// [`crate::config::data_scale_rule`] of the RMS span (first observed point to endpoint) of
/// the real training windows the run will see ([`load_train_split`]), with that span and the
/// window count. Errors when the split has no window.
pub fn auto_data_scale(cfg: &TrainConfig, data_root: &Path) -> Result<(f32, f64, usize)> {
    data_scale_of(cfg, data_root, &load_train_split(cfg, data_root)?.windows)
}

/// [`auto_data_scale`] of windows already loaded with [`load_train_split`] (`data_root` and
/// `cfg` only name the data in the error).
pub fn data_scale_of(
    cfg: &TrainConfig,
    data_root: &Path,
    windows: &[Window],
) -> Result<(f32, f64, usize)> {
    let n = windows.len();
    let sum: f64 = windows
        .iter()
        .map(|w| {
            let dx = f64::from(w.pos[w.pos.len() - 1][0] - w.pos[0][0]);
            let dy = f64::from(w.pos[w.pos.len() - 1][1] - w.pos[0][1]);
            dx * dx + dy * dy
        })
        .sum();
    let span = (sum / n.max(1) as f64).sqrt();
    match crate::config::data_scale_rule(span) {
        Some(s) if n > 0 => Ok((s, span, n)),
        _ => bail!(
            "cannot compute data_scale: {n} training windows in {} with RMS span {span} \
             (set data_scale in the config)",
            cfg.dataset_spec()?.location(data_root)
        ),
    }
}

/// Load and prepare the data a config asks for. Never touches the test split.
pub fn prepare_data(cfg: &TrainConfig, data_root: &Path) -> Result<PreparedData> {
    prepare_loaded(cfg, data_root, load_train_split(cfg, data_root)?)
}

/// [`prepare_data`] with the training split already loaded by [`load_train_split`] (so a
/// run that first computes its data scale from it reads it once).
pub fn prepare_loaded(
    cfg: &TrainConfig,
    data_root: &Path,
    mut train: data::Dataset,
) -> Result<PreparedData> {
    let spec = cfg.dataset_spec()?;
    let val = data::load(data_root, &spec, data::Split::Val, &cfg.val_scenes)?;
    if cfg.include_train_extra {
        let extra = data::load_sdd(data_root, data::SddSplit::TrainExtra)?;
        train.windows.extend(extra.windows);
    }
    if train.is_empty() || val.is_empty() {
        // Empty files are named: they are why a split that has files has no window.
        let empty: Vec<String> = [data::Split::Train, data::Split::Val]
            .into_iter()
            .flat_map(|s| spec.empty_files(s))
            .map(|p| p.display().to_string())
            .collect();
        bail!(
            "empty split: {} training and {} validation windows in {}{}",
            train.len(),
            val.len(),
            spec.location(data_root),
            if empty.is_empty() {
                String::new()
            } else {
                format!("; these data files are empty: {}", empty.join(", "))
            }
        );
    }
    let unit = train.unit;
    let n_real = train.len();
    let synthetic = synthetic_windows(cfg, n_real)?;
    let n_synthetic = synthetic.len();
    train.windows.extend(synthetic);
    let fingerprint = DataFingerprint::of(&train.windows, n_real, &val.windows);
    let train = if cfg.time_reversal {
        train.with_time_reversed()
    } else {
        train
    };
    let groups = if cfg.social_pooling {
        social_train_groups(cfg, &train.windows, n_real, cfg.time_reversal)
    } else {
        Vec::new()
    };
    // Heading-canonical frame: every window (each time-reversed copy by its own heading).
    // ADE/FDE are rotation-invariant, so validation runs in the canonical frame too.
    let canon = |ws: Vec<Window>| -> Vec<Window> {
        if cfg.heading_steps == 0 {
            ws
        } else {
            ws.iter()
                .map(|w| crate::frame::canonical_window(w, cfg.heading_steps).0)
                .collect()
        }
    };
    let mut train_windows = canon(train.windows);
    if cfg.mirror {
        let mirrored: Vec<Window> = train_windows.iter().map(crate::data::mirrored).collect();
        train_windows.extend(mirrored);
    }
    if !cfg.speed_scales.is_empty() {
        let base = train_windows.len();
        for &f in &cfg.speed_scales {
            for i in 0..base {
                let mut m = train_windows[i].clone();
                m.scale(f);
                train_windows.push(m);
            }
        }
    }
    let train = train_windows
        .iter()
        .map(|w| data::normalize(w, cfg.data_scale))
        .collect();
    Ok(PreparedData {
        fingerprint,
        groups,
        train,
        train_windows: if cfg.obs_noise > 0.0 {
            train_windows
        } else {
            Vec::new()
        },
        val: canon(val.windows),
        unit,
        n_real,
        n_synthetic,
    })
}
