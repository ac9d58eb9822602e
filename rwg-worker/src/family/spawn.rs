//! Starting a member of the family: a worker ([`crate::Worker`]) or a
//! helper process ([`FamilyChild`]), in a process group of its own, with a
//! death signal and the family's mark.

use std::process::{Child, Command, ExitStatus};
use std::time::{Duration, Instant};

/// A child process that is not a protocol worker (`rwg check`'s checking
/// process), started as a member of the family: in a process group of its
/// own, killed when rwg ends (even by SIGKILL: `PR_SET_PDEATHSIG`), marked;
/// when it ends, what it started ends too (its group, and what left its
/// group once orphaned to rwg), so that no process it started holds its
/// pipes open.
pub struct FamilyChild {
    child: Child,
    /// `None` once reaped and swept.
    mark: Option<String>,
}

impl FamilyChild {
    /// Starts `command`.
    pub fn spawn(mut command: Command) -> std::io::Result<FamilyChild> {
        let mark = super::enlist(&mut command);
        let child = spawn_in_family(command)?;
        super::joined(child.id(), &mark);
        Ok(FamilyChild {
            child,
            mark: Some(mark),
        })
    }

    /// The process, to take its pipes.
    pub fn child_mut(&mut self) -> &mut Child {
        &mut self.child
    }

    /// Waits up to `limit` for the process to end (killing it then), ends
    /// what it started and reaps it: its exit status, or `None` if it was
    /// killed after `limit`.
    pub fn wait_timeout(&mut self, limit: Duration) -> std::io::Result<Option<ExitStatus>> {
        let t0 = Instant::now();
        let ended = loop {
            if self.ended()? {
                break true;
            }
            if t0.elapsed() >= limit {
                break false;
            }
            std::thread::sleep(Duration::from_millis(20));
        };
        self.end_group();
        let _ = self.child.kill();
        let status = self.child.wait()?;
        self.swept();
        Ok(ended.then_some(status))
    }

    /// Whether the process has ended, without reaping it (Linux), so that
    /// its process group can still be killed by its id.
    fn ended(&mut self) -> std::io::Result<bool> {
        #[cfg(target_os = "linux")]
        return Ok(super::ended_unreaped(self.child.id()));
        #[cfg(not(target_os = "linux"))]
        Ok(self.child.try_wait()?.is_some())
    }

    /// Kills what is left of its process group (before it is reaped).
    fn end_group(&mut self) {
        #[cfg(unix)]
        if self.mark.is_some() {
            // SAFETY: signalling our own child's process group.
            unsafe {
                libc::kill(-(self.child.id() as i32), libc::SIGKILL);
            }
        }
    }

    /// After it is reaped: forgets it and ends what left its group.
    fn swept(&mut self) {
        if let Some(mark) = self.mark.take() {
            super::left(self.child.id());
            super::sweep(&mark);
        }
    }
}

impl Drop for FamilyChild {
    fn drop(&mut self) {
        if self.mark.is_some() {
            self.end_group();
            let _ = self.child.kill();
            let _ = self.child.wait();
            self.swept();
        }
    }
}

/// Starts `command` as a member of rwg's family of workers: on Linux the
/// child is killed (SIGKILL) as soon as rwg ends, however it ends (a signal,
/// SIGKILL included, `_exit`, a crash), so that a worker hung in its
/// environment is never left running on its own. The kernel ties this
/// (`PR_SET_PDEATHSIG`) to the thread that forked the child, so every worker
/// is forked by one thread that lives as long as the process.
pub(crate) fn spawn_in_family(command: Command) -> std::io::Result<Child> {
    #[cfg(target_os = "linux")]
    {
        use std::sync::mpsc::{channel, Sender};
        type Request = (Command, Sender<std::io::Result<Child>>);
        static SPAWNER: std::sync::Mutex<Option<Sender<Request>>> = std::sync::Mutex::new(None);
        let (tx, rx) = channel();
        let mut spawner = SPAWNER.lock().unwrap_or_else(|p| p.into_inner());
        let sender = match spawner.as_ref() {
            Some(s) => s.clone(),
            None => {
                let (req_tx, req_rx) = channel::<Request>();
                std::thread::Builder::new()
                    .name("rwg-worker-spawner".into())
                    .spawn(move || {
                        for (command, reply) in req_rx {
                            let _ = reply.send(spawn_with_death_signal(command));
                        }
                    })?;
                spawner.insert(req_tx).clone()
            }
        };
        drop(spawner);
        sender
            .send((command, tx))
            .map_err(|_| std::io::Error::other("the worker spawner thread is gone"))?;
        rx.recv()
            .map_err(|_| std::io::Error::other("the worker spawner thread is gone"))?
    }
    #[cfg(not(target_os = "linux"))]
    {
        let mut command = command;
        command.spawn()
    }
}

/// Forks and execs `command` with `PR_SET_PDEATHSIG` = SIGKILL set in the
/// child (on the spawner thread of [`spawn_in_family`]).
#[cfg(target_os = "linux")]
fn spawn_with_death_signal(mut command: Command) -> std::io::Result<Child> {
    use std::os::unix::process::CommandExt;
    // A process group of its own, killed with the worker (Worker::kill).
    command.process_group(0);
    // SAFETY: getpid has no preconditions.
    let parent = unsafe { libc::getpid() };
    // SAFETY: the closure runs in the forked child before exec and calls
    // only async-signal-safe functions (prctl, getppid, raise).
    unsafe {
        command.pre_exec(move || {
            if libc::prctl(libc::PR_SET_PDEATHSIG, libc::SIGKILL, 0, 0, 0) != 0 {
                return Err(std::io::Error::last_os_error());
            }
            // rwg ended between the fork and the prctl: no signal will come.
            if libc::getppid() != parent {
                libc::raise(libc::SIGKILL);
            }
            Ok(())
        })
    };
    command.spawn()
}
