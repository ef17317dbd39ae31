//! What a model will see of a data-set folder (`gpecnet data check DIR`): the folder read
//! exactly as training and evaluation read it (`super::folder`), reported per split and file:
//! detections, pedestrians, the native clock against the models' 0.4 s grid, windows, the
//! observed speeds of the windows, and the pedestrians that give no window, with why.
//!
//! A pedestrian gives windows only where its track covers 20 consecutive grid points (8
//! observed, 12 predicted: 7.6 s) without a gap longer than `max_gap_s`; the others'
//! detections are read and checked but no model sees them. A missing `val/` or `train/` is
//! reported, not an error (a folder with only `test/` is a zero-shot set); a missing `test/`
//! or any bad file is the loader's error, naming the file and line.

use std::collections::HashSet;
use std::path::{Path, PathBuf};

use serde::Serialize;

use super::detections::read_detections;
use super::folder::parse_folder_file;
use super::folder_info::{FolderError, FolderInfo};
use super::rows::scene_name;
use super::*;

/// Upper bounds (exclusive) of the speed bins of [`FileCheck::speeds`], metres per second:
/// standing, slow, walking, fast (the online loop's motion states' thresholds).
pub const SPEED_BINS_M_S: [f64; 3] = [0.3, 0.8, 2.0];

/// The names of the four speed bins of [`SPEED_BINS_M_S`], slowest first.
pub const SPEED_BIN_NAMES: [&str; 4] = ["standing", "slow", "walking", "fast"];

/// The observed speed of a window in its unit per second: `|p_7 − p_0|` over the 2.8 s the
/// [`PAST`] positions span.
pub fn observed_speed(w: &Window) -> f64 {
    let (a, b) = (w.pos[0], w.pos[PAST - 1]);
    let span = (PAST - 1) as f64 * f64::from(PERIOD_S);
    f64::from(b[0] - a[0]).hypot(f64::from(b[1] - a[1])) / span
}

/// A window's change of motion state between its past and its future, in metres:
/// [`MOTION_CHANGE_NAMES`] `[0]` a **starter** (standing when forecast, observed speed under
/// the first bin of [`SPEED_BINS_M_S`], and more than 1 m from its last observed position at
/// the endpoint), `[1]` a **stopper** (moving when forecast, at least that speed, and standing
/// over the last 4 predicted steps, 1.6 s: moving less than that speed's distance), `[2]`
/// neither.
pub fn motion_change(w: &Window) -> usize {
    let standing = SPEED_BINS_M_S[0];
    let last = w.pos[PAST - 1];
    let end = w.pos[WINDOW - 1];
    let far = f64::from(end[0] - last[0]).hypot(f64::from(end[1] - last[1])) > 1.0;
    let before = w.pos[WINDOW - 5];
    let tail_s = 4.0 * f64::from(PERIOD_S);
    let tail = f64::from(end[0] - before[0]).hypot(f64::from(end[1] - before[1])) / tail_s;
    match observed_speed(w) < standing {
        true if far => 0,
        false if tail < standing => 1,
        _ => 2,
    }
}

/// The names of [`motion_change`]'s groups.
pub const MOTION_CHANGE_NAMES: [&str; 3] = ["starters", "stoppers", "neither"];

/// The bin of [`SPEED_BINS_M_S`] a speed in m/s falls in (0 = standing … 3 = fast).
pub fn speed_bin(v: f64) -> usize {
    SPEED_BINS_M_S
        .iter()
        .position(|&t| v < t)
        .unwrap_or(SPEED_BINS_M_S.len())
}

/// The report of [`check_folder`].
#[derive(Clone, Debug, Serialize)]
pub struct FolderCheck {
    /// The folder.
    pub dir: PathBuf,
    /// The set's name.
    pub name: String,
    /// The files' unit (`m` or `px`).
    pub file_unit: String,
    /// How positions become what the model sees: as they are, a factor per file, or a
    /// homography per file.
    pub camera: String,
    /// The unit the windows are in (`m`, or `px` for pixel data without a camera model).
    pub unit: String,
    /// The clock in words (`FolderInfo::describe_clock`).
    pub clock: String,
    /// The splits, `train`, `val`, `test`.
    pub splits: Vec<SplitCheck>,
}

/// One split of a [`FolderCheck`].
#[derive(Clone, Debug, Serialize)]
pub struct SplitCheck {
    /// `train`, `val` or `test`.
    pub split: String,
    /// `None` when the split folder holds data; else why not (missing, no data file).
    pub absent: Option<String>,
    /// Its files, in load order.
    pub files: Vec<FileCheck>,
}

/// One file of a [`SplitCheck`].
#[derive(Clone, Debug, Serialize)]
pub struct FileCheck {
    /// The file.
    pub file: PathBuf,
    /// Its scene name (the stem).
    pub scene: String,
    /// Detections (rows).
    pub detections: usize,
    /// Pedestrians (distinct ids).
    pub pedestrians: usize,
    /// The median time between consecutive detections of one pedestrian, seconds (`None`
    /// without two detections of one pedestrian).
    pub native_step_s: Option<f64>,
    /// Windows on the 0.4 s grid (8 observed + 12 predicted positions).
    pub windows: usize,
    /// Windows per observed speed (`|p_7 − p_0| / 2.8 s`): standing, slow, walking, fast
    /// ([`SPEED_BINS_M_S`]); only for data in metres.
    pub speeds: Option<[usize; 4]>,
    /// Pedestrians that give no window (no 7.6 s of track without a gap over `max_gap_s`).
    pub pedestrians_without_window: usize,
    /// Their detections: read, checked, and seen by no model.
    pub detections_without_window: usize,
}

/// Reads the folder at `dir` as training and evaluation do, and reports what the model will
/// see (module docs). Errors are the loader's.
pub fn check_folder(dir: &Path) -> Result<FolderCheck, FolderError> {
    let info = FolderInfo::read(dir)?;
    let mut splits = Vec::new();
    for split in ["train", "val", "test"] {
        let files = match info.split_files(dir, split) {
            Ok(f) => f,
            Err(FolderError::Split { msg, .. }) if split != "test" => {
                splits.push(SplitCheck {
                    split: split.into(),
                    absent: Some(msg),
                    files: Vec::new(),
                });
                continue;
            }
            Err(e) => return Err(e),
        };
        let mut out = Vec::new();
        for f in files {
            out.push(check_file(&f, &info)?);
        }
        splits.push(SplitCheck {
            split: split.into(),
            absent: None,
            files: out,
        });
    }
    let camera = if !info.homography.is_empty() {
        "pixels to metres by a homography per file ([homography])"
    } else if !info.metres_per_pixel.is_empty() {
        "pixels to metres by a factor per file ([metres_per_pixel])"
    } else if info.unit == "m" {
        "metres as written"
    } else {
        "pixels as written (no camera model: models in metres cannot use this set)"
    };
    Ok(FolderCheck {
        dir: dir.to_path_buf(),
        name: info.name.clone().unwrap_or_else(|| scene_name(dir)),
        file_unit: info.unit.clone(),
        camera: camera.into(),
        unit: info.unit().suffix().into(),
        clock: info.describe_clock(),
        splits,
    })
}

/// One file: its detections, its windows as [`super::load_folder`] makes them, and the rest.
fn check_file(path: &Path, info: &FolderInfo) -> Result<FileCheck, FolderError> {
    let file = read_detections(path, info)?;
    let mut windows = parse_folder_file(path, info)?;
    let scene = scene_name(path);
    // To metres as the loader converts (a homography has been applied to the detections).
    let mapped = info.homography_of(path)?.is_some();
    let factor = if mapped {
        None
    } else {
        info.metres_per_pixel.get(&scene).map(|&s| s as f32)
    };
    if let Some(s) = factor {
        for w in windows.iter_mut() {
            w.scale(s);
        }
    }
    let metres = info.unit == "m" || factor.is_some() || mapped;
    // The native clock: consecutive detections of each pedestrian, in time order.
    let secs = info.seconds_per_frame;
    let mut by_ped: Vec<Vec<f64>> = vec![Vec::new(); file.ped_ids.len()];
    for d in &file.dets {
        if let Some(v) = by_ped.get_mut(d.id) {
            v.push(d.t);
        }
    }
    let mut steps: Vec<f64> = Vec::new();
    for ts in by_ped.iter_mut() {
        ts.sort_by(f64::total_cmp);
        steps.extend(ts.windows(2).map(|w| (w[1] - w[0]) * secs));
    }
    steps.sort_by(f64::total_cmp);
    let native_step_s = steps.get(steps.len() / 2).copied();
    let seen: HashSet<u64> = windows.iter().map(|w| w.ped_id.to_bits()).collect();
    let (mut peds_without, mut dets_without) = (0, 0);
    for (i, id) in file.ped_ids.iter().enumerate() {
        if !seen.contains(&id.to_bits()) {
            peds_without += 1;
            dets_without += by_ped.get(i).map_or(0, Vec::len);
        }
    }
    let speeds = metres.then(|| {
        let mut bins = [0usize; 4];
        for w in &windows {
            bins[speed_bin(observed_speed(w))] += 1;
        }
        bins
    });
    Ok(FileCheck {
        file: path.to_path_buf(),
        scene,
        detections: file.dets.len(),
        pedestrians: file.ped_ids.len(),
        native_step_s,
        windows: windows.len(),
        speeds,
        pedestrians_without_window: peds_without,
        detections_without_window: dets_without,
    })
}
