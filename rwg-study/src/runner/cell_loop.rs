//! The per-cell loop of a run: each cell verified (complete before this
//! session) or sampled block by block, its blocks committed by I/O threads,
//! its end (finalising it) on a thread of its own, and the cells recorded in
//! order by the recorder (`run.json`), while the next cells sample.

use super::setup::Work;
use super::{Progress, RunOptions};
use crate::cells::Cell;
use crate::committer::Committer;
use crate::error::CellError;
use crate::fault_context;
use crate::manifest::Manifest;
use crate::recorder::{spawn_cell_end, Record, Recorded, Recorder};
use crate::rundir::blocks::tidy_complete_cell;
use crate::rundir::cell_dir;
use crate::rundir::checksum::verify_cell;
use crate::rundir::meta::{read_cell_meta, write_run_meta, RunMeta};
use crate::timing::CellTiming;
use crate::StudyError;
use rwg_core::sampler::BlockResult;
use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::thread::Scope;
use std::time::{Duration, Instant};

/// What the per-cell loop reads.
pub(super) struct Session<'a> {
    /// The study.
    pub m: &'a Manifest,
    /// How it runs.
    pub opts: &'a RunOptions<'a>,
    /// Its cells.
    pub cells: &'a [Cell],
    /// The blocks this run owes.
    pub work: &'a Work,
    /// The worker threads.
    pub pool: &'a rayon::ThreadPool,
    /// When the computing started.
    pub t0: Instant,
    /// Set by the recorder when a cell's end fails: the run stops after the
    /// blocks in flight and reports that failure.
    pub abort: &'a AtomicBool,
}

/// What the per-cell loop did.
pub(super) struct Sampled {
    /// What the recorder recorded.
    pub recorded: Recorded,
    /// Env steps computed in this session.
    pub steps: u64,
    /// Each sampled cell's time on the main thread outside its sampling, in
    /// cell order.
    pub serial: Vec<Duration>,
    /// Waiting for the last cells' ends and the recorder.
    pub drain: Duration,
}

/// A cell's step that stopped the run: its error, and whether the run was
/// already stopped by the recorder (`abort` was set) when it came.
struct Failed {
    error: StudyError,
    aborted: bool,
}

impl Failed {
    /// The run was stopped by the recorder while handing it a cell.
    fn interrupted() -> Failed {
        Failed {
            error: StudyError::Interrupted,
            aborted: true,
        }
    }
}

/// Runs every cell of `s`, the recorder starting from `meta`; on a failure
/// ends the run as [`fail`] does.
pub(super) fn run_cells(
    s: &Session<'_>,
    meta: RunMeta,
    progress: &mut dyn Progress,
) -> Result<Sampled, StudyError> {
    let out = &*s.opts.out;
    let mut steps = 0u64;
    let mut serial = Vec::with_capacity(s.cells.len());
    std::thread::scope(|fin| -> Result<Sampled, StudyError> {
        let recorder = Recorder::start(fin, out, s.t0, meta, s.abort);
        // Every JAX env's first worker started while the study was planned:
        // only the first cell's is kept, so that a study of many JAX envs
        // holds the workers of one env at a time, not of all.
        let first = s
            .cells
            .iter()
            .find(|c| !s.work.skips(&cell_dir(out, &c.id.dir)));
        for cell in s.cells {
            cell.source
                .release_unless_used(first.map(|c| &c.source).into_iter());
        }
        for (ci, cell) in s.cells.iter().enumerate() {
            let t_iter = Instant::now();
            let dir = cell_dir(out, &cell.id.dir);
            let done = if s.work.skips(&dir) {
                hand_complete(s, &recorder, cell, &dir)
            } else {
                sample_cell(s, fin, &recorder, ci, cell, progress, &mut steps).map(|sampling| {
                    serial.push(t_iter.elapsed() - sampling);
                })
            };
            if let Err(f) = done {
                return fail(progress, recorder, out, s.t0, f.error, f.aborted);
            }
            // the env's last cell: its workers end
            cell.source
                .release_unless_used(s.cells[ci + 1..].iter().map(|c| &c.source));
        }
        let t_drain = Instant::now();
        let (mut rec, ended) = recorder.finish();
        let drain = t_drain.elapsed();
        if let Err(e) = ended {
            progress.finish(false);
            rec.meta.wall_s = s.t0.elapsed().as_secs_f64();
            let _ = write_run_meta(out, &rec.meta);
            return Err(e);
        }
        Ok(Sampled {
            recorded: rec,
            steps,
            serial,
            drain,
        })
    })
}

/// A cell complete before this session: tidied, verified, and its
/// `cell.json` handed to the recorder.
fn hand_complete<'scope, 'c: 'scope>(
    s: &Session<'_>,
    recorder: &Recorder<'scope, 'c>,
    cell: &Cell,
    dir: &Path,
) -> Result<(), Failed> {
    let checked = tidy_complete_cell(dir)
        .map_err(|source| StudyError::RunDir {
            context: format!("cannot tidy cell {}", cell.id.dir),
            source,
        })
        .and_then(|()| {
            verify_cell(dir).map_err(|source| StudyError::RunDir {
                context: format!("cell {} is complete but does not verify", cell.id.dir),
                source,
            })
        })
        .and_then(|_| read_cell_meta(dir));
    let aborted = s.abort.load(Ordering::SeqCst);
    let handed = match checked {
        Ok(cm) => recorder.send(Record::Complete(cm)),
        Err(error) => return Err(Failed { error, aborted }),
    };
    if !handed {
        return Err(Failed::interrupted());
    }
    Ok(())
}

/// Samples the blocks cell `ci` owes, its commits on I/O threads, then
/// hands its end (spawned on a thread of its own) to the recorder. Returns
/// the time spent sampling.
fn sample_cell<'scope, 'a: 'scope>(
    s: &Session<'a>,
    fin: &'scope Scope<'scope, '_>,
    recorder: &Recorder<'scope, 'a>,
    ci: usize,
    cell: &'a Cell,
    progress: &mut dyn Progress,
    steps_now: &mut u64,
) -> Result<Duration, Failed> {
    let (m, opts, out) = (s.m, s.opts, &*s.opts.out);
    let dir = &cell_dir(out, &cell.id.dir);
    let label = format!(
        "cell {}/{} ({} done): {}",
        ci + 1,
        s.cells.len(),
        ci,
        cell.id.dir
    );
    progress.cell(&label);
    fault_context::set_cell_label(cell.source.fault_label(cell));
    let blocks = s.work.blocks(ci);
    let t_cell = Instant::now();
    let mut cell_steps = 0u64;
    // Blocks are committed by I/O threads while the workers compute
    // the next ones; the cell's end waits for the last commits.
    let (committer, io_threads) = Committer::start(fin, dir, cell.rows(m), opts.commit_linger);
    let t_sampling = Instant::now();
    let warm_before = cell.source.warm_up_time();
    let stop = [opts.stop, s.abort];
    let sampled = s.pool.install(|| {
        cell.source
            .run_blocks(&cell.plan, &blocks, |b: BlockResult| {
                let steps: u64 = b.episodes.iter().map(|r| r.steps as u64).sum();
                cell_steps += steps;
                *steps_now += steps;
                progress.block(&label, b.samples.end - b.samples.start, steps);
                on_block(&committer, &stop, b)
            })
    });
    let sampling = t_sampling.elapsed();
    let warm_up = cell
        .source
        .warm_up_time()
        .zip(warm_before)
        .map(|(after, before)| after.saturating_sub(before));
    // A cell sampled to its end is finalised from the blocks still
    // gathering for a commit, without writing them.
    committer.close(sampled.is_ok() && opts.shard.is_none());
    if let Err(e) = sampled {
        // The blocks computed before are committed before the run
        // ends (a rerun resumes after them).
        let e = match io_threads.finish() {
            Err(io) if matches!(e, CellError::Interrupted) => CellError::from(io),
            _ => e,
        };
        // On a full disk run.json fails too, and would hide which
        // file failed first: the cell's error is the one to report
        // (unless the run was stopped by an earlier cell's failure).
        let aborted = s.abort.load(Ordering::SeqCst);
        let error = cell.failure(out, e);
        return Err(Failed { error, aborted });
    }
    let end = spawn_cell_end(
        fin,
        cell,
        m,
        out,
        s.pool,
        io_threads,
        t_cell,
        opts.shard.is_some(),
        opts.keep_episodes,
    );
    let handed = recorder.send(Record::Sampled {
        cell,
        steps: cell_steps,
        timing: CellTiming {
            dir: cell.id.dir.clone(),
            sampling,
            warm_up,
            ..CellTiming::default()
        },
        end,
    });
    if !handed {
        return Err(Failed::interrupted());
    }
    Ok(sampling)
}

/// What happens to each finished block, in block order: committed, then the
/// cell stops if a flag of `stop` is set.
fn on_block(committer: &Committer, stop: &[&AtomicBool], b: BlockResult) -> Result<(), CellError> {
    committer.submit(b)?;
    if stop.iter().any(|s| s.load(Ordering::SeqCst)) {
        return Err(CellError::Interrupted);
    }
    Ok(())
}

/// Ends a run that failed with `e`: waits for the cells handed to the
/// recorder, writes `run.json`, and returns the error to report: the
/// recorder's if it stopped the run (`aborted`: a cell's end failed), else `e`.
fn fail<'scope, 'c: 'scope>(
    progress: &mut dyn Progress,
    recorder: Recorder<'scope, 'c>,
    out: &Path,
    t0: Instant,
    e: StudyError,
    aborted: bool,
) -> Result<Sampled, StudyError> {
    progress.finish(false);
    let (mut rec, ended) = recorder.finish();
    rec.meta.wall_s = t0.elapsed().as_secs_f64();
    let _ = write_run_meta(out, &rec.meta);
    Err(match ended {
        Err(first) if aborted => first,
        _ => e,
    })
}
