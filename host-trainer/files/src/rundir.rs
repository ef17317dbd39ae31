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
//! * **Temp files.** Atomic writes go through `.<name>.tmp.<pid>.<nonce>` files in the
//!   folder ([`write_atomic`], [`create_temp`]): created exclusively (`O_CREAT|O_EXCL`,
//!   `O_NOFOLLOW`) under a name no other process can predict, so a file or symbolic link
//!   planted at a temp name is never written through (another name is drawn), and removed
//!   on any failure. Once a run holds the lock, every such file of another pid is a
//!   leftover of a killed run and [`remove_stale_temp_files`] deletes it.

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
    let linked = match create_temp(dir, &name, 0o666) {
        Ok((tmp, mut f)) => {
            let linked = f
                .write_all(owner.to_text().as_bytes())
                .and_then(|()| f.sync_all())
                .and_then(|()| fs::hard_link(&tmp, path));
            let _ = fs::remove_file(&tmp);
            linked
        }
        Err(e) => Err(e),
    };
    match linked {
        Ok(()) => Ok(()),
        Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => Err(e),
        Err(e) if e.kind() == std::io::ErrorKind::StorageFull => Err(e),
        Err(_) => {
            // No hard links here (or the temp file could not be made): create the lock
            // directly and remove it again if it cannot be written completely.
            let mut f = create_exclusive(path, 0o666)?;
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
/// `.<target>.tmp.<pid>.<nonce>` ([`create_temp`]; the nonce hexadecimal) or, as
/// earlier versions named them, `.<target>.tmp.<pid>`.
pub fn parse_temp_name(name: &str) -> Option<(&str, u32)> {
    let rest = name.strip_prefix('.')?;
    let (target, tail) = rest.rsplit_once(".tmp.")?;
    let pid = match tail.split_once('.') {
        Some((pid, nonce)) if !nonce.is_empty() && nonce.bytes().all(|b| b.is_ascii_hexdigit()) => {
            pid
        }
        Some(_) => return None,
        None => tail,
    };
    if target.is_empty() || pid.is_empty() || !pid.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    Some((target, pid.parse().ok()?))
}

/// Attempts at a fresh temp name before [`create_temp`] gives up: each name is 64 random
/// bits, so only names planted on purpose collide, and a folder cannot hold enough of them.
const TEMP_ATTEMPTS: u32 = 64;

/// A name no other process can predict: 64 bits from the standard library's per-process
/// random hash keys, over a counter and the clock.
fn nonce() -> u64 {
    use std::hash::{BuildHasher, Hasher};
    use std::sync::atomic::{AtomicU64, Ordering};
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let mut h = std::collections::hash_map::RandomState::new().build_hasher();
    h.write_u64(COUNTER.fetch_add(1, Ordering::Relaxed));
    let now = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_nanos())
        .unwrap_or(0);
    h.write_u128(now);
    h.write_u32(std::process::id());
    h.finish()
}

/// Opens `path` for writing only if it does not exist yet (`O_CREAT|O_EXCL`: an existing
/// file, or a symbolic link even to nowhere, is `AlreadyExists`), never following a link
/// (`O_NOFOLLOW`), with permissions `mode` (before the umask).
pub fn create_exclusive(path: &Path, mode: u32) -> std::io::Result<fs::File> {
    use std::os::unix::fs::OpenOptionsExt;
    OpenOptions::new()
        .write(true)
        .create_new(true)
        .custom_flags(libc::O_NOFOLLOW | libc::O_CLOEXEC)
        .mode(mode)
        .open(path)
}

/// A fresh temp file for the target file name `name` in `dir`:
/// `.<name>.tmp.<pid>.<nonce>`, created with [`create_exclusive`] (permissions `mode`
/// before the umask); a name that exists (planted or not) is skipped for another.
/// Returns the path and the open file; the caller removes the path on failure.
pub fn create_temp(dir: &Path, name: &str, mode: u32) -> std::io::Result<(PathBuf, fs::File)> {
    let mut last = None;
    for _ in 0..TEMP_ATTEMPTS {
        let tmp = temp_path(dir, name);
        match create_exclusive(&tmp, mode) {
            Ok(f) => return Ok((tmp, f)),
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => last = Some(e),
            Err(e) => return Err(e),
        }
    }
    let e = last.unwrap_or_else(|| std::io::Error::from(std::io::ErrorKind::AlreadyExists));
    Err(std::io::Error::new(
        e.kind(),
        format!(
            "no fresh temp name for {name} in {} after {TEMP_ATTEMPTS} attempts: {e}",
            dir.display()
        ),
    ))
}

/// A fresh temp name `.<name>.tmp.<pid>.<nonce>` in `dir` (not created: for a hard link,
/// which refuses an existing name by itself).
pub fn temp_path(dir: &Path, name: &str) -> PathBuf {
    dir.join(format!(
        ".{name}.tmp.{}.{:016x}",
        std::process::id(),
        nonce()
    ))
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
/// `path`'s folder if needed, then writes `bytes` through a fresh temp file in the same
/// directory ([`create_temp`]: exclusive, never through a link), fsync, rename, fsync the
/// directory. On failure the temp file is removed, and the error
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
    let mut tmp = None;
    let mut write = || -> std::io::Result<()> {
        let (t, mut f) = create_temp(dir, &name, 0o666)?;
        let t = tmp.insert(t);
        f.write_all(bytes)?;
        f.sync_all()?;
        drop(f);
        fs::rename(t, path)
    };
    if let Err(e) = write() {
        // Only a temp file this call created is removed (never a planted name).
        let removed = tmp.as_ref().filter(|t| fs::remove_file(t).is_ok());
        let left = temp_files(dir, |_| true);
        let mut msg = format!("writing {} failed: {e}", path.display());
        if let Some(t) = removed {
            msg += &format!(" (removed the partial {})", t.display());
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
        assert_eq!(
            parse_temp_name(".x.svg.tmp.42.00ff12ab00ff12ab"),
            Some(("x.svg", 42))
        );
        assert_eq!(parse_temp_name(".x.tmp.42.zz"), None);
        assert_eq!(parse_temp_name(".x.tmp.42."), None);
        let dir = std::env::temp_dir();
        let t = temp_path(&dir, "m.gpec");
        let name = t.file_name().unwrap().to_str().unwrap();
        assert_eq!(parse_temp_name(name), Some(("m.gpec", std::process::id())));
        assert_ne!(t, temp_path(&dir, "m.gpec"), "a fresh name per call");
        let o = LockOwner {
            pid: 7,
            host: "h".into(),
            started: 9,
        };
        assert_eq!(LockOwner::parse(&o.to_text()), Some(o));
        assert_eq!(LockOwner::parse("garbage"), None);
        assert!(!pid_is_dead(std::process::id()));
    }

    /// Links planted at the predictable temp name of earlier versions and at many other
    /// temp names of this process, all pointing at a victim file.
    fn plant(dir: &Path, name: &str, victim: &Path) -> Vec<PathBuf> {
        let pid = std::process::id();
        let mut links = vec![dir.join(format!(".{name}.tmp.{pid}"))];
        for i in 0..200u64 {
            links.push(dir.join(format!(".{name}.tmp.{pid}.{i:016x}")));
            links.push(dir.join(format!(".{name}.tmp.{}", pid.wrapping_add(1 + i as u32))));
        }
        for l in &links {
            std::os::unix::fs::symlink(victim, l).unwrap();
        }
        links
    }

    #[test]
    fn an_atomic_write_never_follows_a_planted_link() {
        let d = tempfile::tempdir().unwrap();
        let victim = d.path().join("victim");
        fs::write(&victim, b"precious").unwrap();
        let links = plant(d.path(), "d.svg", &victim);
        let out = d.path().join("d.svg");
        write_atomic(&out, b"<svg/>").unwrap();
        assert_eq!(fs::read(&out).unwrap(), b"<svg/>");
        assert_eq!(
            fs::read(&victim).unwrap(),
            b"precious",
            "the victim is untouched"
        );
        for l in &links {
            assert!(fs::symlink_metadata(l).unwrap().file_type().is_symlink());
        }
        // Nothing of ours is left: every temp-named entry is a planted link.
        let ours = temp_files(d.path(), |_| true);
        assert!(ours.is_empty(), "{ours:?}");
        // A lock is written the same way.
        plant(d.path(), ".gpecnet.lock", &victim);
        let lock = RunLock::acquire(d.path()).unwrap();
        assert!(lock.path().is_file());
        assert_eq!(fs::read(&victim).unwrap(), b"precious");
    }

    #[test]
    fn create_exclusive_refuses_a_link_even_to_nowhere() {
        let d = tempfile::tempdir().unwrap();
        let victim = d.path().join("victim");
        fs::write(&victim, b"precious").unwrap();
        let link = d.path().join("l");
        std::os::unix::fs::symlink(&victim, &link).unwrap();
        let e = create_exclusive(&link, 0o600).unwrap_err();
        assert_eq!(e.kind(), std::io::ErrorKind::AlreadyExists);
        let dangling = d.path().join("nowhere");
        std::os::unix::fs::symlink(d.path().join("missing"), &dangling).unwrap();
        assert!(create_exclusive(&dangling, 0o600).is_err());
        assert!(
            !d.path().join("missing").exists(),
            "no file made through the link"
        );
        assert_eq!(fs::read(&victim).unwrap(), b"precious");
    }

    #[test]
    fn a_failed_atomic_write_removes_its_temp_file() {
        let d = tempfile::tempdir().unwrap();
        // The rename fails: the destination is a non-empty folder.
        let out = d.path().join("busy");
        fs::create_dir(&out).unwrap();
        fs::write(out.join("inside"), b"x").unwrap();
        let e = write_atomic(&out, b"data").unwrap_err();
        assert!(e.to_string().contains("removed the partial"), "{e}");
        assert!(temp_files(d.path(), |_| true).is_empty());
        let names: Vec<_> = fs::read_dir(d.path()).unwrap().collect();
        assert_eq!(names.len(), 1, "only the folder is left");
    }
}
