//! The run directory's writer lock.
//!
//! Every command that writes into a run directory (`run`, `merge`, `stats`,
//! `report`, and `plot`, `compare` or `replay --export-weights` writing a
//! file into the run: see [`crate::rundir::outputs`])
//! first takes an exclusive `flock(2)` on `RUN/rwg.lock`. The kernel releases
//! it when the holder exits or is killed, so a SIGKILL leaves no stale lock.
//! A second writer fails at once with [`LockError::Held`], which names the
//! holder (its pid and command line, which the holder writes into the lock
//! file), and changes nothing. Readers (`status`, `verify`, `top`) take no
//! lock.
//!
//! Within one process the lock is shared: taking it again on a directory the
//! process already holds returns another handle to the same lock (so `rwg
//! run` can hold it across the study and the analysis written after it).
//!
//! On systems without `flock` (Windows) no lock is taken.

use std::collections::HashMap;
use std::fs::File;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, Weak};

/// Name of the lock file in a run directory.
pub const LOCK_FILE: &str = "rwg.lock";

/// Why the lock could not be taken.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum LockError {
    /// Another process holds the lock.
    #[error(
        "{} is being written by another rwg process ({holder}); nothing was changed. \
         Wait for it to finish (or stop it), then run this again",
        dir.display()
    )]
    Held {
        /// The run directory.
        dir: PathBuf,
        /// Who holds it: "pid N: command line", as the holder recorded it.
        holder: String,
    },
    /// The lock file could not be opened or locked.
    #[error("cannot lock {}{}", path.display(), read_only_hint(source))]
    Io {
        /// The lock file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
}

/// What to say when the lock cannot be taken because the run directory is
/// on a read-only file system, or the lock file is a symbolic link (empty
/// otherwise).
fn read_only_hint(e: &std::io::Error) -> &'static str {
    if e.kind() == std::io::ErrorKind::ReadOnlyFilesystem {
        ": the run directory is on a read-only file system, and this command writes into it \
         (so it takes the writers' lock first); the readers work there: rwg verify, rwg \
         status, rwg top, rwg stats --no-write"
    } else if e.raw_os_error() == Some(ELOOP) {
        ": it is a symbolic link, which rwg never follows there (whatever it points to would \
         be written); remove the link, and rwg makes the lock file again"
    } else {
        ""
    }
}

/// The errno of opening a symbolic link with `O_NOFOLLOW`.
#[cfg(unix)]
const ELOOP: i32 = libc::ELOOP;
#[cfg(not(unix))]
const ELOOP: i32 = -1;

struct Inner {
    file: File,
}

/// A held lock on a run directory; released when the last handle is dropped.
#[derive(Clone)]
pub struct RunLock {
    inner: Arc<Inner>,
}

impl std::fmt::Debug for RunLock {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("RunLock")
    }
}

fn held() -> &'static Mutex<HashMap<PathBuf, Weak<Inner>>> {
    static HELD: std::sync::OnceLock<Mutex<HashMap<PathBuf, Weak<Inner>>>> =
        std::sync::OnceLock::new();
    HELD.get_or_init(Default::default)
}

impl RunLock {
    /// Takes the lock of run directory `dir` (which must exist), recording
    /// this process's pid and command line in it.
    pub fn acquire(dir: &Path) -> Result<RunLock, LockError> {
        let path = dir.join(LOCK_FILE);
        let io = |source| LockError::Io {
            path: path.clone(),
            source,
        };
        let key = std::fs::canonicalize(dir).map_err(io)?;
        let mut map = held().lock().unwrap_or_else(|e| e.into_inner());
        if let Some(inner) = map.get(&key).and_then(Weak::upgrade) {
            return Ok(RunLock { inner });
        }
        let file = lock_file(&path, dir)?;
        let inner = Arc::new(Inner { file });
        map.insert(key, Arc::downgrade(&inner));
        Ok(RunLock { inner })
    }
}

impl RunLock {
    /// Whether the run directory this lock was taken in is still at `dir`:
    /// `None` if it is; else where it is now, as far as the system says
    /// (`Some(None)`: deleted, or not known). A run directory moved or
    /// deleted while a writer holds it is what this tells.
    pub fn moved_from(&self, dir: &Path) -> Option<Option<PathBuf>> {
        #[cfg(unix)]
        {
            use std::os::unix::fs::MetadataExt;
            use std::os::unix::io::AsRawFd;
            let held = self.inner.file.metadata().ok()?;
            let there = std::fs::symlink_metadata(dir.join(LOCK_FILE)).ok();
            if there.is_some_and(|m| (m.dev(), m.ino()) == (held.dev(), held.ino())) {
                return None;
            }
            let fd = self.inner.file.as_raw_fd();
            let now = std::fs::read_link(format!("/proc/self/fd/{fd}"))
                .ok()
                .filter(|p| held.nlink() > 0 && !p.to_string_lossy().ends_with(" (deleted)"))
                .and_then(|p| p.parent().map(Path::to_path_buf));
            Some(now)
        }
        #[cfg(not(unix))]
        {
            let _ = dir;
            None
        }
    }
}

/// The command line of this process, for the lock file (an argument that
/// is not UTF-8 with U+FFFD for its bad bytes).
fn command_line() -> String {
    let args: Vec<String> = std::env::args_os()
        .map(|a| a.to_string_lossy().into_owned())
        .collect();
    args.join(" ")
}

/// The record of the process that holds (or last held) the lock of `dir`,
/// `pid N: command line`, when that process is alive: a reader's view of
/// who is writing the run, taken without touching the lock. (A pid reused
/// by another process since reads as alive.)
pub fn live_holder(dir: &Path) -> Option<String> {
    let text = crate::limits::read_own_text(&dir.join(LOCK_FILE), 4096).ok()?;
    let record = text.lines().next()?.trim().to_string();
    let pid: i32 = record
        .strip_prefix("pid ")?
        .split(':')
        .next()?
        .parse()
        .ok()?;
    alive(pid).then_some(record)
}

/// [`live_holder`] when it is an `rwg run` or `rwg merge` of another
/// process: what a directory without `run.json` (or `manifest.toml`) yet
/// holds in the first moments of a run or merge. (A command that takes the
/// lock itself before reading, such as `rwg plot`, is none.)
pub fn live_writer(dir: &Path) -> Option<String> {
    let own = format!("pid {}:", std::process::id());
    live_holder(dir).filter(|h| {
        h.split_whitespace()
            .nth(3)
            .is_some_and(|c| c == "run" || c == "merge")
            && !h.starts_with(&own)
    })
}

#[cfg(unix)]
fn alive(pid: i32) -> bool {
    // SAFETY: signal 0 checks that the process exists and sends nothing.
    pid > 0
        && (unsafe { libc::kill(pid, 0) } == 0
            || std::io::Error::last_os_error().raw_os_error() == Some(libc::EPERM))
}

#[cfg(not(unix))]
fn alive(_pid: i32) -> bool {
    false
}

#[cfg(unix)]
fn lock_file(path: &Path, dir: &Path) -> Result<File, LockError> {
    use std::io::{Read, Seek, Write};
    use std::os::unix::fs::OpenOptionsExt;
    use std::os::unix::io::AsRawFd;
    let io = |source| LockError::Io {
        path: path.to_path_buf(),
        source,
    };
    let mut file = std::fs::OpenOptions::new()
        .read(true)
        .write(true)
        .create(true)
        .truncate(false)
        .custom_flags(libc::O_NOFOLLOW | libc::O_CLOEXEC)
        .open(path)
        .map_err(io)?;
    // SAFETY: flock on a file descriptor we own.
    if unsafe { libc::flock(file.as_raw_fd(), libc::LOCK_EX | libc::LOCK_NB) } != 0 {
        let err = std::io::Error::last_os_error();
        if err.kind() != std::io::ErrorKind::WouldBlock {
            return Err(io(err));
        }
        // the holder's line (a file of rwg's own: the first few bytes)
        let mut text = String::new();
        let _ = (&mut file).take(4096).read_to_string(&mut text);
        let holder = text.trim();
        return Err(LockError::Held {
            dir: dir.to_path_buf(),
            holder: if holder.is_empty() {
                "it has not recorded its pid yet".into()
            } else {
                holder.to_string()
            },
        });
    }
    let record = format!("pid {}: {}\n", std::process::id(), command_line());
    // Written over the old record, then cut to length: a reader
    // (live_holder) sees one whole first line, never an empty file.
    file.rewind().map_err(io)?;
    file.write_all(record.as_bytes()).map_err(io)?;
    file.set_len(record.len() as u64).map_err(io)?;
    Ok(file)
}

#[cfg(not(unix))]
fn lock_file(path: &Path, _dir: &Path) -> Result<File, LockError> {
    std::fs::OpenOptions::new()
        .read(true)
        .write(true)
        .create(true)
        .truncate(false)
        .open(path)
        .map_err(|source| LockError::Io {
            path: path.to_path_buf(),
            source,
        })
}

#[cfg(all(test, unix))]
mod tests {
    use super::*;

    #[test]
    fn a_process_shares_its_own_lock_and_releases_it() {
        let dir = std::env::temp_dir().join(format!("rwg-lock-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let a = RunLock::acquire(&dir).unwrap();
        let b = RunLock::acquire(&dir).unwrap();
        let text = std::fs::read_to_string(dir.join(LOCK_FILE)).unwrap();
        assert!(
            text.starts_with(&format!("pid {}: ", std::process::id())),
            "{text}"
        );
        // Another open file description conflicts while the lock is held.
        let f = File::open(dir.join(LOCK_FILE)).unwrap();
        use std::os::unix::io::AsRawFd;
        let try_lock = || unsafe { libc::flock(f.as_raw_fd(), libc::LOCK_EX | libc::LOCK_NB) } == 0;
        assert!(!try_lock());
        drop(a);
        assert!(!try_lock(), "still held by the second handle");
        drop(b);
        assert!(try_lock(), "released with the last handle");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_lock_file_that_is_a_link_is_refused_saying_so_and_a_moved_directory_is_told() {
        let base = std::env::temp_dir().join(format!("rwg-lock-moved-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&base);
        let (dir, moved) = (base.join("run"), base.join("moved"));
        std::fs::create_dir_all(&dir).unwrap();
        std::os::unix::fs::symlink(base.join("elsewhere"), dir.join(LOCK_FILE)).unwrap();
        let err = RunLock::acquire(&dir).unwrap_err().to_string();
        assert!(
            err.contains("it is a symbolic link, which rwg never follows"),
            "{err}"
        );
        assert!(!base.join("elsewhere").exists());
        std::fs::remove_file(dir.join(LOCK_FILE)).unwrap();
        let lock = RunLock::acquire(&dir).unwrap();
        assert_eq!(lock.moved_from(&dir), None);
        std::fs::rename(&dir, &moved).unwrap();
        assert_eq!(lock.moved_from(&dir), Some(Some(moved.clone())));
        std::fs::remove_dir_all(&moved).unwrap();
        assert_eq!(lock.moved_from(&moved), Some(None));
        std::fs::remove_dir_all(&base).unwrap();
    }
}
