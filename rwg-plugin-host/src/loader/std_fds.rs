//! File descriptors 0, 1 and 2 kept open whatever a plugin closes.
//!
//! A plugin that closes them (daemon-style code: `close(1); close(2);`)
//! would let the next file this process opens take descriptor 1 or 2: the
//! plugin's later prints would land in that file (a result file, the run's
//! lock) and its next `close(1)` would close it under rwg. [`refill`] points
//! each closed one at `/dev/null`; the loader calls it after a plugin's
//! `init` and every `create`, and rwg's watchdog calls it every tick.

/// Points each of descriptors 0, 1 and 2 that is closed at `/dev/null`.
/// What rwg prints is unaffected: it writes through private duplicates.
pub fn refill() {
    #[cfg(unix)]
    for fd in 0..3 {
        // SAFETY: descriptor calls on numbers; the one opened is ours.
        unsafe {
            if libc::fcntl(fd, libc::F_GETFD) != -1 {
                continue;
            }
            let null = libc::open(c"/dev/null".as_ptr(), libc::O_RDWR);
            // open takes the lowest free descriptor: `fd` itself, unless a
            // lower one was closed too (then the next pass fills `fd`)
            if null >= 0 && null != fd {
                libc::dup2(null, fd);
                libc::close(null);
            }
        }
    }
}
