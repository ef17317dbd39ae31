//! The Stanford Drone Dataset (TrajNet split, pixels).

use std::collections::HashMap;
use std::path::Path;

use super::rows::{id_key, load_split, load_split_where, scene_name};
use super::*;

/// The SDD splits shipped in `shared/data/sdd/`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum SddSplit {
    /// `sdd/train/`: 30 scenes, 8494 trajectories (Y-Net's training set).
    Train,
    /// `sdd/train_extra/`: `nexus_2`, 491 trajectories (in TrajNet's training set, not Y-Net's).
    TrainExtra,
    /// `sdd/test/`: 17 scenes, 2829 trajectories (the PECNet / Y-Net benchmark test set).
    Test,
}

impl SddSplit {
    /// Folder name under `sdd/`.
    pub fn dir_name(self) -> &'static str {
        match self {
            SddSplit::Train => "train",
            SddSplit::TrainExtra => "train_extra",
            SddSplit::Test => "test",
        }
    }
}

/// Parse one SDD file into windows (see [`load_sdd`] for the rules).
pub fn parse_sdd_file(path: &Path) -> Result<Vec<Window>, DataError> {
    let rows = read_rows(path)?;
    let scene = scene_name(path);
    // Group by ped id in first-appearance order.
    let mut order: Vec<u64> = Vec::new();
    let mut groups: HashMap<u64, Vec<Row>> = HashMap::new();
    for r in rows {
        let k = id_key(r.ped_id);
        groups
            .entry(k)
            .or_insert_with(|| {
                order.push(k);
                Vec::new()
            })
            .push(r);
    }
    let mut windows = Vec::with_capacity(order.len());
    for k in order {
        let g = match groups.get(&k) {
            Some(g) if !g.is_empty() => g,
            _ => continue,
        };
        let (first, last) = (g[0], g[g.len() - 1]);
        if g.len() % WINDOW != 0 {
            return Err(DataError::TrajectoryLength {
                path: path.to_path_buf(),
                line: first.line,
                last_line: last.line,
                ped_id: first.ped_id,
                rows: g.len(),
            });
        }
        for chunk in g.chunks_exact(WINDOW) {
            let mut w = Window {
                scene: scene.clone(),
                ped_id: first.ped_id,
                frames: [0; WINDOW],
                pos: [[0.0; 2]; WINDOW],
            };
            for (t, r) in chunk.iter().enumerate() {
                if t > 0 {
                    let prev = chunk[t - 1].frame;
                    let step = r.frame - prev;
                    if step != SDD_FRAME_STEP {
                        return Err(DataError::FrameStep {
                            path: path.to_path_buf(),
                            line: r.line,
                            ped_id: r.ped_id,
                            prev_frame: prev,
                            frame: r.frame,
                            found: step,
                            expected: SDD_FRAME_STEP,
                        });
                    }
                }
                w.frames[t] = r.frame;
                w.pos[t] = r.pos;
            }
            windows.push(w);
        }
    }
    Ok(windows)
}

/// Load an SDD split (TrajNet release, pixels) from `root/sdd/<split>/`.
///
/// Every `*.txt` file is read in **sorted file-name order**; the scene is the file stem. Rows
/// are grouped by ped id (parsed as a number, so `100` and `28.0` both work) in
/// first-appearance order. Each id must have exactly 20 rows (a multiple of 20 is accepted and
/// cut into consecutive 20-row trajectories) with a frame step of 12 between consecutive rows.
///
/// Counts: train 30 scenes / 8494 windows, train_extra 1 / 491, test 17 / 2829.
pub fn load_sdd(root: &Path, split: SddSplit) -> Result<Dataset, DataError> {
    let dir = root.join("sdd").join(split.dir_name());
    load_split(
        &dir,
        &format!("SDD {} directory", split.dir_name()),
        parse_sdd_file,
        format!("sdd/{}", split.dir_name()),
        Unit::Pixels,
    )
}

/// The windows of the scenes `scenes` of an SDD split, exactly as they sit in
/// [`load_sdd`]'s data set (same order, same name), reading only those scenes' files: the
/// validation scenes without parsing the whole training split.
pub(crate) fn load_sdd_scenes(
    root: &Path,
    split: SddSplit,
    scenes: &[String],
) -> Result<Dataset, DataError> {
    let dir = root.join("sdd").join(split.dir_name());
    load_split_where(
        &dir,
        &format!("SDD {} directory", split.dir_name()),
        parse_sdd_file,
        format!("sdd/{}", split.dir_name()),
        Unit::Pixels,
        |f| scenes.contains(&scene_name(f)),
    )
}
