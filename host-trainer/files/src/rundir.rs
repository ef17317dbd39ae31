//! Run-folder safety for `gpecnet train --out DIR`: one run per folder, nothing overwritten
//! silently, no temp files left behind.
//!
//! * **Lock.** A run holds `DIR/.gpecnet.lock` for its whole life: the file is created with
//!   `create_new` (atomic: of two runs starting at once exactly one succeeds) and holds the
//!   owner's pid, host name and start time (Unix seconds). [`RunLock`] removes it when dropped
//!   (normal exit, error exit). A run killed with SIGKILL/SIGINT leaves it behind; such a
//!   *stale* lock is taken over automatically **only when its pid is provably dead**: the lock
//!   names this host and `/proc/<pid>` does not exist (Linux, `/proc` mounted). Every other
//!   lock (pid alive, another host, no `/proc`) refuses the run with an error naming the
//!   owner; if no run is really using the folder (say, the pid was reused by an unrelated
//!   process) delete the lock file by hand. `--force` never breaks a lock.
//! * **No silent overwrite.** A new run into a folder that already holds files (other than
//!   the lock and stale temp files) is refused unless `--force` (then `config.toml`,
//!   `metrics.*` and `curves.svg` are overwritten); a folder with a checkpoint is continued
//!   with `--resume`, never restarted.
//! * **Temp files.** Atomic writes go through `.<name>.tmp.<pid>` files in the folder
//!   ([`write_atomic`]). Once a run holds the lock, every such file of
//!   another pid is a leftover of a killed run and [`remove_stale_temp_files`] deletes it.

use std::fs::{self, OpenOptions};
use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};

/// File name of the run lock inside a run directory.
pub const LOCK_FILE: &str = ".gpecnet.lock";

/// Owner of a run lock, as written in the lock file.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct LockOwner {
    /// Process id.
    pub pid: u32,
    /// Host name.
    pub host: String,
    /// Start time, Unix seconds.
    pub started: u64,
}

impl LockOwner {
    fn me() -> Self {
        Self {
            pid: std::process::id(),
            host: host_name(),
            started: std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map_or(0, |d| d.as_secs()),
        }
    }

    fn to_text(&self) -> String {
        format!(
            "pid={}\nhost={}\nstarted={}\n",
            self.pid, self.host, self.started
        )
    }

    fn parse(text: &str) -> Option<Self> {
        let mut pid = None;
        let mut host = None;
        let mut started = None;
        for line in text.lines() {
            match line.split_once('=') {
                Some(("pid", v)) => pid = v.trim().parse().ok(),
                Some(("host", v)) => host = Some(v.trim().to_string()),
                Some(("started", v)) => started = v.trim().parse().ok(),
                _ => {}
            }
        }
        Some(Self {
            pid: pid?,
            host: host?,
            started: started.unwrap_or(0),
        })
    }
}

impl std::fmt::Display for LockOwner {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "pid {} on host {:?}, started at Unix time {}",
            self.pid, self.host, self.started
        )
    }
}

/// This machine's host name (`/proc/sys/kernel/hostname`, `/etc/hostname`, `$HOSTNAME`), or
/// `"unknown"`.
pub fn host_name() -> String {
    for p in ["/proc/sys/kernel/hostname", "/etc/hostname"] {
        if let Ok(s) = fs::read_to_string(p) {
            let s = s.trim();
            if !s.is_empty() {
                return s.to_string();
            }
        }
    }
    std::env::var("HOSTNAME")
        .ok()
        .filter(|s| !s.trim().is_empty())
        .unwrap_or_else(|| "unknown".to_string())
}

/// Whether process `pid` on this host is provably gone: `/proc` is mounted (`/proc/self`
/// exists) and `/proc/<pid>` does not. `false` whenever that cannot be known.
pub fn pid_is_dead(pid: u32) -> bool {
    Path::new("/proc/self").exists() && !Path::new(&format!("/proc/{pid}")).exists()
}

/// An exclusive lock on a run directory; removed on drop.
#[derive(Debug)]
pub struct RunLock {
    path: PathBuf,
    owner: LockOwner,
}

impl RunLock {
    /// Lock `run_dir` (which must exist). Takes over a stale lock of a provably dead process
    /// on this host (with a warning on stderr); refuses every other existing lock.
    pub fn acquire(run_dir: &Path) -> Result<Self> {
        Self::acquire_file(&run_dir.join(LOCK_FILE), |other, path| {
            format!(
                "{} is in use by another gpecnet run ({other}; lock file {}). \
                 Wait for it to finish or pick another --out; if no run is using the folder \
                 (the process is gone, or its pid was reused), delete the lock file",
                run_dir.display(),
                path.display()
            )
        })
    }

    /// Take the lock file `path` (its folder must exist), with the same rules as
    /// [`RunLock::acquire`]; `busy(owner, path)` is the error text when another live process
    /// holds it.
    ///
    /// The lock's text is written to a temp file first and then hard-linked to `path`, which
    /// fails when `path` exists: the lock appears complete or not at all (a full disk cannot
    /// leave an empty lock that blocks every later run). Where hard links are not supported
    /// the lock is created with `create_new` and removed again if writing it fails.
    pub fn acquire_file(path: &Path, busy: impl Fn(&LockOwner, &Path) -> String) -> Result<Self> {
        let path = path.to_path_buf();
        let owner = LockOwner::me();
        for _ in 0..3 {
            match create_lock(&path, &owner) {
                Ok(()) => return Ok(Self { path, owner }),
                Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {
                    let text =
                        crate::inpath::read_text_limited(&path, crate::inpath::FileKind::Text)
                            .unwrap_or_default();
                    let Some(other) = LockOwner::parse(&text) else {
                        bail!(
                            "{} exists but is not a gpecnet lock ({text:?}); another process may be \
                             writing there: if none is, delete the lock file",
                            path.display(),
                        );
                    };
                    if other.host == owner.host && other.pid != owner.pid && pid_is_dead(other.pid)
                    {
                        // Take over: only remove the lock if it is still the stale one.
                        if crate::inpath::read_text_limited(&path, crate::inpath::FileKind::Text)
                            .ok()
                            .as_deref()
                            == Some(text.as_str())
                        {
                            eprintln!(
                                "warning: taking over the stale run lock {} of a dead process ({other})",
                                path.display()
                            );
                            let _ = fs::remove_file(&path);
                        }
                        continue;
                    }
                    bail!("{}", busy(&other, path.as_path()));
                }
                Err(e) => {
                    return Err(e)
                        .with_context(|| format!("cannot create the lock {}", path.display()))
                }
            }
        }
        bail!(
            "could not take the lock {} (other processes keep racing for it)",
            path.display()
        )
    }

    /// The lock file.
    pub fn path(&self) -> &Path {
        &self.path
    }
}

/// Creates the lock file `path` holding `owner`, complete or not at all; `AlreadyExists`
/// when it exists.
fn create_lock(path: &Path, owner: &LockOwner) -> std::io::Result<()> {
    let dir = path
        .parent()
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let tmp = dir.join(format!(".{name}.tmp.{}", std::process::id()));
    let _ = fs::remove_file(&tmp);
    let written = (|| -> std::io::Result<()> {
        let mut f = OpenOptions::new().write(true).create_new(true).open(&tmp)?;
        f.write_all(owner.to_text().as_bytes())?;
        f.sync_all()
    })();
    let linked = written.and_then(|()| fs::hard_link(&tmp, path));
    let _ = fs::remove_file(&tmp);
    match linked {
        Ok(()) => Ok(()),
        Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => Err(e),
        Err(e) if e.kind() == std::io::ErrorKind::StorageFull => Err(e),
        Err(_) => {
            // No hard links here (or the temp file could not be made): create the lock
            // directly and remove it again if it cannot be written completely.
            let mut f = OpenOptions::new().write(true).create_new(true).open(path)?;
            let r = f
                .write_all(owner.to_text().as_bytes())
                .and_then(|()| f.sync_all());
            if let Err(e) = r {
                drop(f);
                let _ = fs::remove_file(path);
                return Err(e);
            }
            Ok(())
        }
    }
}

impl Drop for RunLock {
    fn drop(&mut self) {
        // Remove only our own lock (never one a later run took over).
        let ours = crate::inpath::read_text_limited(&self.path, crate::inpath::FileKind::Text)
            .ok()
            .and_then(|t| LockOwner::parse(&t))
            .is_some_and(|o| o == self.owner);
        if ours {
            let _ = fs::remove_file(&self.path);
        }
    }
}

/// `Some((target file name, pid))` when `name` is an atomic-write temp file
/// `.<target>.tmp.<pid>`.
pub fn parse_temp_name(name: &str) -> Option<(&str, u32)> {
    let rest = name.strip_prefix('.')?;
    let (target, pid) = rest.rsplit_once(".tmp.")?;
    if target.is_empty() || pid.is_empty() || !pid.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    Some((target, pid.parse().ok()?))
}

/// Temp files `.<name>.tmp.<pid>` in `dir` (path, size) whose pid satisfies `keep`.
pub fn temp_files(dir: &Path, keep: impl Fn(u32) -> bool) -> Vec<(PathBuf, u64)> {
    let Ok(rd) = fs::read_dir(dir) else {
        return Vec::new();
    };
    let mut out: Vec<(PathBuf, u64)> = rd
        .filter_map(|e| e.ok())
        .filter_map(|e| {
            let name = e.file_name().to_string_lossy().into_owned();
            let (_, pid) = parse_temp_name(&name)?;
            let md = e.metadata().ok()?;
            (md.is_file() && keep(pid)).then(|| (e.path(), md.len()))
        })
        .collect();
    out.sort();
    out
}

/// Delete the temp files of other processes in `dir` (call it while holding the run lock:
/// then they are leftovers of killed runs). Returns what was removed (path, bytes); prints
/// one line per file on stderr.
pub fn remove_stale_temp_files(dir: &Path) -> Vec<(PathBuf, u64)> {
    let me = std::process::id();
    let mut removed = Vec::new();
    for (p, n) in temp_files(dir, |pid| pid != me) {
        if fs::remove_file(&p).is_ok() {
            eprintln!(
                "removed stale temp file {} ({n} bytes) left by an interrupted write",
                p.display()
            );
            removed.push((p, n));
        }
    }
    removed
}

/// Files a new run would overwrite or mix with: every entry of `dir` except the lock and
/// temp files (sorted names).
pub fn existing_entries(dir: &Path) -> Result<Vec<String>> {
    let rd = match fs::read_dir(dir) {
        Ok(rd) => rd,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Vec::new()),
        Err(e) => return Err(e).with_context(|| format!("cannot read {}", dir.display())),
    };
    let mut names: Vec<String> = rd
        .filter_map(|e| e.ok())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n != LOCK_FILE && parse_temp_name(n).is_none())
        .collect();
    names.sort();
    Ok(names)
}

/// The one atomic, durable write (checkpoints, metrics, blobs, golden files, cards): creates
/// `path`'s folder if needed, then writes `bytes` through the temp file `.<name>.tmp.<pid>` in the same directory,
/// fsync, rename, fsync the directory. On failure the temp file is removed, and the error
/// names every temp file still in the directory (leftovers of killed runs that may be what
/// fills the disk; see [`remove_stale_temp_files`]).
pub fn write_atomic(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let dir = path
        .parent()
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    fs::create_dir_all(dir)
        .map_err(|e| std::io::Error::new(e.kind(), format!("creating {}: {e}", dir.display())))?;
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let tmp = dir.join(format!(".{name}.tmp.{}", std::process::id()));
    let write = || -> std::io::Result<()> {
        let mut f = fs::File::create(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
        drop(f);
        fs::rename(&tmp, path)
    };
    if let Err(e) = write() {
        let removed = fs::remove_file(&tmp).is_ok();
        let left = temp_files(dir, |_| true);
        let mut msg = format!("writing {} failed: {e}", path.display());
        if removed {
            msg += &format!(" (removed the partial {})", tmp.display());
        }
        if !left.is_empty() {
            let total: u64 = left.iter().map(|(_, n)| n).sum();
            msg += &format!(
                "; temp files left in {} by interrupted writes ({total} bytes; delete them if no run is using the folder): {}",
                dir.display(),
                left.iter()
                    .map(|(p, n)| format!("{} ({n} bytes)", p.display()))
                    .collect::<Vec<_>>()
                    .join(", ")
            );
        }
        return Err(std::io::Error::new(e.kind(), msg));
    }
    #[cfg(unix)]
    if let Ok(d) = fs::File::open(dir) {
        let _ = d.sync_all();
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn temp_names_and_lock_text() {
        assert_eq!(
            parse_temp_name(".checkpoint.bin.tmp.123"),
            Some(("checkpoint.bin", 123))
        );
        assert_eq!(parse_temp_name("checkpoint.bin"), None);
        assert_eq!(parse_temp_name(".x.tmp.12a"), None);
        let o = LockOwner {
            pid: 7,
            host: "h".into(),
            started: 9,
        };
        assert_eq!(LockOwner::parse(&o.to_text()), Some(o));
        assert_eq!(LockOwner::parse("garbage"), None);
        assert!(!pid_is_dead(std::process::id()));
    }
}
