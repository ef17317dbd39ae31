//! One file of a data-set folder read into detections `(time, id, position)`, in either of
//! the two layouts a folder may use (`dataset.toml`'s `[columns]`, `super::folder`):
//!
//! * **plain text** (no `[columns]`): `*.txt` files of whitespace-separated `time id x y`
//!   rows, no header, exactly four columns;
//! * **with a header** (`[columns]`): `*.csv` (comma), `*.tsv` (tab) and `*.txt` (runs of
//!   whitespace) files whose first non-blank line names the columns; `[columns]` says which
//!   column is the time (or frame), the id, x and y, by name; other columns are ignored.
//!   `delimiter` overrides the extension's separator. Fields may be quoted (`"a,b"`, `""`
//!   for a quote), within one line.
//!
//! The time is a whole frame number (a frame clock, `seconds_per_frame`) or a timestamp
//! (`time_unit`, any finite number). Ids are text: when every id of a file is a number they
//! are compared by value (`28` and `28.0` are one pedestrian) and kept as the window's
//! `ped_id`; otherwise (`"ped_7"`, `"a3f1"`) each distinct id is numbered 1, 2, … in order of
//! first appearance. Blank lines are skipped but counted, a trailing `\r` and a leading UTF-8
//! byte-order mark are ignored. Every problem is an error naming the file and the 1-based line
//! (and, in a file with a header, the `[columns]` key and the column's name).

use std::collections::HashMap;
use std::path::Path;

use super::folder_info::{Columns, FolderError, FolderInfo, TimeColumn};
use super::rows::{four_columns, id_key, lines, parse_f64, read_data_file, MAX_FRAME};
use super::*;

/// One detection of a file.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Detection {
    /// 1-based line in the file.
    pub line: usize,
    /// The time column's value: a frame number or a timestamp in the folder's time unit.
    pub t: f64,
    /// Index of the pedestrian in [`FileDetections::ped_ids`].
    pub id: usize,
    /// Position `[x, y]` in the file's unit.
    pub pos: [f32; 2],
}

/// The detections of one file, in file order, and the pedestrians they belong to.
#[derive(Clone, Debug, Default)]
pub(super) struct FileDetections {
    /// Every detection, in file order.
    pub dets: Vec<Detection>,
    /// The `ped_id` of each pedestrian, in order of first appearance.
    pub ped_ids: Vec<f64>,
}

/// One row before its id is resolved.
struct RawRow {
    line: usize,
    t: f64,
    id: String,
    pos: [f32; 2],
}

/// Reads `path` in the folder's layout (module docs).
pub(super) fn read_detections(
    path: &Path,
    info: &FolderInfo,
) -> Result<FileDetections, FolderError> {
    let bytes = read_data_file(path, "data file")?;
    let bytes = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(&bytes);
    let mut rows = match &info.columns {
        None => plain_rows(path, bytes, info.time)?,
        Some(c) => header_rows(path, bytes, info.time, c)?,
    };
    // A calibrated camera's pixels go to the ground here, detection by detection: the map
    // is not linear, so it must come before the tracks are resampled.
    if let Some(h) = info.homography_of(path)? {
        for r in rows.iter_mut() {
            r.pos = h.apply(r.pos).map_err(|msg| FolderError::Row {
                path: path.to_path_buf(),
                line: r.line,
                msg: format!("{msg} ([homography] of dataset.toml)"),
            })?;
        }
    }
    Ok(resolve_ids(rows))
}

/// The separator of a file with a header: `[columns].delimiter`, else by extension (`None`:
/// runs of whitespace).
fn delimiter_of(path: &Path, columns: &Columns) -> Option<u8> {
    if let Some(d) = columns.delimiter {
        return (d != b' ').then_some(d);
    }
    match path.extension().and_then(|e| e.to_str()) {
        Some("csv") => Some(b','),
        Some("tsv") => Some(b'\t'),
        _ => None,
    }
}

/// One line of a delimited file split into trimmed fields. A field may be quoted (`"a,b"`,
/// `""` for a quote inside); a quoted field spanning lines is not supported (`Err`).
fn split_delimited(text: &str, d: char) -> Result<Vec<String>, &'static str> {
    let mut out = Vec::new();
    let mut chars = text.chars().peekable();
    loop {
        while chars.peek().is_some_and(|c| *c != d && c.is_whitespace()) {
            chars.next();
        }
        let mut field = String::new();
        if chars.peek() == Some(&'"') {
            chars.next();
            loop {
                match chars.next() {
                    Some('"') if chars.peek() == Some(&'"') => {
                        chars.next();
                        field.push('"');
                    }
                    Some('"') => break,
                    Some(c) => field.push(c),
                    None => {
                        return Err("a quoted field does not end on its line (fields spanning \
                                    lines are not supported)")
                    }
                }
            }
            while chars.peek().is_some_and(|c| *c != d && c.is_whitespace()) {
                chars.next();
            }
            match chars.next() {
                None => {
                    out.push(field);
                    return Ok(out);
                }
                Some(c) if c == d => out.push(field),
                Some(_) => return Err("text after a quoted field"),
            }
        } else {
            loop {
                match chars.next() {
                    None => {
                        out.push(field.trim().to_string());
                        return Ok(out);
                    }
                    Some(c) if c == d => break,
                    Some(c) => field.push(c),
                }
            }
            out.push(field.trim().to_string());
        }
    }
}

/// Checks a time value: a whole frame number for a frame clock, any finite number of at most
/// [`MAX_FRAME`] in magnitude for timestamps. `Err` holds what was expected.
fn check_time(v: f64, time: TimeColumn) -> Result<f64, &'static str> {
    if v.abs() > MAX_FRAME {
        return Err("a time of at most 1e15 in magnitude");
    }
    if time == TimeColumn::Frame && v.fract() != 0.0 {
        return Err("a whole frame number (for timestamps set time_unit in dataset.toml)");
    }
    Ok(v)
}

/// Checks a coordinate: finite in f32 and within ±[`MAX_COORDINATE`].
fn check_coordinate(v: f64) -> Result<f32, ()> {
    let f = v as f32;
    if f.is_finite() && f.abs() <= MAX_COORDINATE {
        Ok(f)
    } else {
        Err(())
    }
}

/// `time id x y` rows without a header.
fn plain_rows(path: &Path, bytes: &[u8], time: TimeColumn) -> Result<Vec<RawRow>, FolderError> {
    let mut rows = Vec::new();
    for item in lines(path, bytes) {
        let (line, text) = item?;
        let cols = four_columns(path, line, text)?;
        let t = parse_f64(path, line, 1, cols[0])?;
        let t = check_time(t, time).map_err(|expected| DataError::BadNumber {
            path: path.to_path_buf(),
            line,
            column: 1,
            text: cols[0].to_string(),
            expected,
        })?;
        let mut pos = [0.0f32; 2];
        for (c, p) in pos.iter_mut().enumerate() {
            let v = parse_f64(path, line, 3 + c, cols[2 + c])?;
            *p = check_coordinate(v).map_err(|()| DataError::OutOfRange {
                path: path.to_path_buf(),
                line,
                column: 3 + c,
                text: cols[2 + c].to_string(),
            })?;
        }
        rows.push(RawRow {
            line,
            t,
            id: cols[1].to_string(),
            pos,
        });
    }
    Ok(rows)
}

/// Rows of a file with a header, mapped by `columns`.
fn header_rows(
    path: &Path,
    bytes: &[u8],
    time: TimeColumn,
    columns: &Columns,
) -> Result<Vec<RawRow>, FolderError> {
    // Every record as (line, fields), the header first.
    let mut records: Vec<(usize, Vec<String>)> = Vec::new();
    let delimiter = delimiter_of(path, columns);
    for item in lines(path, bytes) {
        let (line, text) = item?;
        let fields = match delimiter {
            None => text.split_whitespace().map(str::to_string).collect(),
            Some(d) => split_delimited(text, char::from(d)).map_err(|msg| FolderError::Row {
                path: path.to_path_buf(),
                line,
                msg: msg.to_string(),
            })?,
        };
        // A line of only separators and spaces counts as blank.
        if fields.iter().all(String::is_empty) {
            continue;
        }
        records.push((line, fields));
    }
    let mut it = records.into_iter();
    let Some((header_line, header)) = it.next() else {
        return Ok(Vec::new());
    };
    let find = |key: &'static str, name: &str| -> Result<usize, FolderError> {
        header
            .iter()
            .position(|h| h == name)
            .ok_or_else(|| FolderError::NoColumn {
                path: path.to_path_buf(),
                line: header_line,
                key,
                name: name.to_string(),
                header: header.clone(),
            })
    };
    let time_key = match time {
        TimeColumn::Frame => "columns.frame",
        _ => "columns.time",
    };
    let idx = [
        (time_key, find(time_key, &columns.time)?),
        ("columns.id", find("columns.id", &columns.id)?),
        ("columns.x", find("columns.x", &columns.x)?),
        ("columns.y", find("columns.y", &columns.y)?),
    ];
    let mut rows = Vec::new();
    for (line, fields) in it {
        let field = |k: usize| -> Result<&str, FolderError> {
            let (key, i) = idx[k];
            fields
                .get(i)
                .map(String::as_str)
                .ok_or_else(|| FolderError::Value {
                    path: path.to_path_buf(),
                    line,
                    key,
                    column: header[i].clone(),
                    text: String::new(),
                    expected: "a value (the line has too few fields)",
                })
        };
        let bad = |k: usize, text: &str, expected: &'static str| FolderError::Value {
            path: path.to_path_buf(),
            line,
            key: idx[k].0,
            column: header[idx[k].1].clone(),
            text: text.to_string(),
            expected,
        };
        let number = |k: usize| -> Result<f64, FolderError> {
            let text = field(k)?;
            match text.parse::<f64>() {
                Ok(v) if v.is_finite() => Ok(v),
                _ => Err(bad(k, text, "a finite number")),
            }
        };
        let t = check_time(number(0)?, time).map_err(|e| bad(0, field(0).unwrap_or(""), e))?;
        let id = field(1)?;
        if id.is_empty() {
            return Err(bad(1, id, "an id (it is empty)"));
        }
        let mut pos = [0.0f32; 2];
        for (c, p) in pos.iter_mut().enumerate() {
            *p = check_coordinate(number(2 + c)?).map_err(|()| {
                bad(
                    2 + c,
                    field(2 + c).unwrap_or(""),
                    "a coordinate within ±1e6 (gpecnet_core::frame::MAX_COORDINATE; shift \
                     the coordinates to a nearby origin)",
                )
            })?;
        }
        rows.push(RawRow {
            line,
            t,
            id: id.to_string(),
            pos,
        });
    }
    Ok(rows)
}

/// Numbers the pedestrians of a file (module docs: numeric ids by value, others 1, 2, …).
fn resolve_ids(rows: Vec<RawRow>) -> FileDetections {
    let numeric: Option<Vec<f64>> = rows
        .iter()
        .map(|r| r.id.parse::<f64>().ok().filter(|v| v.is_finite()))
        .collect();
    let mut out = FileDetections {
        dets: Vec::with_capacity(rows.len()),
        ped_ids: Vec::new(),
    };
    match numeric {
        Some(values) => {
            let mut index: HashMap<u64, usize> = HashMap::new();
            for (r, v) in rows.iter().zip(values) {
                let next = out.ped_ids.len();
                let id = *index.entry(id_key(v)).or_insert(next);
                if id == next {
                    out.ped_ids.push(v);
                }
                out.dets.push(Detection {
                    line: r.line,
                    t: r.t,
                    id,
                    pos: r.pos,
                });
            }
        }
        None => {
            let mut index: HashMap<&str, usize> = HashMap::new();
            for r in &rows {
                let next = out.ped_ids.len();
                let id = *index.entry(r.id.as_str()).or_insert(next);
                if id == next {
                    out.ped_ids.push((next + 1) as f64);
                }
                out.dets.push(Detection {
                    line: r.line,
                    t: r.t,
                    id,
                    pos: r.pos,
                });
            }
        }
    }
    out
}
