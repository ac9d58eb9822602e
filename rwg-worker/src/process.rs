//! The worker process: spawning it, reading its answers with a deadline,
//! and saying why it is gone when it dies.

use crate::ProcError;
use std::collections::VecDeque;
use std::io::{Read, Write};
use std::process::{Child, ChildStdin, ChildStdout, Command, Stdio};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// How much of the worker's stderr is kept for error messages.
const STDERR_KEEP: usize = 16 * 1024;

/// A running worker: its pipes and the tail of its stderr.
pub struct Worker {
    child: Child,
    stdin: ChildStdin,
    stdout: ChildStdout,
    stderr: Arc<Mutex<VecDeque<u8>>>,
    drain: Option<std::thread::JoinHandle<()>>,
    program: String,
    dump_signal: Option<i32>,
    /// The worker's own process group (Linux: it leads one), killed with it
    /// so that processes the env started go too; `None` once killed.
    group: Option<i32>,
    /// Bytes a read took past the end of a message: the start of the next.
    pending: Vec<u8>,
    /// The worker's mark in the family (see [`crate::family`]); `None` once
    /// its strays are swept.
    mark: Option<String>,
}

/// How often a wait for the worker's answer checks that the worker still
/// runs: a worker that exits while a process it started holds its pipe open
/// is reported within this time, not at the deadline.
const EXIT_CHECK: Duration = Duration::from_millis(50);

/// What a wait for the worker's answer found.
enum Waited {
    /// Something to read (or the pipe hung up: the read says which).
    Readable,
    /// The deadline passed.
    TimedOut,
    /// The worker process ended, with nothing left to read.
    Exited,
}

impl Worker {
    /// Starts `command` (its stdin, stdout and stderr are replaced by
    /// pipes); `program` names it in errors. `dump_signal`: a signal the
    /// worker answers by printing where it is to stderr (Python's
    /// faulthandler: SIGUSR1), sent before a hung worker is killed.
    pub fn spawn(
        mut command: Command,
        program: &str,
        dump_signal: Option<i32>,
    ) -> Result<Worker, ProcError> {
        command
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped());
        let mark = crate::family::enlist(&mut command);
        let mut child =
            crate::family::spawn_in_family(command).map_err(|source| ProcError::Spawn {
                program: program.to_string(),
                source,
            })?;
        crate::family::joined(child.id(), &mark);
        let stdin = child.stdin.take().expect("piped");
        let stdout = child.stdout.take().expect("piped");
        let mut err = child.stderr.take().expect("piped");
        let stderr = Arc::new(Mutex::new(VecDeque::new()));
        let keep = stderr.clone();
        let drain = std::thread::spawn(move || {
            let mut buf = [0u8; 4096];
            while let Ok(n) = err.read(&mut buf) {
                if n == 0 {
                    break;
                }
                let mut k = keep.lock().unwrap_or_else(|p| p.into_inner());
                k.extend(&buf[..n]);
                let excess = k.len().saturating_sub(STDERR_KEEP);
                k.drain(..excess);
            }
        });
        #[cfg(target_os = "linux")]
        let group = Some(child.id() as i32);
        #[cfg(not(target_os = "linux"))]
        let group = None;
        Ok(Worker {
            child,
            stdin,
            stdout,
            stderr,
            drain: Some(drain),
            program: program.to_string(),
            dump_signal,
            group,
            pending: Vec::new(),
            mark: Some(mark),
        })
    }

    /// CPU time (user + system) the process has used so far, in seconds
    /// (Linux: from /proc; `None` elsewhere).
    pub fn cpu_seconds(&self) -> Option<f64> {
        let stat = std::fs::read_to_string(format!("/proc/{}/stat", self.child.id())).ok()?;
        // Fields after the command name (which is in parentheses): state is
        // field 3, utime 14, stime 15.
        let rest = &stat[stat.rfind(')')? + 2..];
        let f: Vec<&str> = rest.split_whitespace().collect();
        let ticks: f64 = f.get(11)?.parse::<f64>().ok()? + f.get(12)?.parse::<f64>().ok()?;
        #[cfg(unix)]
        // SAFETY: sysconf has no preconditions.
        let hz = unsafe { libc::sysconf(libc::_SC_CLK_TCK) } as f64;
        #[cfg(not(unix))]
        let hz = 100.0;
        Some(ticks / hz)
    }

    /// The program this worker runs, as given to [`Worker::spawn`].
    pub fn program(&self) -> &str {
        &self.program
    }

    /// The worker's process id.
    pub fn id(&self) -> u32 {
        self.child.id()
    }

    /// Writes a whole message.
    pub fn send(&mut self, bytes: &[u8]) -> Result<(), ProcError> {
        match self.stdin.write_all(bytes).and_then(|_| self.stdin.flush()) {
            Ok(()) => Ok(()),
            Err(_) => Err(self.died()),
        }
    }

    /// Reads one whole message (header included) into `buf`, in as few
    /// reads as the pipe allows (usually one: the worker writes a message at
    /// once and sends nothing unasked). Returns the tag; the payload is
    /// `buf[5..]`. A read may take more than the message (when `buf` is
    /// longer than it and the next message is already in the pipe): the
    /// surplus is kept as the start of the next message.
    pub fn recv_message(&mut self, buf: &mut Vec<u8>, timeout: Duration) -> Result<u8, ProcError> {
        let deadline = Instant::now() + timeout;
        let mut got = self.pending.len();
        if buf.len() < got.max(5) {
            buf.resize(got.max(5), 0);
        }
        buf[..got].copy_from_slice(&self.pending);
        self.pending.clear();
        let mut need = 5;
        loop {
            if need == 5 && got >= 5 {
                need = 4 + u32::from_le_bytes(buf[..4].try_into().expect("4 bytes")) as usize;
                if buf.len() < need {
                    buf.resize(need, 0);
                }
            }
            if got >= need {
                break;
            }
            match self.wait_readable(deadline) {
                Waited::Readable => {}
                Waited::Exited => return Err(self.died()),
                Waited::TimedOut => return Err(self.timed_out(timeout)),
            }
            let cap = buf.len();
            match self.stdout.read(&mut buf[got..cap]) {
                Ok(0) | Err(_) => return Err(self.died()),
                Ok(n) => got += n,
            }
        }
        self.pending.extend_from_slice(&buf[need..got]);
        buf.truncate(need);
        Ok(buf[4])
    }

    /// The error for a worker that did not answer within `timeout`, killed
    /// (after it was asked where it hangs, unless it is stopped).
    fn timed_out(&mut self, timeout: Duration) -> ProcError {
        let stopped = self.stopped();
        if !stopped {
            self.dump_traceback();
        }
        self.kill();
        if let Some(d) = self.drain.take() {
            let _ = d.join();
        }
        let secs = timeout.as_secs_f64();
        if stopped {
            return ProcError::Died {
                how: format!(
                    "was stopped (by SIGSTOP or SIGTSTP: a debugger, a shell's job control, \
                     someone's kill -STOP?) and so did not answer within {secs} s; it was killed"
                ),
                stderr: self.stderr_tail(),
            };
        }
        ProcError::Timeout {
            secs,
            stderr: self.stderr_tail(),
        }
    }

    /// Whether the worker is stopped (Linux: its state in /proc is `T` or `t`).
    fn stopped(&self) -> bool {
        std::fs::read_to_string(format!("/proc/{}/stat", self.child.id())).is_ok_and(|s| {
            s.rfind(')')
                .and_then(|at| s[at + 1..].split_whitespace().next())
                .is_some_and(|state| state == "T" || state == "t")
        })
    }

    /// Waits until the worker's stdout has something to read, the deadline
    /// passes, or the worker ends (checked every [`EXIT_CHECK`]: a process
    /// it started may hold the pipe open after it is gone).
    #[cfg(unix)]
    fn wait_readable(&mut self, deadline: Instant) -> Waited {
        use std::os::unix::io::AsRawFd;
        let fd = self.stdout.as_raw_fd();
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            let ms = left.min(EXIT_CHECK).as_millis() as i32;
            let mut p = libc::pollfd {
                fd,
                events: libc::POLLIN,
                revents: 0,
            };
            // SAFETY: one valid pollfd for the duration of the call.
            let r = unsafe { libc::poll(&mut p, 1, ms) };
            if r > 0 {
                return Waited::Readable; // or hung up (the read says which)
            }
            if r < 0 {
                if std::io::Error::last_os_error().kind() == std::io::ErrorKind::Interrupted {
                    continue;
                }
                return Waited::Readable;
            }
            if cfg!(target_os = "linux") && self.wait_for_end(Duration::ZERO) {
                // what it wrote before it ended is read first
                // SAFETY: as above, without waiting.
                let r = unsafe { libc::poll(&mut p, 1, 0) };
                return if r > 0 {
                    Waited::Readable
                } else {
                    Waited::Exited
                };
            }
            if left.is_zero() {
                return Waited::TimedOut;
            }
        }
    }

    #[cfg(not(unix))]
    fn wait_readable(&mut self, _deadline: Instant) -> Waited {
        Waited::Readable
    }

    /// Asks a hung worker where it is (its `dump_signal`, e.g. SIGUSR1,
    /// which a Python worker's faulthandler answers on stderr) and gives it
    /// a moment.
    fn dump_traceback(&mut self) {
        #[cfg(unix)]
        if let Some(sig) = self.dump_signal {
            // SAFETY: sending a signal to our own child process.
            unsafe {
                libc::kill(self.child.id() as libc::pid_t, sig);
            }
            std::thread::sleep(Duration::from_millis(300));
        }
    }

    /// Kills the process (if still running) and reaps it.
    pub fn kill(&mut self) {
        self.kill_group();
        let _ = self.child.kill();
        let _ = self.child.wait();
        self.reaped();
    }

    /// After the worker is reaped: forgets it, and ends the processes it
    /// started that left its process group ([`crate::family::sweep`]).
    fn reaped(&mut self) {
        if let Some(mark) = self.mark.take() {
            crate::family::left(self.child.id());
            crate::family::sweep(&mark);
        }
    }

    /// Kills what is left of the worker's process group: processes the env
    /// started (which would otherwise outlive it, and hold its stderr open).
    /// Only before the worker is reaped, so that the group's id is still
    /// the worker's.
    fn kill_group(&mut self) {
        #[cfg(unix)]
        if let Some(g) = self.group.take() {
            // SAFETY: signalling our own child's process group.
            unsafe {
                libc::kill(-g, libc::SIGKILL);
            }
        }
    }

    /// Waits up to `limit` for the worker to end, without reaping it
    /// (Linux), so that its process group can still be killed by its id.
    /// Whether it ended (always `true` elsewhere).
    fn wait_for_end(&mut self, limit: Duration) -> bool {
        #[cfg(target_os = "linux")]
        {
            let t0 = Instant::now();
            loop {
                let ended = crate::family::ended_unreaped(self.child.id());
                if ended || t0.elapsed() >= limit {
                    return ended;
                }
                std::thread::sleep(Duration::from_millis(10));
            }
        }
        #[cfg(not(target_os = "linux"))]
        {
            let _ = limit;
            true
        }
    }

    /// The error for a worker that stopped answering: how it ended and the
    /// end of what it wrote to stderr.
    pub fn died(&mut self) -> ProcError {
        // Give it a moment to finish dying, so the status is known; what it
        // started goes with it.
        if self.wait_for_end(Duration::from_secs(2)) {
            self.kill_group();
        }
        let t0 = Instant::now();
        let status = loop {
            match self.child.try_wait() {
                Ok(Some(s)) => break Some(s),
                Ok(None) if t0.elapsed() < Duration::from_secs(2) => {
                    std::thread::sleep(Duration::from_millis(10))
                }
                _ => {
                    self.kill();
                    break None;
                }
            }
        };
        // reaped: its id may name another process's group from now on
        self.group = None;
        self.reaped();
        if let Some(d) = self.drain.take() {
            let _ = d.join();
        }
        ProcError::Died {
            how: status.map_or("stopped answering".into(), describe_status),
            stderr: self.stderr_tail(),
        }
    }

    /// The last lines the worker wrote to stderr.
    pub fn stderr_tail(&self) -> String {
        let k = self.stderr.lock().unwrap_or_else(|p| p.into_inner());
        let bytes: Vec<u8> = k.iter().copied().collect();
        let text = String::from_utf8_lossy(&bytes);
        let lines: Vec<&str> = text.lines().collect();
        lines[lines.len().saturating_sub(30)..].join("\n")
    }
}

impl Drop for Worker {
    fn drop(&mut self) {
        self.kill();
    }
}

/// How a child process ended, to follow its name: "was killed by signal 11
/// (SIGSEGV)", "exited with status 3". SIGKILL's says where to see whether
/// the kernel's out-of-memory killer sent it (the usual sender for a worker
/// holding a large model or batch).
pub fn describe_status(s: std::process::ExitStatus) -> String {
    #[cfg(unix)]
    {
        use std::os::unix::process::ExitStatusExt;
        if let Some(sig) = s.signal() {
            let name = match sig {
                2 => " (SIGINT)",
                4 => " (SIGILL)",
                6 => " (SIGABRT)",
                7 => " (SIGBUS)",
                8 => " (SIGFPE)",
                9 => {
                    " (SIGKILL: sent by another process, or by the kernel when memory ran out: \
                     `dmesg` or `journalctl -k` shows an out-of-memory kill)"
                }
                11 => " (SIGSEGV)",
                15 => " (SIGTERM)",
                _ => "",
            };
            return format!("was killed by signal {sig}{name}");
        }
    }
    match s.code() {
        Some(c) => format!("exited with status {c}"),
        None => "ended".into(),
    }
}

#[cfg(all(test, target_os = "linux"))]
mod tests {
    use super::*;

    /// The kernel's death signal follows the thread that forked a child:
    /// a worker started from a thread that ends (a rayon thread, a
    /// scoped thread) must live on.
    #[test]
    fn a_worker_outlives_the_thread_that_started_it() {
        let mut w = std::thread::spawn(|| {
            let mut c = Command::new("sleep");
            c.arg("30");
            Worker::spawn(c, "sleep", None).unwrap()
        })
        .join()
        .unwrap();
        std::thread::sleep(Duration::from_millis(300));
        assert!(
            w.child.try_wait().unwrap().is_none(),
            "ended with its thread"
        );
        w.kill();
    }

    /// A read that takes more than the message (the buffer was left longer
    /// by an earlier, longer message, and the next messages are already in
    /// the pipe) keeps the surplus for the next call.
    #[test]
    fn bytes_read_past_a_message_are_the_next_messages() {
        // a 10-byte message, then two of 6 bytes, written at once
        let mut c = Command::new("sh");
        c.arg("-c").arg(
            "printf '\\011\\000\\000\\000Aabcdefgh\\005\\000\\000\\000B1234\\005\\000\\000\\000C5678'; sleep 30",
        );
        let mut w = Worker::spawn(c, "sh", None).unwrap();
        let mut buf = vec![0; 14];
        let t = Duration::from_secs(10);
        assert_eq!(w.recv_message(&mut buf, t).unwrap(), b'A');
        assert_eq!(&buf[5..], b"abcdefgh");
        buf.resize(14, 0); // longer than the next message
        assert_eq!(w.recv_message(&mut buf, t).unwrap(), b'B');
        assert_eq!(&buf[5..], b"1234");
        assert_eq!(w.recv_message(&mut buf, t).unwrap(), b'C');
        assert_eq!(&buf[5..], b"5678");
        w.kill();
    }
}
