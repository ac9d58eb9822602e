//! The family's set-up (subreaper, exit handler) and the signals that end
//! rwg: their handlers only write the signal's number to a pipe; a thread
//! reads it, reports it, ends the family and lets the signal take its
//! default action. Also rwg's own handling of SIGINT, SIGTERM and SIGHUP,
//! kept and put back where an in-process plugin changed it.

use super::{Disposition, Restored};
use std::sync::atomic::{AtomicI32, AtomicUsize, Ordering};
use std::sync::Mutex;

/// The signals whose default action ends rwg and that can be caught
/// (SIGINT too, where nothing else handles it). Not SIGXFSZ: rwg's `main`
/// ignores it, so that a write past `ulimit -f` fails with an error that
/// names the file instead of killing rwg.
const ENDING: [libc::c_int; 10] = [
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
];

/// The signals whose handling rwg keeps: those that stop it.
const KEPT: [libc::c_int; 3] = [libc::SIGINT, libc::SIGTERM, libc::SIGHUP];

/// The write end of the pipe the signal handler writes to.
static PIPE_W: AtomicI32 = AtomicI32::new(-1);
/// The signal rwg is ending by (0: none yet).
static ENDING_BY: AtomicI32 = AtomicI32::new(0);
/// The report run before the family ends (a `fn(i32)`; 0: none).
static REPORT: AtomicUsize = AtomicUsize::new(0);
/// rwg's own handling of [`KEPT`]'s signals, as last kept.
static KEPT_ACTIONS: Mutex<[Option<libc::sigaction>; 3]> = Mutex::new([None; 3]);

pub(super) fn set_report(report: fn(i32)) {
    REPORT.store(report as usize, Ordering::SeqCst);
}

/// rwg becomes a subreaper, its exit ends the family, and a thread waits for
/// ending signals, whose handlers (installed where the signal's action is
/// the default) only write the signal's number to a pipe.
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
    PIPE_W.store(fds[1], Ordering::SeqCst);
    let read_fd = fds[0];
    let started = std::thread::Builder::new()
        .name("rwg-worker-family".into())
        .spawn(move || loop {
            let mut sig = 0u8;
            // SAFETY: reading one byte into a local.
            let n = unsafe { libc::read(read_fd, (&mut sig as *mut u8).cast(), 1) };
            if n == 1 {
                end_by(sig as libc::c_int);
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
    keep_dispositions();
}

/// rwg ends by `sig`: the report, the family's end, then the signal's
/// default action (rwg's exit status names it), or `_exit(128 + sig)` where
/// something keeps the signal from ending rwg.
fn end_by(sig: libc::c_int) -> ! {
    ENDING_BY.store(sig, Ordering::SeqCst);
    let report = REPORT.load(Ordering::SeqCst);
    if report != 0 {
        // SAFETY: stored from a `fn(i32)` by `set_report`.
        let report: fn(i32) = unsafe { std::mem::transmute::<usize, fn(i32)>(report) };
        report(sig);
    }
    super::end_all();
    // SAFETY: the default action back, the signal unblocked in this thread,
    // then the signal again; plain libc calls.
    unsafe {
        libc::signal(sig, libc::SIG_DFL);
        let mut set: libc::sigset_t = std::mem::zeroed();
        libc::sigemptyset(&mut set);
        libc::sigaddset(&mut set, sig);
        libc::pthread_sigmask(libc::SIG_UNBLOCK, &set, std::ptr::null_mut());
        libc::raise(sig);
        libc::_exit(128 + sig)
    }
}

pub(super) fn ending_by() -> Option<i32> {
    match ENDING_BY.load(Ordering::SeqCst) {
        0 => None,
        sig => Some(sig),
    }
}

extern "C" fn on_signal(sig: libc::c_int) {
    let fd = PIPE_W.load(Ordering::SeqCst);
    let b = sig as u8;
    // SAFETY: write(2) is async-signal-safe.
    unsafe {
        libc::write(fd, (&b as *const u8).cast(), 1);
    }
}

/// The current action of `sig`.
fn action_of(sig: libc::c_int) -> Option<libc::sigaction> {
    // SAFETY: reading a disposition into a zeroed struct.
    unsafe {
        let mut old: libc::sigaction = std::mem::zeroed();
        (libc::sigaction(sig, std::ptr::null(), &mut old) == 0).then_some(old)
    }
}

pub(super) fn keep_dispositions() {
    let mut kept = KEPT_ACTIONS.lock().unwrap_or_else(|p| p.into_inner());
    for (slot, sig) in kept.iter_mut().zip(KEPT) {
        *slot = action_of(sig);
    }
}

pub(super) fn restore_dispositions() -> Vec<Restored> {
    let kept = *KEPT_ACTIONS.lock().unwrap_or_else(|p| p.into_inner());
    let mut out = Vec::new();
    for (want, sig) in kept.iter().zip(KEPT) {
        let (Some(want), Some(now)) = (want, action_of(sig)) else {
            continue;
        };
        if now.sa_sigaction == want.sa_sigaction {
            continue;
        }
        // SAFETY: setting back an action read from the kernel.
        unsafe {
            libc::sigaction(sig, want, std::ptr::null_mut());
        }
        out.push(Restored {
            signal: sig,
            found: match now.sa_sigaction {
                libc::SIG_IGN => Disposition::Ignored,
                libc::SIG_DFL => Disposition::Default,
                _ => Disposition::Handled,
            },
        });
    }
    out
}
