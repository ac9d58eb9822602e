//! Running a study: the manifest's cells, block by block, into a run
//! directory, resumable and shardable.
//!
//! [`run_study`] plans the cells, prepares (or resumes) the directory, runs
//! every block it owns through `rwg_core`'s sampler and commits each one
//! ([`rundir::blocks`](crate::rundir::blocks)), finalises complete cells and
//! keeps `run.json` current. What it reports while running goes to a
//! [`Progress`]; the caller prints.

use crate::cells::{new_meta, plan_cells, Cell, SummaryLine};
use crate::committer::Committer;
use crate::error::CellError;
use crate::fault_context;
use crate::manifest::Manifest;
use crate::recorder::{spawn_cell_end, Record, Recorded, Recorder};
use crate::rundir::blocks::{
    block_samples, cell_complete, n_blocks, tidy_complete_cell, BlockIndex,
};
use crate::rundir::checksum::{verify_cell, SUMS};
use crate::rundir::data::KeptEpisodes;
use crate::rundir::env_record::{check_record, write_record};
use crate::rundir::export::{rfc3339, write_atomic};
use crate::rundir::lock::RunLock;
use crate::rundir::meta::{
    read_cell_meta, read_run_meta, write_run_meta, RunMeta, ShardMeta, RUN_FORMAT,
};
use crate::rundir::study::{edited_message, manifest_edits};
use crate::rundir::{cell_dir, BLOCKS, CELLS, MANIFEST, RUN_JSON};
use crate::timing::{CellTiming, RunTiming};
use crate::StudyError;
use rwg_core::sampler::BlockResult;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant, SystemTime};

/// How to run a study.
#[derive(Debug, Clone)]
pub struct RunOptions<'a> {
    /// The run directory.
    pub out: PathBuf,
    /// Compute only this shard (every N-th block across all cells).
    pub shard: Option<ShardMeta>,
    /// Delete what the run directory holds and start over.
    pub force_new: bool,
    /// Set to stop after the blocks in flight (e.g. by a Ctrl-C handler);
    /// the run then ends with [`StudyError::Interrupted`], resumable.
    pub stop: &'a AtomicBool,
    /// Keep the episodes of every cell finalised in this session in memory
    /// ([`RunReport::episodes`], 12 bytes per episode), for an analysis of
    /// the run that follows it (which then need not read `scores.csv` back).
    pub keep_episodes: bool,
    /// How long finished blocks gather before they are committed as a group
    /// ([`crate::committer::LINGER`] by default; zero commits each at once).
    pub commit_linger: Duration,
    /// The manifest file the study was read from, if any: never written
    /// over (when it is the run directory's own `manifest.toml`, that file
    /// must hold the study as rwg wrote it).
    pub manifest_file: Option<&'a Path>,
}

/// What a run reports while it works.
pub trait Progress: Send {
    /// The cells are planned (plugins loaded, one instance of each env
    /// created), before the run directory is touched.
    fn planned(&mut self, _cells: &[Cell]) {}
    /// Networks this session will compute, once the work is known.
    fn start(&mut self, networks: u64);
    /// A cell starts (`label`: "cell i/n (k done): dir").
    fn cell(&mut self, label: &str);
    /// Something the user should know that does not stop the run (say,
    /// blocks that must be computed again).
    fn note(&mut self, _message: &str) {}
    /// A block of `networks` networks with `env_steps` steps was committed.
    fn block(&mut self, label: &str, networks: u64, env_steps: u64);
    /// The run stopped (done or failed): remove the progress display.
    fn finish(&mut self, ok: bool);
}

/// How a run ended.
#[derive(Debug)]
pub enum RunOutcome {
    /// The directory already held this study, complete; nothing was run.
    /// The run directory's lock is still held (drop it when done writing).
    AlreadyComplete(RunLock),
    /// The cells (or the shard's blocks) are computed.
    Finished(Box<RunReport>),
}

/// What a finished run did.
#[derive(Debug)]
pub struct RunReport {
    /// The final `run.json`.
    pub meta: RunMeta,
    /// The summary line of each cell finalised in this session (whole
    /// studies only; see [`Cell::summary_line`]).
    pub lines: Vec<SummaryLine>,
    /// Cells in the study.
    pub cells: usize,
    /// Env steps computed in this session.
    pub env_steps: u64,
    /// Worker threads used.
    pub threads: usize,
    /// Where the wall time went, phase by phase.
    pub timing: RunTiming,
    /// With [`RunOptions::keep_episodes`]: the episodes of each cell
    /// finalised in this session, by cell directory name.
    pub episodes: KeptEpisodes,
    /// The run directory's lock, still held (drop it when done writing).
    pub lock: RunLock,
}

/// Runs the study `m` (overrides applied) into `opts.out`: plans the cells
/// (plugins are loaded), resumes what the directory holds, computes the
/// blocks this run owns and finalises complete cells. The manifest gets the
/// plugin files it resolved written in (see [`plan_cells`]).
pub fn run_study(
    m: &mut Manifest,
    opts: &RunOptions<'_>,
    progress: &mut dyn Progress,
) -> Result<RunOutcome, StudyError> {
    let t_setup = Instant::now();
    let mut timing = RunTiming::default();
    let out = &opts.out;
    let cells = plan_cells(m)?;
    progress.planned(&cells);
    let m = &*m;
    let threads = m.threads.unwrap_or_else(|| {
        std::thread::available_parallelism()
            .map_or(1, |n| n.get())
            .min(crate::limits::MAX_THREADS)
    });
    crate::rundir::export::create_dir_all(out)
        .map_err(StudyError::io(format!("cannot create {}", out.display())))?;
    let lock = RunLock::acquire(out)?;
    let manifest_path = out.join(MANIFEST);
    // The manifest given is the directory's own: it is the study, never rewritten.
    let own_manifest = opts
        .manifest_file
        .is_some_and(|f| crate::rundir::export::same_file(f, &manifest_path));
    let previous = prepare_dir(out, m, opts.shard, opts.force_new, own_manifest)?;
    if previous.as_ref().is_some_and(|p| p.end_time.is_some()) {
        // Complete only if everything in it still verifies. Blocks that do
        // not (a shard's, say, after a crash of the machine) are computed
        // again below, as in any resume.
        let check = crate::rundir::verify::verify_run(out);
        if check.problems.len() > check.block_problems {
            return Err(StudyError::Refused(format!(
                "{} holds this study, finished, but its files do not verify:\n  {}\n\
                 delete the damaged cell directories and run again to recompute them",
                out.display(),
                check.problems.join("\n  ")
            )));
        }
        if check.block_problems == 0 {
            return Ok(RunOutcome::AlreadyComplete(lock));
        }
    }
    if !own_manifest {
        write_atomic(&manifest_path, m.to_toml().as_bytes()).map_err(StudyError::io(format!(
            "cannot write {}",
            manifest_path.display()
        )))?;
    }

    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| StudyError::Refused(format!("cannot start {threads} worker threads: {e}")))?;
    let nb = n_blocks(m.samples);
    let owned = |ci: usize, b: u64| opts.shard.is_none_or(|s| s.owns(ci, nb, b));
    let mut indexes = Vec::with_capacity(cells.len());
    for c in &cells {
        let dir = cell_dir(out, &c.id.dir);
        let (index, dropped) =
            BlockIndex::load_checked(&dir).map_err(|source| StudyError::RunDir {
                context: format!("cannot read the block index of cell {}", c.id.dir),
                source,
            })?;
        if !dropped.is_empty() {
            progress.note(&format!(
                "{} committed block(s) of cell {} do not match {} \
                 (missing, changed, or not written to disk before a crash of the machine): \
                 computing them again ({})",
                dropped.len(),
                c.id.dir,
                dir.join(BLOCKS).join(SUMS).display(),
                dropped.join(", ")
            ));
        }
        indexes.push(index);
    }
    let todo: u64 = cells
        .iter()
        .enumerate()
        .map(|(ci, c)| {
            let dir = cell_dir(out, &c.id.dir);
            if opts.shard.is_none() && cell_complete(&dir) {
                return 0;
            }
            (0..nb)
                .filter(|&b| owned(ci, b) && !indexes[ci].done(b))
                .map(|b| block_samples(b, m.samples).count() as u64)
                .sum()
        })
        .sum();
    // Every block of a cell is computed under the env its first block was:
    // the env as the cells start is recorded, and a resume under another
    // env is refused before anything runs.
    for (ci, c) in cells.iter().enumerate() {
        let dir = cell_dir(out, &c.id.dir);
        let works = !(opts.shard.is_none() && cell_complete(&dir))
            && (0..nb).any(|b| owned(ci, b) && !indexes[ci].done(b));
        if works {
            let now = c.env_record();
            if !check_record(&dir, &now, RESUME_REFUSED)? {
                write_record(&dir, &now)?;
            }
        }
    }
    progress.start(todo);
    timing.setup = t_setup.elapsed();
    let t0 = Instant::now();
    let mut meta = new_meta(m, threads, rfc3339(SystemTime::now()), opts.shard);
    match &previous {
        Some(p) => meta.start_time = p.start_time.clone(),
        // A run in progress has its run.json (and study) before its first cell ends.
        None => write_run_meta(out, &meta)?,
    }
    let mut steps_now = 0u64;
    // Set by the recorder when a cell's end fails: the run stops after the
    // blocks in flight and reports that failure.
    let abort = AtomicBool::new(false);

    // After a cell's sampling, its end (the last block commits, finalising
    // it: scores.csv, statistics, samples.csv, cell.json) runs on a thread of
    // its own, and the recorder records the cells in order (run.json), while
    // the next cells sample (see `recorder`).
    let mut main_serial = Vec::with_capacity(cells.len());
    let recorded = std::thread::scope(|fin| -> Result<Recorded, StudyError> {
        let recorder = Recorder::start(fin, out, t0, meta, &abort);
        for (ci, cell) in cells.iter().enumerate() {
            let t_iter = Instant::now();
            let dir = cell_dir(out, &cell.id.dir);
            if opts.shard.is_none() && cell_complete(&dir) {
                let checked = tidy_complete_cell(&dir)
                    .map_err(|source| StudyError::RunDir {
                        context: format!("cannot tidy cell {}", cell.id.dir),
                        source,
                    })
                    .and_then(|()| {
                        verify_cell(&dir).map_err(|source| StudyError::RunDir {
                            context: format!(
                                "cell {} is complete but does not verify",
                                cell.id.dir
                            ),
                            source,
                        })
                    })
                    .and_then(|_| read_cell_meta(&dir));
                let aborted = abort.load(Ordering::SeqCst);
                let handed = match checked {
                    Ok(cm) => recorder.send(Record::Complete(cm)),
                    Err(e) => return fail(progress, recorder, out, t0, e, aborted),
                };
                if !handed {
                    return fail(progress, recorder, out, t0, StudyError::Interrupted, true);
                }
                continue;
            }
            let label = format!(
                "cell {}/{} ({} done): {}",
                ci + 1,
                cells.len(),
                ci,
                cell.id.dir
            );
            progress.cell(&label);
            fault_context::set_cell_label(cell.source.fault_label(cell));
            let blocks: Vec<_> = (0..nb)
                .filter(|&b| owned(ci, b) && !indexes[ci].done(b))
                .map(|b| block_samples(b, m.samples))
                .collect();
            let t_cell = Instant::now();
            let mut cell_steps = 0u64;
            // Blocks are committed by I/O threads while the workers compute
            // the next ones; the cell's end waits for the last commits.
            let (committer, io_threads) =
                Committer::start(fin, &dir, m.episodes, opts.commit_linger);
            let t_sampling = Instant::now();
            let stop = [opts.stop, &abort];
            let sampled = pool.install(|| {
                cell.source
                    .run_blocks(&cell.plan, &blocks, |b: BlockResult| {
                        let s: u64 = b.episodes.iter().map(|r| r.steps as u64).sum();
                        cell_steps += s;
                        steps_now += s;
                        progress.block(&label, b.samples.end - b.samples.start, s);
                        committer.submit(b)?;
                        if stop.iter().any(|s| s.load(Ordering::SeqCst)) {
                            return Err(CellError::Interrupted);
                        }
                        Ok(())
                    })
            });
            let sampling = t_sampling.elapsed();
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
                let aborted = abort.load(Ordering::SeqCst);
                let e = cell.failure(out, e);
                return fail(progress, recorder, out, t0, e, aborted);
            }
            let end = spawn_cell_end(
                fin,
                cell,
                m,
                out,
                &pool,
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
                    ..CellTiming::default()
                },
                end,
            });
            main_serial.push(t_iter.elapsed() - sampling);
            if !handed {
                return fail(progress, recorder, out, t0, StudyError::Interrupted, true);
            }
        }
        let t_drain = Instant::now();
        let (mut rec, ended) = recorder.finish();
        timing.drain = t_drain.elapsed();
        if let Err(e) = ended {
            progress.finish(false);
            rec.meta.wall_s = t0.elapsed().as_secs_f64();
            let _ = write_run_meta(out, &rec.meta);
            return Err(e);
        }
        Ok(rec)
    })?;
    let Recorded {
        mut meta,
        lines,
        cells: mut cell_timing,
        episodes,
    } = recorded;
    for (ct, serial) in cell_timing.iter_mut().zip(main_serial) {
        ct.serial = serial;
    }
    timing.cells = cell_timing;
    let t_wrap = Instant::now();
    progress.finish(true);
    meta.wall_s = t0.elapsed().as_secs_f64();
    meta.steps_per_s = steps_now as f64 / meta.wall_s;
    meta.end_time = Some(rfc3339(SystemTime::now()));
    write_run_meta(out, &meta)?;
    timing.wrap_up = t_wrap.elapsed();
    Ok(RunOutcome::Finished(Box::new(RunReport {
        meta,
        lines,
        cells: cells.len(),
        env_steps: steps_now,
        threads,
        timing,
        episodes,
        lock,
    })))
}

/// What a resume under another env than a cell started with says to do.
const RESUME_REFUSED: &str = "the cell's committed blocks were computed under the env as it \
    was then: restore it (the version of its package, the environment variables it reads), or \
    delete the cell's directory (or rerun with --force-new) to compute the cell again";

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
) -> Result<Recorded, StudyError> {
    progress.finish(false);
    let (mut rec, ended) = recorder.finish();
    rec.meta.wall_s = t0.elapsed().as_secs_f64();
    let _ = write_run_meta(out, &rec.meta);
    Err(match ended {
        Err(first) if aborted => first,
        _ => e,
    })
}

/// The environment variable that chooses how built-in envs are stepped:
/// `0` runs every cell through the lane sampler, one scalar env per lane
/// (for comparisons); unset (or `1`) runs every built-in env that
/// has a lockstep version (`rwg_envs::lockstep`) through it, all lanes of a
/// worker in one `step_many`. The results are identical either way.
pub const LOCKSTEP_VAR: &str = "RWG_LOCKSTEP";

/// Whether built-in envs run through their lockstep versions: see
/// [`LOCKSTEP_VAR`].
pub fn use_lockstep() -> bool {
    lockstep_setting().unwrap_or(true)
}

/// [`LOCKSTEP_VAR`]: `1` or unset: lockstep, `0`: the lane sampler; an
/// error naming the variable for any other value.
pub fn lockstep_setting() -> Result<bool, rwg_env::vars::VarError> {
    rwg_env::vars::switch(
        LOCKSTEP_VAR,
        true,
        "0: built-in envs one instance per lane, not in lockstep",
    )
}

/// The study `run.json` in `out` records, if it reads and records one.
fn recorded_study(out: &Path) -> Option<String> {
    read_run_meta(out).ok()?.study
}

/// Creates the run directory, or checks that the one there holds the same
/// study (to resume it), and that its `manifest.toml` still holds the study
/// `run.json` recorded. `own_manifest`: the study was read from the
/// directory's own `manifest.toml`. Returns the previous run's metadata, if
/// any.
fn prepare_dir(
    out: &Path,
    m: &Manifest,
    shard: Option<ShardMeta>,
    force_new: bool,
    own_manifest: bool,
) -> Result<Option<RunMeta>, StudyError> {
    let manifest_path = out.join(MANIFEST);
    if force_new && own_manifest {
        return Err(StudyError::Refused(format!(
            "--force-new would delete {}, the manifest given: copy it out of the directory \
             first (cp {} study.toml && rwg run study.toml --out {} --force-new)",
            manifest_path.display(),
            crate::shell::sh_path(&manifest_path),
            crate::shell::sh_path(out)
        )));
    }
    if force_new {
        for p in [CELLS, RUN_JSON, MANIFEST] {
            let p = out.join(p);
            let removed = if p.is_dir() {
                std::fs::remove_dir_all(&p)
            } else if p.exists() {
                std::fs::remove_file(&p)
            } else {
                Ok(())
            };
            removed.map_err(StudyError::io(format!("cannot remove {}", p.display())))?;
        }
    }
    let mut previous = None;
    if manifest_path.exists() {
        let old = Manifest::load(&manifest_path).map_err(|e| match recorded_study(out) {
            Some(_) => StudyError::Refused(format!(
                "{e}\n{} does not read, but run.json records the study it held: restore it \
                 (e.g. jq -r .study {} > {}) and run again",
                manifest_path.display(),
                out.join(RUN_JSON).display(),
                manifest_path.display()
            )),
            None => e.into(),
        })?;
        if out.join(RUN_JSON).exists() {
            let meta = read_run_meta(out)?;
            let edits = manifest_edits(out, &meta, &old);
            if !edits.is_empty() {
                return Err(StudyError::Refused(edited_message(out, &edits)));
            }
        } else if own_manifest {
            // No run yet: rwg would write the run's manifest over this one,
            // unless it already is the study as rwg writes it.
            let text = std::fs::read_to_string(&manifest_path).map_err(StudyError::io(format!(
                "cannot read {}",
                manifest_path.display()
            )))?;
            if text != m.to_toml() {
                return Err(StudyError::Refused(format!(
                    "{} is the manifest given and {} holds no run: rwg writes the study's \
                     resolved manifest.toml into its run directory, which would replace yours \
                     (comments and layout lost); give the run a directory of its own, e.g. \
                     --out runs/{}",
                    manifest_path.display(),
                    out.display(),
                    std::path::absolute(out)
                        .ok()
                        .and_then(|p| p.file_name().map(|n| n.to_string_lossy().into_owned()))
                        .unwrap_or_else(|| "study".into())
                )));
            }
        }
        let diffs = old.study_differences(m);
        if !diffs.is_empty() {
            return Err(StudyError::Refused(format!(
                "{} holds a different study ({}); use another --out, or --force-new to delete it and start over",
                out.display(),
                diffs.join("; ")
            )));
        }
        if out.join(RUN_JSON).exists() {
            let meta = read_run_meta(out)?;
            if meta.format < RUN_FORMAT {
                return Err(StudyError::Refused(format!(
                    "{} was written by an older rwg (run format {}, without checksums), so what it \
                     holds cannot be verified; rerun with --force-new to start over, or use another --out",
                    out.display(),
                    meta.format
                )));
            }
            if meta.shard != shard {
                let show = |s: Option<ShardMeta>| {
                    s.map_or("the whole study".into(), |s| {
                        format!("shard {}/{}", s.index, s.count)
                    })
                };
                return Err(StudyError::Refused(format!(
                    "{} holds {}, not {}; use another --out",
                    out.display(),
                    show(meta.shard),
                    show(shard)
                )));
            }
            previous = Some(meta);
        }
    } else if out.join(RUN_JSON).exists() {
        return Err(StudyError::Refused(format!(
            "{} holds a run.json but no manifest.toml; use another --out, or --force-new",
            out.display()
        )));
    }
    let cells = out.join(CELLS);
    crate::rundir::export::create_dir_all(&cells)
        .map_err(StudyError::io(format!("cannot create {}", cells.display())))?;
    Ok(previous)
}
