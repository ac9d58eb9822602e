//! Running a study: the manifest's cells, block by block, into a run
//! directory, resumable and shardable.
//!
//! [`run_study`] plans the cells, prepares (or resumes) the directory
//! (`setup`), runs every block it owns through the sampler of its cell's
//! [`EnvSource`](crate::env_source::EnvSource) and commits each one
//! ([`rundir::blocks`](crate::rundir::blocks)), finalises complete cells and
//! keeps `run.json` current (`cell_loop`). What it reports while running
//! goes to a [`Progress`]; the caller prints.

mod cell_loop;
mod setup;

use crate::cells::{new_meta, plan_cells, Cell, SummaryLine};
use crate::manifest::Manifest;
use crate::recorder::Recorded;
use crate::rundir::data::KeptEpisodes;
use crate::rundir::export::rfc3339;
use crate::rundir::lock::RunLock;
use crate::rundir::meta::{write_run_meta, RunMeta, ShardMeta};
use crate::timing::RunTiming;
use crate::StudyError;
use cell_loop::{run_cells, Sampled, Session};
use setup::{open_dir, own_manifest, thread_count, worker_pool, Opened, Work};
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use std::time::{Duration, Instant, SystemTime};

/// How to run a study.
#[derive(Debug, Clone)]
pub struct RunOptions<'a> {
    /// The run directory.
    pub out: PathBuf,
    /// Compute only this shard (every N-th block across all cells).
    pub shard: Option<ShardMeta>,
    /// Delete the run the directory holds (every file it wrote, nothing
    /// else: [`crate::rundir::clear`]) and start over.
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
    let absolute = absolute_options(opts)?;
    let opts = &absolute;
    let out = &opts.out;
    let own_manifest = own_manifest(opts);
    let cells = plan_cells(m)?;
    progress.planned(&cells);
    let m = &*m;
    let threads = thread_count(m);
    let (lock, previous) = match open_dir(m, opts, own_manifest)? {
        Opened::Complete(lock) => return Ok(RunOutcome::AlreadyComplete(lock)),
        Opened::Ready { lock, previous } => (lock, previous),
    };
    // A run directory moved or deleted while the run writes it is said so.
    let held = lock.clone();
    let run = || -> Result<RunOutcome, StudyError> {
        let pool = worker_pool(threads)?;
        let work = Work::load(out, m, opts.shard, &cells, progress)?;
        let todo = work.todo(out, &cells);
        work.record_envs(out, &cells)?;
        progress.start(todo);
        timing.setup = t_setup.elapsed();
        let t0 = Instant::now();
        let meta = start_meta(m, threads, opts.shard, out, previous.as_deref())?;
        let abort = AtomicBool::new(false);
        let session = Session {
            m,
            opts,
            cells: &cells,
            work: &work,
            pool: &pool,
            t0,
            abort: &abort,
        };
        let Sampled {
            recorded,
            steps,
            serial,
            drain,
        } = run_cells(&session, meta, progress)?;
        timing.drain = drain;
        let Recorded {
            meta,
            lines,
            cells: mut cell_timing,
            episodes,
        } = recorded;
        for (ct, serial) in cell_timing.iter_mut().zip(serial) {
            ct.serial = serial;
        }
        timing.cells = cell_timing;
        let t_wrap = Instant::now();
        progress.finish(true);
        let meta = end_meta(out, meta, t0, steps)?;
        timing.wrap_up = t_wrap.elapsed();
        Ok(RunOutcome::Finished(Box::new(RunReport {
            meta,
            lines,
            cells: cells.len(),
            env_steps: steps,
            threads,
            timing,
            episodes,
            lock,
        })))
    };
    run().map_err(|e| moved_away(&held, out, e))
}

/// `e`, the error a run stopped with, or if the run directory `out` was
/// moved or deleted while the run wrote it (the writers' lock tells), that.
pub(crate) fn moved_away(lock: &RunLock, out: &Path, e: StudyError) -> StudyError {
    let Some(now) = lock.moved_from(out) else {
        return e;
    };
    if matches!(e, StudyError::Interrupted) {
        return e;
    }
    let what = match now {
        Some(p) => format!(
            "moved while this run was writing it: it is now {}, with every block committed \
             before; resume it there: {}",
            p.display(),
            crate::rundir::study::resume_command(&p)
        ),
        None => "deleted (or moved to another file system) while this run was writing it; \
                 rwg cannot tell where its committed blocks went"
            .into(),
    };
    // (the write that failed: the last two of the error's causes, the
    // file and why)
    let mut at: &dyn std::error::Error = &e;
    while let Some(s) = at.source().filter(|s| s.source().is_some()) {
        at = s;
    }
    StudyError::Refused(format!(
        "{} was {what}. (The write that failed: {})",
        out.display(),
        crate::rundir::error::with_causes(at)
    ))
}

/// `opts` with its paths made absolute against the working directory now,
/// before plugin code runs: a plugin that changes the working directory
/// (in `create`, say) moves nothing rwg writes or reads.
fn absolute_options<'a>(opts: &RunOptions<'a>) -> Result<RunOptions<'a>, StudyError> {
    let absolute = |p: &Path| {
        std::path::absolute(p).map_err(StudyError::io(format!("cannot resolve {}", p.display())))
    };
    Ok(RunOptions {
        out: absolute(&opts.out)?,
        ..opts.clone()
    })
}

/// The finished run's `run.json`, written: its wall time and speed since
/// `t0` (`steps` env steps computed), its end time.
fn end_meta(out: &Path, mut meta: RunMeta, t0: Instant, steps: u64) -> Result<RunMeta, StudyError> {
    meta.wall_s = t0.elapsed().as_secs_f64();
    meta.steps_per_s = steps as f64 / meta.wall_s;
    meta.end_time = Some(rfc3339(SystemTime::now()));
    write_run_meta(out, &meta)?;
    Ok(meta)
}

/// The run's metadata as it starts: a resumed run keeps its start time; a
/// new one writes its `run.json` (and study) before its first cell ends.
fn start_meta(
    m: &Manifest,
    threads: usize,
    shard: Option<ShardMeta>,
    out: &Path,
    previous: Option<&RunMeta>,
) -> Result<RunMeta, StudyError> {
    let mut meta = new_meta(m, threads, rfc3339(SystemTime::now()), shard);
    match previous {
        Some(p) => meta.start_time = p.start_time.clone(),
        None => write_run_meta(out, &meta)?,
    }
    Ok(meta)
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
