//! `rwg __plugin-worker` (hidden): an isolated plugin env's worker process
//! (`rwg_study::isolate`), started by `rwg run` for plugin envs with
//! `isolate`. It speaks the protocol of `docs/bridge-protocol.md` on its
//! stdin and stdout; the plugin's own prints go to stderr.

use anyhow::{Context, Result};
use std::io::BufReader;

/// Runs the worker until the host quits or goes away.
pub fn run() -> Result<()> {
    // main() has already moved rwg's stdout off fd 1 (fd 1 is stderr now,
    // where a plugin's printf lands); the protocol's input moves off fd 0
    // the same way, and fd 0 reads /dev/null, so a plugin that reads stdin
    // cannot eat the host's messages either.
    let input = private_stdin().context("cannot set up the worker's input")?;
    // Ctrl-C on a terminal reaches the whole process group: rwg decides
    // (stop after the blocks in flight), the worker goes on until told to
    // quit or its input ends.
    #[cfg(unix)]
    // SAFETY: setting a signal's disposition to "ignore".
    unsafe {
        libc::signal(libc::SIGINT, libc::SIG_IGN);
    }
    let mut output = crate::stdio::stdout();
    rwg_study::isolate::worker_main(&mut BufReader::new(input), &mut output)
        .context("isolated plugin worker")?;
    Ok(())
}

/// A private duplicate of fd 0, with fd 0 pointed at `/dev/null` (unix;
/// elsewhere stdin itself).
#[cfg(unix)]
fn private_stdin() -> std::io::Result<std::fs::File> {
    use std::os::unix::io::{FromRawFd, IntoRawFd};
    // SAFETY: plain descriptor calls on fds this process owns.
    unsafe {
        let own = libc::fcntl(0, libc::F_DUPFD_CLOEXEC, 3);
        if own < 0 {
            return Err(std::io::Error::last_os_error());
        }
        let null = std::fs::File::open("/dev/null")?.into_raw_fd();
        if libc::dup2(null, 0) < 0 {
            return Err(std::io::Error::last_os_error());
        }
        libc::close(null);
        Ok(std::fs::File::from_raw_fd(own))
    }
}

#[cfg(not(unix))]
fn private_stdin() -> std::io::Result<std::io::Stdin> {
    Ok(std::io::stdin())
}
