//! A cell's end, off the sampling path: its last block commits, its
//! finalisation and `run.json`, while the next cell samples.
//!
//! When a cell's workers are done, its last blocks are still being committed
//! by the I/O threads ([`crate::committer`]: write, rename, index line; the
//! group still gathering is kept back and finalised from memory), and the
//! cell is still to be finalised (`scores.csv`, statistics, `samples.csv`,
//! `cell.json`) and recorded in `run.json` (a synced write). Done by the
//! runner's thread, all of it would keep the workers waiting; on a short
//! cell, longer than a few percent of its wall time. Instead the runner
//! hands the cell to a thread of its own ([`spawn_cell_end`]: wait for the
//! commits, then finalise) and the [`Recorder`] thread takes the cells in
//! cell order, waits for each one's end and records it, rewriting
//! `run.json`; meanwhile the next cell samples.
//!
//! What is on disk, and when, keeps its guarantees: a block counts as
//! committed once its file is renamed into place and indexed (the I/O threads
//! do that, as before); a cell is finalised only once all its blocks are
//! committed; `run.json` lists cells in cell order, and a cell only once
//! its files are finalised. A failure of a cell's end (a commit or the
//! finalisation) stops the recorder and sets the runner's `abort` flag, so
//! the run stops after the blocks in flight and reports that failure.

use crate::cells::{Cell, SummaryLine};
use crate::committer::CommitThreads;
use crate::error::CellError;
use crate::manifest::Manifest;
use crate::rundir::blocks::write_blocks;
use crate::rundir::cell_dir;
use crate::rundir::data::KeptEpisodes;
use crate::rundir::finalize::CellTotals;
use crate::rundir::meta::{write_run_meta, CellMeta, RunMeta};
use crate::timing::CellTiming;
use crate::StudyError;
use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{sync_channel, Receiver, SyncSender};
use std::thread::{Scope, ScopedJoinHandle};
use std::time::{Duration, Instant};

/// Cells handed over and not yet recorded beyond the one the recorder waits
/// for; a runner with more waits (bounds the threads and the memory of
/// cells not yet finalised).
const QUEUED: usize = 3;

/// The end of a sampled cell, as its thread returns it.
pub(crate) struct CellEnd {
    /// Busy time of the cell's I/O threads.
    commit_io: Duration,
    /// From the end of the sampling to the last commit.
    commit_end: Duration,
    /// Finalising the cell.
    finalize: Duration,
    /// The finalised cell (`None` for a shard, which finalises nothing).
    finalized: Option<(CellMeta, CellTotals)>,
}

/// What the runner hands to the recorder, in cell order.
pub(crate) enum Record<'scope, 'c> {
    /// A cell complete on disk before this session (a resumed run).
    Complete(CellMeta),
    /// A cell sampled in this session, its end running on its own thread.
    Sampled {
        /// The cell.
        cell: &'c Cell,
        /// Env steps computed for it in this session.
        steps: u64,
        /// Its timing so far (name, sampling).
        timing: CellTiming,
        /// Its end ([`spawn_cell_end`]).
        end: ScopedJoinHandle<'scope, Result<CellEnd, StudyError>>,
    },
}

/// What the recorder has recorded: the run's metadata as last written to
/// `run.json`, the summary lines and the timing of the sampled cells.
pub(crate) struct Recorded {
    /// The run's metadata.
    pub meta: RunMeta,
    /// The summary line of each cell finalised in this session.
    pub lines: Vec<SummaryLine>,
    /// The sampled cells' timing, in cell order (sampling and the phases of
    /// their ends; the runner adds its own serial time).
    pub cells: Vec<CellTiming>,
    /// The episodes of each cell finalised in this session, when kept
    /// ([`crate::runner::RunOptions::keep_episodes`]).
    pub episodes: KeptEpisodes,
}

/// The recorder's thread, joined by [`Recorder::finish`].
pub(crate) struct Recorder<'scope, 'c> {
    tx: SyncSender<Record<'scope, 'c>>,
    thread: ScopedJoinHandle<'scope, (Recorded, Result<(), StudyError>)>,
}

impl<'scope, 'c: 'scope> Recorder<'scope, 'c> {
    /// Starts the recorder in `scope`, writing `run.json` into `out` from
    /// `meta` (`t0`: the start of the run's computing, for `wall_s`). On a
    /// failure it sets `abort`.
    pub fn start(
        scope: &'scope Scope<'scope, '_>,
        out: &'scope Path,
        t0: Instant,
        meta: RunMeta,
        abort: &'scope AtomicBool,
    ) -> Self {
        let (tx, rx) = sync_channel(QUEUED);
        let thread = scope.spawn(move || {
            let mut rec = Recorded {
                meta,
                lines: vec![],
                cells: vec![],
                episodes: KeptEpisodes::new(),
            };
            let result = record_loop(&rx, &mut rec, out, t0);
            if result.is_err() {
                abort.store(true, Ordering::SeqCst);
            }
            (rec, result)
        });
        Recorder { tx, thread }
    }

    /// Hands over the next cell (waits while [`QUEUED`] cells wait). False
    /// if the recorder has stopped on a failure ([`Recorder::finish`] returns
    /// it).
    pub fn send(&self, r: Record<'scope, 'c>) -> bool {
        self.tx.send(r).is_ok()
    }

    /// Waits until every cell handed over is recorded; returns what was
    /// recorded and the first failure.
    pub fn finish(self) -> (Recorded, Result<(), StudyError>) {
        drop(self.tx);
        self.thread
            .join()
            .unwrap_or_else(|panic| std::panic::resume_unwind(panic))
    }
}

fn record_loop(
    rx: &Receiver<Record<'_, '_>>,
    rec: &mut Recorded,
    out: &Path,
    t0: Instant,
) -> Result<(), StudyError> {
    for r in rx {
        let (cell, steps, mut timing, end) = match r {
            Record::Complete(cm) => {
                rec.meta.env_steps += cm.env_steps;
                rec.meta.cells.push(cm);
                continue;
            }
            Record::Sampled {
                cell,
                steps,
                timing,
                end,
            } => (cell, steps, timing, end),
        };
        let end = end
            .join()
            .unwrap_or_else(|panic| std::panic::resume_unwind(panic))?;
        timing.commit_io = end.commit_io;
        timing.commit_end = end.commit_end;
        timing.finalize = end.finalize;
        match end.finalized {
            Some((cm, mut totals)) => {
                rec.lines
                    .push(cell.summary_line(&totals.means, Some(cm.steps_per_s)));
                if !totals.episodes.0.is_empty() {
                    let episodes = std::mem::take(&mut totals.episodes);
                    rec.episodes.insert(cell.id.dir.clone(), episodes);
                }
                rec.meta.env_steps += cm.env_steps;
                rec.meta.cells.push(cm);
            }
            None => rec.meta.env_steps += steps,
        }
        let t = Instant::now();
        rec.meta.wall_s = t0.elapsed().as_secs_f64();
        write_run_meta(out, &rec.meta)?;
        timing.run_json = t.elapsed();
        rec.cells.push(timing);
    }
    Ok(())
}

/// Starts, in `scope`, the end of a sampled cell: waits for `commits` (the
/// cell's I/O threads, their committer dropped), then, unless `shard`,
/// finalises the cell on `pool` (its `wall_s` runs from `t_cell` to the last
/// commit, as it did when the runner waited for the commits itself), keeping
/// its episodes in memory if `keep`.
#[expect(
    clippy::too_many_arguments,
    reason = "the cell's parts, each handed to the thread that finishes it"
)]
pub(crate) fn spawn_cell_end<'scope>(
    scope: &'scope Scope<'scope, '_>,
    cell: &'scope Cell,
    m: &'scope Manifest,
    out: &'scope Path,
    pool: &'scope rayon::ThreadPool,
    commits: CommitThreads<'scope>,
    t_cell: Instant,
    shard: bool,
    keep: bool,
) -> ScopedJoinHandle<'scope, Result<CellEnd, StudyError>> {
    scope.spawn(move || {
        let t = Instant::now();
        let (commit_io, tail) = commits
            .finish()
            .map_err(|e| cell.failure(out, CellError::from(e)))?;
        let commit_end = t.elapsed();
        let wall = t_cell.elapsed().as_secs_f64();
        let t = Instant::now();
        let finalized = if shard {
            None
        } else {
            let finalized = pool.install(|| cell.finalize(m, out, wall, keep, &tail));
            if finalized.is_err() && !tail.is_empty() {
                // Kept back for the finalisation, which failed: committed
                // now, so that a rerun resumes after them.
                let _ = write_blocks(&cell_dir(out, &cell.id.dir), &tail, cell.rows(m));
            }
            Some(finalized?)
        };
        Ok(CellEnd {
            commit_io,
            commit_end,
            finalize: t.elapsed(),
            finalized,
        })
    })
}
