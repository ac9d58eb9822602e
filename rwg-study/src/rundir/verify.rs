//! Checking a whole run directory against its checksums (`rwg verify`).

use crate::rundir::blocks::BlockIndex;
use crate::rundir::checksum::{self, read_sums, SUMS};
use crate::rundir::data::Run;
use crate::rundir::meta::{read_run_meta, RUN_FORMAT};
use std::path::{Path, PathBuf};

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
/// again) and are not problems.
pub fn verify_run(dir: &Path) -> VerifyReport {
    let mut r = VerifyReport::default();
    let meta = match read_run_meta(dir) {
        Ok(m) => m,
        Err(e) => {
            r.problems.push(format!("{e:#}"));
            return r;
        }
    };
    if meta.format < RUN_FORMAT {
        r.problems.push(format!(
            "{}: run format {}: written by an older rwg without checksums, so nothing in it \
             can be verified",
            dir.join(crate::rundir::RUN_JSON).display(),
            meta.format
        ));
        return r;
    }
    // manifest.toml against the study run.json records (when it records one).
    if meta.study.is_some() {
        let manifest = dir.join(crate::rundir::MANIFEST);
        match crate::manifest::Manifest::load(&manifest) {
            Ok(m) => {
                let edits = crate::rundir::study::manifest_edits(dir, &meta, &m);
                if !edits.is_empty() {
                    r.problems
                        .push(crate::rundir::study::edited_message(dir, &edits));
                }
            }
            Err(e) => r.problems.push(format!(
                "{e} (run.json records the study it held: restore it from there)"
            )),
        }
    }
    let cells_dir = dir.join("cells");
    let mut names: Vec<String> = match std::fs::read_dir(&cells_dir) {
        Ok(rd) => rd
            .filter_map(|e| e.ok())
            .filter(|e| e.path().is_dir())
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .collect(),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => vec![],
        Err(e) => {
            r.problems
                .push(format!("cannot read {}: {e}", cells_dir.display()));
            return r;
        }
    };
    names.sort();
    for c in &meta.cells {
        if !cells_dir.join(&c.id.dir).join(SUMS).is_file() {
            r.problems.push(format!(
                "{}: missing: run.json lists cell {} as finished",
                cells_dir.join(&c.id.dir).join(SUMS).display(),
                c.id.dir
            ));
        }
    }
    let run = if meta.shard.is_none() {
        Run::open(dir).ok()
    } else {
        None
    };
    for name in &names {
        let cdir = cells_dir.join(name);
        let before = r.problems.len();
        let mut what = vec![];
        match read_sums(&cdir.join(SUMS), true) {
            Ok(Some(sums)) => {
                for (file, d) in &sums {
                    r.files += 1;
                    if let Err(e) = checksum::verify_file(&cdir, file, d) {
                        r.problems.push(e.to_string());
                    }
                }
                what.push(format!("{} files", sums.len()));
                // The rows, as stats and report read them.
                let listed = run.as_ref().and_then(|run| {
                    run.meta
                        .cells
                        .iter()
                        .find(|c| &c.id.dir == name)
                        .map(|c| (run, c))
                });
                if let (Some((run, c)), true) = (listed, r.problems.len() == before) {
                    if let Err(e) = run.load_cell(c) {
                        r.problems.push(e.to_string());
                    }
                }
            }
            Ok(None) => {}
            Err(e) => r.problems.push(e.to_string()),
        }
        match verify_blocks(&cdir) {
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
    r
}

/// Checks a cell's committed blocks; returns (committed, uncommitted files).
fn verify_blocks(cell_dir: &Path) -> Result<(usize, usize), Vec<String>> {
    let bdir = cell_dir.join("blocks");
    if !bdir.is_dir() {
        return Ok((0, 0));
    }
    let index = BlockIndex::load(cell_dir).map_err(|e| vec![e.to_string()])?;
    let mut files: Vec<PathBuf> = std::fs::read_dir(&bdir)
        .map_err(|e| vec![format!("cannot read {}: {e}", bdir.display())])?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            p.file_name()
                .and_then(|n| n.to_str())
                .is_some_and(|n| n.starts_with('b') && n.ends_with(".csv"))
        })
        .collect();
    files.sort();
    let (mut n, mut uncommitted, mut problems) = (0, 0, vec![]);
    for f in files {
        let b: Option<u64> = f
            .file_stem()
            .and_then(|s| s.to_str())
            .and_then(|s| s[1..].parse().ok());
        match b.and_then(|b| index.digest(b)) {
            Some(d) => {
                n += 1;
                let got = checksum::hash_file(&f);
                match got {
                    Ok(got) => {
                        if let Err(e) = checksum::check(&f, d, &got) {
                            problems.push(e.to_string());
                        }
                    }
                    Err(e) => problems.push(format!("cannot read {}: {e}", f.display())),
                }
            }
            None => uncommitted += 1,
        }
    }
    if problems.is_empty() {
        Ok((n, uncommitted))
    } else {
        Err(problems)
    }
}
