//! Block commits off the sampling path.
//!
//! Committing a block (formatting its rows, writing and renaming its file,
//! appending its index line: [`write_blocks`]) is file-system work: creating a
//! file costs more than a CartPole block's sampling on some disks. Done on the
//! thread that collects the blocks, it would stall every worker after each
//! wave. A [`Committer`] hands the blocks to a few I/O threads instead, which
//! commit them while the workers compute the next ones, in groups: a thread
//! gathers the blocks that arrive within [`LINGER`] (2 s) of a group's first.
//! A block counts as committed once its file is renamed into place and listed
//! in the cell's block index; a run killed by a signal loses at most the
//! blocks not yet committed (about the last [`LINGER`] of work), which a
//! resumed run computes again (as it does blocks that a crash of the machine
//! kept from the disk: nothing is synced, see [`write_blocks`]).
//!
//! When a cell has been sampled to its end, the blocks still gathering are
//! not written at all: [`Committer::close`] keeps them back and the cell's end
//! finalises from them ([`crate::rundir::finalize::finalize_cell`]'s `pending`),
//! so a cell computed within [`LINGER`] creates no block file (on a CartPole
//! cell, creating, reading back and deleting its block files cost about a
//! fifth of the whole run). An interrupted or failed cell, and a shard, commit
//! every block. A process that ends early on purpose (a plugin called
//! `exit()`, a plugin call hangs) first waits for the blocks already handed
//! over ([`wait_for_commits`], which stops the lingering). The I/O threads
//! append to the block index concurrently: each entry is one `O_APPEND` write
//! of a whole line, and the index is keyed by block name, so its line order
//! does not matter.

use crate::rundir::blocks::{write_blocks, BLOCK_SAMPLES};
use crate::rundir::error::RunDirError;
use crate::rundir::rows::CellRows;
use rwg_core::sampler::BlockResult;
use std::path::Path;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering::SeqCst};
use std::sync::mpsc::{sync_channel, Receiver, RecvTimeoutError, SyncSender};
use std::sync::{Arc, Mutex};
use std::thread::{Scope, ScopedJoinHandle};
use std::time::{Duration, Instant};

/// I/O threads per cell.
pub const COMMIT_THREADS: usize = 4;
/// Blocks waiting for an I/O thread before [`Committer::submit`] blocks
/// (bounds the memory held by finished, uncommitted blocks).
const QUEUE: usize = 64;
/// Most blocks one I/O thread gathers into one group.
const GROUP: usize = 256;
/// Most episodes in one group (bounds its memory: 12 bytes each).
const GROUP_EPISODES: usize = 1 << 20;
/// How long an I/O thread waits, by default, for more blocks to join a group
/// after its first: a block is committed at most this long after it was
/// computed ([`Committer::start`]'s `linger`; `rwg run` reads
/// `RWG_COMMIT_LINGER`).
pub const LINGER: Duration = Duration::from_secs(2);
/// How often a lingering I/O thread looks at [`FLUSH`].
const POLL: Duration = Duration::from_millis(10);

/// Blocks handed to an I/O thread (of any committer of this process) and not
/// yet through [`write_blocks`].
static IN_FLIGHT: AtomicUsize = AtomicUsize::new(0);
/// Set by [`wait_for_commits`]: commit every block at once, without
/// lingering or keeping any back.
static FLUSH: AtomicBool = AtomicBool::new(false);

/// Waits, at most `limit`, until every block handed to a committer has been
/// committed (or has failed); true if none is left. For a process about to
/// end early (a plugin called `exit()`, a plugin call hangs), so that blocks
/// computed before are not lost on their way to the disk.
pub fn wait_for_commits(limit: Duration) -> bool {
    FLUSH.store(true, SeqCst);
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

/// What the I/O threads of one committer share.
struct Shared {
    rx: Mutex<Receiver<BlockResult>>,
    /// The first commit error.
    failed: FirstError,
    /// Set by [`Committer::close`]: the blocks still gathering when the
    /// channel closes go to `tail` instead of being written.
    keep_tail: AtomicBool,
    tail: Mutex<Vec<BlockResult>>,
    /// Most blocks per group (from [`GROUP`] and [`GROUP_EPISODES`]).
    group: usize,
    /// How long a group gathers after its first block.
    linger: Duration,
}

/// Hands finished blocks of one cell to I/O threads that commit them.
pub struct Committer {
    tx: SyncSender<BlockResult>,
    shared: Arc<Shared>,
}

/// The I/O threads of a [`Committer`], joined by [`CommitThreads::finish`].
pub struct CommitThreads<'scope> {
    handles: Vec<ScopedJoinHandle<'scope, Duration>>,
    shared: Arc<Shared>,
}

impl Committer {
    /// Starts [`COMMIT_THREADS`] I/O threads in `scope` committing blocks of
    /// the cell in `cell_dir` (its `rows`: episodes per network, flagged or
    /// not). The threads may
    /// outlive the cell's sampling (the runner waits for them on another
    /// thread while the next cell samples).
    pub fn start<'scope>(
        scope: &'scope Scope<'scope, '_>,
        cell_dir: &Path,
        rows: impl Into<CellRows>,
        linger: Duration,
    ) -> (Committer, CommitThreads<'scope>) {
        let rows = rows.into();
        let episodes = rows.episodes;
        let cell_dir: Arc<Path> = Arc::from(cell_dir);
        let (tx, rx) = sync_channel::<BlockResult>(QUEUE);
        let per_block = BLOCK_SAMPLES as usize * (episodes as usize).max(1);
        let shared = Arc::new(Shared {
            rx: Mutex::new(rx),
            failed: FirstError::default(),
            keep_tail: AtomicBool::new(false),
            tail: Mutex::default(),
            group: (GROUP_EPISODES / per_block).clamp(1, GROUP),
            linger,
        });
        let handles = (0..COMMIT_THREADS)
            .map(|_| {
                let shared = Arc::clone(&shared);
                let cell_dir = Arc::clone(&cell_dir);
                scope.spawn(move || commit_loop(&shared, &cell_dir, rows))
            })
            .collect();
        (
            Committer {
                tx,
                shared: Arc::clone(&shared),
            },
            CommitThreads { handles, shared },
        )
    }

    /// No more blocks. With `keep_tail` (the cell's every block is computed
    /// and the cell will be finalised by this process), the blocks the I/O
    /// threads are still gathering are not written but handed back by
    /// [`CommitThreads::finish`]; otherwise (an interrupted or failed cell, a
    /// shard) every block is committed. Dropping a committer closes it
    /// without `keep_tail`.
    pub fn close(self, keep_tail: bool) {
        self.shared.keep_tail.store(keep_tail, SeqCst);
    }

    /// Queues a finished block for its commit (waits while the queue is
    /// full). Fails with the first commit error, once one happened.
    pub fn submit(&self, block: BlockResult) -> Result<(), RunDirError> {
        if let Some(e) = lock(&self.shared.failed).take() {
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
    /// Waits until every queued block is committed, or kept back (the
    /// [`Committer`] must have been closed or dropped). Returns the I/O
    /// threads' total busy time and the blocks kept back
    /// ([`Committer::close`]), in block order, or the first commit error not
    /// yet returned by [`Committer::submit`].
    pub fn finish(self) -> Result<(Duration, Vec<BlockResult>), RunDirError> {
        let mut busy = Duration::ZERO;
        for h in self.handles {
            match h.join() {
                Ok(t) => busy += t,
                Err(panic) => std::panic::resume_unwind(panic),
            }
        }
        if let Some(e) = lock(&self.shared.failed).take() {
            return Err(e);
        }
        let mut tail = std::mem::take(&mut *lock(&self.shared.tail));
        tail.sort_by_key(|b| b.samples.start);
        Ok((busy, tail))
    }
}

/// One I/O thread: commits blocks until the channel closes; after an error,
/// only drains the queue. Gathers every block that arrives within [`LINGER`]
/// of a group's first (up to the group's size) and commits them as one
/// group ([`write_blocks`]): fewer, larger commits, and a cell computed
/// within [`LINGER`] writes no block file at all when its blocks are kept
/// back ([`Committer::close`]). Returns its busy time.
fn commit_loop(shared: &Shared, cell_dir: &Path, rows: CellRows) -> Duration {
    let mut busy = Duration::ZERO;
    let mut group = Vec::with_capacity(shared.group);
    loop {
        let mut closed = false;
        {
            // The guard is dropped at the end of this block: the other
            // threads wait only for the hand-over, not for the commit.
            let rx = lock(&shared.rx);
            let Ok(block) = rx.recv() else { return busy };
            group.push(block);
            let t0 = Instant::now();
            while group.len() < shared.group {
                let left = shared.linger.saturating_sub(t0.elapsed());
                let wait = if FLUSH.load(SeqCst) {
                    Duration::ZERO
                } else {
                    left.min(POLL)
                };
                match rx.recv_timeout(wait) {
                    Ok(block) => group.push(block),
                    Err(RecvTimeoutError::Timeout) => {
                        if wait.is_zero() || t0.elapsed() >= shared.linger {
                            break;
                        }
                    }
                    Err(RecvTimeoutError::Disconnected) => {
                        closed = true;
                        break;
                    }
                }
            }
        }
        if closed && shared.keep_tail.load(SeqCst) && !FLUSH.load(SeqCst) {
            IN_FLIGHT.fetch_sub(group.len(), SeqCst);
            lock(&shared.tail).append(&mut group);
            return busy;
        }
        let t = Instant::now();
        let stopped = lock(&shared.failed).is_some();
        if !stopped {
            if let Err(e) = write_blocks(cell_dir, &group, rows) {
                lock(&shared.failed).get_or_insert(e);
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
                non_finite: false,
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
        std::fs::create_dir_all(&base).unwrap();
        let samples = 40 * 32 + 3;
        for i in 0..n_blocks(samples) {
            write_block(&a, &block(i, samples), 1).unwrap();
        }
        let busy = std::thread::scope(|s| {
            let (c, threads) = Committer::start(s, &b, 1, LINGER);
            for i in (0..n_blocks(samples)).rev() {
                c.submit(block(i, samples)).unwrap();
            }
            drop(c);
            let (busy, tail) = threads.finish().unwrap();
            assert!(tail.is_empty());
            busy
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
    fn blocks_gathering_at_the_close_are_kept_back_when_asked() {
        let base = std::env::temp_dir().join(format!("rwg-committer-k-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&base);
        std::fs::create_dir_all(&base).unwrap();
        let samples = 10 * 32;
        let run = |dir: &Path, keep: bool| {
            std::thread::scope(|s| {
                let (c, threads) = Committer::start(s, dir, 1, LINGER);
                for i in 0..n_blocks(samples) {
                    c.submit(block(i, samples)).unwrap();
                }
                c.close(keep);
                threads.finish().unwrap().1
            })
        };
        // Submitted within LINGER: all kept back, in block order, no file.
        let tail = run(&base.join("keep"), true);
        let order: Vec<u64> = tail.iter().map(|b| b.samples.start / 32).collect();
        assert_eq!(order, (0..n_blocks(samples)).collect::<Vec<_>>());
        assert!(!base.join("keep").join("blocks").exists());
        // Without keep_tail every block is committed.
        assert!(run(&base.join("all"), false).is_empty());
        assert!((0..n_blocks(samples)).all(|i| block_done(&base.join("all"), i)));
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
            let (c, threads) = Committer::start(s, &cell, 1, LINGER);
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
