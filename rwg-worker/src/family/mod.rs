//! Every process an environment starts ends with rwg: a worker's helpers (a
//! simulator server, a daemon) are reached through the worker's process
//! group, and those that leave it (`setsid`, a double fork) through rwg being
//! their **subreaper**; so are the processes an in-process plugin forks.
//!
//! On Linux, [`set_up`] (rwg's `main` calls it before any plugin is loaded;
//! the first worker started calls it otherwise) makes rwg a child subreaper
//! (`PR_SET_CHILD_SUBREAPER`): a process orphaned below rwg (a helper whose
//! worker died, a daemon that forked away from it or from a plugin) becomes
//! rwg's child instead of init's. Every worker gets [`MARK_VAR`] =
//! `RWGPID:N` in its environment, which its descendants inherit, so rwg
//! tells which of its children belong to which worker. When a worker ends,
//! its process group is killed and so are rwg's children that bear its mark
//! (`sweep`). When rwg ends — on a catchable signal that would kill it
//! (SIGTERM, SIGHUP, SIGQUIT, SIGINT where nothing else handles it,
//! SIGUSR1/2, SIGALRM, ...), through `exit`, or through [`end_all`] before
//! `_exit` or a crash's default action — every worker's group goes, and
//! every child rwg has then, marked or not (a plugin's forks bear no mark),
//! and the processes orphaned by their deaths in turn.
//!
//! Why not a cgroup: creating one needs a delegated, writable cgroup
//! (systemd's user slices, root), which Slurm jobs and containers rarely
//! give; a subreaper needs no privilege. What neither reaches: anything
//! once rwg is SIGKILLed (its workers still die: `PR_SET_PDEATHSIG`; what an
//! in-process plugin forked does not, as rwg cannot set a death signal on a
//! process it did not start), and a process that leaves its worker's group
//! *and* clears its environment while its worker still runs (it is found
//! when rwg ends).

#[cfg(target_os = "linux")]
mod reap;
#[cfg(target_os = "linux")]
mod signals;
mod spawn;

pub(crate) use spawn::spawn_in_family;
pub use spawn::FamilyChild;

use std::sync::Mutex;

/// The environment variable marking a worker and its descendants:
/// `RWGPID:N`, rwg's process id and the worker's number.
pub const MARK_VAR: &str = "RWG_WORKER_FAMILY";

/// The live workers: (process id, which is also its process group's, mark).
static LIVE: Mutex<Vec<(i32, String)>> = Mutex::new(Vec::new());

/// Sets the family up, once per process: rwg becomes a subreaper, its exit
/// ends the family, and a thread waits for the signals that would end rwg
/// (their handlers are installed where a signal's action is the default) to
/// end the family first. Call it early, before any plugin is loaded and
/// before threads are started (they inherit the signal mask of their
/// creator). Safe to call more than once; a no-op off Linux.
pub fn set_up() {
    #[cfg(target_os = "linux")]
    {
        static ONCE: std::sync::Once = std::sync::Once::new();
        ONCE.call_once(signals::set_up);
    }
}

/// Registers `report`, run on the family's thread when a signal that ends
/// rwg arrives (its number as the argument), before the family ends and
/// the signal takes its default action: to say what ended rwg.
pub fn on_ending_signal(report: fn(i32)) {
    #[cfg(target_os = "linux")]
    signals::set_report(report);
    #[cfg(not(target_os = "linux"))]
    let _ = report;
}

/// The signal rwg is ending by, once its family's thread has taken it up:
/// from then on what other threads see (a worker killed by the family's
/// end, a run cut short) is a consequence of that signal, not news, and
/// rwg's exit status is the signal's.
pub fn ending_by() -> Option<i32> {
    #[cfg(target_os = "linux")]
    return signals::ending_by();
    #[cfg(not(target_os = "linux"))]
    None
}

/// A signal whose disposition something other than rwg changed, found and
/// undone by [`restore_dispositions`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Restored {
    /// The signal's number.
    pub signal: i32,
    /// What it had been set to.
    pub found: Disposition,
}

/// How a signal was being handled.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Disposition {
    /// Ignored (`SIG_IGN`).
    Ignored,
    /// Its default action (`SIG_DFL`).
    Default,
    /// A handler other than rwg's.
    Handled,
}

/// Records how SIGINT, SIGTERM and SIGHUP are handled now as rwg's own way
/// (after [`set_up`] and after rwg installs a handler of its own), for
/// [`restore_dispositions`].
pub fn keep_dispositions() {
    #[cfg(target_os = "linux")]
    signals::keep_dispositions();
}

/// Puts back rwg's own handling of SIGINT, SIGTERM and SIGHUP (as last
/// [`keep_dispositions`]) where code running in rwg's process (an
/// in-process plugin) changed it, so that Ctrl-C and `kill` still reach
/// rwg; returns what was found changed.
pub fn restore_dispositions() -> Vec<Restored> {
    #[cfg(target_os = "linux")]
    return signals::restore_dispositions();
    #[cfg(not(target_os = "linux"))]
    Vec::new()
}

/// The mark of the next worker, set in `command`'s environment; sets the
/// family up on first use.
pub(crate) fn enlist(command: &mut std::process::Command) -> String {
    use std::sync::atomic::{AtomicU64, Ordering};
    static NEXT: AtomicU64 = AtomicU64::new(0);
    set_up();
    let mark = format!(
        "{}:{}",
        std::process::id(),
        NEXT.fetch_add(1, Ordering::Relaxed)
    );
    command.env(MARK_VAR, &mark);
    mark
}

/// Whether rwg's child `pid` has ended, without reaping it (Linux), so that
/// its process group can still be killed by its id. Async-signal-safe.
#[cfg(target_os = "linux")]
pub(crate) fn ended_unreaped(pid: u32) -> bool {
    // SAFETY: a zeroed siginfo_t for waitid to fill.
    let mut info: libc::siginfo_t = unsafe { std::mem::zeroed() };
    // SAFETY: waitid on our own child; WNOWAIT leaves it unreaped.
    let r = unsafe {
        libc::waitid(
            libc::P_PID,
            pid as libc::id_t,
            &mut info,
            libc::WEXITED | libc::WNOHANG | libc::WNOWAIT,
        )
    };
    // SAFETY: filled by waitid (zero while the child runs); an error means
    // there is no such child to wait for.
    r != 0 || unsafe { info.si_pid() } != 0
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

/// Kills rwg's children that bear exactly `mark` (the processes a worker
/// started that left its process group, once orphaned), and theirs as they
/// are orphaned in turn, and reaps them.
pub(crate) fn sweep(mark: &str) {
    #[cfg(target_os = "linux")]
    reap::sweep_marked(&format!("{MARK_VAR}={mark}"));
    #[cfg(not(target_os = "linux"))]
    let _ = mark;
}

/// Reaps the orphans rwg adopted as their subreaper once they end (a
/// plugin's daemon that exits), which no one else waits for: call it now
/// and then (rwg run's watchdog does; it looks once a second). A child
/// that is a zombie for a second and is not a listed worker counts as such
/// an orphan (a plugin that waits for its own child later than that gets
/// `ECHILD`).
pub fn reap_orphans() {
    #[cfg(target_os = "linux")]
    {
        let workers: Vec<i32> = live().iter().map(|(p, _)| *p).collect();
        reap::reap_orphans(&workers);
    }
}

/// Kills every worker's process group and every process of the family that
/// rwg can reach — every child rwg has, and those orphaned by their deaths —
/// and reaps them: for rwg's own ends (`exit`, `_exit` after a second
/// Ctrl-C, a fatal signal). Async-signal-safe (no allocation, no blocking
/// lock), so a signal handler may call it; safe to call more than once (a
/// call while another runs returns at once).
pub fn end_all() {
    #[cfg(target_os = "linux")]
    {
        // not `live()`: a thread stopped while holding the lock must not
        // stop rwg from ending
        let mut workers = [0i32; reap::MAX_WORKERS];
        let mut n = 0;
        let mut copy = |l: &Vec<(i32, String)>| {
            for (p, _) in l.iter().take(workers.len()) {
                workers[n] = *p;
                n += 1;
            }
        };
        match LIVE.try_lock() {
            Ok(l) => copy(&l),
            Err(std::sync::TryLockError::Poisoned(p)) => copy(&p.into_inner()),
            Err(std::sync::TryLockError::WouldBlock) => {}
        }
        reap::end_all(&workers[..n]);
    }
}

#[cfg(all(test, target_os = "linux"))]
mod tests;
