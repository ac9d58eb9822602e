//! How rwg ends when something outside its own code ends it — a signal, a
//! resource limit — and how it keeps its signal handling from a plugin:
//!
//! - [`set_up`], first thing in `main`: SIGXFSZ ignored (a write past
//!   `ulimit -f` then fails with an I/O error naming the file, status 1,
//!   instead of killing rwg without a word), rwg's family of processes set up
//!   (`rwg_worker::family`: what rwg and its plugins start ends with rwg),
//!   the fatal-signal and `exit()` handlers of [`crate::fault_guard`], and
//!   [`report_signal`] for the signals that end rwg.
//! - A signal that ends rwg (SIGTERM, SIGHUP, SIGALRM from a plugin's
//!   `alarm()`, ...) is named on stderr, with how to resume during a run
//!   (after the blocks already computed are committed); rwg then ends as the
//!   signal says (status 128 + N).
//! - [`restore_signal_handling`] (the watchdog's tick): rwg's handling of
//!   SIGINT, SIGTERM and SIGHUP put back where a plugin changed it.
//! - [`thread_start_failure`]: a thread that cannot start (std and rayon
//!   panic) is a resource error, not "a bug in rwg".
//! - [`Allocator`], rwg's global allocator (the system's), records an
//!   allocation that fails, so that the abort which follows is reported as
//!   rwg running out of memory ([`failed_allocation`]), not as a crash.

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicU32, AtomicUsize, Ordering::SeqCst};
use std::time::Duration;

/// How long a run ended by a signal waits for the blocks already computed
/// to be committed.
const SIGNAL_COMMIT_WAIT: Duration = Duration::from_secs(2);

/// Sets up how rwg ends (see the module's documentation); before any
/// plugin is loaded and any thread is started.
pub fn set_up() {
    #[cfg(unix)]
    // SAFETY: setting a signal's disposition to "ignore".
    unsafe {
        libc::signal(libc::SIGXFSZ, libc::SIG_IGN);
    }
    rwg_worker::family::set_up();
    rwg_worker::family::on_ending_signal(report_signal);
    crate::fault_guard::install();
}

/// A signal's name and what usually sends it.
fn signal_text(sig: i32) -> String {
    #[cfg(unix)]
    let what = match sig {
        libc::SIGHUP => "SIGHUP (the terminal or session that started rwg closed)",
        libc::SIGQUIT => "SIGQUIT (Ctrl-\\ on a terminal)",
        libc::SIGTERM => {
            "SIGTERM (a request to end: `kill`, `timeout`, a batch scheduler's time limit or \
             preemption)"
        }
        libc::SIGUSR1 | libc::SIGUSR2 => {
            return format!(
                "SIGUSR{} (a user-defined signal, which rwg does not use)",
                if sig == libc::SIGUSR1 { 1 } else { 2 }
            )
        }
        libc::SIGALRM => {
            "SIGALRM (a timer's alarm, which rwg never sets: a plugin calling alarm() or \
             setitimer()?)"
        }
        libc::SIGVTALRM | libc::SIGPROF => {
            "a timer's signal (SIGVTALRM or SIGPROF), which rwg never sets: a plugin or a \
             profiler?"
        }
        libc::SIGXCPU => "SIGXCPU (the limit on CPU time, `ulimit -t`, was reached)",
        _ => return format!("signal {sig}"),
    };
    #[cfg(not(unix))]
    let what = "a signal";
    what.to_string()
}

/// Says which signal ends rwg (run on rwg's family thread, before the
/// family ends): during a run, after the blocks already computed are
/// committed, with how to resume. Nothing for SIGINT outside a run (the
/// shell shows `^C`; a run's Ctrl-C has its own handler).
pub fn report_signal(sig: i32) {
    REPORTING.with(|r| r.set(true));
    #[cfg(unix)]
    if sig == libc::SIGINT && !crate::fault_guard::armed() {
        return;
    }
    let mut text = format!("\nerror: rwg received {}; it ends", signal_text(sig));
    if crate::fault_guard::armed() {
        rwg_study::committer::wait_for_commits(SIGNAL_COMMIT_WAIT);
        text.push_str(". ");
        text.push_str(&crate::fault_guard::resume_stopped_text());
    }
    text.push('\n');
    crate::stdio::write_err(&text);
}

thread_local! {
    /// Set on the thread that reports the signal rwg ends by.
    static REPORTING: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

/// Whether what this thread would print is to be dropped: rwg is ending by
/// a signal, whose report is the one message (what other threads see — a
/// worker killed by the family's end, a run cut short — is its consequence).
pub fn quiet_while_ending() -> bool {
    rwg_worker::family::ending_by().is_some() && !REPORTING.with(|r| r.get())
}

/// Waits for the end by a signal that the family's thread has taken up
/// (the exit status is the signal's), if it has.
pub fn wait_if_ending() {
    if rwg_worker::family::ending_by().is_some() {
        loop {
            std::thread::sleep(Duration::from_secs(1));
        }
    }
}

/// Puts back rwg's own handling of SIGINT, SIGTERM and SIGHUP where code in
/// rwg's process (an in-process plugin) changed it, with a warning the
/// first time for each signal.
pub fn restore_signal_handling() {
    use rwg_worker::family::{restore_dispositions, Disposition};
    /// Bit `sig` set: warned about already.
    static WARNED: AtomicU32 = AtomicU32::new(0);
    for r in restore_dispositions() {
        let bit = 1u32 << (r.signal as u32 % 32);
        if WARNED.fetch_or(bit, SeqCst) & bit != 0 {
            continue;
        }
        let found = match r.found {
            Disposition::Ignored => "to be ignored",
            Disposition::Default => "back to its default action",
            Disposition::Handled => "to a handler of its own",
        };
        #[cfg(unix)]
        let (name, so) = match r.signal {
            libc::SIGINT => ("SIGINT", "Ctrl-C still stops the run"),
            libc::SIGTERM => ("SIGTERM", "`kill` still ends the run"),
            _ => ("SIGHUP", "closing the terminal still ends the run"),
        };
        #[cfg(not(unix))]
        let (name, so) = ("a signal", "rwg can still be stopped");
        crate::errln!(
            "warning: code running in rwg's process (an in-process plugin) set {name} {found}; \
             rwg put back its own handling, so that {so}"
        );
    }
}

/// For a panic's message: the resource error it stands for, if it is a
/// thread that could not start (std's "failed to spawn thread", rayon's
/// pool that could not be built), with what to do.
pub fn thread_start_failure(msg: &str) -> Option<String> {
    let threadish = msg.contains("spawn thread")
        || msg.contains("ThreadPoolBuildError")
        || msg.contains("thread pool")
        || (msg.contains("thread") && msg.contains("Os {"));
    if !threadish {
        return None;
    }
    let os = msg
        .split_once("code: ")
        .and_then(|(_, rest)| rest.split(|c: char| !c.is_ascii_digit()).next())
        .and_then(|n| n.parse::<i32>().ok())
        .map(|code| std::io::Error::from_raw_os_error(code).to_string())
        .unwrap_or_else(|| "the system refused".into());
    Some(format!(
        "cannot start a thread: {os}; {}",
        rwg_env::text::THREAD_LIMIT_ADVICE
    ))
}

/// The size of the last allocation of rwg's that failed (0: none).
static FAILED_ALLOCATION: AtomicUsize = AtomicUsize::new(0);

/// The system allocator, recording an allocation that fails (Rust then
/// aborts: [`failed_allocation`] tells the SIGABRT handler why).
pub struct Allocator;

impl Allocator {
    fn note(p: *mut u8, layout: Layout) -> *mut u8 {
        if p.is_null() {
            // the first failure (printing its report may fail again)
            let _ = FAILED_ALLOCATION.compare_exchange(0, layout.size().max(1), SeqCst, SeqCst);
        }
        p
    }
}

// SAFETY: every call is the system allocator's, unchanged.
unsafe impl GlobalAlloc for Allocator {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        // SAFETY: the caller's contract, passed on.
        Allocator::note(unsafe { System.alloc(layout) }, layout)
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        // SAFETY: the caller's contract, passed on.
        Allocator::note(unsafe { System.alloc_zeroed(layout) }, layout)
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: the caller's contract, passed on.
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        // SAFETY: the caller's contract, passed on.
        let p = unsafe { System.realloc(ptr, layout, new_size) };
        // SAFETY: `new_size` is valid for `layout`'s alignment (the contract).
        Allocator::note(p, unsafe {
            Layout::from_size_align_unchecked(new_size, layout.align())
        })
    }
}

/// The size of an allocation of rwg's own that failed, if one did (read by
/// the SIGABRT handler: async-signal-safe).
pub fn failed_allocation() -> Option<usize> {
    match FAILED_ALLOCATION.load(SeqCst) {
        0 => None,
        n => Some(n),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn failed_thread_starts_are_resource_errors() {
        let std_msg = "failed to spawn thread: Os { code: 11, kind: WouldBlock, message: \
                       \"Resource temporarily unavailable\" }";
        let e = thread_start_failure(std_msg).unwrap();
        assert!(
            e.starts_with("cannot start a thread: Resource temporarily unavailable (os error 11)"),
            "{e}"
        );
        let rayon = "The global thread pool has not been initialized.: ThreadPoolBuildError { \
                     kind: IOError(Os { code: 12, kind: OutOfMemory, message: \"Cannot \
                     allocate memory\" }) }";
        assert!(thread_start_failure(rayon).unwrap().contains("os error 12"));
        assert_eq!(
            thread_start_failure("index out of bounds: the len is 3"),
            None
        );
    }

    #[cfg(unix)]
    #[test]
    fn signals_are_named_with_what_sends_them() {
        assert!(signal_text(libc::SIGALRM).contains("alarm()"));
        assert!(signal_text(libc::SIGTERM).starts_with("SIGTERM"));
        assert!(signal_text(libc::SIGUSR2).starts_with("SIGUSR2"));
    }
}
