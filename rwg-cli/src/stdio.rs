//! rwg's own standard output, kept apart from what plugins print.
//!
//! A plugin runs in rwg's process and may write to file descriptor 1
//! (`printf`, `println!`), which would mix into rwg's output (`rwg rollout
//! --format csv`, `rwg check`'s child protocol, ...). [`protect`] therefore
//! moves rwg's standard output to a private duplicate of fd 1 and points
//! fd 1 at stderr: what a plugin prints appears on stderr, never in rwg's
//! output. rwg prints through [`stdout`] and [`outln!`](crate::outln).

use std::io::{self, Write};
use std::sync::atomic::{AtomicI32, Ordering};

/// rwg's own stdout once [`protect`]ed (-1: fd 1 itself).
static OWN_FD: AtomicI32 = AtomicI32::new(-1);

/// Moves rwg's output off fd 1 (unix; elsewhere a no-op). Call once, early,
/// before any plugin is loaded.
pub fn protect() {
    #[cfg(unix)]
    {
        let _ = io::stdout().flush();
        // SAFETY: plain descriptor calls; fd 1 and 2 are open (or the calls fail).
        unsafe {
            let own = libc::fcntl(1, libc::F_DUPFD_CLOEXEC, 3);
            if own >= 0 && libc::dup2(2, 1) >= 0 {
                OWN_FD.store(own, Ordering::SeqCst);
            } else if own >= 0 {
                libc::close(own);
            }
        }
    }
}

/// rwg's standard output (unbuffered: wrap it in a `BufWriter` for many
/// small writes).
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

impl Write for Stdout {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        let fd = OWN_FD.load(Ordering::Relaxed);
        if fd < 0 {
            return io::stdout().write(buf);
        }
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

    fn flush(&mut self) -> io::Result<()> {
        io::stdout().flush()
    }
}

/// Writes `text` to rwg's stdout; a closed pipe (`rwg ... | head`) ends rwg
/// quietly, as the main error handler does.
pub fn write_text(text: &str) {
    if let Err(e) = stdout().write_all(text.as_bytes()) {
        if e.kind() == io::ErrorKind::BrokenPipe {
            std::process::exit(0);
        }
        panic!("cannot write to stdout: {e}");
    }
}

/// Writes one whole line to rwg's stdout; a closed pipe (`rwg ... | head`)
/// ends rwg quietly, as the main error handler does.
pub fn write_line(line: &str) {
    let mut text = String::with_capacity(line.len() + 1);
    text.push_str(line);
    text.push('\n');
    if let Err(e) = stdout().write_all(text.as_bytes()) {
        if e.kind() == io::ErrorKind::BrokenPipe {
            std::process::exit(0);
        }
        panic!("cannot write to stdout: {e}");
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
