//! The `frame ped_id x y` row reader both benchmarks share, and file helpers.

use std::path::{Path, PathBuf};

use super::*;

/// Default data root: `../shared/data` relative to the current directory if that exists
/// (running from the repository root), otherwise `<workspace>/../shared/data` computed from this
/// crate's manifest directory (running tests from anywhere).
pub fn default_data_root() -> PathBuf {
    let rel = PathBuf::from("../shared/data");
    if rel.is_dir() {
        return rel;
    }
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data")
}

/// One parsed `frame ped_id x y` row.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Row {
    /// 1-based line number in the file.
    pub line: usize,
    /// Frame index.
    pub frame: i64,
    /// Agent id.
    pub ped_id: f64,
    /// Position `[x, y]`.
    pub pos: [f32; 2],
}

pub(super) fn parse_f64(
    path: &Path,
    line: usize,
    column: usize,
    text: &str,
) -> Result<f64, DataError> {
    let v: f64 = text.parse().map_err(|_| DataError::BadNumber {
        path: path.to_path_buf(),
        line,
        column,
        text: text.to_string(),
        expected: "a number",
    })?;
    if !v.is_finite() {
        return Err(DataError::NonFinite {
            path: path.to_path_buf(),
            line,
            column,
            text: text.to_string(),
        });
    }
    Ok(v)
}

/// Largest frame magnitude accepted (keeps i64 arithmetic on frames overflow-free).
pub(super) const MAX_FRAME: f64 = 1.0e15;

/// Text lines of `bytes`: `(1-based line, text)` without the `\r`, blank lines skipped.
pub(super) fn lines<'a>(
    path: &'a Path,
    bytes: &'a [u8],
) -> impl Iterator<Item = Result<(usize, &'a str), DataError>> + 'a {
    bytes
        .split(|&b| b == b'\n')
        .enumerate()
        .filter_map(move |(i, raw)| {
            let line = i + 1;
            let Ok(text) = std::str::from_utf8(raw) else {
                return Some(Err(DataError::Encoding {
                    path: path.to_path_buf(),
                    line,
                }));
            };
            let text = text.strip_suffix('\r').unwrap_or(text);
            (!text.trim().is_empty()).then_some(Ok((line, text)))
        })
}

/// The four whitespace-separated columns of line `line` (`text`) of a
/// headerless file, else [`DataError::ColumnCount`].
pub(super) fn four_columns<'t>(
    path: &Path,
    line: usize,
    text: &'t str,
) -> Result<Vec<&'t str>, DataError> {
    let cols: Vec<&str> = text.split_whitespace().collect();
    if cols.len() != 4 {
        return Err(DataError::ColumnCount {
            path: path.to_path_buf(),
            line,
            expected: 4,
            found: cols.len(),
        });
    }
    Ok(cols)
}

/// Read a whitespace-separated `frame ped_id x y` file (SDD: single spaces; ETH/UCY: tabs).
///
/// Blank lines are skipped (they still count for line numbers); a trailing `\r` is ignored.
/// The frame must be a whole number (`780` and `780.0` are both accepted).
pub fn read_rows(path: &Path) -> Result<Vec<Row>, DataError> {
    let bytes = read_data_file(path, "data file")?;
    let mut rows = Vec::new();
    for item in lines(path, &bytes) {
        let (line, text) = item?;
        let cols = four_columns(path, line, text)?;
        let frame_f = parse_f64(path, line, 1, cols[0])?;
        if frame_f.fract() != 0.0 || frame_f.abs() > MAX_FRAME {
            return Err(DataError::BadNumber {
                path: path.to_path_buf(),
                line,
                column: 1,
                text: cols[0].to_string(),
                expected: "a whole frame number",
            });
        }
        let ped_id = parse_f64(path, line, 2, cols[1])?;
        let mut pos = [0.0f32; 2];
        for (c, p) in pos.iter_mut().enumerate() {
            let v = parse_f64(path, line, 3 + c, cols[2 + c])? as f32;
            if !v.is_finite() {
                return Err(DataError::NonFinite {
                    path: path.to_path_buf(),
                    line,
                    column: 3 + c,
                    text: cols[2 + c].to_string(),
                });
            }
            if v.abs() > MAX_COORDINATE {
                return Err(DataError::OutOfRange {
                    path: path.to_path_buf(),
                    line,
                    column: 3 + c,
                    text: cols[2 + c].to_string(),
                });
            }
            *p = v;
        }
        rows.push(Row {
            line,
            frame: frame_f as i64,
            ped_id,
            pos,
        });
    }
    Ok(rows)
}

fn io_or_missing(path: &Path, source: std::io::Error, what: &str) -> DataError {
    if source.kind() == std::io::ErrorKind::NotFound {
        DataError::Missing {
            path: path.to_path_buf(),
            what: what.to_string(),
        }
    } else {
        DataError::Io {
            path: path.to_path_buf(),
            source,
        }
    }
}

/// The bytes of the data file `path` ([`crate::inpath::read_limited`], at most
/// [`crate::inpath::MAX_DATA_BYTES`]); a file that does not exist is [`DataError::Missing`]
/// (`what` names it), every other problem [`DataError::Read`].
pub(super) fn read_data_file(path: &Path, what: &str) -> Result<Vec<u8>, DataError> {
    crate::inpath::read_limited(path, crate::inpath::FileKind::Data).map_err(|e| {
        if e.is_not_found() {
            DataError::Missing {
                path: path.to_path_buf(),
                what: what.to_string(),
            }
        } else {
            DataError::Read(e)
        }
    })
}

/// All `*.txt` files of a directory, sorted by file name. An entry named `*.txt` that is
/// not a regular file once links are followed (a dangling or looping link, a directory, a
/// FIFO, ...) is an error naming it, never skipped.
pub(super) fn sorted_txt_files(dir: &Path, what: &str) -> Result<Vec<PathBuf>, DataError> {
    sorted_files(dir, what, &["txt"])
}

/// [`sorted_txt_files`] for the files whose extension is one of `exts`.
pub(super) fn sorted_files(
    dir: &Path,
    what: &str,
    exts: &[&str],
) -> Result<Vec<PathBuf>, DataError> {
    if !dir.is_dir() {
        return Err(DataError::Missing {
            path: dir.to_path_buf(),
            what: what.to_string(),
        });
    }
    let entries = std::fs::read_dir(dir).map_err(|source| io_or_missing(dir, source, what))?;
    let mut files = Vec::new();
    for e in entries {
        let e = e.map_err(|source| DataError::Io {
            path: dir.to_path_buf(),
            source,
        })?;
        let p = e.path();
        if p.extension().is_some_and(|x| exts.iter().any(|e| x == *e)) {
            match std::fs::metadata(&p) {
                Ok(md) if md.is_file() => files.push(p),
                Ok(md) => {
                    return Err(DataError::Read(crate::inpath::ReadError::NotRegular {
                        path: p,
                        kind: crate::inpath::FileKind::Data,
                        found: crate::inpath::describe_file_type(md.file_type()),
                    }))
                }
                // A link that leads nowhere (dangling, or a loop).
                Err(source) => {
                    return Err(DataError::Read(crate::inpath::ReadError::Open {
                        path: p,
                        kind: crate::inpath::FileKind::Data,
                        source,
                    }))
                }
            }
        }
    }
    if files.is_empty() {
        return Err(DataError::NoFiles {
            path: dir.to_path_buf(),
        });
    }
    files.sort_by(|a, b| a.file_name().cmp(&b.file_name()));
    Ok(files)
}

/// One split of a benchmark: every `*.txt` file of `dir` ([`sorted_txt_files`]; `what` names
/// the directory in a "missing" error) cut into windows by `parse`, in file order.
pub(super) fn load_split(
    dir: &Path,
    what: &str,
    parse: fn(&Path) -> Result<Vec<Window>, DataError>,
    name: String,
    unit: Unit,
) -> Result<Dataset, DataError> {
    load_split_where(dir, what, parse, name, unit, |_| true)
}

/// [`load_split`] of the files `keep` accepts only (the others are not read).
pub(super) fn load_split_where(
    dir: &Path,
    what: &str,
    parse: fn(&Path) -> Result<Vec<Window>, DataError>,
    name: String,
    unit: Unit,
    keep: impl Fn(&Path) -> bool,
) -> Result<Dataset, DataError> {
    let mut windows = Vec::new();
    for f in sorted_txt_files(dir, what)?.iter().filter(|f| keep(f)) {
        windows.extend(parse(f)?);
    }
    Ok(Dataset {
        name,
        unit,
        windows,
    })
}

pub(super) fn scene_name(path: &Path) -> String {
    path.file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default()
}

/// Bit pattern used to group rows by ped id (`28.0` and `28` are the same id; -0.0 == 0.0).
pub(super) fn id_key(id: f64) -> u64 {
    if id == 0.0 {
        0
    } else {
        id.to_bits()
    }
}
