//! rwg's own standard output and error, kept apart from what plugins print,
//! and writes to them that never panic.
//!
//! A plugin runs in rwg's process and may write to file descriptor 1
//! (`printf`, `println!`), which would mix into rwg's output (`rwg rollout
//! --format csv`, `rwg check`'s child protocol, ...). [`protect`] therefore
//! moves rwg's standard output to a private duplicate of fd 1 and points
//! fd 1 at stderr: what a plugin prints appears on stderr, never in rwg's
//! output. rwg prints through [`stdout`] and [`outln!`](crate::outln), and
//! to stderr through [`errln!`](crate::errln), which writes to a private
//! duplicate of fd 2 taken at the same time: a plugin that closes fd 2 or
//! points it at `/dev/null` silences itself, never rwg's messages.
//!
//! Output can always fail (`rwg ... | head`, a full disk): a failed write
//! never panics and never ends the command half-way (so its files and its
//! exit status are what they would be); it is recorded, later writes to that
//! stream are skipped, and [`exit_status`] turns it into the exit status: a
//! command that failed keeps its own, one that succeeded exits 141 after a
//! closed pipe (as if killed by SIGPIPE) and 1 after any other write error.

use std::io::{self, Write};
use std::sync::atomic::{AtomicI32, AtomicU8, Ordering};
use std::sync::Mutex;

/// rwg's own stdout once [`protect`]ed (-1: fd 1 itself).
static OWN_FD: AtomicI32 = AtomicI32::new(-1);
/// rwg's own stderr once [`protect`]ed (-1: fd 2 itself).
static OWN_ERR_FD: AtomicI32 = AtomicI32::new(-1);

/// The exit status of a command whose output went to a closed pipe: that
/// of a process killed by SIGPIPE (128 + 13), as the shell reports it.
pub const CLOSED_PIPE_STATUS: i32 = 141;

/// How a stream has fared: [`OK`], [`CLOSED`] (a closed pipe) or [`FAILED`]
/// (any other write error).
const OK: u8 = 0;
const CLOSED: u8 = 1;
const FAILED: u8 = 2;

/// The state of rwg's stdout and of its stderr.
static STDOUT_STATE: AtomicU8 = AtomicU8::new(OK);
static STDERR_STATE: AtomicU8 = AtomicU8::new(OK);
/// The first write error on stdout that was not a closed pipe.
static STDOUT_ERROR: Mutex<Option<String>> = Mutex::new(None);

/// Moves rwg's output off fd 1 and keeps its own copy of stderr (unix;
/// elsewhere a no-op). Call once, early, before any plugin is loaded.
pub fn protect() {
    #[cfg(unix)]
    {
        let _ = io::stdout().flush();
        // SAFETY: plain descriptor calls; fd 1 and 2 are open (or the calls fail).
        unsafe {
            let err = libc::fcntl(2, libc::F_DUPFD_CLOEXEC, 3);
            if err >= 0 {
                OWN_ERR_FD.store(err, Ordering::SeqCst);
            }
            let own = libc::fcntl(1, libc::F_DUPFD_CLOEXEC, 3);
            if own >= 0 && libc::dup2(2, 1) >= 0 {
                OWN_FD.store(own, Ordering::SeqCst);
            } else if own >= 0 {
                libc::close(own);
            }
        }
    }
}

/// Records a failed write on the stream whose state is `state`.
fn record(state: &AtomicU8, e: &io::Error, first_error: Option<&Mutex<Option<String>>>) {
    let what = if e.kind() == io::ErrorKind::BrokenPipe {
        CLOSED
    } else {
        FAILED
    };
    if state
        .compare_exchange(OK, what, Ordering::SeqCst, Ordering::SeqCst)
        .is_ok()
        && what == FAILED
    {
        if let Some(slot) = first_error {
            *slot.lock().unwrap_or_else(|p| p.into_inner()) = Some(e.to_string());
        }
    }
}

/// rwg's standard output (unbuffered: wrap it in a `BufWriter` for many
/// small writes). A failed write returns its error and is recorded for
/// [`exit_status`].
pub fn stdout() -> Stdout {
    Stdout
}

/// See [`stdout`].
#[derive(Debug, Clone, Copy)]
pub struct Stdout;

impl Stdout {
    /// The same handle (writes are whole `write(2)` calls; callers that
    /// need atomic lines write them in one piece or through a `BufWriter`).
    pub fn lock(&self) -> Stdout {
        *self
    }
}

/// The descriptor of rwg's own stderr: its private copy once [`protect`]ed,
/// else 2. Async-signal-safe (one atomic load), for the fatal-signal handler.
pub fn stderr_fd() -> i32 {
    match OWN_ERR_FD.load(Ordering::Relaxed) {
        fd if fd >= 0 => fd,
        _ => 2,
    }
}

/// Whether rwg's own stderr is a terminal (whatever a plugin did to fd 2).
pub fn stderr_is_terminal() -> bool {
    #[cfg(unix)]
    // SAFETY: isatty on a descriptor number.
    return unsafe { libc::isatty(stderr_fd()) == 1 };
    #[cfg(not(unix))]
    std::io::IsTerminal::is_terminal(&io::stderr())
}

/// One `write(2)` to rwg's own stdout.
fn write_own(buf: &[u8]) -> io::Result<usize> {
    let fd = OWN_FD.load(Ordering::Relaxed);
    if fd < 0 {
        return io::stdout().write(buf);
    }
    write_fd(fd, buf)
}

/// All of `buf` to rwg's own stderr.
fn write_all_err(mut buf: &[u8]) -> io::Result<()> {
    if OWN_ERR_FD.load(Ordering::Relaxed) < 0 {
        return io::stderr().lock().write_all(buf);
    }
    while !buf.is_empty() {
        match write_fd(stderr_fd(), buf)? {
            0 => return Err(io::ErrorKind::WriteZero.into()),
            n => buf = &buf[n..],
        }
    }
    Ok(())
}

/// One `write(2)` to `fd`, retried when interrupted.
#[cfg_attr(not(unix), allow(unused_variables))]
fn write_fd(fd: i32, buf: &[u8]) -> io::Result<usize> {
    #[cfg(unix)]
    loop {
        // SAFETY: a live buffer and our own descriptor.
        let n = unsafe { libc::write(fd, buf.as_ptr().cast(), buf.len()) };
        if n >= 0 {
            return Ok(n as usize);
        }
        let e = io::Error::last_os_error();
        if e.kind() != io::ErrorKind::Interrupted {
            return Err(e);
        }
    }
    #[cfg(not(unix))]
    io::stdout().write(buf)
}

impl Write for Stdout {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        write_own(buf).inspect_err(|e| record(&STDOUT_STATE, e, Some(&STDOUT_ERROR)))
    }

    fn flush(&mut self) -> io::Result<()> {
        io::stdout()
            .flush()
            .inspect_err(|e| record(&STDOUT_STATE, e, Some(&STDOUT_ERROR)))
    }
}

/// Writes `text` to rwg's stdout, unless an earlier write to it failed; a
/// failure is recorded for [`exit_status`], never a panic.
pub fn write_text(text: &str) {
    if STDOUT_STATE.load(Ordering::SeqCst) == OK {
        let _ = stdout().write_all(text.as_bytes());
    }
}

/// Writes one whole line to rwg's stdout, as [`write_text`].
pub fn write_line(line: &str) {
    let mut text = String::with_capacity(line.len() + 1);
    text.push_str(line);
    text.push('\n');
    write_text(&text);
}

/// Writes `text` to stderr, unless an earlier write to it failed; a failure
/// is recorded for [`exit_status`], never a panic (a closed stderr leaves
/// nowhere to report it). Control characters other than newline and tab are
/// written escaped: what rwg prints on stderr quotes text from plugins,
/// workers and file names, whose terminal escape sequences must not reach
/// the terminal.
pub fn write_err(text: &str) {
    if crate::ending::quiet_while_ending() {
        return;
    }
    if STDERR_STATE.load(Ordering::SeqCst) == OK {
        let text = rwg_env::text::escape_controls(text);
        if let Err(e) = write_all_err(text.as_bytes()) {
            record(&STDERR_STATE, &e, None);
        }
    }
}

/// Whether a write to rwg's stdout found it a closed pipe.
pub fn stdout_closed() -> bool {
    STDOUT_STATE.load(Ordering::SeqCst) == CLOSED
}

/// The first error a write to rwg's stdout met, other than a closed pipe.
pub fn stdout_error() -> Option<String> {
    STDOUT_ERROR
        .lock()
        .unwrap_or_else(|p| p.into_inner())
        .clone()
}

/// Whether `e` is, or is caused by, a write to a closed pipe.
pub fn is_closed_pipe(e: &anyhow::Error) -> bool {
    e.chain().any(|c| {
        c.downcast_ref::<io::Error>()
            .is_some_and(|io| io.kind() == io::ErrorKind::BrokenPipe)
    })
}

/// The exit status of a command that otherwise ends with `status` (0:
/// success), given how its output fared: a failed command keeps its status;
/// a successful one whose stdout or stderr was a closed pipe gets
/// [`CLOSED_PIPE_STATUS`], and one whose stdout failed otherwise (a full
/// disk) gets 1, with the error reported on stderr.
pub fn exit_status(status: i32) -> i32 {
    if status != 0 {
        return status;
    }
    match STDOUT_STATE.load(Ordering::SeqCst) {
        FAILED => {
            let e = stdout_error().unwrap_or_default();
            write_err(&format!("error: cannot write to standard output: {e}\n"));
            1
        }
        CLOSED => CLOSED_PIPE_STATUS,
        _ if STDERR_STATE.load(Ordering::SeqCst) == CLOSED => CLOSED_PIPE_STATUS,
        _ => 0,
    }
}

/// `print!` to rwg's own stdout (see [`protect`]).
#[macro_export]
macro_rules! out {
    ($($arg:tt)*) => { $crate::stdio::write_text(&format!($($arg)*)) };
}

/// `println!` to rwg's own stdout (see [`protect`]).
#[macro_export]
macro_rules! outln {
    () => { $crate::stdio::write_line("") };
    ($($arg:tt)*) => { $crate::stdio::write_line(&format!($($arg)*)) };
}

/// `eprintln!` that never panics (see [`write_err`]).
#[macro_export]
macro_rules! errln {
    () => { $crate::stdio::write_err("\n") };
    ($($arg:tt)*) => { $crate::stdio::write_err(&format!("{}\n", format_args!($($arg)*))) };
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_failed_command_keeps_its_status() {
        // whatever the streams' state, a failure's own status stands
        assert_eq!(exit_status(1), 1);
        assert_eq!(exit_status(130), 130);
    }

    #[test]
    fn write_errors_are_recorded_by_kind() {
        let state = AtomicU8::new(OK);
        let slot = Mutex::new(None);
        record(
            &state,
            &io::Error::from(io::ErrorKind::BrokenPipe),
            Some(&slot),
        );
        assert_eq!(state.load(Ordering::SeqCst), CLOSED);
        assert!(slot.lock().unwrap().is_none());
        let state = AtomicU8::new(OK);
        record(&state, &io::Error::from_raw_os_error(28), Some(&slot));
        assert_eq!(state.load(Ordering::SeqCst), FAILED);
        assert!(slot
            .lock()
            .unwrap()
            .as_deref()
            .unwrap()
            .contains("os error 28"));
        // the first failure is the one reported
        record(
            &state,
            &io::Error::from(io::ErrorKind::BrokenPipe),
            Some(&slot),
        );
        assert_eq!(state.load(Ordering::SeqCst), FAILED);
    }
}
