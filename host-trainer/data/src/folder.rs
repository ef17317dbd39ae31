//! Loading a user's own data-set folder (described by `dataset.toml`, `super::folder_info`)
//! into windows: each file's detections (`super::detections`) resampled per pedestrian onto the
//! models' 0.4 s grid by the core's timed track table (`super::resample`).

use std::path::Path;

use super::detections::read_detections;
use super::resample::{track_windows, TrackClock};
use super::rows::scene_name;
use super::*;

/// The clock the core's track table resamples a file of `info` with.
fn clock(info: &FolderInfo) -> TrackClock {
    TrackClock {
        ms_per_unit: info.seconds_per_frame * 1000.0,
        frames: info.time == TimeColumn::Frame,
        max_gap_ms: (info.max_gap_s * 1000.0).round() as u32,
    }
}

/// Cut one file of a folder data set into windows on the models' grid (module docs), in the
/// file's unit (no `metres_per_pixel` applied), or in metres for a file under a homography.
pub fn parse_folder_file(path: &Path, info: &FolderInfo) -> Result<Vec<Window>, FolderError> {
    let file = read_detections(path, info)?;
    let scene = scene_name(path);
    let mut tracks: Vec<Vec<super::detections::Detection>> = vec![Vec::new(); file.ped_ids.len()];
    for d in &file.dets {
        if let Some(t) = tracks.get_mut(d.id) {
            t.push(*d);
        }
    }
    let clock = clock(info);
    let mut out = Vec::new();
    for (t, &ped_id) in tracks.iter_mut().zip(&file.ped_ids) {
        // Stable: detections at one time stay in file order, so an error names the later line.
        t.sort_by(|a, b| a.t.total_cmp(&b.t));
        track_windows(path, &scene, ped_id, t, &clock, &mut out)?;
    }
    Ok(out)
}

/// One split (`train`, `val` or `test`) of the folder data set at `dir`.
pub fn load_folder(dir: &Path, split: &str) -> Result<Dataset, FolderError> {
    let info = FolderInfo::read(dir)?;
    let mut windows = Vec::new();
    for f in info.split_files(dir, split)? {
        let mut ws = parse_folder_file(&f, &info)?;
        // A file under a homography is in metres already (`super::detections`).
        if !info.metres_per_pixel.is_empty() && info.homography_of(&f)?.is_none() {
            let stem = scene_name(&f);
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
