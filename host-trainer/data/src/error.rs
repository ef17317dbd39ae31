//! [`DataError`]: every parse problem, naming the file and the 1-based line.

use std::fmt;
use std::path::{Path, PathBuf};

use super::*;

/// Which column of a `frame ped_id x y` line a value came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Column {
    /// Column 1, the frame index.
    Frame,
    /// Column 2, the agent id.
    PedId,
    /// Column 3, x.
    X,
    /// Column 4, y.
    Y,
}

impl fmt::Display for Column {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Column::Frame => "column 1 (frame)",
            Column::PedId => "column 2 (ped_id)",
            Column::X => "column 3 (x)",
            Column::Y => "column 4 (y)",
        })
    }
}

/// Everything that can go wrong while loading data. Each variant names the file and, where
/// the problem is in the content, the 1-based line number.
#[derive(Debug, thiserror::Error)]
pub enum DataError {
    /// A directory or file the loader needs does not exist.
    #[error("{path}: {what} not found; {hint}", path = .path.display(), hint = DATA_HINT)]
    Missing {
        /// The missing path.
        path: PathBuf,
        /// What was expected there (e.g. "SDD split directory").
        what: String,
    },
    /// A directory exists but holds no `*.txt` data file.
    #[error("{path}: no *.txt files in this directory; {hint}", path = .path.display(), hint = DATA_HINT)]
    NoFiles {
        /// The empty directory.
        path: PathBuf,
    },
    /// An I/O error while listing or reading.
    #[error("{path}: cannot read: {source}", path = .path.display())]
    Io {
        /// The file or directory.
        path: PathBuf,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
    /// A coordinate beyond ±[`MAX_COORDINATE`].
    #[error(
        "{path}:{line}: column {column}: coordinate {text} is outside the accepted range \
         -1e6..=1e6 (gpecnet_core::frame::MAX_COORDINATE: the core refuses such inputs); \
         shift the coordinates to a nearby origin",
        path = .path.display()
    )]
    OutOfRange {
        /// The file.
        path: PathBuf,
        /// 1-based line number.
        line: usize,
        /// 1-based column (3 = x, 4 = y).
        column: usize,
        /// The text of the value.
        text: String,
    },
    /// A line is not valid UTF-8.
    #[error("{path}:{line}: line is not valid UTF-8", path = .path.display())]
    Encoding {
        /// The file.
        path: PathBuf,
        /// 1-based line number.
        line: usize,
    },
    /// A line does not have the expected number of columns.
    #[error("{path}:{line}: expected {expected} columns, found {found}", path = .path.display())]
    ColumnCount {
        /// The file.
        path: PathBuf,
        /// 1-based line number.
        line: usize,
        /// Number of columns expected.
        expected: usize,
        /// Number of columns found.
        found: usize,
    },
    /// A value is not a number (or a frame index is not a whole number).
    #[error("{path}:{line}: {column}: cannot parse {text:?} as {expected}", path = .path.display())]
    BadNumber {
        /// The file.
        path: PathBuf,
        /// 1-based line number.
        line: usize,
        /// 1-based column number.
        column: usize,
        /// The offending text.
        text: String,
        /// What was expected ("a number", "a whole frame number").
        expected: &'static str,
    },
    /// A value parsed but is NaN or infinite (or overflows f32 for a coordinate).
    #[error("{path}:{line}: column {column}: value {text:?} is not finite", path = .path.display())]
    NonFinite {
        /// The file.
        path: PathBuf,
        /// 1-based line number.
        line: usize,
        /// 1-based column number.
        column: usize,
        /// The offending text.
        text: String,
    },
    /// An SDD ped id whose row count is not a (non-zero) multiple of [`WINDOW`].
    #[error(
        "{path}:{line}: ped_id {ped_id} has {rows} rows (first at line {line}, last at line {last_line}); \
         SDD trajectories must be exactly {WINDOW} rows each",
        path = .path.display()
    )]
    TrajectoryLength {
        /// The file.
        path: PathBuf,
        /// 1-based line of the ped's first row.
        line: usize,
        /// 1-based line of the ped's last row.
        last_line: usize,
        /// The ped id.
        ped_id: f64,
        /// How many rows it has.
        rows: usize,
    },
    /// Two consecutive rows of one SDD trajectory are not [`SDD_FRAME_STEP`] frames apart, or
    /// two consecutive annotated frames of an ETH/UCY file are not a multiple of
    /// [`ETH_UCY_FRAME_STEP`] apart (another clock than the benchmark's 0.4 s).
    #[error(
        "{path}:{line}: ped_id {ped_id}: frame {frame} follows frame {prev_frame} (step {found}, expected {expected})",
        path = .path.display()
    )]
    FrameStep {
        /// The file.
        path: PathBuf,
        /// 1-based line of the row with the wrong step.
        line: usize,
        /// The ped id.
        ped_id: f64,
        /// Frame on the previous row of this trajectory.
        prev_frame: i64,
        /// Frame on this row.
        frame: i64,
        /// The step found.
        found: i64,
        /// The step expected.
        expected: i64,
    },
    /// A pedestrian appears twice in the same frame of an ETH/UCY file.
    #[error("{path}:{line}: ped_id {ped_id} appears twice in frame {frame}", path = .path.display())]
    DuplicateRow {
        /// The file.
        path: PathBuf,
        /// 1-based line of the second occurrence.
        line: usize,
        /// The ped id.
        ped_id: f64,
        /// The frame.
        frame: i64,
    },
    /// A data file that cannot be read as one: not a regular file (a FIFO, device,
    /// directory), larger than [`crate::inpath::MAX_DATA_BYTES`], or a symbolic link that
    /// leads nowhere (dangling or looping).
    #[error(transparent)]
    Read(#[from] crate::inpath::ReadError),
    /// A malformed row of the SDD metres-per-pixel CSV.
    #[error("{path}:{line}: {msg}", path = .path.display())]
    BadScale {
        /// The file.
        path: PathBuf,
        /// 1-based line number.
        line: usize,
        /// What is wrong.
        msg: String,
    },
}

impl DataError {
    /// The file (or directory) the error is about.
    pub fn path(&self) -> &Path {
        self.location().0
    }

    /// The 1-based line number, for errors about file content.
    pub fn line(&self) -> Option<usize> {
        self.location().1
    }

    /// The file (or directory) and, for errors about file content, the 1-based line.
    fn location(&self) -> (&Path, Option<usize>) {
        match self {
            DataError::Missing { path, .. }
            | DataError::NoFiles { path }
            | DataError::Io { path, .. } => (path, None),
            DataError::Read(e) => (e.path(), None),
            DataError::Encoding { path, line }
            | DataError::ColumnCount { path, line, .. }
            | DataError::BadNumber { path, line, .. }
            | DataError::NonFinite { path, line, .. }
            | DataError::OutOfRange { path, line, .. }
            | DataError::TrajectoryLength { path, line, .. }
            | DataError::FrameStep { path, line, .. }
            | DataError::DuplicateRow { path, line, .. }
            | DataError::BadScale { path, line, .. } => (path, Some(*line)),
        }
    }
}
