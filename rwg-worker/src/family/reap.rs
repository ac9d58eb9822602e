//! Finding, killing and reaping rwg's children through `/proc`: the end of
//! the whole family ([`end_all`], async-signal-safe: raw system calls into
//! static buffers) and of one worker's strays ([`sweep_marked`]).

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

/// The most workers [`end_all`] kills by their process group (more than
/// rwg ever starts; the rest are still found as rwg's children).
pub(super) const MAX_WORKERS: usize = 1024;

/// How long the family's end may take: a process that will not die (stuck
/// in the kernel) does not keep rwg from ending.
const LIMIT: Duration = Duration::from_secs(2);
/// How long rwg waits for its killed workers to be gone: a worker holding
/// a GPU may take seconds to release it, and rwg does not end before.
const WORKER_LIMIT: Duration = Duration::from_secs(10);

/// One [`end_all`] at a time: it owns the static buffers.
static BUSY: AtomicBool = AtomicBool::new(false);

/// Kills the process groups of `workers` (rwg's children that lead one),
/// waits for them to end, then kills every child of rwg and every process
/// orphaned to rwg by their deaths until none is left (or [`LIMIT`]), and
/// reaps them. Async-signal-safe; returns at once while another call runs.
pub(super) fn end_all(workers: &[i32]) {
    if BUSY.swap(true, Ordering::SeqCst) {
        return;
    }
    for &p in workers {
        // SAFETY: signalling our own workers' process groups.
        unsafe {
            libc::kill(-p, libc::SIGKILL);
        }
    }
    // Only once a worker is gone are the processes it started that left its
    // group re-parented to rwg, where the scan finds them.
    wait_ended(workers, WORKER_LIMIT);
    // SAFETY: BUSY gives this call the buffers alone.
    let bufs = unsafe { &mut *std::ptr::addr_of_mut!(BUFS) };
    let t0 = now();
    loop {
        let mut living = 0;
        for_each_child(bufs, |pid, zombie| {
            // SAFETY: killing and reaping our own children.
            unsafe {
                if zombie {
                    libc::waitpid(pid, std::ptr::null_mut(), libc::WNOHANG);
                } else {
                    living += 1;
                    libc::kill(-pid, libc::SIGKILL); // its group, if it leads one
                    libc::kill(pid, libc::SIGKILL);
                }
            }
        });
        if living == 0 || elapsed(t0) > LIMIT {
            break;
        }
        nap();
    }
    BUSY.store(false, Ordering::SeqCst);
}

/// Kills rwg's children (other than workers still listed) whose environment
/// holds the entry `entry` exactly, then those orphaned by their deaths, for
/// up to [`LIMIT`]; reaps them.
pub(super) fn sweep_marked(entry: &str) {
    let t0 = Instant::now();
    let mut bufs = Box::new(ScanBufs::new());
    loop {
        let mut strays = Vec::new();
        for_each_child(&mut bufs, |pid, zombie| {
            if !zombie && bears(pid, entry.as_bytes()) {
                strays.push(pid);
            }
        });
        if strays.is_empty() || t0.elapsed() > LIMIT {
            return;
        }
        for &p in &strays {
            // SAFETY: killing and reaping our own children (orphans rwg
            // adopted as their subreaper, not a `Child` of rwg's).
            unsafe {
                libc::kill(-p, libc::SIGKILL);
                libc::kill(p, libc::SIGKILL);
                libc::waitpid(p, std::ptr::null_mut(), 0);
            }
        }
    }
}

/// Waits up to `limit` until every one of `pids` (rwg's children) has
/// ended, without reaping them. Async-signal-safe.
pub(super) fn wait_ended(pids: &[i32], limit: Duration) {
    let t0 = now();
    for &p in pids {
        while !super::ended_unreaped(p as u32) && elapsed(t0) <= limit {
            nap();
        }
    }
}

/// How often [`reap_orphans`] looks (and so how long a zombie that no one
/// waits for stays at least): longer than any wait of rwg's own takes to
/// reap its child, and than a plugin's wait right after its child ends.
const ORPHAN_AGE: Duration = Duration::from_secs(1);

/// When [`reap_orphans`] last looked, and the zombies it saw then.
static ZOMBIES: std::sync::Mutex<(Option<Instant>, Vec<i32>)> =
    std::sync::Mutex::new((None, Vec::new()));

/// Reaps rwg's zombie children that no one waits for: not a listed worker
/// (`live`), and a zombie already when it last looked, [`ORPHAN_AGE`]
/// before (a wait in progress reaps its child at once). As a subreaper rwg
/// adopts the orphans of what it and its plugins start; each one that ends
/// (a plugin's daemon that exits) would otherwise hold a process id until
/// rwg ends. One `waitid` when there is none; a scan of `/proc` otherwise.
pub(super) fn reap_orphans(live: &[i32]) {
    let mut state = ZOMBIES.lock().unwrap_or_else(|p| p.into_inner());
    let now = Instant::now();
    if state.0.is_some_and(|t| now - t < ORPHAN_AGE) {
        return;
    }
    state.0 = Some(now);
    // SAFETY: a zeroed siginfo_t for waitid to fill.
    let mut info: libc::siginfo_t = unsafe { std::mem::zeroed() };
    // SAFETY: waitid on any child; WNOWAIT leaves it unreaped.
    let r = unsafe {
        libc::waitid(
            libc::P_ALL,
            0,
            &mut info,
            libc::WEXITED | libc::WNOHANG | libc::WNOWAIT,
        )
    };
    // SAFETY: filled by waitid (zero: no zombie).
    if r != 0 || unsafe { info.si_pid() } == 0 {
        state.1.clear();
        return;
    }
    let mut zombies = Vec::new();
    for_each_child(&mut ScanBufs::new(), |pid, zombie| {
        if zombie && !live.contains(&pid) {
            zombies.push(pid);
        }
    });
    let before = std::mem::take(&mut state.1);
    for pid in zombies {
        if before.contains(&pid) {
            // SAFETY: reaping our own zombie child, which no one waits for.
            unsafe {
                libc::waitpid(pid, std::ptr::null_mut(), libc::WNOHANG);
            }
        } else {
            state.1.push(pid);
        }
    }
}

/// Whether process `pid`'s environment has the entry `entry`.
fn bears(pid: i32, entry: &[u8]) -> bool {
    std::fs::read(format!("/proc/{pid}/environ"))
        .map(|env| env.split(|&b| b == 0).any(|e| e == entry))
        .unwrap_or(false)
}

/// The monotonic clock (async-signal-safe, unlike nothing in std that says so).
fn now() -> libc::timespec {
    let mut t = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: clock_gettime is async-signal-safe; a valid timespec.
    unsafe {
        libc::clock_gettime(libc::CLOCK_MONOTONIC, &mut t);
    }
    t
}

fn elapsed(t0: libc::timespec) -> Duration {
    let t = now();
    let ns = (t.tv_sec - t0.tv_sec) as i128 * 1_000_000_000 + (t.tv_nsec - t0.tv_nsec) as i128;
    Duration::from_nanos(ns.max(0) as u64)
}

/// Two milliseconds' sleep (async-signal-safe).
fn nap() {
    let t = libc::timespec {
        tv_sec: 0,
        tv_nsec: 2_000_000,
    };
    // SAFETY: nanosleep is async-signal-safe; a valid timespec.
    unsafe {
        libc::nanosleep(&t, std::ptr::null_mut());
    }
}

/// Buffers of the `/proc` scan: a directory listing and a process's `stat`.
struct ScanBufs {
    dents: [u8; 8192],
    stat: [u8; 512],
}

impl ScanBufs {
    const fn new() -> ScanBufs {
        ScanBufs {
            dents: [0; 8192],
            stat: [0; 512],
        }
    }
}

/// [`end_all`]'s buffers (static: a signal handler's stack is small), owned
/// under [`BUSY`].
static mut BUFS: ScanBufs = ScanBufs::new();

/// Calls `f(pid, is_zombie)` for each child of rwg's, read from `/proc`
/// with raw system calls into `bufs` (async-signal-safe).
fn for_each_child(bufs: &mut ScanBufs, mut f: impl FnMut(i32, bool)) {
    // SAFETY: getpid has no preconditions.
    let me = unsafe { libc::getpid() };
    // SAFETY: a NUL-terminated path.
    let dir = unsafe {
        libc::open(
            c"/proc".as_ptr(),
            libc::O_RDONLY | libc::O_DIRECTORY | libc::O_CLOEXEC,
        )
    };
    if dir >= 0 {
        loop {
            // SAFETY: getdents64 fills at most the buffer's length.
            let n = unsafe {
                libc::syscall(
                    libc::SYS_getdents64,
                    dir,
                    bufs.dents.as_mut_ptr(),
                    bufs.dents.len(),
                )
            };
            if n <= 0 {
                break;
            }
            let mut off = 0usize;
            while off + 19 < n as usize {
                // struct linux_dirent64: ino u64, off i64, reclen u16, type u8, name
                let rec = &bufs.dents[off..n as usize];
                let reclen = u16::from_ne_bytes([rec[16], rec[17]]) as usize;
                if reclen == 0 {
                    break;
                }
                if let Some(pid) = pid_of(&rec[19..reclen.min(rec.len())]) {
                    match parent_of(pid, &mut bufs.stat) {
                        Some((ppid, zombie)) if ppid == me => f(pid, zombie),
                        _ => {}
                    }
                }
                off += reclen;
            }
        }
        // SAFETY: our own descriptor.
        unsafe {
            libc::close(dir);
        }
    }
}

/// The process id a `/proc` entry's NUL-terminated name is, if it is one.
fn pid_of(name: &[u8]) -> Option<i32> {
    let mut pid: i32 = 0;
    let mut digits = 0;
    for &b in name {
        match b {
            0 => break,
            b'0'..=b'9' => {
                pid = pid.checked_mul(10)?.checked_add((b - b'0') as i32)?;
                digits += 1;
            }
            _ => return None,
        }
    }
    (digits > 0).then_some(pid)
}

/// Process `pid`'s parent and whether it is a zombie (or dead), from
/// `/proc/PID/stat` read into `buf`.
fn parent_of(pid: i32, buf: &mut [u8; 512]) -> Option<(i32, bool)> {
    let mut path = *b"/proc/\0\0\0\0\0\0\0\0\0\0\0/stat\0\0\0\0\0";
    let mut digits = [0u8; 11];
    let (mut v, mut k) = (pid, digits.len());
    loop {
        k -= 1;
        digits[k] = b'0' + (v % 10) as u8;
        v /= 10;
        if v == 0 {
            break;
        }
    }
    let d = &digits[k..];
    path[6..6 + d.len()].copy_from_slice(d);
    path[6 + d.len()..6 + d.len() + 6].copy_from_slice(b"/stat\0");
    // SAFETY: a NUL-terminated path.
    let fd = unsafe { libc::open(path.as_ptr().cast(), libc::O_RDONLY | libc::O_CLOEXEC) };
    if fd < 0 {
        return None;
    }
    // SAFETY: reading into our buffer; our own descriptor.
    let n = unsafe {
        let n = libc::read(fd, buf.as_mut_ptr().cast(), buf.len());
        libc::close(fd);
        n
    };
    if n <= 0 {
        return None;
    }
    // pid (comm) state ppid ...: after the last ')'
    let text = &buf[..n as usize];
    let close = text.iter().rposition(|&b| b == b')')?;
    let rest = text.get(close + 2..)?;
    let state = *rest.first()?;
    let mut ppid: i32 = 0;
    for &b in rest.get(2..)? {
        if !b.is_ascii_digit() {
            break;
        }
        ppid = ppid.checked_mul(10)?.checked_add((b - b'0') as i32)?;
    }
    Some((ppid, matches!(state, b'Z' | b'X')))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn proc_names_and_stat_lines() {
        assert_eq!(pid_of(b"1234\0\0"), Some(1234));
        assert_eq!(pid_of(b"self\0"), None);
        assert_eq!(pid_of(b"\0"), None);
        let me = std::process::id() as i32;
        let mut buf = [0u8; 512];
        let (ppid, zombie) = parent_of(me, &mut buf).unwrap();
        // SAFETY: getppid has no preconditions.
        assert_eq!(ppid, unsafe { libc::getppid() });
        assert!(!zombie);
    }

    #[test]
    fn children_are_found_and_ended() {
        let mut c = std::process::Command::new("sleep")
            .arg("600")
            .spawn()
            .unwrap();
        let pid = c.id() as i32;
        let mut seen = false;
        for_each_child(&mut ScanBufs::new(), |p, _| seen |= p == pid);
        assert!(seen, "the child {pid} was not found");
        // SAFETY: killing the test's own child.
        unsafe {
            libc::kill(pid, libc::SIGKILL);
        }
        let _ = c.wait();
    }
}
