//! Outputs that never destroy anything the command was not asked to write.
//!
//! * **Outputs are never inputs, never special files** ([`check_output`]): an output path
//!   that is the same file (device and inode, after following links) as one of the
//!   command's inputs is refused, and so is one that lies inside an input folder (the data
//!   root's `sdd/` and `eth_ucy/`, [`data_input_dirs`]), or exists and is not a regular
//!   file (a directory, device, FIFO, socket, or a link to one, or a dangling link). Writing goes through [`crate::rundir::write_atomic`], which
//!   renames a new regular file into place: without this check `--out /dev/null` would
//!   replace the device node.
//! * **Artefact sets written as one** ([`ArtefactWriter`]): a model's blob, golden file and
//!   cards (`<name>.gpec/.golden/.json/.md`) are written into a staging folder next to the
//!   destination, read back and verified through `gpecnet-core` (the blob through
//!   [`gpecnet_core::Model::from_blob`], the golden file through
//!   [`gpecnet_core::golden::GoldenSet::parse`] and its model CRC, the card as JSON), and only
//!   then renamed into place; the old files are hard-linked into the staging folder first and
//!   put back if a rename fails, so on any failure the old set stays as it was. An existing
//!   artefact of the same name is only replaced with `--force`. A writer holds the lock
//!   `.<name>.lock` in the destination folder from before its (long) evaluation until it is
//!   done, so a second writer of the same name is refused at once.

use std::fs;
use std::io::Write;
use std::os::unix::fs::MetadataExt;
use std::path::{Path, PathBuf};

use crate::inpath::{describe_file_type, read_limited, FileKind};
use crate::rundir::RunLock;

/// The file extensions of a model's artefact set, in the order they are written.
pub const ARTEFACT_EXTENSIONS: [&str; 4] = ["gpec", "golden", "json", "md"];

/// Why an output was refused or could not be written.
#[derive(Debug, thiserror::Error)]
pub enum OutputError {
    /// The output may not be written there ([`Refusal`]).
    #[error("{option} {out}: {why} (choose another output path)", out = .out.display())]
    Refused {
        /// The option that named the output.
        option: String,
        /// The output path.
        out: PathBuf,
        /// Why not.
        why: Refusal,
    },
    /// Artefacts of this name exist and `--force` was not given.
    #[error("{}", exists_message(.paths))]
    Exists {
        /// The existing artefacts.
        paths: Vec<PathBuf>,
    },
    /// Another writer holds the lock of this artefact name.
    #[error("{0}")]
    Locked(String),
    /// A staged file did not verify; nothing was replaced.
    #[error("the staged {path} does not verify ({why}); nothing was replaced", path = .path.display())]
    Verify {
        /// The staged file.
        path: PathBuf,
        /// What is wrong.
        why: String,
    },
    /// An I/O error; `what` says what was being done. Nothing of the old set was replaced.
    #[error("{what}: {source}")]
    Io {
        /// What was being done, naming the file.
        what: String,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
}

/// Why [`check_output`] refuses an output path.
#[derive(Debug, thiserror::Error)]
pub enum Refusal {
    /// The output is one of the command's inputs (that input).
    #[error(
        "this is the same file as the input {}; refusing to overwrite an input",
        .0.display()
    )]
    SameAsInput(PathBuf),
    /// The output lies inside an input folder (that folder).
    #[error(
        "this is inside the input folder {}; refusing to write among the inputs",
        .0.display()
    )]
    InsideInput(PathBuf),
    /// The output exists and is not a regular file (what it is, in words).
    #[error(
        "exists and is {0}; outputs are written as regular files only and this would replace it"
    )]
    NotRegular(&'static str),
}

fn exists_message(paths: &[PathBuf]) -> String {
    let list = paths
        .iter()
        .map(|p| p.display().to_string())
        .collect::<Vec<_>>()
        .join(", ");
    let (verb, it) = if paths.len() == 1 {
        ("exists", "it")
    } else {
        ("exist", "them")
    };
    format!(
        "{list} already {verb}; use --force to replace {it} (a model's artefacts, such as the \
         shipped weights/ set, are never replaced by accident)"
    )
}

fn io(what: impl Into<String>) -> impl FnOnce(std::io::Error) -> OutputError {
    let what = what.into();
    move |source| OutputError::Io { what, source }
}

/// Checks that `out` (named by the command-line `option`) may be written: it is not the same
/// file as any of `inputs` (device and inode after following links; inputs that do not exist
/// are skipped), not inside any of `input_dirs`, and, if it exists, a regular file (following
/// links; a dangling link is refused too).
pub fn check_output(
    option: &str,
    out: &Path,
    inputs: &[&Path],
    input_dirs: &[&Path],
) -> Result<(), OutputError> {
    let refused = |why| OutputError::Refused {
        option: option.to_string(),
        out: out.to_path_buf(),
        why,
    };
    let md = match fs::metadata(out) {
        Ok(md) => Some(md),
        Err(_) => match fs::symlink_metadata(out) {
            // A link that leads nowhere (dangling, looping): renaming over it is not what
            // the user meant either.
            Ok(_) => {
                return Err(refused(Refusal::NotRegular(
                    "a symbolic link that leads to no file",
                )))
            }
            Err(_) => None,
        },
    };
    if let Some(md) = &md {
        if !md.is_file() {
            return Err(refused(Refusal::NotRegular(describe_file_type(
                md.file_type(),
            ))));
        }
        for input in inputs {
            if let Ok(im) = fs::metadata(input) {
                if im.dev() == md.dev() && im.ino() == md.ino() {
                    return Err(refused(Refusal::SameAsInput(input.to_path_buf())));
                }
            }
        }
    }
    if !input_dirs.is_empty() {
        // The output's folder, resolved; the file itself need not exist.
        let parent = out
            .parent()
            .filter(|d| !d.as_os_str().is_empty())
            .unwrap_or(Path::new("."));
        // Folders the write would create count too: the nearest existing ancestor is
        // resolved and the rest appended.
        if let Some(parent) = resolve_lenient(parent) {
            for dir in input_dirs {
                if let Ok(d) = fs::canonicalize(dir) {
                    if parent.starts_with(&d) {
                        return Err(refused(Refusal::InsideInput(dir.to_path_buf())));
                    }
                }
            }
        }
    }
    Ok(())
}

/// `p` with its nearest existing ancestor resolved (links followed) and the components
/// below it appended as written; `None` when a missing component is `..` or the like.
fn resolve_lenient(p: &Path) -> Option<PathBuf> {
    let mut rest = Vec::new();
    let mut cur = p;
    loop {
        if let Ok(mut c) = fs::canonicalize(cur) {
            c.extend(rest.iter().rev());
            return Some(c);
        }
        rest.push(cur.file_name()?.to_owned());
        cur = match cur.parent() {
            Some(d) if !d.as_os_str().is_empty() => d,
            _ => Path::new("."),
        };
    }
}

/// The folders of a data root that the loaders read (`sdd/`, `eth_ucy/`): outputs are
/// refused inside them. The root itself may hold other things (runs, weights).
pub fn data_input_dirs(root: &Path) -> [PathBuf; 2] {
    [root.join("sdd"), root.join("eth_ucy")]
}

/// A blob path and its sidecars (`.golden`, `.json`, `.md`): the inputs a command that reads
/// a blob may look at.
pub fn blob_and_sidecars(blob: &Path) -> [PathBuf; 4] {
    ARTEFACT_EXTENSIONS.map(|e| blob.with_extension(e))
}

/// The writer of one model's artefact set `<dir>/<name>.{gpec,golden,json,md}`: created
/// (checked and locked) before the work, committed once at the end. See the module
/// documentation.
#[derive(Debug)]
pub struct ArtefactWriter {
    dir: PathBuf,
    name: String,
    force: bool,
    _lock: RunLock,
}

impl ArtefactWriter {
    /// Checks the four destination paths (see [`check_output`]; `option` names the output
    /// option in errors), refuses existing artefacts of this name unless `force`, and takes
    /// the lock `<dir>/.<name>.lock` (creating `dir` if needed). The lock is released when
    /// the writer is dropped.
    pub fn begin(
        option: &str,
        dir: &Path,
        name: &str,
        force: bool,
        inputs: &[&Path],
        input_dirs: &[&Path],
    ) -> Result<Self, OutputError> {
        // `--out q.gpec` has the empty folder: the working directory.
        let dir = if dir.as_os_str().is_empty() {
            Path::new(".")
        } else {
            dir
        };
        let paths = Self::paths_in(dir, name);
        for p in &paths {
            check_output(option, p, inputs, input_dirs)?;
        }
        if !force {
            Self::refuse_existing(&paths)?;
        }
        fs::create_dir_all(dir).map_err(io(format!("creating {}", dir.display())))?;
        let lock = RunLock::acquire_file(&dir.join(format!(".{name}.lock")), |other, path| {
            format!(
                "another gpecnet command is writing model {name:?} into {} ({other}; lock file {}); \
                 the second writer of one name is refused. If no such command is running, delete the lock file",
                dir.display(),
                path.display()
            )
        })
        .map_err(|e| OutputError::Locked(format!("{e:#}")))?;
        Ok(Self {
            dir: dir.to_path_buf(),
            name: name.to_string(),
            force,
            _lock: lock,
        })
    }

    fn paths_in(dir: &Path, name: &str) -> Vec<PathBuf> {
        ARTEFACT_EXTENSIONS
            .iter()
            .map(|e| dir.join(format!("{name}.{e}")))
            .collect()
    }

    fn refuse_existing(paths: &[PathBuf]) -> Result<(), OutputError> {
        let existing: Vec<PathBuf> = paths
            .iter()
            .filter(|p| fs::symlink_metadata(p).is_ok())
            .cloned()
            .collect();
        if existing.is_empty() {
            Ok(())
        } else {
            Err(OutputError::Exists { paths: existing })
        }
    }

    /// The destination paths, in [`ARTEFACT_EXTENSIONS`] order.
    pub fn paths(&self) -> Vec<PathBuf> {
        Self::paths_in(&self.dir, &self.name)
    }

    /// Writes the set: `blob`, `golden`, the card's `json` and `md` are staged in
    /// `<dir>/.<name>.staging.<pid>/`, read back and verified, then renamed into place
    /// (the old files restored if a rename fails). Nothing of the old set changes unless all
    /// four new files are in place.
    pub fn commit(
        &self,
        blob: &[u8],
        golden: &[u8],
        json: &[u8],
        md: &[u8],
    ) -> Result<(), OutputError> {
        let paths = self.paths();
        // Re-checked under the lock: another command may have written them meanwhile.
        for p in &paths {
            check_output("output", p, &[], &[])?;
        }
        if !self.force {
            Self::refuse_existing(&paths)?;
        }
        let staging = self
            .dir
            .join(format!(".{}.staging.{}", self.name, std::process::id()));
        let _ = fs::remove_dir_all(&staging);
        fs::create_dir(&staging).map_err(io(format!("creating {}", staging.display())))?;
        let result = self.stage_and_swap(&staging, &paths, [blob, golden, json, md]);
        let _ = fs::remove_dir_all(&staging);
        if let Ok(d) = fs::File::open(&self.dir) {
            let _ = d.sync_all();
        }
        result
    }

    fn stage_and_swap(
        &self,
        staging: &Path,
        paths: &[PathBuf],
        contents: [&[u8]; 4],
    ) -> Result<(), OutputError> {
        let staged: Vec<PathBuf> = ARTEFACT_EXTENSIONS
            .iter()
            .map(|e| staging.join(format!("{}.{e}", self.name)))
            .collect();
        for (p, bytes) in staged.iter().zip(contents) {
            // Exclusive and never through a link: the staging folder is new, so any entry
            // in it was planted.
            let mut f = crate::rundir::create_exclusive(p, 0o666)
                .map_err(io(format!("creating {}", p.display())))?;
            f.write_all(bytes)
                .and_then(|()| f.sync_all())
                .map_err(io(format!("writing {}", p.display())))?;
        }
        verify_set(&staged[0], &staged[1], &staged[2])?;
        // Keep the old files (hard links into the staging folder) until the new ones are in.
        let mut backups = Vec::new();
        for p in paths {
            if fs::symlink_metadata(p).is_ok() {
                let b = staging.join(format!(
                    "old.{}",
                    p.file_name().unwrap_or_default().to_string_lossy()
                ));
                fs::hard_link(p, &b).map_err(io(format!(
                    "keeping the old {} while the new set goes in",
                    p.display()
                )))?;
                backups.push((p.clone(), Some(b)));
            } else {
                backups.push((p.clone(), None));
            }
        }
        for (i, (from, to)) in staged.iter().zip(paths).enumerate() {
            if let Err(e) = fs::rename(from, to) {
                // Put back what was replaced so far; remove what did not exist before.
                for (p, b) in &backups[..i] {
                    match b {
                        Some(b) => {
                            let _ = fs::rename(b, p);
                        }
                        None => {
                            let _ = fs::remove_file(p);
                        }
                    }
                }
                return Err(OutputError::Io {
                    what: format!(
                        "moving {} into place (the old set was restored)",
                        to.display()
                    ),
                    source: e,
                });
            }
        }
        Ok(())
    }
}

/// Reads a staged set back and checks it through `gpecnet-core`: the blob validates, the
/// golden file parses and names the blob's CRC, the card is JSON.
fn verify_set(blob: &Path, golden: &Path, json: &Path) -> Result<(), OutputError> {
    let bad = |path: &Path, why: String| OutputError::Verify {
        path: path.to_path_buf(),
        why,
    };
    let b = read_limited(blob, FileKind::Blob).map_err(|e| bad(blob, e.to_string()))?;
    let model = gpecnet_core::Model::from_blob(&b).map_err(|e| bad(blob, e.to_string()))?;
    let g = read_limited(golden, FileKind::Golden).map_err(|e| bad(golden, e.to_string()))?;
    let set = gpecnet_core::golden::GoldenSet::parse(&g).map_err(|e| bad(golden, e.to_string()))?;
    if set.info().model_crc != model.crc() {
        return Err(bad(
            golden,
            format!(
                "it names blob CRC {:#010x}, the blob's is {:#010x}",
                set.info().model_crc,
                model.crc()
            ),
        ));
    }
    let j = read_limited(json, FileKind::Text).map_err(|e| bad(json, e.to_string()))?;
    serde_json::from_slice::<serde_json::Value>(&j).map_err(|e| bad(json, e.to_string()))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn special_and_input_outputs_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        let input = dir.path().join("in.gpec");
        fs::write(&input, b"x").unwrap();
        let e = check_output("--out", &input, &[&input], &[]).unwrap_err();
        assert!(
            matches!(
                e,
                OutputError::Refused {
                    why: Refusal::SameAsInput(_),
                    ..
                }
            ),
            "{e}"
        );
        let link = dir.path().join("link.gpec");
        std::os::unix::fs::symlink(&input, &link).unwrap();
        assert!(matches!(
            check_output("--out", &link, &[&input], &[]),
            Err(OutputError::Refused {
                why: Refusal::SameAsInput(_),
                ..
            })
        ));
        assert!(matches!(
            check_output("--out", Path::new("/dev/null"), &[], &[]),
            Err(OutputError::Refused {
                why: Refusal::NotRegular(_),
                ..
            })
        ));
        assert!(matches!(
            check_output("--out", dir.path(), &[], &[]),
            Err(OutputError::Refused {
                why: Refusal::NotRegular(_),
                ..
            })
        ));
        let dangling = dir.path().join("dangling");
        std::os::unix::fs::symlink(dir.path().join("nothing"), &dangling).unwrap();
        assert!(check_output("--out", &dangling, &[], &[]).is_err());
        let inside = dir.path().join("sub").join("x.svg");
        fs::create_dir(dir.path().join("sub")).unwrap();
        assert!(matches!(
            check_output("--draw", &inside, &[], &[dir.path()]),
            Err(OutputError::Refused {
                why: Refusal::InsideInput(_),
                ..
            })
        ));
        assert!(check_output("--out", &dir.path().join("new.gpec"), &[&input], &[]).is_ok());
        // A folder the write would create inside an input folder is inside it too.
        let deep = dir.path().join("sub/train/run.txt/config.toml");
        assert!(matches!(
            check_output("--out", &deep, &[], &[&dir.path().join("sub")]),
            Err(OutputError::Refused {
                why: Refusal::InsideInput(_),
                ..
            })
        ));
        assert!(!dir.path().join("sub/train").exists(), "nothing created");
    }

    #[test]
    fn a_set_that_does_not_verify_changes_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let old = dir.path().join("m.gpec");
        fs::write(&old, b"old").unwrap();
        let e = ArtefactWriter::begin("--out", dir.path(), "m", false, &[], &[]).unwrap_err();
        assert!(e.to_string().contains("use --force"), "{e}");
        let w = ArtefactWriter::begin("--out", dir.path(), "m", true, &[], &[]).unwrap();
        let second = ArtefactWriter::begin("--out", dir.path(), "m", true, &[], &[]).unwrap_err();
        assert!(matches!(second, OutputError::Locked(_)), "{second}");
        let e = w.commit(b"not a blob", b"", b"{}", b"").unwrap_err();
        assert!(matches!(e, OutputError::Verify { .. }), "{e}");
        assert_eq!(fs::read(&old).unwrap(), b"old");
        let names: Vec<_> = fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name().into_string().unwrap())
            .collect();
        assert!(names.iter().all(|n| !n.contains("staging")), "{names:?}");
        drop(w);
        assert!(!dir.path().join(".m.lock").exists());
    }
}
