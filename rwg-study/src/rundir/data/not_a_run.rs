//! Telling a run directory from other folders, and saying what a folder
//! that is not one holds instead (a run being started, shards, a typo).

use super::{study_cells, RunReadError, Unfinished};
use crate::rundir::{MANIFEST, RUN_JSON};
use std::path::{Path, PathBuf};

/// Whether `dir` holds a `run.json`.
fn is_run_dir(dir: &Path) -> bool {
    dir.join(RUN_JSON).is_file()
}

/// The run directories directly inside `dir`, sorted.
fn run_dirs_in(dir: &Path) -> Vec<PathBuf> {
    let mut out: Vec<PathBuf> = std::fs::read_dir(dir)
        .into_iter()
        .flatten()
        .flatten()
        .map(|e| e.path())
        .filter(|p| is_run_dir(p))
        .collect();
    out.sort();
    out
}

/// The error for a directory without `run.json`: a run whose first cell has
/// not finished (written by an rwg that wrote `run.json` only then), or no
/// run at all, with a hint: the run directories inside it, or the
/// nearest-named run directory beside it.
pub(super) fn not_a_run_dir(dir: &Path) -> RunReadError {
    let run_json = dir.join(RUN_JSON);
    if std::fs::symlink_metadata(&run_json).is_ok() {
        // There, but not a file rwg reads: a folder or a device in its place.
        return RunReadError::Mismatch {
            path: run_json,
            message: format!(
                "not a regular file (a folder or device where rwg writes run.json); remove it, \
                 then run {} to rebuild it from the cells' own files",
                crate::rundir::study::resume_command(dir)
            ),
        };
    }
    if dir.join(MANIFEST).is_file() && dir.join(crate::rundir::CELLS).is_dir() {
        let manifest = std::fs::read_to_string(dir.join(MANIFEST)).ok();
        return RunReadError::Unfinished {
            dir: dir.to_path_buf(),
            progress: Unfinished {
                cells_done: 0,
                cells: study_cells(dir, None, manifest.as_deref()),
            },
        };
    }
    let mut first = vec![];
    if let Some(holder) = crate::rundir::lock::live_writer(dir) {
        first.push(format!(
            "{} (held by {holder})",
            crate::rundir::lock::LOCK_FILE
        ));
    }
    if dir.join(MANIFEST).is_file() {
        first.push(MANIFEST.to_string());
    }
    if !first.is_empty() {
        return RunReadError::Starting {
            dir: dir.to_path_buf(),
            what: first.join(" and "),
        };
    }
    let why = if dir.is_dir() {
        "it has no run.json"
    } else if dir.exists() {
        "it is a file"
    } else {
        "it does not exist"
    };
    let hint = nearby_runs_hint(dir);
    RunReadError::NotARunDir {
        dir: dir.to_path_buf(),
        why: why.into(),
        hint,
    }
}

/// The hint of the "not a run directory" error: the shard directories of
/// a study inside `dir`, the run directories inside it, or the
/// nearest-named run directory beside it (empty, or `; ...`).
fn nearby_runs_hint(dir: &Path) -> String {
    if let Some(run) = run_above(dir) {
        // a cell's folder or a file of a run (`rwg stats RUN/cells/C`)
        return format!(
            "; it is inside the run directory {}: give that",
            run.display()
        );
    }
    if dir.is_file() && dir.extension().is_some_and(|e| e == "toml") {
        return format!(
            "; a manifest is run with `rwg run {}`, which writes a run directory",
            crate::shell::sh_path(dir)
        );
    }
    let inside = if dir.is_dir() {
        run_dirs_in(dir)
    } else {
        vec![]
    };
    let shards = if dir.is_dir() {
        run_dirs_in(&dir.join("shards"))
    } else {
        vec![]
    };
    if !shards.is_empty() {
        // The layout of `rwg slurm`: the study's shards in DIR/shards/K.
        let q: Vec<String> = shards.iter().map(|p| crate::shell::sh_path(p)).collect();
        format!(
            "; it holds the {} shard directories of a study in shards/: `rwg status {}` shows \
             them, `rwg verify {}` checks one, `rwg merge {} --out {}` combines them",
            shards.len(),
            crate::shell::sh_path(dir),
            q[0],
            q.join(" "),
            crate::shell::sh_path(dir)
        )
    } else if !inside.is_empty() {
        let list: Vec<String> = inside
            .iter()
            .take(5)
            .map(|p| p.display().to_string())
            .collect();
        format!("; run directories inside it: {}", list.join(", "))
    } else {
        let parent = match dir.parent() {
            Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
            _ => PathBuf::from("."),
        };
        let siblings = run_dirs_in(&parent);
        let names: Vec<String> = siblings
            .iter()
            .filter_map(|p| p.file_name().map(|n| n.to_string_lossy().into_owned()))
            .collect();
        let name = dir
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        match rwg_env::suggest::nearest(&name, names.iter().map(String::as_str)) {
            Some(n) => format!("; did you mean {}?", dir.with_file_name(n).display()),
            None => String::new(),
        }
    }
}

/// The run directory that `path` (a cell's folder, a file of a run) is
/// inside, if any.
pub fn run_above(path: &Path) -> Option<&Path> {
    path.ancestors()
        .skip(1)
        .filter(|a| !a.as_os_str().is_empty())
        .find(|a| is_run_dir(a))
}

/// `Ok` when `dir` holds a `run.json` (a run or a shard's directory), else
/// the "not a run directory" error with its hint.
pub fn require_run_dir(dir: &Path) -> Result<(), RunReadError> {
    if is_run_dir(dir) {
        Ok(())
    } else {
        Err(not_a_run_dir(dir))
    }
}
