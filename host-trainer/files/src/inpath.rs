//! Bounded, typed reading of every file the command line is given.
//!
//! A path given by the user may name anything: a device that never ends (`/dev/zero`), a
//! FIFO with no writer (whose `open` would block forever), a directory, or a regular file far
//! larger than anything the trainer writes. [`read_limited`] opens without blocking
//! (`O_NONBLOCK`, which has no effect on regular files), checks on the open descriptor that
//! it is a regular file, and reads at most the limit of its [`FileKind`]; anything else is a
//! [`ReadError`] naming the file, what it was expected to be, and the limit.
//!
//! The limits (each far above what the trainer itself writes):
//!
//! | kind | limit | why |
//! |---|---|---|
//! | blob (`.gpec`) | [`MAX_BLOB_BYTES`] = 64 MiB | twice the f32 weights of the largest network a config may describe (`gpecnet_train::config::MAX_PARAMETERS`) |
//! | golden file | [`MAX_GOLDEN_BYTES`] = 64 MiB | shipped ones are below 1 MiB |
//! | checkpoint | [`MAX_CHECKPOINT_BYTES`] = 1 GiB | weights, Adam moments and the best model: a few copies of the largest network |
//! | text (config, card, fingerprint, JSON) | [`MAX_TEXT_BYTES`] = 16 MiB | hand-written or small generated files |
//! | data file (scene, pool CSV, scales) | [`MAX_DATA_BYTES`] = 512 MiB | every benchmark file is below 10 MiB |

use std::fs::{File, OpenOptions};
use std::io::Read;
use std::os::unix::fs::{FileTypeExt, OpenOptionsExt};
use std::path::{Path, PathBuf};

/// Largest weight blob read (64 MiB).
pub const MAX_BLOB_BYTES: u64 = 64 << 20;
/// Largest golden-vector file read (64 MiB).
pub const MAX_GOLDEN_BYTES: u64 = 64 << 20;
/// Largest checkpoint read (1 GiB).
pub const MAX_CHECKPOINT_BYTES: u64 = 1 << 30;
/// Largest small text file read: configs, model cards, fingerprints (16 MiB).
pub const MAX_TEXT_BYTES: u64 = 16 << 20;
/// Largest data file read: scene files, synthetic pools, scale tables (512 MiB).
pub const MAX_DATA_BYTES: u64 = 512 << 20;

/// What a file is expected to be; sets its size limit and how errors name it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FileKind {
    /// A weight blob (`.gpec`), [`MAX_BLOB_BYTES`].
    Blob,
    /// A golden-vector file (`.golden`), [`MAX_GOLDEN_BYTES`].
    Golden,
    /// A training checkpoint, [`MAX_CHECKPOINT_BYTES`].
    Checkpoint,
    /// A config, model card, fingerprint or other small text file, [`MAX_TEXT_BYTES`].
    Text,
    /// A data file (scene, pool CSV, scale table), [`MAX_DATA_BYTES`].
    Data,
}

impl FileKind {
    /// The size limit in bytes.
    pub fn limit(self) -> u64 {
        match self {
            FileKind::Blob => MAX_BLOB_BYTES,
            FileKind::Golden => MAX_GOLDEN_BYTES,
            FileKind::Checkpoint => MAX_CHECKPOINT_BYTES,
            FileKind::Text => MAX_TEXT_BYTES,
            FileKind::Data => MAX_DATA_BYTES,
        }
    }

    /// The kind in words, as errors name it.
    pub fn describe(self) -> &'static str {
        match self {
            FileKind::Blob => "weight blob",
            FileKind::Golden => "golden file",
            FileKind::Checkpoint => "checkpoint",
            FileKind::Text => "text file",
            FileKind::Data => "data file",
        }
    }
}

/// Why a file could not be read.
#[derive(Debug, thiserror::Error)]
pub enum ReadError {
    /// The file could not be opened (missing, no permission, a dangling or looping link).
    #[error("cannot open the {what} {path}: {source}", what = .kind.describe(), path = .path.display())]
    Open {
        /// The file.
        path: PathBuf,
        /// What it was expected to be.
        kind: FileKind,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
    /// The path names a directory, device, FIFO or socket.
    #[error(
        "the {what} {path} is {found}, not a regular file; refusing to read it",
        what = .kind.describe(), path = .path.display()
    )]
    NotRegular {
        /// The file.
        path: PathBuf,
        /// What it was expected to be.
        kind: FileKind,
        /// What it is, in words ("a FIFO", "a character device", ...).
        found: &'static str,
    },
    /// The file is larger than its kind's limit.
    #[error(
        "the {what} {path} is larger than {limit} bytes, the limit for a {what}; refusing to read it",
        what = .kind.describe(), path = .path.display(), limit = .kind.limit()
    )]
    TooLarge {
        /// The file.
        path: PathBuf,
        /// What it was expected to be.
        kind: FileKind,
    },
    /// Reading failed after the file was opened.
    #[error("reading the {what} {path}: {source}", what = .kind.describe(), path = .path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// What it was expected to be.
        kind: FileKind,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
    /// A text file is not UTF-8.
    #[error("the {what} {path} is not valid UTF-8", what = .kind.describe(), path = .path.display())]
    NotUtf8 {
        /// The file.
        path: PathBuf,
        /// What it was expected to be.
        kind: FileKind,
    },
}

impl ReadError {
    /// The file the error is about.
    pub fn path(&self) -> &Path {
        match self {
            ReadError::Open { path, .. }
            | ReadError::NotRegular { path, .. }
            | ReadError::TooLarge { path, .. }
            | ReadError::Read { path, .. }
            | ReadError::NotUtf8 { path, .. } => path,
        }
    }

    /// Whether the file does not exist (and is not a dangling link either).
    pub fn is_not_found(&self) -> bool {
        matches!(self, ReadError::Open { source, path, .. }
            if source.kind() == std::io::ErrorKind::NotFound && std::fs::symlink_metadata(path).is_err())
    }
}

/// What a non-regular file type is, in words.
pub fn describe_file_type(t: std::fs::FileType) -> &'static str {
    if t.is_dir() {
        "a directory"
    } else if t.is_fifo() {
        "a FIFO"
    } else if t.is_socket() {
        "a socket"
    } else if t.is_char_device() {
        "a character device"
    } else if t.is_block_device() {
        "a block device"
    } else if t.is_symlink() {
        "a symbolic link"
    } else if t.is_file() {
        "a regular file"
    } else {
        "not a regular file"
    }
}

/// Opens `path` without blocking (a FIFO with no writer does not hang) and checks, on the
/// open descriptor, that it is a regular file no larger than `kind`'s limit.
pub fn open_regular(path: &Path, kind: FileKind) -> Result<File, ReadError> {
    let f = OpenOptions::new()
        .read(true)
        .custom_flags(libc::O_NONBLOCK)
        .open(path)
        .map_err(|source| ReadError::Open {
            path: path.to_path_buf(),
            kind,
            source,
        })?;
    let md = f.metadata().map_err(|source| ReadError::Read {
        path: path.to_path_buf(),
        kind,
        source,
    })?;
    if !md.is_file() {
        return Err(ReadError::NotRegular {
            path: path.to_path_buf(),
            kind,
            found: describe_file_type(md.file_type()),
        });
    }
    if md.len() > kind.limit() {
        return Err(ReadError::TooLarge {
            path: path.to_path_buf(),
            kind,
        });
    }
    Ok(f)
}

/// The bytes of the regular file `path`, at most `kind.limit()` of them (see the module
/// documentation); the one way the trainer reads a file whose path a user gave.
pub fn read_limited(path: &Path, kind: FileKind) -> Result<Vec<u8>, ReadError> {
    let f = open_regular(path, kind)?;
    let limit = kind.limit();
    let mut bytes = Vec::new();
    f.take(limit + 1)
        .read_to_end(&mut bytes)
        .map_err(|source| ReadError::Read {
            path: path.to_path_buf(),
            kind,
            source,
        })?;
    // The file may have grown since it was checked.
    if bytes.len() as u64 > limit {
        return Err(ReadError::TooLarge {
            path: path.to_path_buf(),
            kind,
        });
    }
    Ok(bytes)
}

/// [`read_limited`] as UTF-8 text.
pub fn read_text_limited(path: &Path, kind: FileKind) -> Result<String, ReadError> {
    String::from_utf8(read_limited(path, kind)?).map_err(|_| ReadError::NotUtf8 {
        path: path.to_path_buf(),
        kind,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn refuses_devices_directories_and_large_files() {
        let e = read_limited(Path::new("/dev/zero"), FileKind::Blob).unwrap_err();
        assert!(
            matches!(
                e,
                ReadError::NotRegular {
                    found: "a character device",
                    ..
                }
            ),
            "{e}"
        );
        let dir = tempfile::tempdir().unwrap();
        let e = read_limited(dir.path(), FileKind::Text).unwrap_err();
        assert!(
            matches!(
                e,
                ReadError::NotRegular {
                    found: "a directory",
                    ..
                }
            ),
            "{e}"
        );
        let big = dir.path().join("big.toml");
        let f = File::create(&big).unwrap();
        f.set_len(MAX_TEXT_BYTES + 1).unwrap();
        let e = read_limited(&big, FileKind::Text).unwrap_err();
        assert!(matches!(e, ReadError::TooLarge { .. }), "{e}");
        assert!(e.to_string().contains("16777216"), "{e}");
        let small = dir.path().join("ok.toml");
        std::fs::write(&small, b"a = 1\n").unwrap();
        assert_eq!(
            read_text_limited(&small, FileKind::Text).unwrap(),
            "a = 1\n"
        );
        let missing = dir.path().join("missing");
        assert!(read_limited(&missing, FileKind::Text)
            .unwrap_err()
            .is_not_found());
        let dangling = dir.path().join("dangling");
        std::os::unix::fs::symlink(&missing, &dangling).unwrap();
        let e = read_limited(&dangling, FileKind::Text).unwrap_err();
        assert!(!e.is_not_found(), "a dangling link is not a missing file");
    }
}
