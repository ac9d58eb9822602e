//! Block commits off the sampling path.
//!
//! Committing a block (formatting its rows, writing and renaming its file,
//! appending its index line: [`write_blocks`]) is file-system work: creating a
//! file costs more than a CartPole block's sampling on some disks. Done on the
//! thread that collects the blocks, it would stall every worker after each
//! wave. A [`Committer`] hands the blocks to a few I/O threads instead, which
//! commit them while the workers compute the next ones. A block counts as
//! committed once its file is renamed into place and listed in the cell's
//! block index; a run killed by a signal loses at most the blocks not yet
//! committed, which a resumed run computes again (as it does blocks that a
//! crash of the machine kept from the disk: nothing is synced, see
//! [`write_blocks`]). A process
//! that ends early on purpose (a plugin called `exit()`, a plugin call hangs)
//! first waits for the blocks already handed over ([`wait_for_commits`]). The I/O
//! threads append to the block index concurrently: each entry is one
//! `O_APPEND` write of a whole line, and the index is keyed by block name,
//! so its line order does not matter.

use crate::rundir::blocks::{write_blocks, RunDirError};
use rwg_core::sampler::BlockResult;
use std::path::Path;
use std::sync::atomic::{AtomicUsize, Ordering::SeqCst};
use std::sync::mpsc::{sync_channel, Receiver, SyncSender};
use std::sync::{Arc, Mutex};
use std::thread::{Scope, ScopedJoinHandle};
use std::time::{Duration, Instant};

/// I/O threads per cell.
pub const COMMIT_THREADS: usize = 4;
/// Blocks waiting for an I/O thread before [`Committer::submit`] blocks
/// (bounds the memory held by finished, uncommitted blocks).
const QUEUE: usize = 64;
/// Most blocks one I/O thread commits as one group.
const GROUP: usize = 16;

/// Blocks handed to an I/O thread (of any committer of this process) and not
/// yet through [`write_blocks`].
static IN_FLIGHT: AtomicUsize = AtomicUsize::new(0);

/// Waits, at most `limit`, until every block handed to a committer has been
/// committed (or has failed); true if none is left. For a process about to
/// end early (a plugin called `exit()`, a plugin call hangs), so that blocks
/// computed before are not lost on their way to the disk.
pub fn wait_for_commits(limit: Duration) -> bool {
    let t0 = Instant::now();
    while IN_FLIGHT.load(SeqCst) > 0 {
        if t0.elapsed() >= limit {
            return false;
        }
        std::thread::sleep(Duration::from_millis(2));
    }
    true
}

/// The first commit error, shared by the I/O threads.
type FirstError = Arc<Mutex<Option<RunDirError>>>;

/// Hands finished blocks of one cell to I/O threads that commit them.
pub struct Committer {
    tx: SyncSender<BlockResult>,
    failed: FirstError,
}

/// The I/O threads of a [`Committer`], joined by [`CommitThreads::finish`].
pub struct CommitThreads<'scope> {
    handles: Vec<ScopedJoinHandle<'scope, Duration>>,
    failed: FirstError,
}

impl Committer {
    /// Starts [`COMMIT_THREADS`] I/O threads in `scope` committing blocks of
    /// the cell in `cell_dir` (`episodes` per network). The threads may
    /// outlive the cell's sampling (the runner waits for them on another
    /// thread while the next cell samples).
    pub fn start<'scope>(
        scope: &'scope Scope<'scope, '_>,
        cell_dir: &Path,
        episodes: u32,
    ) -> (Committer, CommitThreads<'scope>) {
        let cell_dir: Arc<Path> = Arc::from(cell_dir);
        let (tx, rx) = sync_channel::<BlockResult>(QUEUE);
        let rx = Arc::new(Mutex::new(rx));
        let failed: FirstError = Arc::default();
        let handles = (0..COMMIT_THREADS)
            .map(|_| {
                let rx = Arc::clone(&rx);
                let failed = Arc::clone(&failed);
                let cell_dir = Arc::clone(&cell_dir);
                scope.spawn(move || commit_loop(&rx, &failed, &cell_dir, episodes))
            })
            .collect();
        (
            Committer {
                tx,
                failed: Arc::clone(&failed),
            },
            CommitThreads { handles, failed },
        )
    }

    /// Queues a finished block for its commit (waits while the queue is
    /// full). Fails with the first commit error, once one happened.
    pub fn submit(&self, block: BlockResult) -> Result<(), RunDirError> {
        if let Some(e) = lock(&self.failed).take() {
            return Err(e);
        }
        // The receivers live until the sender is dropped (they only stop on
        // disconnection), so the send cannot fail.
        IN_FLIGHT.fetch_add(1, SeqCst);
        self.tx
            .send(block)
            .expect("the commit threads outlive the committer");
        Ok(())
    }
}

impl CommitThreads<'_> {
    /// Waits until every queued block is committed (the [`Committer`] must
    /// have been dropped). Returns the I/O threads' total busy time, or the
    /// first commit error not yet returned by [`Committer::submit`].
    pub fn finish(self) -> Result<Duration, RunDirError> {
        let mut busy = Duration::ZERO;
        for h in self.handles {
            match h.join() {
                Ok(t) => busy += t,
                Err(panic) => std::panic::resume_unwind(panic),
            }
        }
        match lock(&self.failed).take() {
            Some(e) => Err(e),
            None => Ok(busy),
        }
    }
}

/// One I/O thread: commits blocks until the channel closes; after an error,
/// only drains the queue. Takes every block waiting (up to [`GROUP`]) and
/// commits them as one group ([`write_blocks`]): when the workers produce
/// blocks faster than the disk syncs them, fewer syncs per block. Returns
/// its busy time.
fn commit_loop(
    rx: &Mutex<Receiver<BlockResult>>,
    failed: &Mutex<Option<RunDirError>>,
    cell_dir: &Path,
    episodes: u32,
) -> Duration {
    let mut busy = Duration::ZERO;
    let mut group = Vec::with_capacity(GROUP);
    loop {
        {
            // The guard is dropped at the end of this block: the other
            // threads wait only for the hand-over, not for the commit.
            let rx = lock(rx);
            let Ok(block) = rx.recv() else { return busy };
            group.push(block);
            while group.len() < GROUP {
                match rx.try_recv() {
                    Ok(block) => group.push(block),
                    Err(_) => break,
                }
            }
        }
        let t = Instant::now();
        let stopped = lock(failed).is_some();
        if !stopped {
            if let Err(e) = write_blocks(cell_dir, &group, episodes) {
                lock(failed).get_or_insert(e);
            }
        }
        IN_FLIGHT.fetch_sub(group.len(), SeqCst);
        group.clear();
        busy += t.elapsed();
    }
}

/// Locks `m`, ignoring poisoning (a panicking I/O thread is re-raised by
/// [`CommitThreads::finish`]).
fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|e| e.into_inner())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rundir::blocks::{block_done, block_path, block_samples, n_blocks, write_block};
    use rwg_core::sampler::EpisodeResult;

    fn block(b: u64, samples: u64) -> BlockResult {
        let r = block_samples(b, samples);
        let episodes = (0..r.end - r.start)
            .map(|i| EpisodeResult {
                score: (r.start + i) as f64 * 0.25,
                steps: 7,
            })
            .collect();
        BlockResult {
            samples: r,
            episodes,
        }
    }

    #[test]
    fn commits_every_block_as_write_block_would() {
        let base = std::env::temp_dir().join(format!("rwg-committer-{}", std::process::id()));
        let (a, b) = (base.join("a"), base.join("b"));
        let _ = std::fs::remove_dir_all(&base);
        let samples = 40 * 32 + 3;
        for i in 0..n_blocks(samples) {
            write_block(&a, &block(i, samples), 1).unwrap();
        }
        let busy = std::thread::scope(|s| {
            let (c, threads) = Committer::start(s, &b, 1);
            for i in (0..n_blocks(samples)).rev() {
                c.submit(block(i, samples)).unwrap();
            }
            drop(c);
            threads.finish().unwrap()
        });
        assert!(busy > Duration::ZERO);
        for i in 0..n_blocks(samples) {
            assert!(block_done(&b, i));
            assert_eq!(
                std::fs::read(block_path(&a, i)).unwrap(),
                std::fs::read(block_path(&b, i)).unwrap()
            );
        }
        std::fs::remove_dir_all(&base).unwrap();
    }

    #[test]
    fn a_failed_commit_is_reported() {
        let base = std::env::temp_dir().join(format!("rwg-committer-f-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&base);
        std::fs::create_dir_all(&base).unwrap();
        // A file where the cell directory should be: every commit fails.
        let cell = base.join("cell");
        std::fs::write(&cell, "not a directory").unwrap();
        let err = std::thread::scope(|s| {
            let (c, threads) = Committer::start(s, &cell, 1);
            let mut first = None;
            for i in 0..8 {
                if let Err(e) = c.submit(block(i, 8 * 32)) {
                    first = Some(e);
                    break;
                }
                std::thread::sleep(Duration::from_millis(5));
            }
            drop(c);
            let rest = threads.finish();
            first.unwrap_or_else(|| rest.unwrap_err())
        });
        assert!(err.to_string().contains("cell"), "{err}");
        std::fs::remove_dir_all(&base).unwrap();
    }
}
