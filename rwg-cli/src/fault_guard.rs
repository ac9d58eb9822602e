//! Plugin faults during `rwg run`, in-process (the default): a plugin's code
//! runs in rwg's own process, so a plugin that calls `exit()`, crashes, aborts
//! or hangs would end or stall rwg without a word. This module makes each of
//! those end the run non-zero with a message naming the plugin, env, cell,
//! network, episode and step, and the command that resumes the run (every
//! committed block is on disk already: blocks are committed atomically).
//!
//! - The study runner records every call into a plugin env, with its
//!   network, episode and step, per thread (`rwg_study::fault_context`).
//! - `exit()` from a plugin: an `atexit` handler turns the exit of an
//!   unfinished run into exit status 1 with the message.
//! - SIGSEGV, SIGBUS, SIGILL, SIGFPE, SIGABRT: a signal handler writes the
//!   message with `write(2)` only (async-signal-safe), ends rwg's family of
//!   processes (`rwg_worker::family::end_all`), then the signal takes its
//!   default course (the exit status still says which signal). After the
//!   command finished ([`finished`]), such a crash (a plugin's exit handler
//!   or destructor) is reported as one that spared the results.
//! - A call that does not return within `--step-timeout` seconds: a watchdog
//!   thread reports it and exits with status 1 (a call in progress cannot be
//!   stopped in-process).
//! - Ctrl-C: the first one stops after the blocks in flight, but exits at
//!   once (status 130) if a plugin call is stuck, and after
//!   [`INTERRUPT_GRACE`] in any case; a second one exits at once. The
//!   watchdog puts rwg's handling of SIGINT, SIGTERM and SIGHUP back where a
//!   plugin changed it (`crate::ending`).
//!
//! What in-process cannot do: report a plugin's own threads (no network or
//! episode is known there), survive `_exit()`/`quick_exit()` or a SIGKILL
//! (nothing runs), or catch a crash that corrupts rwg's memory before it
//! shows. Isolation (`isolate = true`, `rwg run --isolate`: the plugin in worker
//! processes, `rwg_study::isolate`) does; see docs/plugins.md.

use rwg_study::fault_context::{all_threads, cell_label, this_thread, CallSnapshot, Phase};
use std::sync::atomic::{AtomicBool, AtomicPtr, AtomicU64, Ordering::*};
use std::sync::Mutex;
use std::time::{Duration, Instant};

/// Text the handlers print, set from the main thread, read anywhere
/// (leaked when replaced: a few per run).
struct Text(Box<[u8]>);

/// What to do after a plugin's fault (fix the plugin, then resume).
static RESUME: AtomicPtr<Text> = AtomicPtr::new(std::ptr::null_mut());
/// What to do after an interrupted run (resume), whatever its envs are.
static RESUME_STOPPED: AtomicPtr<Text> = AtomicPtr::new(std::ptr::null_mut());
/// What is complete once the command finished (see [`finished`]); null
/// before.
static FINISHED: AtomicPtr<Text> = AtomicPtr::new(std::ptr::null_mut());
/// A run is in progress: an exit now is not rwg's own.
static ARMED: AtomicBool = AtomicBool::new(false);
/// The process that installed the handlers (a plugin's `fork()` without
/// `exec` copies them into a helper: there they hand the signal on).
static OWNER_PID: std::sync::atomic::AtomicI32 = std::sync::atomic::AtomicI32::new(0);
static INTERRUPTED: AtomicBool = AtomicBool::new(false);
/// Seconds a plugin call may take (0: no limit).
static STEP_TIMEOUT_S: AtomicU64 = AtomicU64::new(0);
/// How long a run ended by a plugin (`exit()`, a hung call) waits for the
/// blocks already computed to reach the disk before it exits.
const COMMIT_WAIT: Duration = Duration::from_secs(30);

/// How long the first Ctrl-C waits for the blocks in flight.
pub const INTERRUPT_GRACE: Duration = Duration::from_secs(10);
/// The default of `rwg run --step-timeout`.
pub const DEFAULT_STEP_TIMEOUT_S: u64 = 60;

fn set_text(slot: &AtomicPtr<Text>, s: String) {
    let t = Box::into_raw(Box::new(Text(s.into_bytes().into_boxed_slice())));
    slot.store(t, SeqCst);
}

fn text(slot: &AtomicPtr<Text>) -> &'static [u8] {
    let p = slot.load(SeqCst);
    if p.is_null() {
        b""
    } else {
        // SAFETY: set by `set_text` from a leaked box, never freed.
        unsafe { &(*p).0 }
    }
}

/// Set by the first Ctrl-C once armed (the runner stops after the blocks
/// in flight).
pub fn interrupt_flag() -> &'static AtomicBool {
    &INTERRUPTED
}

/// While alive, a run is in progress: a plugin's faults are reported with
/// `resume` (what to do next, e.g. fix the plugin and resume), an
/// interruption that does not stop in time with `resume_stopped`.
pub struct Armed(());

impl Drop for Armed {
    fn drop(&mut self) {
        ARMED.store(false, SeqCst);
    }
}

/// Arms the handlers for a run (installed once per process) and starts the
/// watchdog. `step_timeout_s` 0: no limit on a plugin call.
pub fn arm(resume: String, resume_stopped: String, step_timeout_s: u64) -> Armed {
    set_resume(resume, resume_stopped);
    STEP_TIMEOUT_S.store(step_timeout_s, SeqCst);
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        let _ = ctrlc::set_handler(|| {
            if INTERRUPTED.swap(true, SeqCst) {
                disarm_and_exit(130);
            }
            crate::errln!(
                "\ninterrupted: finishing the blocks in flight (Ctrl-C again to quit at once)"
            );
            *INTERRUPT_AT.lock().unwrap_or_else(|e| e.into_inner()) = Some(Instant::now());
        });
        // Ctrl-C's handler is rwg's own from now on: put back where a plugin
        // changes it (the watchdog checks).
        rwg_worker::family::keep_dispositions();
        std::thread::Builder::new()
            .name("rwg-watchdog".into())
            .spawn(watchdog)
            .expect("cannot start the watchdog thread");
    });
    ARMED.store(true, SeqCst);
    Armed(())
}

/// Installs the handlers of fatal signals and of `exit()` (once, early in
/// `main`, before any plugin is loaded): a crash during a run is reported
/// as [`arm`] says, one after the command finished (a plugin's exit handler
/// or destructor) as such, and every process of rwg's family ends first.
pub fn install() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(install_handlers);
}

/// Whether a run is in progress (armed).
pub fn armed() -> bool {
    ARMED.load(SeqCst)
}

/// What to do after a run that stops early, whatever its envs are
/// (`Every committed block is kept in DIR; resume with: ...`).
pub fn resume_stopped_text() -> String {
    String::from_utf8_lossy(text(&RESUME_STOPPED)).into_owned()
}

/// The command has finished (its output is complete): a crash from now on
/// happens while rwg exits (a plugin's exit handler or destructor), and is
/// reported with `what` (what is complete and how to check it; "" for the
/// command's output).
pub fn finished(what: String) {
    set_text(&FINISHED, what);
}

/// [`finished`] with `what`, unless the command said what is complete itself.
pub fn finished_unless_said(what: String) {
    if FINISHED.load(SeqCst).is_null() {
        finished(what);
    }
}

/// Reports a resource error that leaves rwg unable to go on (a thread that
/// cannot start), with how to resume during a run, and exits with status 1
/// once the blocks already computed are committed.
pub fn exit_on_resource_error(error: &str) -> ! {
    let mut text = format!("error: {error}");
    if ARMED.load(SeqCst) {
        rwg_study::committer::wait_for_commits(Duration::from_secs(2));
        text.push_str(". ");
        text.push_str(&resume_stopped_text());
    }
    text.push('\n');
    crate::stdio::write_err(&text);
    disarm_and_exit(1)
}

/// Replaces what the handlers print after a fault (`resume`) and after an
/// interruption that does not stop in time (`resume_stopped`): a run's
/// resume command changes once its directory holds the study.
pub fn set_resume(resume: String, resume_stopped: String) {
    set_text(&RESUME, resume);
    set_text(&RESUME_STOPPED, resume_stopped);
}

static INTERRUPT_AT: Mutex<Option<Instant>> = Mutex::new(None);

/// Ends the run's armed state early, before rwg exits on its own accord
/// (the exit after `main` returns runs the `atexit` handler).
pub fn disarm() {
    ARMED.store(false, SeqCst);
}

/// Exits at once with `code`, without running exit handlers (a thread may
/// be stuck inside a plugin holding locks they need).
pub fn disarm_and_exit(code: i32) -> ! {
    ARMED.store(false, SeqCst);
    rwg_worker::family::end_all(); // _exit runs no atexit handler
    #[cfg(unix)]
    // SAFETY: _exit is always safe to call.
    unsafe {
        libc::_exit(code)
    };
    // (Called from the Ctrl-C handler and the watchdog, not on main's path:
    // the main thread may be stuck in a plugin call, so the status cannot be
    // returned up to `main`.)
    #[cfg(not(unix))]
    std::process::exit(code)
}

/// `in step: ..., network 3, episode 0, step 7` for a call.
fn where_text(c: CallSnapshot, out: &mut Msg) {
    let CallSnapshot {
        phase,
        sample,
        episode,
        step,
        ..
    } = c;
    out.push(match phase {
        Phase::Create => b"while creating an instance (no network or episode yet): ",
        Phase::Reset => b"in reset: ",
        Phase::Step => b"in step: ",
        Phase::ResetMany => b"in reset_many (a batched reset): ",
        Phase::StepMany => b"in step_many (a batched step): ",
        Phase::VecReset => b"in vec_reset (a vector env's reset): ",
        Phase::VecStep => b"in vec_step (a vector env's step): ",
        Phase::Idle => b"outside any call rwg made into a plugin (a plugin's own thread?): ",
    });
    out.push(cell_label());
    if matches!(
        phase,
        Phase::ResetMany | Phase::StepMany | Phase::VecReset | Phase::VecStep
    ) {
        out.push(b", one of ");
        out.num(episode);
        out.push(b" lanes (call ");
        out.num(step);
        out.push(b" of the thread; rerun with RWG_PLUGIN_BATCH=0 to name the network and step)");
    }
    if matches!(phase, Phase::Reset | Phase::Step) {
        out.push(b", network ");
        out.num(sample);
        out.push(b", episode ");
        out.num(episode);
        if phase == Phase::Step {
            out.push(b", step ");
            out.num(step);
        } else {
            out.push(b", at reset (step 0)");
        }
    }
}

/// A message built without allocating and with almost no stack (the signal
/// handlers may run on a small alternate stack), in a static buffer.
struct Msg {
    buf: &'static mut [u8; MSG_BYTES],
    len: usize,
}

const MSG_BYTES: usize = 4096;
static mut MSG_BUF: [u8; MSG_BYTES] = [0; MSG_BYTES];
/// The thread reporting a fault (see [`thread_token`]); 0: none.
static MSG_OWNER: AtomicU64 = AtomicU64::new(0);

thread_local! {
    static TOKEN: u8 = const { 0 };
}

/// A number unique to the calling thread: the address of a thread-local
/// (async-signal-safe: no allocation, no lock).
fn thread_token() -> u64 {
    TOKEN
        .try_with(|t| t as *const u8 as u64)
        .unwrap_or(u64::MAX)
}

impl Msg {
    /// The buffer. If another thread is reporting a fault already, this
    /// thread waits for good: that report ends the process, and it is the
    /// one to read (two lanes often crash at once). `None` if this thread
    /// holds it already (a fault inside a report).
    fn new() -> Option<Msg> {
        let me = thread_token();
        match MSG_OWNER.compare_exchange(0, me, SeqCst, SeqCst) {
            Ok(_) => {}
            Err(owner) if owner == me => return None,
            Err(_) => loop {
                #[cfg(unix)]
                // SAFETY: nanosleep is async-signal-safe; a valid timespec.
                unsafe {
                    let t = libc::timespec {
                        tv_sec: 1,
                        tv_nsec: 0,
                    };
                    libc::nanosleep(&t, std::ptr::null_mut());
                }
                #[cfg(not(unix))]
                std::thread::sleep(Duration::from_secs(1));
            },
        }
        // SAFETY: MSG_OWNER gives one thread the buffer, for good.
        Some(Msg {
            buf: unsafe { &mut *std::ptr::addr_of_mut!(MSG_BUF) },
            len: 0,
        })
    }
    fn push(&mut self, b: &[u8]) {
        let n = b.len().min(self.buf.len() - self.len);
        self.buf[self.len..self.len + n].copy_from_slice(&b[..n]);
        self.len += n;
    }
    fn num(&mut self, mut v: u64) {
        let mut d = [0u8; 20];
        let mut i = d.len();
        loop {
            i -= 1;
            d[i] = b'0' + (v % 10) as u8;
            v /= 10;
            if v == 0 {
                break;
            }
        }
        self.push(&d[i..]);
    }
    fn resume(&mut self) {
        self.resume_with(&RESUME);
    }
    fn resume_with(&mut self, what: &AtomicPtr<Text>) {
        self.push(b". ");
        self.push(text(what));
        self.push(b"\n");
    }
    /// Writes the message to stderr with `write(2)` only.
    fn emit(&self) {
        #[cfg(unix)]
        {
            let mut off = 0;
            while off < self.len {
                // SAFETY: a live buffer; write is async-signal-safe.
                let n = unsafe {
                    let fd = crate::stdio::stderr_fd();
                    libc::write(fd, self.buf[off..].as_ptr().cast(), self.len - off)
                };
                if n <= 0 {
                    break;
                }
                off += n as usize;
            }
        }
        #[cfg(not(unix))]
        crate::stdio::write_err(&String::from_utf8_lossy(&self.buf[..self.len]));
    }
}

/// This thread's plugin call as the handlers see it.
fn this_call() -> CallSnapshot {
    this_thread().unwrap_or(CallSnapshot {
        phase: Phase::Idle,
        sample: 0,
        episode: 0,
        step: 0,
    })
}

#[cfg(unix)]
extern "C" fn on_exit() {
    // SAFETY: getpid has no preconditions.
    if !ARMED.load(SeqCst) || unsafe { libc::getpid() } != OWNER_PID.load(SeqCst) {
        return;
    }
    let call = this_call();
    // Blocks computed before the exit are kept: the I/O threads still run.
    rwg_study::committer::wait_for_commits(COMMIT_WAIT);
    if let Some(mut m) = Msg::new() {
        m.push(b"\nerror: exit() was called ");
        where_text(call, &mut m);
        m.push(b"; the run is not finished, so rwg exits with status 1 whatever status was given");
        m.resume();
        m.emit();
    }
    rwg_worker::family::end_all(); // _exit runs no other exit handler
                                   // SAFETY: _exit is always safe to call.
    unsafe { libc::_exit(1) }
}

/// The handlers that were installed before ours, by signal number.
#[cfg(unix)]
static mut PREVIOUS: [Option<libc::sigaction>; 32] = [None; 32];

#[cfg(unix)]
const FATAL: [(libc::c_int, &[u8]); 5] = [
    (libc::SIGSEGV, b"SIGSEGV (invalid memory access)"),
    (libc::SIGBUS, b"SIGBUS (bus error)"),
    (libc::SIGILL, b"SIGILL (illegal instruction)"),
    (libc::SIGFPE, b"SIGFPE (arithmetic fault)"),
    (libc::SIGABRT, b"SIGABRT (abort)"),
];

#[cfg(unix)]
extern "C" fn on_fatal(sig: libc::c_int, _info: *mut libc::siginfo_t, _uctx: *mut libc::c_void) {
    // SAFETY: getpid is async-signal-safe.
    let own = unsafe { libc::getpid() } == OWNER_PID.load(SeqCst);
    let name = FATAL
        .iter()
        .find(|(n, _)| *n == sig)
        .map_or(&b"a fatal signal"[..], |(_, d)| d);
    if own && sig == libc::SIGABRT {
        if let Some(bytes) = crate::ending::failed_allocation() {
            out_of_memory(bytes);
        }
    }
    if own && ARMED.load(SeqCst) {
        let call = this_call();
        if let Some(mut m) = Msg::new() {
            m.push(b"\nerror: rwg was killed by ");
            m.push(name);
            m.push(b" ");
            where_text(call, &mut m);
            m.resume();
            m.emit();
        }
    } else if own && !FINISHED.load(SeqCst).is_null() {
        if let Some(mut m) = Msg::new() {
            m.push(b"\nerror: rwg was killed by ");
            m.push(name);
            m.push(
                b" while exiting, after the command had finished: in a plugin's exit handler \
                  or destructor? ",
            );
            m.push(text(&FINISHED));
            m.push(b"\n");
            m.emit();
        }
    }
    if own {
        // What rwg started, and what its plugins forked, ends with it.
        rwg_worker::family::end_all();
    }
    // Hand the signal on: to the handler installed before ours (Rust's
    // stack-overflow report), else to the default action. Returning re-runs
    // the faulting instruction (SIGSEGV, ...) or lets abort() raise again.
    // SAFETY: sigaction is async-signal-safe; PREVIOUS is written once,
    // before any handler of ours is installed.
    unsafe {
        let prev = (*std::ptr::addr_of!(PREVIOUS))
            .get(sig as usize)
            .copied()
            .flatten();
        match prev {
            Some(p) => {
                libc::sigaction(sig, &p, std::ptr::null_mut());
            }
            None => {
                libc::signal(sig, libc::SIG_DFL);
            }
        }
        // Pending until we return (the signal is blocked in its handler);
        // covers a signal sent with kill(), which returning would not repeat.
        libc::raise(sig);
    }
}

/// rwg's own allocation of `bytes` failed and Rust aborts: reported as the
/// resource error it is, with how to resume during a run, and status 1.
#[cfg(unix)]
fn out_of_memory(bytes: usize) -> ! {
    if let Some(mut m) = Msg::new() {
        m.push(b"\nerror: rwg ran out of memory: an allocation of ");
        m.num(bytes as u64);
        m.push(
            b" bytes failed; its process is at a limit on memory (`ulimit -v`, a container's or \
              job's memory limit) or the machine's memory is used up: raise the limit, or run \
              with fewer --threads",
        );
        if ARMED.load(SeqCst) {
            m.resume_with(&RESUME_STOPPED);
        } else {
            m.push(b"\n");
        }
        m.emit();
    }
    disarm_and_exit(1)
}

#[cfg(unix)]
fn install_handlers() {
    // SAFETY: plain libc calls with valid arguments, before any handler of
    // ours can run.
    unsafe {
        OWNER_PID.store(libc::getpid(), SeqCst);
        libc::atexit(on_exit);
        for (sig, _) in FATAL {
            let mut old: libc::sigaction = std::mem::zeroed();
            let mut new: libc::sigaction = std::mem::zeroed();
            new.sa_sigaction = on_fatal as *const () as usize;
            new.sa_flags = libc::SA_SIGINFO | libc::SA_ONSTACK;
            libc::sigemptyset(&mut new.sa_mask);
            if libc::sigaction(sig, &new, &mut old) == 0 && (sig as usize) < 32 {
                (*std::ptr::addr_of_mut!(PREVIOUS))[sig as usize] = Some(old);
            }
        }
    }
}

#[cfg(not(unix))]
fn install_handlers() {}

/// Reports plugin calls that exceed the step timeout, and ends an
/// interrupted run that does not stop.
fn watchdog() {
    const TICK: Duration = Duration::from_millis(100);
    // Per registered context: (the call seen, since when unchanged).
    type Key = (Phase, u64, u64, u64);
    let mut seen: Vec<(Key, Instant)> = Vec::new();
    loop {
        std::thread::sleep(TICK);
        crate::ending::restore_signal_handling();
        rwg_worker::family::reap_orphans();
        rwg_plugin_host::loader::refill_std_fds();
        if !ARMED.load(SeqCst) {
            seen.clear();
            continue;
        }
        let now = Instant::now();
        let ctxs = all_threads();
        seen.resize(ctxs.len(), ((Phase::Idle, 0, 0, 0), now));
        let mut stuck: Option<(CallSnapshot, Duration)> = None;
        for (c, (key, since)) in ctxs.iter().zip(seen.iter_mut()) {
            let c = c.snapshot();
            if c.phase == Phase::Idle || c.key() != *key {
                (*key, *since) = (c.key(), now);
                continue;
            }
            let d = now - *since;
            if stuck.is_none_or(|(_, longest)| d > longest) {
                stuck = Some((c, d));
            }
        }
        let timeout = STEP_TIMEOUT_S.load(SeqCst);
        let interrupt_at = *INTERRUPT_AT.lock().unwrap_or_else(|e| e.into_inner());
        let report = |c: CallSnapshot, why: &str, code: i32| -> ! {
            rwg_study::committer::wait_for_commits(COMMIT_WAIT);
            if let Some(mut m) = Msg::new() {
                m.push(b"\nerror: ");
                m.push(why.as_bytes());
                m.push(b": ");
                where_text(c, &mut m);
                m.push(b". A call in progress cannot be stopped in-process, so rwg exits");
                m.resume();
                m.emit();
            }
            disarm_and_exit(code)
        };
        if let Some((c, d)) = stuck {
            if timeout > 0 && d >= Duration::from_secs(timeout) {
                report(
                    c,
                    &format!(
                        "a plugin call has not returned for {timeout} s (--step-timeout {timeout}; \
                         raise it if the env is just slow)"
                    ),
                    1,
                );
            }
            if interrupt_at.is_some() && d >= Duration::from_secs(1) {
                report(
                    c,
                    &format!(
                        "interrupted while a plugin call has not returned for {} s",
                        d.as_secs()
                    ),
                    130,
                );
            }
        }
        if interrupt_at.is_some_and(|t| now - t >= INTERRUPT_GRACE) {
            if let Some(mut m) = Msg::new() {
                m.push(b"\ninterrupted: the blocks in flight did not finish within ");
                m.num(INTERRUPT_GRACE.as_secs());
                m.push(b" s; quitting without them");
                m.resume_with(&RESUME_STOPPED);
                m.emit();
            }
            disarm_and_exit(130);
        }
    }
}
