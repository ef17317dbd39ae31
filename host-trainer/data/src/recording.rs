//! Recordings: a split's files as a drone would see them, frame by frame in time order, with
//! every detection of every pedestrian (lone walkers and short tracks included), not cut into
//! windows. The input of the streaming evaluation (`gpecnet stream`).
//!
//! A recording is one data file: its rows grouped by frame, frames in ascending order, each
//! frame's time in milliseconds from the file's first frame (`(frame − first) · ms_per_frame`,
//! rounded to the nearest millisecond in f64), ids numbered 1, 2, … by first appearance (the
//! file's ids may be any number). Clocks: SDD 30 frames per second (its 12-frame steps are
//! 0.4 s), ETH/UCY 25 (10-frame steps), a folder its `dataset.toml`'s clock and layout (any
//! clock, plain text or files with a header: `super::folder_info`). `metres_per_unit`
//! is 1 for metre data and the scene's metres per pixel for pixel data where it is known.

use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};

use super::rows::{id_key, scene_name, sorted_txt_files};
use super::*;

/// One frame of a recording: its time and its detections `(id, position)`.
#[derive(Clone, Debug, PartialEq)]
pub struct RecordedFrame {
    /// Milliseconds since the recording's first frame.
    pub t_ms: u32,
    /// The detections of this frame, in file order.
    pub detections: Vec<(u32, [f32; 2])>,
}

/// One data file as a time-ordered sequence of frames (module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct Recording {
    /// The scene (the file stem).
    pub scene: String,
    /// The file it was read from.
    pub path: PathBuf,
    /// The unit of the positions.
    pub unit: Unit,
    /// Metres per unit of the positions (1 for metres; `None`: pixels of unknown scale).
    pub metres_per_unit: Option<f32>,
    /// The frames, in time order.
    pub frames: Vec<RecordedFrame>,
}

impl Recording {
    /// Detections in the recording.
    pub fn detections(&self) -> usize {
        self.frames.iter().map(|f| f.detections.len()).sum()
    }

    /// Distinct pedestrians in the recording.
    pub fn pedestrians(&self) -> usize {
        let mut ids: Vec<u32> = self
            .frames
            .iter()
            .flat_map(|f| f.detections.iter().map(|d| d.0))
            .collect();
        ids.sort_unstable();
        ids.dedup();
        ids.len()
    }
}

/// Milliseconds per SDD frame (30 fps).
const SDD_MS_PER_FRAME: f64 = 1000.0 / 30.0;
/// Milliseconds per ETH/UCY frame (25 fps: 10 frames are 0.4 s).
const ETH_UCY_MS_PER_FRAME: f64 = 40.0;

/// The recordings of one split of `spec` under `root`, one per file, in the order the
/// window loaders read them. For SDD, `val_scenes` are the validation scenes held out of
/// `sdd/train` (the validation split is their files; the training split the others).
pub fn recordings(
    root: &Path,
    spec: &DatasetSpec,
    split: Split,
    val_scenes: &[String],
) -> Result<Vec<Recording>, LoadError> {
    match spec {
        DatasetSpec::Sdd | DatasetSpec::SddMetres => {
            let metres = matches!(spec, DatasetSpec::SddMetres);
            let scales = sdd_metres_per_pixel(root)?;
            let sub = if split == Split::Test {
                "test"
            } else {
                "train"
            };
            let dir = root.join("sdd").join(sub);
            let mut out = Vec::new();
            for f in sorted_txt_files(&dir, &format!("SDD {sub} directory"))? {
                let scene = scene_name(&f);
                let held_out = val_scenes.contains(&scene);
                let wanted = match split {
                    Split::Test => true,
                    Split::Val => held_out,
                    Split::Train => !held_out,
                };
                if !wanted {
                    continue;
                }
                let scale = scales.get(&scene).map(|&s| s as f32);
                let mut r = read_recording(&f, SDD_MS_PER_FRAME, Unit::Pixels, scale)?;
                if metres {
                    let s = scale.ok_or_else(|| LoadError::NoScale {
                        scene: scene.clone(),
                        table: root
                            .join("sdd")
                            .join("scales")
                            .join("sdd_meters_per_pixel.csv"),
                    })?;
                    r.scale(s);
                }
                out.push(r);
            }
            if split == Split::Val {
                for s in val_scenes {
                    if !out.iter().any(|r| &r.scene == s) {
                        return Err(LoadError::UnknownValScene {
                            scene: s.clone(),
                            dataset: "sdd/train".into(),
                        });
                    }
                }
            }
            Ok(out)
        }
        DatasetSpec::EthUcy(scene) => {
            let dir = root.join("eth_ucy").join(scene).join(split.dir_name());
            let what = format!("ETH/UCY {scene}/{} directory", split.dir_name());
            sorted_txt_files(&dir, &what)?
                .iter()
                .map(|f| {
                    read_recording(f, ETH_UCY_MS_PER_FRAME, Unit::Metres, Some(1.0))
                        .map_err(LoadError::from)
                })
                .collect()
        }
        DatasetSpec::Folder { dir, .. } => {
            let dir = Path::new(dir);
            let info = FolderInfo::read(dir)?;
            let mut out = Vec::new();
            for f in info.split_files(dir, split.dir_name())? {
                let stem = scene_name(&f);
                if info.unit == "m" || info.homography_of(&f)?.is_some() {
                    out.push(read_folder_recording(&f, &info, Unit::Metres, Some(1.0))?);
                } else if let Some(&s) = info.metres_per_pixel.get(&stem) {
                    let mut r = read_folder_recording(&f, &info, Unit::Pixels, Some(s as f32))?;
                    r.scale(s as f32);
                    out.push(r);
                } else if info.metres_per_pixel.is_empty() {
                    out.push(read_folder_recording(&f, &info, Unit::Pixels, None)?);
                } else {
                    return Err(FolderError::NoScale { path: f, stem }.into());
                }
            }
            Ok(out)
        }
        DatasetSpec::Combined(parts) => {
            let mut out = Vec::new();
            for p in parts {
                out.extend(recordings(root, p, split, val_scenes)?);
            }
            Ok(out)
        }
    }
}

impl Recording {
    /// Pixel positions into metres: every coordinate times `s` in f32 (as the window loaders
    /// convert SDD), the unit metres.
    fn scale(&mut self, s: f32) {
        for f in &mut self.frames {
            for d in &mut f.detections {
                d.1 = [d.1[0] * s, d.1[1] * s];
            }
        }
        self.unit = Unit::Metres;
        self.metres_per_unit = Some(1.0);
    }
}

/// One file of a data-set folder as a recording, in the folder's layout and clock (plain
/// `time id x y` text or a file with a header; frame numbers or timestamps): times rounded to
/// whole milliseconds from the file's first detection. Two detections of one pedestrian in the
/// same millisecond are [`DataError::DuplicateRow`].
fn read_folder_recording(
    path: &Path,
    info: &FolderInfo,
    unit: Unit,
    metres_per_unit: Option<f32>,
) -> Result<Recording, FolderError> {
    let file = super::detections::read_detections(path, info)?;
    let ms_per_unit = info.seconds_per_frame * 1000.0;
    let first = file.dets.iter().map(|d| d.t).fold(f64::INFINITY, f64::min);
    let mut frames: BTreeMap<u64, Vec<(u32, [f32; 2], usize)>> = BTreeMap::new();
    for d in &file.dets {
        let t = ((d.t - first) * ms_per_unit).round();
        let id = u32::try_from(d.id + 1).unwrap_or(u32::MAX);
        let ped = file.ped_ids.get(d.id).copied().unwrap_or(f64::NAN);
        if !(0.0..=f64::from(u32::MAX)).contains(&t) {
            return Err(DataError::BadNumber {
                path: path.to_path_buf(),
                line: d.line,
                column: 1,
                text: d.t.to_string(),
                expected: "a time within 2^32 milliseconds of the file's first detection",
            }
            .into());
        }
        let f = frames.entry(t as u64).or_default();
        if f.iter().any(|x| x.0 == id) {
            return Err(DataError::DuplicateRow {
                path: path.to_path_buf(),
                line: d.line,
                ped_id: ped,
                frame: t as i64,
            }
            .into());
        }
        f.push((id, d.pos, d.line));
    }
    Ok(Recording {
        scene: scene_name(path),
        path: path.to_path_buf(),
        unit,
        metres_per_unit,
        frames: frames
            .into_iter()
            .map(|(t, dets)| RecordedFrame {
                t_ms: t as u32,
                detections: dets.into_iter().map(|d| (d.0, d.1)).collect(),
            })
            .collect(),
    })
}

/// One `frame id x y` file as a recording (module docs); two rows of one id in one frame are
/// [`DataError::DuplicateRow`], a time beyond `u32` milliseconds [`DataError::BadNumber`].
pub fn read_recording(
    path: &Path,
    ms_per_frame: f64,
    unit: Unit,
    metres_per_unit: Option<f32>,
) -> Result<Recording, DataError> {
    let rows = read_rows(path)?;
    let mut ids: HashMap<u64, u32> = HashMap::new();
    let mut frames: BTreeMap<i64, Vec<(u32, [f32; 2], usize)>> = BTreeMap::new();
    for r in &rows {
        let next = ids.len() as u32 + 1;
        let id = *ids.entry(id_key(r.ped_id)).or_insert(next);
        let f = frames.entry(r.frame).or_default();
        if f.iter().any(|d| d.0 == id) {
            return Err(DataError::DuplicateRow {
                path: path.to_path_buf(),
                line: r.line,
                ped_id: r.ped_id,
                frame: r.frame,
            });
        }
        f.push((id, r.pos, r.line));
    }
    let first = frames.keys().next().copied().unwrap_or(0);
    let mut out = Vec::with_capacity(frames.len());
    for (frame, dets) in frames {
        let t = ((frame - first) as f64 * ms_per_frame).round();
        if !(0.0..=f64::from(u32::MAX)).contains(&t) {
            let line = dets.first().map_or(0, |d| d.2);
            return Err(DataError::BadNumber {
                path: path.to_path_buf(),
                line,
                column: 1,
                text: frame.to_string(),
                expected: "a frame within 2^32 milliseconds of the file's first frame",
            });
        }
        out.push(RecordedFrame {
            t_ms: t as u32,
            detections: dets.into_iter().map(|d| (d.0, d.1)).collect(),
        });
    }
    Ok(Recording {
        scene: scene_name(path),
        path: path.to_path_buf(),
        unit,
        metres_per_unit,
        frames: out,
    })
}
