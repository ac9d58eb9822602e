//! Checking a whole run directory against its checksums (`rwg verify`).

use crate::manifest::Manifest;
use crate::rundir::block_check::{check_blocks, first_missing_owned};
use crate::rundir::blocks::{block_path, n_blocks, BlockIndex};
use crate::rundir::checksum::{self, read_sums, SUMS};
use crate::rundir::data::{check_cell_list, Run};
use crate::rundir::env_record::ENV_JSON;
use crate::rundir::error::with_causes;
use crate::rundir::meta::{read_run_meta, RunMeta, ShardMeta, RUN_FORMAT};
use crate::rundir::status::cell_dirs;
use crate::rundir::{cell_dir, BLOCKS, CELLS, MANIFEST, RUN_JSON};
use crate::shell::sh_path;
use std::path::Path;

/// What [`verify_run`] found.
#[derive(Debug, Default)]
pub struct VerifyReport {
    /// One line per cell that verified (what was checked).
    pub ok: Vec<String>,
    /// One line per problem, naming the file (and row where it applies).
    pub problems: Vec<String>,
    /// Files whose checksums were checked.
    pub files: usize,
    /// How many of `problems` are committed blocks of unfinished cells
    /// (which a resumed run checks and computes again).
    pub block_problems: usize,
}

/// Checks every committed file of the run (or shard) directory `dir`:
/// finished cells' files against their `SHA256SUMS` (and, for a whole run,
/// their rows against `run.json` and each other, as the analysis reads
/// them), and committed blocks against the block index. Every cell
/// `run.json` lists as finished must be there and verify. Block files
/// without an index line are not committed (a resumed run computes them
/// again) and are not problems. A run (or merge) that is being set up
/// ([`being_set_up`]) has its cells checked alone.
pub fn verify_run(dir: &Path) -> VerifyReport {
    let mut r = VerifyReport::default();
    let meta = match read_run_meta(dir) {
        Ok(m) => m,
        // A run (or merge) in its first moments: what it committed so far.
        Err(_) if being_set_up(dir) => {
            match cell_names(&dir.join(CELLS)) {
                Ok(names) => {
                    for name in &names {
                        verify_cell_dir(&dir.join(CELLS), name, None, &mut r);
                    }
                }
                Err(e) => r.problems.push(e),
            }
            return r;
        }
        Err(e) => {
            r.problems.push(with_causes(&e));
            return r;
        }
    };
    if meta.format < RUN_FORMAT {
        r.problems.push(format!(
            "{}: run format {}: written by an older rwg without checksums, so nothing in it \
             can be verified",
            dir.join(RUN_JSON).display(),
            meta.format
        ));
        return r;
    }
    let study = check_study(dir, &meta, &mut r);
    if meta.shard.is_none() {
        let stale = crate::rundir::derived::check_stats_files(dir, &meta);
        r.problems.extend(stale);
    }
    let cells_dir = dir.join(CELLS);
    let names = match cell_names(&cells_dir) {
        Ok(n) => n,
        Err(e) => {
            r.problems.push(e);
            return r;
        }
    };
    for c in &meta.cells {
        if !cells_dir.join(&c.id.dir).join(SUMS).is_file() {
            r.problems.push(format!(
                "{}: missing: run.json lists cell {} as finished",
                cells_dir.join(&c.id.dir).join(SUMS).display(),
                c.id.dir
            ));
        }
    }
    let run = match meta.shard {
        None => Run::open(dir).ok(),
        Some(_) => None,
    };
    let of_study: Option<std::collections::HashSet<String>> =
        study.as_ref().map(|m| cell_dirs(m).into_iter().collect());
    for name in &names {
        if of_study.as_ref().is_some_and(|s| !s.contains(name)) {
            r.ok.push(format!(
                "--  cells/{name}: not a cell of this study (no command reads it)"
            ));
            continue;
        }
        verify_cell_dir(&cells_dir, name, run.as_ref(), &mut r);
    }
    if let Some(study) = &study {
        let missing = shard_complete(dir, &meta, study);
        r.block_problems += missing.len();
        r.problems.extend(missing);
    }
    r
}

/// Whether `dir` is a run (or merge) that another rwg is setting up: no
/// `run.json` yet, and its writer, alive, holds the lock.
pub fn being_set_up(dir: &Path) -> bool {
    !dir.join(RUN_JSON).exists() && crate::rundir::lock::live_writer(dir).is_some()
}

/// Checks `manifest.toml` against the study `run.json` records, and (for a
/// whole run) `run.json`'s cell list against the study; returns the study.
fn check_study(dir: &Path, meta: &RunMeta, r: &mut VerifyReport) -> Option<Manifest> {
    let manifest = dir.join(MANIFEST);
    let study = match Manifest::load(&manifest) {
        Ok(m) => {
            let edits = crate::rundir::study::manifest_edits(dir, meta, &m);
            if !edits.is_empty() {
                r.problems
                    .push(crate::rundir::study::edited_message(dir, &edits));
            }
            Some(m)
        }
        Err(e) if meta.study.is_some() => {
            r.problems.push(format!(
                "{e} (run.json records the study it held: restore it from there)"
            ));
            None
        }
        Err(_) => None,
    };
    if meta.shard.is_none() {
        let text = std::fs::read_to_string(&manifest).ok();
        if let Err(e) = check_cell_list(dir, meta, text.as_deref()) {
            r.problems.push(with_causes(&e));
        }
    }
    study
}

/// The cell directories under `cells_dir`, sorted (none if it is missing).
fn cell_names(cells_dir: &Path) -> Result<Vec<String>, String> {
    let mut names: Vec<String> = match std::fs::read_dir(cells_dir) {
        Ok(rd) => rd
            .filter_map(|e| e.ok())
            .filter(|e| e.path().is_dir())
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .collect(),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => vec![],
        Err(e) => return Err(format!("cannot read {}: {e}", cells_dir.display())),
    };
    names.sort();
    Ok(names)
}

impl VerifyReport {
    /// Adds what `other` found.
    fn absorb(&mut self, other: VerifyReport) {
        self.ok.extend(other.ok);
        self.problems.extend(other.problems);
        self.files += other.files;
        self.block_problems += other.block_problems;
    }
}

/// How many times a cell that changed while it was checked (a run beside
/// committing its blocks or finalising it) is checked again.
const RECHECKS: usize = 8;

/// What a writer changes in a cell's folder as it commits a block or
/// finalises the cell: its `SHA256SUMS` (written last when it finishes),
/// its `blocks/` folder (removed then) and block index (a line per block).
#[derive(Debug, PartialEq)]
struct CellState {
    sums: Option<(u64, Option<std::time::SystemTime>)>,
    blocks: bool,
    index: Option<(u64, Option<std::time::SystemTime>)>,
}

impl CellState {
    fn of(cdir: &Path) -> CellState {
        let stamp = |p: &Path| {
            std::fs::metadata(p)
                .ok()
                .map(|m| (m.len(), m.modified().ok()))
        };
        CellState {
            sums: stamp(&cdir.join(SUMS)),
            blocks: cdir.join(BLOCKS).is_dir(),
            index: stamp(&cdir.join(BLOCKS).join(SUMS)),
        }
    }
}

/// Checks one cell directory ([`check_cell_dir`]) as one consistent
/// snapshot: when it finds a problem and the cell changed meanwhile (a run
/// finalised it between reading its block index and hashing the blocks,
/// say), the cell is checked again.
fn verify_cell_dir(cells_dir: &Path, name: &str, run: Option<&Run>, r: &mut VerifyReport) {
    let cdir = cells_dir.join(name);
    for attempt in 0..=RECHECKS {
        let before = CellState::of(&cdir);
        let mut one = VerifyReport::default();
        check_cell_dir(&cdir, name, run, &mut one);
        let settled = one.problems.is_empty() || CellState::of(&cdir) == before;
        if settled || attempt == RECHECKS {
            if !settled {
                one.problems.push(format!(
                    "{}: the cell changed each of the {} times it was checked (a run is \
                     writing it): the problems above may be its writes in flight; run rwg \
                     verify again once the run is done",
                    cdir.display(),
                    RECHECKS + 1
                ));
            }
            r.absorb(one);
            return;
        }
    }
}

/// Checks one cell directory: a finished cell's files against its
/// `SHA256SUMS` (and its rows, as the analysis reads them, when `run` lists
/// it), an unfinished one's committed blocks (a finished one's are left
/// over, removed by the writer that finalised it or by the next run).
fn check_cell_dir(cdir: &Path, name: &str, run: Option<&Run>, r: &mut VerifyReport) {
    let before = r.problems.len();
    let mut what = vec![];
    let sums = read_sums(&cdir.join(SUMS), true);
    // A finalised cell's blocks are what finalising has yet to remove: a
    // writer removing them is not a damaged cell.
    let finalised = !matches!(sums, Ok(None));
    match sums {
        Ok(Some(sums)) => {
            for (file, d) in &sums {
                r.files += 1;
                if let Err(e) = checksum::verify_file(cdir, file, d) {
                    r.problems.push(with_causes(&e));
                }
            }
            what.push(format!("{} files", sums.len()));
            if cdir.join(ENV_JSON).is_file() && !sums.contains_key(ENV_JSON) {
                what.push(format!(
                    "{ENV_JSON} unchecked (finished by an rwg that did not list it)"
                ));
            }
            // The rows, as stats and report read them.
            let listed = run.and_then(|run| {
                run.meta
                    .cells
                    .iter()
                    .find(|c| c.id.dir == name)
                    .map(|c| (run, c))
            });
            if let (Some((run, c)), true) = (listed, r.problems.len() == before) {
                if let Err(e) = run.load_cell(c) {
                    r.problems.push(with_causes(&e));
                }
            }
        }
        Ok(None) => {}
        Err(e) => r.problems.push(with_causes(&e)),
    }
    let blocks = match finalised {
        true => Ok((0, 0)),
        false => verify_blocks(cdir),
    };
    match blocks {
        Ok((0, 0)) => {}
        Ok((n, uncommitted)) => {
            r.files += n;
            what.push(format!("{n} committed blocks"));
            if uncommitted > 0 {
                what.push(format!("{uncommitted} uncommitted (to be computed again)"));
            }
        }
        Err(problems) => {
            r.block_problems += problems.len();
            r.problems.extend(problems)
        }
    }
    if r.problems.len() == before {
        r.ok.push(format!(
            "ok  cells/{name}: {}",
            if what.is_empty() {
                "nothing committed yet".to_string()
            } else {
                what.join(", ")
            }
        ));
    }
}

/// Checks a cell's committed blocks ([`check_blocks`], as `rwg merge` does);
/// returns (committed, uncommitted files).
fn verify_blocks(cell_dir: &Path) -> Result<(usize, usize), Vec<String>> {
    if !cell_dir.join(BLOCKS).is_dir() {
        return Ok((0, 0));
    }
    let check = check_blocks(cell_dir).map_err(|e| vec![with_causes(&e)])?;
    if check.problems.is_empty() {
        Ok((check.committed, check.uncommitted))
    } else {
        Err(check.problems.iter().map(|p| with_causes(p)).collect())
    }
}

/// For a shard `run.json` marks finished: every block it owns, as `rwg
/// merge` requires of it, one problem per cell that lacks one.
fn shard_complete(dir: &Path, meta: &RunMeta, study: &Manifest) -> Vec<String> {
    let (Some(shard), Some(_)) = (meta.shard, &meta.end_time) else {
        return vec![];
    };
    let nb = n_blocks(study.samples);
    let mut out = vec![];
    for (ci, cell) in cell_dirs(study).iter().enumerate() {
        let cdir = cell_dir(dir, cell);
        let Ok(index) = BlockIndex::load(&cdir) else {
            continue; // named by the cell's own check
        };
        // (A block listed but gone is named by the cell's own check.)
        let missing = first_missing_owned(&index, shard, ci, nb).filter(|&b| !index.is_listed(b));
        if let Some(b) = missing {
            out.push(format!(
                "{}: missing: shard {}/{} is marked finished in run.json, but block {b} of \
                 cell {cell}, which it owns, is not committed; {} computes it again",
                block_path(&cdir, b).display(),
                shard.index,
                shard.count,
                shard_command(dir, shard)
            ));
        }
    }
    out
}

/// `rwg run DIR/manifest.toml --shard K/N --out DIR`, quoted.
pub fn shard_command(dir: &Path, shard: ShardMeta) -> String {
    format!(
        "rwg run {} --shard {}/{} --out {}",
        sh_path(&dir.join(MANIFEST)),
        shard.index,
        shard.count,
        sh_path(dir)
    )
}

#[cfg(test)]
mod tests;
