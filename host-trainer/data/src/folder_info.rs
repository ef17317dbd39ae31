//! A user's own data set: a folder with `dataset.toml` and `train/`, `val/`, `test/` folders
//! of detection files (the layout `docs/own-data.md` documents).
//!
//! ```text
//! mydrone/
//!   dataset.toml          unit, clock, name, licence, file layout (below)
//!   train/*.txt           one file per scene or flight: `time id x y` rows, any order
//!   val/*.txt             model selection only (optional for `gpecnet eval`)
//!   test/*.txt            touched once per shipped model
//! ```
//!
//! ```toml
//! name = "mydrone"              # optional, default the folder name
//! unit = "m"                    # "m" (metres) or "px" (pixels)
//! seconds_per_frame = 0.1       # the clock: the time column holds frame numbers this far apart
//! # time_unit = "s"             # ... or it holds timestamps in seconds ("s") or milliseconds ("ms")
//! max_gap_s = 1.0               # optional: longest gap between two detections of a track that
//!                               # is interpolated (default below); a longer one ends the track
//! licence = "CC BY 4.0"         # optional: the data's licence, copied into every model card
//! [columns]                     # optional: files with a header row, columns mapped by name
//! time = "timestamp"            # or frame = "frame_no" (with seconds_per_frame)
//! id = "track_id"               # numbers or any text
//! x = "x_m"
//! y = "y_m"
//! delimiter = ","               # optional: default by extension (.csv ",", .tsv tab, .txt spaces)
//! [metres_per_pixel]            # optional, pixel data only: file stem -> factor; with it the
//! flight_01 = 0.041             # whole set is converted to metres (every file must be listed)
//! [homography]                  # optional, pixel data only: file stem (or "*" for every file)
//! "*" = [0.021, 0.0, -4.9, 0.0, 0.021, -3.1, 0.0, 0.00012, 1.0]   # -> image-to-ground 3 x 3,
//!                               # row-major; with it the whole set is in metres
//! ```
//!
//! **Cameras.** A camera looking straight down at a known height has one metres-per-pixel
//! factor (`[metres_per_pixel]`); an oblique, calibrated camera has a homography
//! (`[homography]`, `super::homography`: each detection's pixel mapped to the ground before
//! its track is resampled, since the map is not linear). A file takes one or the other, and
//! either table, when given, must cover every file (a stem of its own, or `"*"` in
//! `[homography]`).
//!
//! Without `[columns]` a split's files are its `*.txt` files of whitespace-separated `time id x
//! y` rows; with it, its `*.csv`, `*.tsv` and `*.txt` files (`super::detections`).
//!
//! **Clock.** Any clock: the tracks are resampled onto the models' [`PERIOD_S`] (0.4 s) grid
//! by the core's timed track table (`super::resample`): linear interpolation between
//! consecutive detections of a track, never across a gap longer than `max_gap_s`. A frame
//! clock takes `seconds_per_frame` in [0.001, 3.2] s (frames must be whole numbers);
//! `max_gap_s` is in [0.001, 3.2] s (at most 8 periods, so the table computes every grid point
//! of a bridged gap), at least `seconds_per_frame`, and by default the larger of 1 s and
//! 1.5 frames (1 s for timestamps). On a clock that divides 0.4 s (30 fps, 25, 10, 2.5 Hz …)
//! with a detection at every grid time the windows are the detections at the grid frames,
//! exactly the windows of a frame-step rule. Files are read in sorted name order,
//! pedestrians in first-appearance order, windows by start time. Nothing else is dropped (no
//! neighbour rule, no speed rule).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use super::rows::sorted_files;
use super::*;

/// The name of a folder data set's description file.
pub const DATASET_TOML: &str = "dataset.toml";

/// Largest `dataset.toml` read (bytes).
const MAX_TOML_BYTES: u64 = 64 * 1024;

/// Longest `max_gap_s` (and slowest frame clock): 8 periods, so a bridged gap never completes
/// more grid points than the track table computes.
pub const MAX_GAP_S: f64 = 3.2;

/// Shortest frame period: the track table's millisecond.
pub const MIN_SECONDS_PER_FRAME: f64 = 0.001;

/// What the time column of a folder's files holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TimeColumn {
    /// Whole frame numbers, `seconds_per_frame` apart.
    Frame,
    /// Timestamps in seconds (`time_unit = "s"`).
    Seconds,
    /// Timestamps in milliseconds (`time_unit = "ms"`).
    Milliseconds,
}

/// `[columns]` of `dataset.toml`: files with a header row, columns by name.
#[derive(Clone, Debug, PartialEq)]
pub struct Columns {
    /// The time column (`frame = …` or `time = …`).
    pub time: String,
    /// The id column.
    pub id: String,
    /// The x column.
    pub x: String,
    /// The y column.
    pub y: String,
    /// The separator (`None`: by extension; `b' '`: runs of whitespace).
    pub delimiter: Option<u8>,
}

/// `dataset.toml`, parsed and checked.
#[derive(Debug, Clone, PartialEq)]
pub struct FolderInfo {
    /// The set's name (default: the folder's name).
    pub name: Option<String>,
    /// `"m"` or `"px"`.
    pub unit: String,
    /// Seconds per unit of the time column: the frame period of a frame clock, 1 for
    /// timestamps in seconds, 0.001 for milliseconds.
    pub seconds_per_frame: f64,
    /// What the time column holds.
    pub time: TimeColumn,
    /// The longest gap between two detections of a track that is interpolated (seconds).
    pub max_gap_s: f64,
    /// The data's licence, copied into model cards.
    pub licence: Option<String>,
    /// Pixel data only: metres per pixel of each file (by stem); converts the set to metres.
    pub metres_per_pixel: BTreeMap<String, f64>,
    /// Pixel data only: the image-to-ground homography of each file (by stem, or `"*"` for
    /// every file without its own); converts the set to metres.
    pub homography: BTreeMap<String, Homography>,
    /// Files with a header row, when set.
    pub columns: Option<Columns>,
}

/// `dataset.toml` as written.
#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct RawInfo {
    #[serde(default)]
    name: Option<String>,
    unit: String,
    #[serde(default)]
    seconds_per_frame: Option<f64>,
    #[serde(default)]
    time_unit: Option<String>,
    #[serde(default)]
    max_gap_s: Option<f64>,
    #[serde(default)]
    licence: Option<String>,
    #[serde(default)]
    metres_per_pixel: BTreeMap<String, f64>,
    #[serde(default)]
    homography: BTreeMap<String, Vec<f64>>,
    #[serde(default)]
    columns: Option<RawColumns>,
}

/// `[columns]` as written.
#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct RawColumns {
    #[serde(default)]
    frame: Option<String>,
    #[serde(default)]
    time: Option<String>,
    id: String,
    x: String,
    y: String,
    #[serde(default)]
    delimiter: Option<String>,
}

/// A problem with a data-set folder: its description, its layout or a file's content.
#[derive(Debug, thiserror::Error)]
pub enum FolderError {
    /// `dataset.toml` is missing, unreadable or not valid TOML.
    #[error("{path}: {msg}", path = .path.display())]
    Toml {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        msg: String,
    },
    /// A key of `dataset.toml` has a wrong or missing value.
    #[error(
        "{path}{at}: {key}: {msg} (docs/own-data.md)",
        path = .path.display(),
        at = .line.map(|l| format!(":{l}")).unwrap_or_default()
    )]
    Key {
        /// The `dataset.toml`.
        path: PathBuf,
        /// The 1-based line of the key, when it is written.
        line: Option<usize>,
        /// The key (`seconds_per_frame`, `columns.x`, …).
        key: String,
        /// What is wrong.
        msg: String,
    },
    /// A split folder is missing or holds no data file.
    #[error(
        "{path}: {msg}; a data-set folder holds dataset.toml and train/, val/, test/ folders \
         of data files (docs/own-data.md)",
        path = .path.display()
    )]
    Split {
        /// The split folder.
        path: PathBuf,
        /// What is wrong.
        msg: String,
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
    /// A file of a pixel set mapped by homographies has none.
    #[error(
        "{path}: no [homography] entry for {stem:?} and no \"*\" in dataset.toml (every \
         file of a mapped set needs one)",
        path = .path.display()
    )]
    NoHomography {
        /// The data file.
        path: PathBuf,
        /// Its stem.
        stem: String,
    },
    /// A column `[columns]` names is not in a file's header.
    #[error(
        "{path}:{line}: {key} = {name:?} is not a column of this header (columns: {header:?})",
        path = .path.display()
    )]
    NoColumn {
        /// The data file.
        path: PathBuf,
        /// The header's 1-based line.
        line: usize,
        /// The key (`columns.x`, …).
        key: &'static str,
        /// The column name it gives.
        name: String,
        /// The header's column names.
        header: Vec<String>,
    },
    /// A value of a mapped column is wrong.
    #[error(
        "{path}:{line}: {key} (column {column:?}): {text:?} is not {expected}",
        path = .path.display()
    )]
    Value {
        /// The data file.
        path: PathBuf,
        /// 1-based line.
        line: usize,
        /// The key (`columns.time`, `columns.x`, …).
        key: &'static str,
        /// The column's name.
        column: String,
        /// The text found.
        text: String,
        /// What was expected.
        expected: &'static str,
    },
    /// A line that cannot be split into fields.
    #[error("{path}:{line}: {msg}", path = .path.display())]
    Row {
        /// The data file.
        path: PathBuf,
        /// 1-based line.
        line: usize,
        /// What is wrong.
        msg: String,
    },
    /// Two detections of one pedestrian in the same millisecond (timestamps).
    #[error(
        "{path}:{line}: ped_id {ped_id} has two detections at the same time (to the \
         millisecond, {ms} ms after its first; the other at line {first_line})",
        path = .path.display()
    )]
    SameTime {
        /// The data file.
        path: PathBuf,
        /// 1-based line of the later detection in time order.
        line: usize,
        /// 1-based line of the other.
        first_line: usize,
        /// The pedestrian.
        ped_id: f64,
        /// Milliseconds after its first detection.
        ms: u32,
    },
    /// A pedestrian's detections span more than the track table's 2³¹ ms.
    #[error(
        "{path}:{line}: ped_id {ped_id} is detected more than 2^31 ms (24.8 days) after its \
         first detection (line {first_line}): split the recording or check the time unit",
        path = .path.display()
    )]
    TimeRange {
        /// The data file.
        path: PathBuf,
        /// 1-based line of the late detection.
        line: usize,
        /// 1-based line of the first.
        first_line: usize,
        /// The pedestrian.
        ped_id: f64,
    },
    /// The track table refused a detection the loader had checked (never expected).
    #[error("{path}:{line}: ped_id {ped_id}: the track table refused the detection: {why}", path = .path.display())]
    Track {
        /// The data file.
        path: PathBuf,
        /// 1-based line.
        line: usize,
        /// The pedestrian.
        ped_id: f64,
        /// The table's answer.
        why: String,
    },
    /// A data file problem.
    #[error(transparent)]
    Data(#[from] DataError),
}

/// The 1-based line of `key` in a TOML text: the first line `key = …` (after the header
/// `[table]` when `table` is given).
fn key_line(text: &str, table: Option<&str>, key: &str) -> Option<usize> {
    let mut in_table = table.is_none();
    for (i, l) in text.lines().enumerate() {
        let t = l.trim();
        if t.starts_with('[') {
            in_table =
                table.is_some_and(|tb| t.trim_matches(|c| c == '[' || c == ']').trim() == tb);
            continue;
        }
        if in_table {
            if let Some(rest) = t.strip_prefix(key) {
                if rest.trim_start().starts_with('=') {
                    return Some(i + 1);
                }
            }
        }
    }
    None
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
                 dataset.toml with unit and seconds_per_frame or time_unit (docs/own-data.md)"
            ))
        })?;
        if !meta.is_file() || meta.len() > MAX_TOML_BYTES {
            return Err(bad(format!(
                "not a regular file of at most {MAX_TOML_BYTES} bytes"
            )));
        }
        let text = crate::inpath::read_text_limited(&path, crate::inpath::FileKind::Text)
            .map_err(|e| bad(e.to_string()))?;
        let raw: RawInfo = toml::from_str(&text).map_err(|e| bad(e.to_string()))?;
        Self::check(raw, &path, &text)
    }

    /// Checks every key of a parsed `dataset.toml` (`path`, `text`: its file and content).
    fn check(raw: RawInfo, path: &Path, text: &str) -> Result<Self, FolderError> {
        let key = |table: Option<&str>, k: &str, msg: String| FolderError::Key {
            path: path.to_path_buf(),
            line: key_line(text, table, k),
            key: match table {
                Some(t) => format!("{t}.{k}"),
                None => k.to_string(),
            },
            msg,
        };
        if raw.unit != "m" && raw.unit != "px" {
            return Err(key(
                None,
                "unit",
                format!("{:?}: expected \"m\" (metres) or \"px\" (pixels)", raw.unit),
            ));
        }
        let (time, seconds_per_frame) = match (raw.seconds_per_frame, raw.time_unit.as_deref()) {
            (Some(s), None) => {
                if !(s.is_finite() && (MIN_SECONDS_PER_FRAME..=MAX_GAP_S).contains(&s)) {
                    return Err(key(
                        None,
                        "seconds_per_frame",
                        format!(
                            "{s}: expected a number of seconds in [{MIN_SECONDS_PER_FRAME}, \
                             {MAX_GAP_S}] (any clock is resampled onto the models' {PERIOD_S} s)"
                        ),
                    ));
                }
                (TimeColumn::Frame, s)
            }
            (None, Some("s")) => (TimeColumn::Seconds, 1.0),
            (None, Some("ms")) => (TimeColumn::Milliseconds, 0.001),
            (None, Some(u)) => {
                return Err(key(
                    None,
                    "time_unit",
                    format!("{u:?}: expected \"s\" (seconds) or \"ms\" (milliseconds)"),
                ))
            }
            (Some(_), Some(_)) => {
                return Err(key(
                    None,
                    "time_unit",
                    "set either seconds_per_frame (the time column holds frame numbers) or \
                     time_unit (it holds timestamps), not both"
                        .into(),
                ))
            }
            (None, None) => {
                return Err(key(
                    None,
                    "seconds_per_frame",
                    "missing: the data's clock is seconds_per_frame = <seconds between \
                     consecutive frame numbers> or time_unit = \"s\" | \"ms\" (timestamps)"
                        .into(),
                ))
            }
        };
        let max_gap_s = match raw.max_gap_s {
            Some(g) => {
                if !(g.is_finite() && (MIN_SECONDS_PER_FRAME..=MAX_GAP_S).contains(&g)) {
                    return Err(key(
                        None,
                        "max_gap_s",
                        format!(
                            "{g}: expected seconds in [{MIN_SECONDS_PER_FRAME}, {MAX_GAP_S}] \
                             (at most 8 periods of {PERIOD_S} s)"
                        ),
                    ));
                }
                if time == TimeColumn::Frame && g < seconds_per_frame {
                    return Err(key(
                        None,
                        "max_gap_s",
                        format!(
                            "{g} is shorter than one frame ({seconds_per_frame} s): no two \
                             detections of a track would be joined"
                        ),
                    ));
                }
                g
            }
            None if time == TimeColumn::Frame => (1.5 * seconds_per_frame).clamp(1.0, MAX_GAP_S),
            None => 1.0,
        };
        let columns = match raw.columns {
            None => None,
            Some(c) => {
                let t = match (c.frame, c.time, time) {
                    (Some(f), None, TimeColumn::Frame) => f,
                    (None, Some(t), TimeColumn::Seconds | TimeColumn::Milliseconds) => t,
                    (Some(_), None, _) => {
                        return Err(key(
                            Some("columns"),
                            "frame",
                            "a frame column needs seconds_per_frame (for timestamps write \
                             columns.time and time_unit)"
                                .into(),
                        ))
                    }
                    (None, Some(_), _) => {
                        return Err(key(
                            Some("columns"),
                            "time",
                            "a time column needs time_unit = \"s\" or \"ms\" (for frame \
                             numbers write columns.frame and seconds_per_frame)"
                                .into(),
                        ))
                    }
                    (Some(_), Some(_), _) => {
                        return Err(key(
                            Some("columns"),
                            "time",
                            "give either frame or time, not both".into(),
                        ))
                    }
                    (None, None, _) => {
                        return Err(key(
                            Some("columns"),
                            "time",
                            "missing: name the time column (time = \"…\") or the frame \
                             column (frame = \"…\")"
                                .into(),
                        ))
                    }
                };
                let delimiter = match c.delimiter.as_deref() {
                    None => None,
                    Some(d) if d.len() == 1 && d.is_ascii() && d != "\"" && d != "\n" => {
                        Some(d.as_bytes()[0])
                    }
                    Some(d) => {
                        return Err(key(
                            Some("columns"),
                            "delimiter",
                            format!(
                                "{d:?}: expected one ASCII character (\",\", \";\", \"\\t\", \
                                 or \" \" for runs of whitespace)"
                            ),
                        ))
                    }
                };
                for (k, v) in [("id", &c.id), ("x", &c.x), ("y", &c.y)] {
                    if v.is_empty() {
                        return Err(key(Some("columns"), k, "an empty column name".into()));
                    }
                }
                Some(Columns {
                    time: t,
                    id: c.id,
                    x: c.x,
                    y: c.y,
                    delimiter,
                })
            }
        };
        if !raw.metres_per_pixel.is_empty() && raw.unit != "px" {
            return Err(key(
                None,
                "unit",
                "metres_per_pixel converts pixel data: set unit = \"px\"".into(),
            ));
        }
        // Positions are scaled in f32: the factor must survive the conversion (1e-300 is a
        // positive f64 and 0 as f32; 1e300 is infinite), as a normal number.
        if let Some((k, v)) = raw.metres_per_pixel.iter().find(|(_, v)| {
            let f = **v as f32;
            !(v.is_finite() && **v > 0.0 && f.is_finite() && f.is_normal())
        }) {
            return Err(key(
                Some("metres_per_pixel"),
                k,
                format!(
                    "{v}: expected a positive number that is a normal f32 (between {:e} and \
                     {:e})",
                    f32::MIN_POSITIVE,
                    f32::MAX
                ),
            ));
        }
        let mut homography = BTreeMap::new();
        for (k, v) in &raw.homography {
            if raw.unit != "px" {
                return Err(key(
                    None,
                    "unit",
                    "[homography] maps pixel data to metres: set unit = \"px\"".into(),
                ));
            }
            let h = Homography::new(v).map_err(|msg| key(Some("homography"), k, msg))?;
            homography.insert(k.clone(), h);
        }
        // One camera model per file: a factor or a homography.
        let all = homography.contains_key("*");
        if let Some(k) = raw
            .metres_per_pixel
            .keys()
            .find(|k| all || homography.contains_key(*k))
        {
            return Err(key(
                Some("metres_per_pixel"),
                k,
                "this file also has a [homography] (or \"*\" covers it): give each file \
                 one of the two"
                    .into(),
            ));
        }
        // The licence is stored in every blob trained on the folder: refused here, naming the
        // key, rather than at export.
        let most = gpecnet_core::blob::MAX_META_TEXT;
        if let Some(l) = raw.licence.as_ref().filter(|l| l.len() > most) {
            return Err(key(
                None,
                "licence",
                format!(
                    "the licence is {} bytes: allowed at most {most} (a blob stores it)",
                    l.len()
                ),
            ));
        }
        Ok(FolderInfo {
            name: raw.name,
            unit: raw.unit,
            seconds_per_frame,
            time,
            max_gap_s,
            licence: raw.licence,
            metres_per_pixel: raw.metres_per_pixel,
            homography,
            columns,
        })
    }

    /// The homography of the data file `path` (its stem's, else `"*"`), `None` for a set
    /// without `[homography]`; [`FolderError::NoHomography`] when the set has one but not for
    /// this file (and it has no metres-per-pixel factor either).
    pub fn homography_of(&self, path: &Path) -> Result<Option<&Homography>, FolderError> {
        if self.homography.is_empty() {
            return Ok(None);
        }
        let stem = super::rows::scene_name(path);
        match self.homography.get(&stem).or(self.homography.get("*")) {
            Some(h) => Ok(Some(h)),
            None if self.metres_per_pixel.contains_key(&stem) => Ok(None),
            None => Err(FolderError::NoHomography {
                path: path.to_path_buf(),
                stem,
            }),
        }
    }

    /// The unit of the loaded windows (metres when pixel data is converted).
    pub fn unit(&self) -> Unit {
        if self.unit == "m" || !self.metres_per_pixel.is_empty() || !self.homography.is_empty() {
            Unit::Metres
        } else {
            Unit::Pixels
        }
    }

    /// The file extensions a split's data files have.
    pub fn extensions(&self) -> &'static [&'static str] {
        if self.columns.is_some() {
            &["csv", "tsv", "txt"]
        } else {
            &["txt"]
        }
    }

    /// The clock of the files in words, for reports.
    pub fn describe_clock(&self) -> String {
        let clock = match self.time {
            TimeColumn::Frame => format!(
                "frame numbers, {} s apart ({:.3} Hz)",
                self.seconds_per_frame,
                1.0 / self.seconds_per_frame
            ),
            TimeColumn::Seconds => "timestamps in seconds".to_string(),
            TimeColumn::Milliseconds => "timestamps in milliseconds".to_string(),
        };
        format!(
            "{clock}, resampled onto {PERIOD_S} s steps (gaps up to {} s interpolated)",
            self.max_gap_s
        )
    }

    /// The data files of one split folder, sorted by name (errors name the folder and
    /// point at the folder layout, not at the benchmark data).
    pub fn split_files(&self, dir: &Path, split: &str) -> Result<Vec<PathBuf>, FolderError> {
        let sub = dir.join(split);
        let exts = self.extensions();
        let pattern = exts
            .iter()
            .map(|e| format!("*.{e}"))
            .collect::<Vec<_>>()
            .join(", ");
        match sorted_files(&sub, split, exts) {
            Ok(f) => Ok(f),
            Err(DataError::Missing { path, .. }) => Err(FolderError::Split {
                path,
                msg: format!("the {split}/ folder of the data set is missing"),
            }),
            Err(DataError::NoFiles { path }) => Err(FolderError::Split {
                path,
                msg: format!("no data file ({pattern}) in the {split}/ folder"),
            }),
            Err(e) => Err(e.into()),
        }
    }
}
