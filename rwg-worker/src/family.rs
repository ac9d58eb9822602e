//! Every process an environment starts ends with rwg: a worker's helpers (a
//! simulator server, a daemon) are reached through the worker's process
//! group, and those that leave it (`setsid`, a double fork) through rwg being
//! their **subreaper** and a mark in their environment.
//!
//! On Linux, the first worker started makes rwg a child subreaper
//! (`PR_SET_CHILD_SUBREAPER`): a process orphaned below rwg (a helper whose
//! worker died, a daemon that forked away from it) becomes rwg's child
//! instead of init's. Every worker gets [`MARK_VAR`] = `RWGPID:N` in its
//! environment, which its descendants inherit, so rwg tells which of its
//! children belong to which worker. When a worker ends, its process group is
//! killed and so are rwg's children that bear its mark (`sweep`); when rwg
//! ends on a catchable signal that would kill it (SIGTERM, SIGHUP, SIGQUIT,
//! SIGINT where nothing else handles it, SIGUSR1/2, SIGALRM, ...), through
//! `exit`, or through [`end_all`] before `_exit`, every worker's group and
//! every marked child go first.
//!
//! Why not a cgroup: creating one needs a delegated, writable cgroup
//! (systemd's user slices, root), which Slurm jobs and containers rarely
//! give; a subreaper needs no privilege. What neither reaches: a process
//! that leaves the group *and* clears its environment, and anything once
//! rwg is SIGKILLed (its workers still die: `PR_SET_PDEATHSIG`).

use std::sync::Mutex;

/// The environment variable marking a worker and its descendants:
/// `RWGPID:N`, rwg's process id and the worker's number.
pub const MARK_VAR: &str = "RWG_WORKER_FAMILY";

/// The live workers: (process id, which is also its process group's, mark).
static LIVE: Mutex<Vec<(i32, String)>> = Mutex::new(Vec::new());

/// The mark of the next worker, set in `command`'s environment; sets the
/// family up on first use.
pub(crate) fn enlist(command: &mut std::process::Command) -> String {
    use std::sync::atomic::{AtomicU64, Ordering};
    static NEXT: AtomicU64 = AtomicU64::new(0);
    #[cfg(target_os = "linux")]
    {
        static ONCE: std::sync::Once = std::sync::Once::new();
        ONCE.call_once(linux::set_up);
    }
    let mark = format!(
        "{}:{}",
        std::process::id(),
        NEXT.fetch_add(1, Ordering::Relaxed)
    );
    command.env(MARK_VAR, &mark);
    mark
}

/// Records a started worker.
pub(crate) fn joined(pid: u32, mark: &str) {
    live().push((pid as i32, mark.to_string()));
}

/// Forgets a worker (reaped: its id may be another process's from now on).
pub(crate) fn left(pid: u32) {
    live().retain(|(p, _)| *p != pid as i32);
}

fn live() -> std::sync::MutexGuard<'static, Vec<(i32, String)>> {
    LIVE.lock().unwrap_or_else(|p| p.into_inner())
}

/// Kills rwg's children that bear `mark` (the processes a worker started
/// that left its process group, once orphaned), and theirs as they are
/// orphaned in turn, and reaps them.
pub(crate) fn sweep(mark: &str) {
    #[cfg(target_os = "linux")]
    linux::sweep(&format!("{MARK_VAR}={mark}"), &[]);
    #[cfg(not(target_os = "linux"))]
    let _ = mark;
}

/// Kills every worker's process group and every process of the family that
/// rwg can reach: for rwg's own ends (`_exit` after a second Ctrl-C, a
/// fatal signal). Safe to call more than once.
pub fn end_all() {
    #[cfg(target_os = "linux")]
    {
        // not `live()`: a thread stopped while holding the lock must not
        // stop rwg from ending
        let workers: Vec<i32> = match LIVE.try_lock() {
            Ok(l) => l.iter().map(|(p, _)| *p).collect(),
            Err(std::sync::TryLockError::Poisoned(p)) => {
                p.into_inner().iter().map(|(p, _)| *p).collect()
            }
            Err(std::sync::TryLockError::WouldBlock) => vec![],
        };
        for &p in &workers {
            // SAFETY: signalling our own workers' process groups.
            unsafe {
                libc::kill(-p, libc::SIGKILL);
            }
        }
        // Only once a worker is gone are the processes it started that left
        // its group re-parented to rwg, where the sweep finds them.
        linux::wait_ended(&workers, std::time::Duration::from_secs(2));
        linux::sweep(&format!("{MARK_VAR}={}:", std::process::id()), &workers);
    }
}

#[cfg(target_os = "linux")]
mod linux {
    use std::time::{Duration, Instant};

    /// The signals whose default action ends rwg and that can be caught
    /// (SIGINT too, where nothing else handles it).
    const ENDING: [libc::c_int; 11] = [
        libc::SIGHUP,
        libc::SIGINT,
        libc::SIGQUIT,
        libc::SIGTERM,
        libc::SIGUSR1,
        libc::SIGUSR2,
        libc::SIGALRM,
        libc::SIGVTALRM,
        libc::SIGPROF,
        libc::SIGXCPU,
        libc::SIGXFSZ,
    ];

    /// The write end of the pipe the signal handler writes to.
    static PIPE_W: std::sync::atomic::AtomicI32 = std::sync::atomic::AtomicI32::new(-1);

    /// rwg becomes a subreaper; a thread waits for ending signals, whose
    /// handlers (installed where the signal's action is the default) only
    /// write the signal's number to a pipe.
    pub(super) fn set_up() {
        // SAFETY: prctl with constant arguments.
        unsafe {
            libc::prctl(libc::PR_SET_CHILD_SUBREAPER, 1, 0, 0, 0);
        }
        extern "C" fn at_exit() {
            super::end_all();
        }
        // SAFETY: registering a plain function.
        unsafe {
            libc::atexit(at_exit);
        }
        let mut fds = [0; 2];
        // SAFETY: a two-int array for pipe2.
        if unsafe { libc::pipe2(fds.as_mut_ptr(), libc::O_CLOEXEC) } != 0 {
            return;
        }
        PIPE_W.store(fds[1], std::sync::atomic::Ordering::SeqCst);
        let read_fd = fds[0];
        let started = std::thread::Builder::new()
            .name("rwg-worker-family".into())
            .spawn(move || loop {
                let mut sig = 0u8;
                // SAFETY: reading one byte into a local.
                let n = unsafe { libc::read(read_fd, (&mut sig as *mut u8).cast(), 1) };
                if n == 1 {
                    super::end_all();
                    // SAFETY: the default action back, then the signal again:
                    // rwg ends as the signal says (its exit status names it).
                    unsafe {
                        libc::signal(sig as libc::c_int, libc::SIG_DFL);
                        libc::raise(sig as libc::c_int);
                    }
                } else if n == 0 {
                    return;
                }
            });
        if started.is_err() {
            return;
        }
        for sig in ENDING {
            // SAFETY: reading and setting dispositions with valid structs; the
            // handler only calls write(2), which is async-signal-safe.
            unsafe {
                let mut old: libc::sigaction = std::mem::zeroed();
                if libc::sigaction(sig, std::ptr::null(), &mut old) != 0
                    || old.sa_sigaction != libc::SIG_DFL
                {
                    continue;
                }
                let mut act: libc::sigaction = std::mem::zeroed();
                act.sa_sigaction = on_signal as extern "C" fn(libc::c_int) as usize;
                act.sa_flags = libc::SA_RESTART;
                libc::sigemptyset(&mut act.sa_mask);
                libc::sigaction(sig, &act, std::ptr::null_mut());
            }
        }
    }

    extern "C" fn on_signal(sig: libc::c_int) {
        let fd = PIPE_W.load(std::sync::atomic::Ordering::SeqCst);
        let b = sig as u8;
        // SAFETY: write(2) is async-signal-safe.
        unsafe {
            libc::write(fd, (&b as *const u8).cast(), 1);
        }
    }

    /// Kills rwg's children (other than `spare`) whose environment holds an
    /// entry starting with `entry`, then those orphaned by their deaths, for
    /// up to two seconds; reaps them.
    pub(super) fn sweep(entry: &str, spare: &[i32]) {
        let t0 = Instant::now();
        loop {
            let strays: Vec<i32> = children()
                .into_iter()
                .filter(|p| !spare.contains(p) && bears(*p, entry.as_bytes()))
                .collect();
            if strays.is_empty() || t0.elapsed() > Duration::from_secs(2) {
                return;
            }
            for &p in &strays {
                // SAFETY: killing and reaping our own children (orphans
                // rwg adopted as their subreaper, not a `Child` of rwg's).
                unsafe {
                    libc::kill(-p, libc::SIGKILL); // its group, if it leads one
                    libc::kill(p, libc::SIGKILL);
                    libc::waitpid(p, std::ptr::null_mut(), 0);
                }
            }
        }
    }

    /// Waits up to `limit` until every one of `pids` (rwg's children) has
    /// ended, without reaping them.
    pub(super) fn wait_ended(pids: &[i32], limit: Duration) {
        let t0 = Instant::now();
        for &p in pids {
            loop {
                // SAFETY: a zeroed siginfo_t for waitid to fill.
                let mut info: libc::siginfo_t = unsafe { std::mem::zeroed() };
                // SAFETY: waitid on our own child; WNOWAIT leaves it unreaped.
                let r = unsafe {
                    libc::waitid(
                        libc::P_PID,
                        p as libc::id_t,
                        &mut info,
                        libc::WEXITED | libc::WNOHANG | libc::WNOWAIT,
                    )
                };
                // SAFETY: filled by waitid (zero while the child runs).
                if r != 0 || unsafe { info.si_pid() } != 0 || t0.elapsed() > limit {
                    break;
                }
                std::thread::sleep(Duration::from_millis(2));
            }
        }
    }

    /// rwg's children that are running (not zombies).
    fn children() -> Vec<i32> {
        let me = std::process::id().to_string();
        let mut out = vec![];
        let Ok(dir) = std::fs::read_dir("/proc") else {
            return out;
        };
        for e in dir.flatten() {
            let Ok(pid) = e.file_name().to_string_lossy().parse::<i32>() else {
                continue;
            };
            let Ok(stat) = std::fs::read_to_string(e.path().join("stat")) else {
                continue;
            };
            let Some(at) = stat.rfind(')') else { continue };
            let mut f = stat[at + 1..].split_whitespace();
            let (state, ppid) = (f.next(), f.next());
            if ppid == Some(me.as_str()) && !matches!(state, Some("Z" | "X")) {
                out.push(pid);
            }
        }
        out
    }

    /// Whether process `pid`'s environment has an entry starting with `entry`.
    fn bears(pid: i32, entry: &[u8]) -> bool {
        std::fs::read(format!("/proc/{pid}/environ"))
            .map(|env| env.split(|&b| b == 0).any(|e| e.starts_with(entry)))
            .unwrap_or(false)
    }
}

#[cfg(all(test, target_os = "linux"))]
mod tests {
    use super::*;
    use std::time::{Duration, Instant};

    fn alive(pid: i32) -> bool {
        std::fs::read_to_string(format!("/proc/{pid}/stat"))
            .map(|s| {
                !matches!(
                    s[s.rfind(')').unwrap() + 2..].chars().next(),
                    Some('Z' | 'X')
                )
            })
            .unwrap_or(false)
    }

    /// A worker's daemon (setsid and a double fork: re-parented to rwg, in a
    /// session of its own) ends with the worker; another worker's does not.
    #[test]
    fn a_workers_daemon_ends_with_it_and_no_other() {
        let daemon = |tag: &str| {
            let mut c = std::process::Command::new("sh");
            c.arg("-c")
                .arg("setsid sh -c 'sleep 600 > /dev/null 2>&1 & echo $!' < /dev/null");
            let mark = enlist(&mut c);
            let out = c.output().unwrap();
            let pid: i32 = String::from_utf8_lossy(&out.stdout).trim().parse().unwrap();
            assert!(alive(pid), "{tag}: the daemon is not running");
            (pid, mark)
        };
        let (mine, mark) = daemon("mine");
        let (other, _) = daemon("other");
        sweep(&mark);
        let t0 = Instant::now();
        while alive(mine) && t0.elapsed() < Duration::from_secs(5) {
            std::thread::sleep(Duration::from_millis(20));
        }
        assert!(!alive(mine), "the worker's daemon outlived it");
        assert!(alive(other), "another worker's daemon was killed");
        // SAFETY: killing the test's own stray.
        unsafe {
            libc::kill(other, libc::SIGKILL);
            libc::waitpid(other, std::ptr::null_mut(), 0);
        }
    }
}
