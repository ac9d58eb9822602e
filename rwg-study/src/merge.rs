//! Combining the shards of a study (`rwg run --shard K/N`) into one run
//! directory, byte-identical to an unsharded run's (timing metadata aside).
//! An interrupted merge into the same directory is finished by merging again:
//! blocks are copied under a temporary name and renamed, finalised cells are
//! kept, and `run.json` gets its end time last.

use crate::cells::{new_meta, plan_cells, Cell, SummaryLine};
use crate::manifest::Manifest;
use crate::rundir::block_check::{check_blocks, first_missing_owned};
use crate::rundir::blocks::{copy_block, n_blocks, BlockIndex};
use crate::rundir::checksum::verify_cell;
use crate::rundir::env_record::{check_record, write_record};
use crate::rundir::error::with_causes;
use crate::rundir::export::{rfc3339, write_atomic};
use crate::rundir::finalize::{cell_complete, tidy_complete_cell};
use crate::rundir::lock::RunLock;
use crate::rundir::meta::{
    read_cell_meta, read_run_meta, write_run_meta, CellMeta, RunMeta, ShardMeta, RUN_FORMAT,
};
use crate::rundir::verify::shard_command;
use crate::rundir::{cell_dir, CELLS, MANIFEST, RUN_JSON};
use crate::StudyError;
use std::path::{Path, PathBuf};
use std::time::SystemTime;

/// What a merge wrote.
#[derive(Debug)]
pub struct MergeReport {
    /// Shards merged.
    pub shards: u64,
    /// The merged `run.json`.
    pub meta: RunMeta,
    /// Cells finalised by an earlier, interrupted merge (kept as they were).
    pub cells_kept: usize,
    /// `out` already held this study, merged and complete: nothing was written.
    pub already_complete: bool,
    /// The lock of `out`, still held (drop it when done writing).
    pub lock: RunLock,
}

/// Checks that the directories in `shards` come from the same study and
/// together hold every block exactly once, then writes the merged run into
/// `out`, which must be empty or hold a merge of the same study (an
/// interrupted one is finished, a complete one left alone). `on_cell` is
/// called with `None` once the shards are checked and copying starts, then
/// with each cell's summary line as the cell is finalised.
pub fn merge_shards(
    shards: &[PathBuf],
    out: &Path,
    mut on_cell: impl FnMut(Option<&SummaryLine>),
) -> Result<MergeReport, StudyError> {
    // Resolved before plugin code runs (planning the cells creates each env
    // once), which may change the working directory.
    let absolute = |p: &Path| {
        std::path::absolute(p).map_err(StudyError::io(format!("cannot resolve {}", p.display())))
    };
    let shards: Vec<PathBuf> = shards
        .iter()
        .map(|d| absolute(d))
        .collect::<Result<_, _>>()?;
    let out = &absolute(out)?;
    let dirs = load_shards(&shards)?;
    let (m, count) = one_study(&dirs)?;
    let owner = shard_owners(&dirs, count)?;
    // The shards' manifests name their plugin files already: nothing to fill in.
    let cells = plan_cells(&mut m.clone())?;
    let nb = n_blocks(m.samples);
    let indexes = shard_blocks(&cells, &owner, nb)?;
    check_env_records(&cells, &owner)?;
    crate::rundir::export::create_dir_all(out)
        .map_err(StudyError::io(format!("cannot create {}", out.display())))?;
    let lock = RunLock::acquire(out)?;
    // A directory moved or deleted while the merge writes it is said so.
    let held = lock.clone();
    let merge = || -> Result<MergeReport, StudyError> {
        if let Some(previous) = check_out(out, m)? {
            if previous.end_time.is_some() {
                check_complete_merge(out)?;
                return Ok(MergeReport {
                    shards: count,
                    meta: previous,
                    cells_kept: cells.len(),
                    already_complete: true,
                    lock,
                });
            }
        }
        let mut meta = start_out(out, m, &dirs)?;
        on_cell(None);
        let mut cells_kept = 0;
        for (ci, cell) in cells.iter().enumerate() {
            let dest = cell_dir(out, &cell.id.dir);
            // A cell finalised by an interrupted merge is kept as it is.
            if cell_complete(&dest) {
                let cm = kept_cell(cell, &dest)?;
                meta.env_steps += cm.env_steps;
                meta.cells.push(cm);
                cells_kept += 1;
                continue;
            }
            copy_cell_blocks(cell, &dest, &indexes[ci], ci, nb)?;
            let (cm, totals) = cell.finalize(m, out, 0.0, false, &[])?;
            on_cell(Some(&cell.summary_line(&totals.means, None)));
            meta.env_steps += cm.env_steps;
            meta.cells.push(cm);
            write_run_meta(out, &meta)?;
        }
        finish_meta(out, &mut meta)?;
        Ok(MergeReport {
            shards: count,
            meta,
            cells_kept,
            already_complete: false,
            lock,
        })
    };
    merge().map_err(|e| crate::runner::moved_away(&held, out, e))
}

/// A shard directory given to the merge: its path, manifest and `run.json`.
type Shard = (PathBuf, Manifest, RunMeta);

fn refuse<T>(msg: String) -> Result<T, StudyError> {
    Err(StudyError::Refused(msg))
}

/// Reads each shard directory's manifest and `run.json`, refusing one whose
/// manifest was edited, that holds a whole run, or that has no checksums.
fn load_shards(shards: &[PathBuf]) -> Result<Vec<Shard>, StudyError> {
    let mut dirs = vec![];
    for d in shards {
        let m = Manifest::load(&d.join(MANIFEST)).map_err(|source| StudyError::NotARunDir {
            dir: d.clone(),
            source,
        })?;
        let meta = read_run_meta(d)?;
        let edits = crate::rundir::study::manifest_edits(d, &meta, &m);
        if !edits.is_empty() {
            return refuse(crate::rundir::study::edited_message(d, &edits));
        }
        if meta.shard.is_none() {
            return refuse(format!("{} holds a whole run, not a shard", d.display()));
        }
        if meta.format < RUN_FORMAT {
            return refuse(format!(
                "{} was written by an older rwg (run format {}, without checksums): its blocks \
                 cannot be verified; run the shard again with this rwg",
                d.display(),
                meta.format
            ));
        }
        dirs.push((d.clone(), m, meta));
    }
    Ok(dirs)
}

/// Checks that the shards hold one study, split into the same number of
/// shards; returns the study and that number.
fn one_study(dirs: &[Shard]) -> Result<(&Manifest, u64), StudyError> {
    let Some((first_dir, m, first_meta)) = dirs.first() else {
        return refuse("no shard directories given".into());
    };
    let count = first_meta.shard.expect("checked").count;
    for (d, other, meta) in &dirs[1..] {
        let diffs = m.study_differences(other);
        if !diffs.is_empty() {
            return refuse(format!(
                "{} and {} hold different studies: {}",
                first_dir.display(),
                d.display(),
                diffs.join("; ")
            ));
        }
        let s = meta.shard.expect("checked");
        if s.count != count {
            return refuse(format!(
                "{} is shard {}/{}, but {} is one of {count} shards",
                d.display(),
                s.index,
                s.count,
                first_dir.display()
            ));
        }
    }
    Ok((m, count))
}

/// The directory of each of the `count` shards (`[k]` holds shard `k`),
/// refusing a shard given twice or missing.
fn shard_owners(dirs: &[Shard], count: u64) -> Result<Vec<&PathBuf>, StudyError> {
    let mut owner: Vec<Option<&PathBuf>> = vec![None; count as usize];
    for (d, _, meta) in dirs {
        let k = meta.shard.expect("checked").index as usize;
        if let Some(prev) = owner[k] {
            return refuse(format!(
                "shard {k}/{count} is given twice: {} and {}",
                prev.display(),
                d.display()
            ));
        }
        owner[k] = Some(d);
    }
    let missing: Vec<String> = owner
        .iter()
        .enumerate()
        .filter(|(_, o)| o.is_none())
        .map(|(k, _)| format!("{k}/{count}"))
        .collect();
    if !missing.is_empty() {
        return refuse(format!(
            "missing shard(s) {} of {count}",
            missing.join(", ")
        ));
    }
    Ok(owner.into_iter().flatten().collect())
}

/// Checks that every shard computed its blocks of a cell under the env as
/// it is now.
fn check_env_records(cells: &[Cell], owner: &[&PathBuf]) -> Result<(), StudyError> {
    for cell in cells {
        let now = cell.env_record();
        for d in owner {
            check_record(&cell_dir(d, &cell.id.dir), &now, MERGE_REFUSED)?;
        }
    }
    Ok(())
}

/// A merge of this study in `out` that is complete counts only if
/// everything in it still verifies.
fn check_complete_merge(out: &Path) -> Result<(), StudyError> {
    let check = crate::rundir::verify::verify_run(out);
    if check.problems.is_empty() {
        return Ok(());
    }
    refuse(format!(
        "{} holds this study, merged, but its files do not verify:\n  {}\n\
         delete the damaged cell directories and merge again",
        out.display(),
        check.problems.join("\n  ")
    ))
}

/// Writes the merged run's `cells/` folder and manifest; returns its
/// `run.json` as it starts (no cells), timed from the shards'.
fn start_out(out: &Path, m: &Manifest, dirs: &[Shard]) -> Result<RunMeta, StudyError> {
    let cells_dir = out.join(CELLS);
    crate::rundir::export::create_dir_all(&cells_dir).map_err(StudyError::io(format!(
        "cannot create {}",
        cells_dir.display()
    )))?;
    let manifest_path = out.join(MANIFEST);
    write_atomic(&manifest_path, m.to_toml().as_bytes()).map_err(StudyError::io(format!(
        "cannot write {}",
        manifest_path.display()
    )))?;
    let threads = dirs.iter().map(|s| s.2.threads).max().unwrap_or(1);
    let start = dirs
        .iter()
        .map(|s| s.2.start_time.clone())
        .min()
        .unwrap_or_default();
    let mut meta = new_meta(m, threads, start, None);
    meta.wall_s = dirs.iter().map(|s| s.2.wall_s).sum();
    Ok(meta)
}

/// A cell an interrupted merge finalised: tidied, verified, its metadata.
fn kept_cell(cell: &Cell, dest: &Path) -> Result<CellMeta, StudyError> {
    tidy_complete_cell(dest).map_err(|source| StudyError::RunDir {
        context: format!("cannot tidy cell {}", cell.id.dir),
        source,
    })?;
    verify_cell(dest).map_err(|source| StudyError::RunDir {
        context: format!("cell {} of the earlier merge does not verify", cell.id.dir),
        source,
    })?;
    read_cell_meta(dest)
}

/// Copies the blocks of cell `ci` that `dest` lacks from the shards that
/// own them (`indexes[k]`: shard `k`'s index of the cell), after recording
/// (or checking) the env the cell is merged under.
fn copy_cell_blocks(
    cell: &Cell,
    dest: &Path,
    indexes: &[BlockIndex],
    ci: usize,
    nb: u64,
) -> Result<(), StudyError> {
    let now = cell.env_record();
    if !check_record(dest, &now, MERGE_REFUSED)? {
        write_record(dest, &now)?;
    }
    let dest_index = BlockIndex::load(dest).map_err(|source| StudyError::RunDir {
        context: format!("cannot read the block index of {}", dest.display()),
        source,
    })?;
    let count = indexes.len() as u64;
    for b in 0..nb {
        if dest_index.done(b) {
            continue; // copied (and checked) by an interrupted merge
        }
        let k = ((ci as u64 * nb + b) % count) as usize;
        copy_block(&indexes[k], dest, b).map_err(|source| StudyError::RunDir {
            context: format!("cannot merge block {b} of cell {}", cell.id.dir),
            source,
        })?;
    }
    Ok(())
}

/// Writes the merged `run.json` with its speed and end time, last.
fn finish_meta(out: &Path, meta: &mut RunMeta) -> Result<(), StudyError> {
    meta.steps_per_s = if meta.wall_s > 0.0 {
        meta.env_steps as f64 / meta.wall_s
    } else {
        0.0
    };
    meta.end_time = Some(rfc3339(SystemTime::now()));
    write_run_meta(out, meta)?;
    Ok(())
}

/// The block index of every cell (outer) in every shard (inner, `owner[k]`
/// holds shard `k`), once each shard's cell has passed the check `rwg
/// verify` makes ([`check_blocks`]: every block it lists is there with its
/// digest) and holds every block it owns.
fn shard_blocks(
    cells: &[Cell],
    owner: &[&PathBuf],
    nb: u64,
) -> Result<Vec<Vec<BlockIndex>>, StudyError> {
    let count = owner.len() as u64;
    let shard = |k: usize| ShardMeta {
        index: k as u64,
        count,
    };
    let mut indexes: Vec<Vec<BlockIndex>> = vec![];
    for cell in cells {
        let mut per_shard = vec![];
        for (k, d) in owner.iter().enumerate() {
            let dir = cell_dir(d, &cell.id.dir);
            let check = check_blocks(&dir).map_err(|source| StudyError::RunDir {
                context: format!("cannot read the block index of {}", dir.display()),
                source,
            })?;
            if !check.problems.is_empty() {
                let list: Vec<String> = check.problems.iter().map(|p| with_causes(p)).collect();
                return refuse(format!(
                    "shard {k}/{count} ({}) does not verify:\n  {}\nrun it again to compute \
                     these blocks again: {}",
                    d.display(),
                    list.join("\n  "),
                    shard_command(d, shard(k))
                ));
            }
            per_shard.push(check.index);
        }
        indexes.push(per_shard);
    }
    for (ci, cell) in cells.iter().enumerate() {
        for (k, d) in owner.iter().enumerate() {
            if let Some(b) = first_missing_owned(&indexes[ci][k], shard(k), ci, nb) {
                return refuse(format!(
                    "shard {k}/{count} ({}) is incomplete: block {b} of cell {} is missing; \
                     finish it with {}",
                    d.display(),
                    cell.id.dir,
                    shard_command(d, shard(k))
                ));
            }
        }
    }
    Ok(indexes)
}

/// What a merge under another env than a shard's cell started with says to do.
const MERGE_REFUSED: &str = "a merged cell's blocks must all be computed under the env as it \
    is where the merge runs: merge where the env is as it was, or compute the shard's cell again \
    under this env (delete its directory and rerun the shard)";

/// Checks that `out` is empty or holds a merge of study `m`; returns that
/// merge's metadata, if it got as far as writing `run.json`.
fn check_out(out: &Path, m: &Manifest) -> Result<Option<RunMeta>, StudyError> {
    if !crate::rundir::clear::holds_run(out) {
        if let Some(why) = crate::rundir::clear::foreign_message(out, false) {
            return refuse(why);
        }
    }
    let manifest_path = out.join(MANIFEST);
    if !manifest_path.exists() {
        if out.join(RUN_JSON).exists() {
            return refuse(format!(
                "{} holds a run.json but no manifest.toml; choose another --out",
                out.display()
            ));
        }
        return Ok(None);
    }
    let old = Manifest::load(&manifest_path)?;
    // An edited manifest.toml is said so before it is compared with the shards'.
    let meta = match out.join(RUN_JSON).exists() {
        true => Some(read_run_meta(out)?),
        false => None,
    };
    if let Some(meta) = &meta {
        let edits = crate::rundir::study::manifest_edits(out, meta, &old);
        if !edits.is_empty() {
            return refuse(crate::rundir::study::edited_message(out, &edits));
        }
    }
    let diffs = old.study_differences(m);
    if !diffs.is_empty() {
        return refuse(format!(
            "{} already holds a different study ({}); choose another --out",
            out.display(),
            diffs.join("; ")
        ));
    }
    let Some(meta) = meta else {
        return Ok(None);
    };
    if let Some(s) = meta.shard {
        return refuse(format!(
            "{} holds shard {}/{} of the study, not a merged run; choose another --out",
            out.display(),
            s.index,
            s.count
        ));
    }
    Ok(Some(meta))
}
