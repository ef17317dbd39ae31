//! A user's own data set: a folder with `dataset.toml` and `train/`, `val/`, `test/` folders
//! of `frame id x y` text files (the layout `docs/own-data.md` documents).
//!
//! ```text
//! mydrone/
//!   dataset.toml          unit, seconds per frame, name, licence (below)
//!   train/*.txt           one file per scene or flight: `frame id x y` rows, any order
//!   val/*.txt             model selection only
//!   test/*.txt            touched once per shipped model
//! ```
//!
//! ```toml
//! name = "mydrone"              # optional, default the folder name
//! unit = "m"                    # "m" (metres) or "px" (pixels)
//! seconds_per_frame = 0.1       # time between consecutive frame numbers (10 Hz here)
//! licence = "CC BY 4.0"         # optional: the data's licence, copied into every model card
//! [metres_per_pixel]            # optional, pixel data only: file stem -> factor; with it the
//! flight_01 = 0.041             # whole set is converted to metres (every file must be listed)
//! ```
//!
//! **Windows.** The models predict 12 steps of [`PERIOD_S`] (0.4 s) from 8. A folder's clock
//! must divide that period: `step = PERIOD_S / seconds_per_frame` must be a whole number of
//! frames (within 1e-4; 30 fps gives 12, 25 fps 10, 10 Hz 4, 2.5 Hz 1), else the loader refuses
//! with [`FolderError::Clock`] (resample first). Per file and per id, the rows are sorted by
//! frame (a duplicate frame for one id is [`DataError::DuplicateRow`]); a window is 20
//! positions of one id at frames `f, f + step, …, f + 19·step`, all present, for every frame
//! `f` of that id with `f ≡ f_first (mod step)`, so consecutive windows of a track overlap by
//! 19 of the 2.5 Hz steps and rows between the 2.5 Hz grid are skipped. Gaps break windows;
//! nothing else is dropped (no neighbour rule). Files are read in sorted name order, ids in
//! first-appearance order, windows by start frame.

use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};

use super::rows::{id_key, sorted_txt_files};
use super::*;

/// The name of a folder data set's description file.
pub const DATASET_TOML: &str = "dataset.toml";

/// Largest `dataset.toml` read (bytes).
const MAX_TOML_BYTES: u64 = 64 * 1024;

/// `dataset.toml`, parsed.
#[derive(Debug, Clone, PartialEq, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FolderInfo {
    /// The set's name (default: the folder's name).
    #[serde(default)]
    pub name: Option<String>,
    /// `"m"` or `"px"`.
    pub unit: String,
    /// Seconds between consecutive frame numbers.
    pub seconds_per_frame: f64,
    /// The data's licence, copied into model cards.
    #[serde(default)]
    pub licence: Option<String>,
    /// Pixel data only: metres per pixel of each file (by stem); converts the set to metres.
    #[serde(default)]
    pub metres_per_pixel: BTreeMap<String, f64>,
}

/// A problem with a data-set folder's description or clock.
#[derive(Debug, thiserror::Error)]
pub enum FolderError {
    /// `dataset.toml` is missing, unreadable or invalid.
    #[error("{path}: {msg}", path = .path.display())]
    Toml {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        msg: String,
    },
    /// The folder's clock does not divide the models' period.
    #[error(
        "{path}: seconds_per_frame = {seconds_per_frame} does not divide the models' period of \
         {PERIOD_S} s into a whole number of frames ({ratio:.4} frames); resample the data to a \
         rate that does (e.g. 2.5, 5, 10, 25 or 30 Hz)",
        path = .path.display()
    )]
    Clock {
        /// The `dataset.toml`.
        path: PathBuf,
        /// Its clock.
        seconds_per_frame: f64,
        /// `PERIOD_S / seconds_per_frame`.
        ratio: f64,
    },
    /// A file of a pixel set converted to metres has no factor.
    #[error(
        "{path}: no metres_per_pixel entry for {stem:?} in dataset.toml (every file of a \
         converted set needs one)",
        path = .path.display()
    )]
    NoScale {
        /// The data file.
        path: PathBuf,
        /// Its stem.
        stem: String,
    },
    /// A data file problem.
    #[error(transparent)]
    Data(#[from] DataError),
}

impl FolderInfo {
    /// Reads and checks `<dir>/dataset.toml`.
    pub fn read(dir: &Path) -> Result<Self, FolderError> {
        let path = dir.join(DATASET_TOML);
        let bad = |msg: String| FolderError::Toml {
            path: path.clone(),
            msg,
        };
        let meta = std::fs::metadata(&path).map_err(|e| {
            bad(format!(
                "cannot read the data set's description ({e}); a data-set folder needs \
                 dataset.toml with unit and seconds_per_frame (docs/own-data.md)"
            ))
        })?;
        if !meta.is_file() || meta.len() > MAX_TOML_BYTES {
            return Err(bad(format!(
                "not a regular file of at most {MAX_TOML_BYTES} bytes"
            )));
        }
        let text = crate::inpath::read_text_limited(&path, crate::inpath::FileKind::Text)
            .map_err(|e| bad(e.to_string()))?;
        let info: FolderInfo = toml::from_str(&text).map_err(|e| bad(e.to_string()))?;
        if info.unit != "m" && info.unit != "px" {
            return Err(bad(format!(
                "unit = {:?}: expected \"m\" (metres) or \"px\" (pixels)",
                info.unit
            )));
        }
        let s = info.seconds_per_frame;
        if !(s.is_finite() && s > 0.0 && s <= f64::from(PERIOD_S)) {
            return Err(bad(format!(
                "seconds_per_frame = {s}: expected a number in (0, {PERIOD_S}]"
            )));
        }
        if !info.metres_per_pixel.is_empty() && info.unit != "px" {
            return Err(bad(
                "metres_per_pixel converts pixel data: set unit = \"px\"".into(),
            ));
        }
        // Positions are scaled in f32: the factor must survive the conversion (1e-300 is a
        // positive f64 and 0 as f32; 1e300 is infinite), as a normal number.
        if let Some((k, v)) = info.metres_per_pixel.iter().find(|(_, v)| {
            let f = **v as f32;
            !(v.is_finite() && **v > 0.0 && f.is_finite() && f.is_normal())
        }) {
            return Err(bad(format!(
                "metres_per_pixel.{k} = {v}: expected a positive number that is a normal f32 \
                 (between {:e} and {:e})",
                f32::MIN_POSITIVE,
                f32::MAX
            )));
        }
        // The licence is stored in every blob trained on the folder: refused here, naming the
        // key, rather than at export.
        let most = gpecnet_core::blob::MAX_META_TEXT;
        if let Some(l) = info.licence.as_ref().filter(|l| l.len() > most) {
            return Err(bad(format!(
                "licence is {} bytes: allowed at most {most} (a blob stores it)",
                l.len()
            )));
        }
        info.step(&path)?;
        Ok(info)
    }

    /// Frames per model step (`PERIOD_S / seconds_per_frame`, a whole number).
    pub fn step(&self, path: &Path) -> Result<i64, FolderError> {
        let ratio = f64::from(PERIOD_S) / self.seconds_per_frame;
        let step = ratio.round();
        if (ratio - step).abs() > 1e-4 * ratio || !(1.0..=1e6).contains(&step) {
            return Err(FolderError::Clock {
                path: path.to_path_buf(),
                seconds_per_frame: self.seconds_per_frame,
                ratio,
            });
        }
        Ok(step as i64)
    }

    /// The unit of the loaded windows (metres when pixel data is converted).
    pub fn unit(&self) -> Unit {
        if self.unit == "m" || !self.metres_per_pixel.is_empty() {
            Unit::Metres
        } else {
            Unit::Pixels
        }
    }
}

/// Cut one file of a folder data set into windows, `step` frames apart (module docs).
pub fn parse_folder_file(path: &Path, step: i64) -> Result<Vec<Window>, DataError> {
    let rows = read_rows(path)?;
    let scene = super::rows::scene_name(path);
    let mut order: Vec<u64> = Vec::new();
    let mut tracks: HashMap<u64, BTreeMap<i64, Row>> = HashMap::new();
    for r in rows {
        let k = id_key(r.ped_id);
        let t = tracks.entry(k).or_insert_with(|| {
            order.push(k);
            BTreeMap::new()
        });
        if t.insert(r.frame, r).is_some() {
            return Err(DataError::DuplicateRow {
                path: path.to_path_buf(),
                line: r.line,
                ped_id: r.ped_id,
                frame: r.frame,
            });
        }
    }
    let mut out = Vec::new();
    for k in order {
        let t = &tracks[&k];
        let Some((&first, _)) = t.iter().next() else {
            continue;
        };
        for (&f, r) in t.iter() {
            if (f - first).rem_euclid(step) != 0 {
                continue;
            }
            let mut w = Window {
                scene: scene.clone(),
                ped_id: r.ped_id,
                frames: [0; WINDOW],
                pos: [[0.0; 2]; WINDOW],
            };
            let complete = (0..WINDOW).all(|i| {
                let fi = f + i as i64 * step;
                match t.get(&fi) {
                    Some(p) => {
                        w.frames[i] = fi;
                        w.pos[i] = p.pos;
                        true
                    }
                    None => false,
                }
            });
            if complete {
                out.push(w);
            }
        }
    }
    Ok(out)
}

/// One split (`train`, `val` or `test`) of the folder data set at `dir`.
pub fn load_folder(dir: &Path, split: &str) -> Result<Dataset, FolderError> {
    let info = FolderInfo::read(dir)?;
    let step = info.step(&dir.join(DATASET_TOML))?;
    let sub = dir.join(split);
    let mut windows = Vec::new();
    for f in sorted_txt_files(&sub, &format!("{split}/ folder of the data set"))? {
        let mut ws = parse_folder_file(&f, step)?;
        if !info.metres_per_pixel.is_empty() {
            let stem = super::rows::scene_name(&f);
            let s = *info
                .metres_per_pixel
                .get(&stem)
                .ok_or_else(|| FolderError::NoScale {
                    path: f.clone(),
                    stem: stem.clone(),
                })? as f32;
            for w in ws.iter_mut() {
                w.scale(s);
            }
        }
        windows.extend(ws);
    }
    let name = info.name.clone().unwrap_or_else(|| {
        dir.file_name()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| dir.display().to_string())
    });
    Ok(Dataset {
        name: format!("{name}/{split}"),
        unit: info.unit(),
        windows,
    })
}
