//! A run's set-up: the run directory created, or checked to hold the same
//! study and resumed; the blocks each cell still owes (its block index,
//! checked against what is on disk); the env each cell started under.

use super::{Progress, RunOptions};
use crate::cells::Cell;
use crate::manifest::Manifest;
use crate::rundir::blocks::{block_samples, cell_complete, n_blocks, BlockIndex};
use crate::rundir::checksum::SUMS;
use crate::rundir::clear::{clear_run, foreign_message, holds_run};
use crate::rundir::env_record::{check_record, write_record};
use crate::rundir::export::write_atomic;
use crate::rundir::lock::RunLock;
use crate::rundir::meta::{read_run_meta, RunMeta, ShardMeta, RUN_FORMAT};
use crate::rundir::study::{edited_message, manifest_edits};
use crate::rundir::{cell_dir, BLOCKS, CELLS, MANIFEST, RUN_JSON};
use crate::StudyError;
use std::ops::Range;
use std::path::Path;

/// The worker threads a run uses: the manifest's `threads`, else one per
/// core (at most [`crate::limits::MAX_THREADS`]).
pub(super) fn thread_count(m: &Manifest) -> usize {
    m.threads.unwrap_or_else(|| {
        std::thread::available_parallelism()
            .map_or(1, |n| n.get())
            .min(crate::limits::MAX_THREADS)
    })
}

/// The run directory, opened by [`open_dir`].
pub(super) enum Opened {
    /// It holds this study, finished, and everything in it verifies.
    Complete(RunLock),
    /// It is ready to run into: locked, the study's manifest written.
    Ready {
        /// The run directory's lock.
        lock: RunLock,
        /// The previous run's metadata, if any (a resume).
        previous: Option<Box<RunMeta>>,
    },
}

/// Whether the manifest the study was read from is the run directory's
/// own `manifest.toml`: then it is the study, never rewritten. (Asked
/// before plugin code runs, which may change the working directory a
/// relative manifest path is resolved against.)
pub(super) fn own_manifest(opts: &RunOptions<'_>) -> bool {
    opts.manifest_file
        .is_some_and(|f| crate::rundir::export::same_file(f, &opts.out.join(MANIFEST)))
}

/// Creates and locks the run directory `opts.out`, prepares it for the study
/// `m` ([`prepare_dir`]), says whether it is complete already, and writes
/// the study's `manifest.toml` (unless it was read from there:
/// `own_manifest`, see [`own_manifest`]).
pub(super) fn open_dir(
    m: &Manifest,
    opts: &RunOptions<'_>,
    own_manifest: bool,
) -> Result<Opened, StudyError> {
    let out = &opts.out;
    crate::rundir::export::create_dir_all(out)
        .map_err(StudyError::io(format!("cannot create {}", out.display())))?;
    let lock = RunLock::acquire(out)?;
    let manifest_path = out.join(MANIFEST);
    let previous = prepare_dir(out, m, opts.shard, opts.force_new, own_manifest)?;
    if previous.as_ref().is_some_and(|p| p.end_time.is_some()) {
        // Complete only if everything in it still verifies. Blocks that do
        // not (a shard's, say, after a crash of the machine) are computed
        // again, as in any resume.
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
            return Ok(Opened::Complete(lock));
        }
    }
    if !own_manifest {
        write_atomic(&manifest_path, m.to_toml().as_bytes()).map_err(StudyError::io(format!(
            "cannot write {}",
            manifest_path.display()
        )))?;
    }
    let previous = previous.map(Box::new);
    Ok(Opened::Ready { lock, previous })
}

/// The pool of `threads` worker threads that samples the blocks.
pub(super) fn worker_pool(threads: usize) -> Result<rayon::ThreadPool, StudyError> {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| {
            StudyError::Refused(format!(
                "cannot start {threads} worker threads: {e}; {}",
                rwg_env::text::THREAD_LIMIT_ADVICE
            ))
        })
}

/// The blocks a run owes: which it owns (all, or a shard's) and which each
/// cell's block index holds already.
pub(super) struct Work {
    /// Blocks per cell.
    nb: u64,
    /// Networks per cell.
    samples: u64,
    /// The shard this run computes, if it is one.
    shard: Option<ShardMeta>,
    /// Each cell's committed blocks, in cell order.
    indexes: Vec<BlockIndex>,
}

impl Work {
    /// Reads the block index of every cell of the run directory `out`;
    /// committed blocks that do not match their files are noted to
    /// `progress` and computed again.
    pub fn load(
        out: &Path,
        m: &Manifest,
        shard: Option<ShardMeta>,
        cells: &[Cell],
        progress: &mut dyn Progress,
    ) -> Result<Work, StudyError> {
        let mut indexes = Vec::with_capacity(cells.len());
        for c in cells {
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
        Ok(Work {
            nb: n_blocks(m.samples),
            samples: m.samples,
            shard,
            indexes,
        })
    }

    /// Whether the cell in `dir` is skipped as complete (a whole study's
    /// cell, finalised): then it is only verified.
    pub fn skips(&self, dir: &Path) -> bool {
        self.shard.is_none() && cell_complete(dir)
    }

    /// Whether this run owns block `b` of cell `ci`.
    fn owned(&self, ci: usize, b: u64) -> bool {
        self.shard.is_none_or(|s| s.owns(ci, self.nb, b))
    }

    /// The blocks of cell `ci` this run owns and has not committed.
    fn owed(&self, ci: usize) -> impl Iterator<Item = u64> + '_ {
        (0..self.nb).filter(move |&b| self.owned(ci, b) && !self.indexes[ci].done(b))
    }

    /// The networks of each block of cell `ci` to compute, in block order.
    pub fn blocks(&self, ci: usize) -> Vec<Range<u64>> {
        self.owed(ci)
            .map(|b| block_samples(b, self.samples))
            .collect()
    }

    /// Networks this run computes, over all `cells` of the run directory `out`.
    pub fn todo(&self, out: &Path, cells: &[Cell]) -> u64 {
        cells
            .iter()
            .enumerate()
            .map(|(ci, c)| {
                if self.skips(&cell_dir(out, &c.id.dir)) {
                    return 0;
                }
                self.owed(ci)
                    .map(|b| block_samples(b, self.samples).count() as u64)
                    .sum()
            })
            .sum()
    }

    /// Every block of a cell is computed under the env its first block was:
    /// the env as the cells start is recorded, and a resume under another
    /// env is refused before anything runs.
    pub fn record_envs(&self, out: &Path, cells: &[Cell]) -> Result<(), StudyError> {
        for (ci, c) in cells.iter().enumerate() {
            let dir = cell_dir(out, &c.id.dir);
            let works = !self.skips(&dir) && self.owed(ci).next().is_some();
            if works {
                let now = c.env_record();
                if !check_record(&dir, &now, RESUME_REFUSED)? {
                    write_record(&dir, &now)?;
                }
            }
        }
        Ok(())
    }
}

/// What a resume under another env than a cell started with says to do.
const RESUME_REFUSED: &str = "the cell's committed blocks were computed under the env as it \
    was then: restore it (the version of its package, the environment variables it reads), or \
    delete the cell's directory (or rerun with --force-new) to compute the cell again";

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
    if !holds_run(out) {
        if let Some(why) = foreign_message(out, own_manifest) {
            return Err(StudyError::Refused(why));
        }
    } else if force_new {
        clear_old_run(out)?;
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
            previous = Some(resumable_meta(out, shard)?);
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

/// Deletes what `--force-new` starts over from: every file the old run in
/// `out` wrote (see [`clear_run`]), its statistics, figures and report
/// included. What rwg did not write is kept, and named: the run stops
/// until it is moved out of `cells/` and `figures/`.
fn clear_old_run(out: &Path) -> Result<(), StudyError> {
    let kept = clear_run(out).map_err(StudyError::io(format!(
        "--force-new cannot clear {}",
        out.display()
    )))?;
    if kept.is_empty() {
        return Ok(());
    }
    let list: Vec<String> = kept.iter().map(|p| p.display().to_string()).collect();
    Err(StudyError::Refused(format!(
        "--force-new removed the old run's files from {} but kept {} (not written by rwg, \
         so not deleted); move {} out of the run directory and run again",
        out.display(),
        list.join(", "),
        if kept.len() == 1 { "it" } else { "them" },
    )))
}

/// The `run.json` of the run directory `out`, which holds this study, if a
/// run of `shard` (or of the whole study) written with checksums can resume
/// from it.
fn resumable_meta(out: &Path, shard: Option<ShardMeta>) -> Result<RunMeta, StudyError> {
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
    Ok(meta)
}
