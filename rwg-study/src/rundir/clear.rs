//! What `--force-new` removes, and what a directory that holds no run may
//! hold before a run starts in it.
//!
//! [`clear_run`] removes the files of a run directory's layout that rwg
//! writes: the study, `run.json`, every cell's files and blocks (by their
//! names and the cells' indexes), the statistics, figures and report, and
//! their temporary files; nothing else. [`foreign_entries`] names what a
//! directory without a run holds under the names of a run's layout: a run
//! started there would mix its files with them, or take them for its own.

use crate::rundir::blocks::block_index;
use crate::rundir::checksum::SUMS;
use crate::rundir::env_record::ENV_JSON;
use crate::rundir::export::tmp_path;
use crate::rundir::{
    BLOCKS, CELLS, CELL_JSON, FIGURES, MANIFEST, REPORT_HTML, RUN_JSON, SAMPLES_CSV, SCORES_CSV,
    STATS_CSV, STATS_JSON,
};
use std::io;
use std::path::{Path, PathBuf};

/// The files rwg writes at the top of a run directory (`rwg.lock` aside:
/// the writer holds it).
const RUN_FILES: [&str; 5] = [MANIFEST, RUN_JSON, STATS_JSON, STATS_CSV, REPORT_HTML];

/// The files rwg writes in a cell's folder.
const CELL_FILES: [&str; 5] = [SCORES_CSV, SAMPLES_CSV, CELL_JSON, ENV_JSON, SUMS];

/// An I/O error naming its path.
fn at(path: &Path) -> impl FnOnce(io::Error) -> io::Error + '_ {
    move |e| io::Error::new(e.kind(), format!("cannot remove {}: {e}", path.display()))
}

/// Whether `dir` holds a run (or the start of one): `run.json`, or the
/// study's `manifest.toml` beside `cells/` (a run writes `cells/` first).
pub fn holds_run(dir: &Path) -> bool {
    dir.join(RUN_JSON).is_file() || (dir.join(MANIFEST).is_file() && dir.join(CELLS).is_dir())
}

/// Removes `path` and its temporary file if they are files (not folders,
/// which rwg never writes under these names).
fn remove_file_and_tmp(path: &Path) -> io::Result<()> {
    for p in [path.to_path_buf(), tmp_path(path)] {
        if p.symlink_metadata().is_ok_and(|m| !m.is_dir()) {
            std::fs::remove_file(&p).map_err(at(&p))?;
        }
    }
    Ok(())
}

/// Removes the files named `rwg_names` says are rwg's (and their
/// temporary files) from folder `dir`, then `dir` itself if that leaves it
/// empty; what is left is pushed to `kept`.
fn clear_folder(
    dir: &Path,
    rwg_names: &dyn Fn(&str) -> bool,
    kept: &mut Vec<PathBuf>,
) -> io::Result<()> {
    let entries = match std::fs::read_dir(dir) {
        Ok(rd) => rd,
        Err(e) if e.kind() == io::ErrorKind::NotFound => return Ok(()),
        Err(e) => {
            return Err(io::Error::new(
                e.kind(),
                format!("cannot read {}: {e}", dir.display()),
            ))
        }
    };
    for e in entries {
        let e = e.map_err(at(dir))?;
        let path = e.path();
        let name = e.file_name();
        let name = name.to_str().unwrap_or("");
        let base = name.strip_suffix(".tmp").unwrap_or(name);
        let is_file = e.file_type().is_ok_and(|t| !t.is_dir());
        if is_file && rwg_names(base) {
            std::fs::remove_file(&path).map_err(at(&path))?;
        } else {
            kept.push(path);
        }
    }
    // (a folder that is a symbolic link, the user's way to put the data on
    // another disk, is kept: emptied of rwg's files)
    if dir
        .symlink_metadata()
        .is_ok_and(|m| m.file_type().is_symlink())
    {
        return Ok(());
    }
    match std::fs::remove_dir(dir) {
        Err(e) if e.kind() != io::ErrorKind::DirectoryNotEmpty => Err(at(dir)(e)),
        _ => Ok(()),
    }
}

/// Removes a cell folder's files: its blocks and their index, its final
/// files; the folder if that empties it.
fn clear_cell(cell: &Path, kept: &mut Vec<PathBuf>) -> io::Result<()> {
    let blocks = cell.join(BLOCKS);
    if blocks.is_dir() {
        clear_folder(&blocks, &|n| n == SUMS || block_index(n).is_some(), kept)?;
    }
    // (blocks/ itself is kept only if something not rwg's is in it)
    let mut inner = vec![];
    clear_folder(cell, &|n| CELL_FILES.contains(&n), &mut inner)?;
    kept.extend(inner.into_iter().filter(|p| *p != blocks));
    Ok(())
}

/// Removes what the run in `dir` wrote: `manifest.toml`, `run.json`, every
/// cell's files and blocks, `stats.json`, `stats.csv`, `report.html`, the
/// figures (`.svg`, `.png`) in `figures/`, and their temporary files;
/// folders left empty go too. Returns what it kept (found under `cells/` or
/// `figures/` but not written by rwg), which the caller names.
pub fn clear_run(dir: &Path) -> io::Result<Vec<PathBuf>> {
    let mut kept = vec![];
    for f in RUN_FILES {
        remove_file_and_tmp(&dir.join(f))?;
    }
    let figures = dir.join(FIGURES);
    if figures.is_dir() {
        clear_folder(
            &figures,
            &|n| n.ends_with(".svg") || n.ends_with(".png"),
            &mut kept,
        )?;
    }
    let cells = dir.join(CELLS);
    if cells.is_dir() {
        let entries = std::fs::read_dir(&cells).map_err(at(&cells))?;
        let mut cell_dirs = vec![];
        for e in entries {
            let e = e.map_err(at(&cells))?;
            match e.file_type().is_ok_and(|t| t.is_dir()) {
                true => cell_dirs.push(e.path()),
                false => kept.push(e.path()),
            }
        }
        for c in cell_dirs {
            let mut inner = vec![];
            clear_cell(&c, &mut inner)?;
            kept.extend(inner);
        }
        let link = cells
            .symlink_metadata()
            .is_ok_and(|m| m.file_type().is_symlink());
        if !link && kept.iter().all(|k| !k.starts_with(&cells)) {
            std::fs::remove_dir(&cells).map_err(at(&cells))?;
        }
    }
    kept.sort();
    Ok(kept)
}

/// The first file found under `dir` (searching at most `limit` entries)
/// that is not a temporary file (`*.tmp`, which rwg's writers remove before
/// writing and never read: what a run killed in its first moments leaves),
/// if any.
fn some_file(dir: &Path, limit: &mut usize) -> Option<PathBuf> {
    let rd = std::fs::read_dir(dir).ok()?;
    for e in rd.flatten() {
        if *limit == 0 {
            return Some(e.path()); // too many to look through: not empty
        }
        *limit -= 1;
        let path = e.path();
        if e.file_type().is_ok_and(|t| t.is_dir()) {
            if let Some(f) = some_file(&path, limit) {
                return Some(f);
            }
        } else if !e.file_name().to_string_lossy().ends_with(".tmp") {
            return Some(path);
        }
    }
    None
}

/// What the directory `dir`, which holds no run ([`holds_run`]), holds
/// under the names of a run's layout: `run.json`... (files), `cells/` and
/// `figures/` (when they hold a file but temporary ones, at any depth). `manifest.toml` is
/// left to the caller when `own_manifest` (it is the manifest given).
pub fn foreign_entries(dir: &Path, own_manifest: bool) -> Vec<PathBuf> {
    let mut found = vec![];
    for f in RUN_FILES {
        let p = dir.join(f);
        if p.symlink_metadata().is_ok() && !(own_manifest && f == MANIFEST) {
            found.push(p);
        }
    }
    for d in [CELLS, FIGURES] {
        let p = dir.join(d);
        let mut limit = 10_000;
        // (a file under a folder's name stops the run where it creates the
        // folder, with its own message)
        if p.is_dir() && some_file(&p, &mut limit).is_some() {
            found.push(p);
        }
    }
    found
}

/// Why a run (or merge) may not start in `dir`, which holds no run
/// ([`holds_run`]), if it holds something under the names of a run's layout
/// ([`foreign_entries`]): the run would mix its files with them (or
/// `rwg.load` take a `stats.csv` found there for the run's).
pub fn foreign_message(dir: &Path, own_manifest: bool) -> Option<String> {
    let found = foreign_entries(dir, own_manifest);
    if found.is_empty() {
        return None;
    }
    let list: Vec<String> = found.iter().map(|p| p.display().to_string()).collect();
    Some(format!(
        "{} holds no run (no run.json, no manifest.toml beside cells/) but holds {}: a run \
         writes these names, and rwg did not write them here, so it neither deletes them (not \
         even with --force-new) nor mixes a run with them; move them out of the way, or \
         choose another --out",
        dir.display(),
        list.join(", ")
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fresh(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("rwg-clear-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    fn touch(p: &Path) {
        std::fs::create_dir_all(p.parent().unwrap()).unwrap();
        std::fs::write(p, "x").unwrap();
    }

    #[test]
    fn clearing_removes_every_file_rwg_writes_and_keeps_and_names_the_rest() {
        let d = fresh("run");
        for f in [
            "manifest.toml",
            "run.json",
            "run.json.tmp",
            "stats.json",
            "stats.csv",
            "report.html",
            "figures/a.hist.svg",
            "figures/overview_nobias.svg.tmp",
            "cells/a/scores.csv",
            "cells/a/samples.csv",
            "cells/a/cell.json",
            "cells/a/env.json",
            "cells/a/SHA256SUMS",
            "cells/b/env.json",
            "cells/b/blocks/b0000000.csv",
            "cells/b/blocks/b0000001.csv.tmp",
            "cells/b/blocks/SHA256SUMS",
            "cells/c/notes.txt",
            "figures/README",
        ] {
            touch(&d.join(f));
        }
        touch(&d.join("rwg.lock"));
        touch(&d.join("mine.txt"));
        let kept = clear_run(&d).unwrap();
        assert_eq!(
            kept,
            vec![d.join("cells/c/notes.txt"), d.join("figures/README")]
        );
        let mut left: Vec<String> = vec![];
        let mut todo = vec![d.clone()];
        while let Some(x) = todo.pop() {
            for e in std::fs::read_dir(&x).unwrap().flatten() {
                let p = e.path();
                left.push(p.strip_prefix(&d).unwrap().display().to_string());
                if p.is_dir() {
                    todo.push(p);
                }
            }
        }
        left.sort();
        assert_eq!(
            left,
            [
                "cells",
                "cells/c",
                "cells/c/notes.txt",
                "figures",
                "figures/README",
                "mine.txt",
                "rwg.lock"
            ]
        );
        // once the rest is moved, nothing of the layout is left
        std::fs::remove_file(d.join("cells/c/notes.txt")).unwrap();
        std::fs::remove_file(d.join("figures/README")).unwrap();
        assert_eq!(clear_run(&d).unwrap(), Vec::<PathBuf>::new());
        assert!(!d.join("cells").exists() && !d.join("figures").exists());
        let _ = std::fs::remove_dir_all(&d);
    }

    #[cfg(unix)]
    #[test]
    fn a_cells_folder_that_is_a_link_is_emptied_of_rwgs_files_and_kept() {
        let d = fresh("link");
        let data = d.join("data");
        touch(&data.join("c/scores.csv"));
        touch(&data.join("c/blocks/b0000000.csv"));
        let run = d.join("run");
        std::fs::create_dir_all(&run).unwrap();
        std::os::unix::fs::symlink(&data, run.join("cells")).unwrap();
        touch(&run.join("run.json"));
        assert_eq!(clear_run(&run).unwrap(), Vec::<PathBuf>::new());
        assert!(run
            .join("cells")
            .symlink_metadata()
            .unwrap()
            .file_type()
            .is_symlink());
        assert!(data.is_dir() && !data.join("c").exists());
        let _ = std::fs::remove_dir_all(&d);
    }

    #[test]
    fn a_directory_without_a_run_names_what_it_holds_under_a_runs_names() {
        let d = fresh("foreign");
        assert!(foreign_entries(&d, false).is_empty());
        std::fs::create_dir_all(d.join("cells/empty")).unwrap();
        touch(&d.join("cells/c/scores.csv.tmp"));
        let empty = "empty folders and temporary files are nothing";
        assert!(foreign_entries(&d, false).is_empty(), "{empty}");
        touch(&d.join("cells/x/data.csv"));
        touch(&d.join("manifest.toml"));
        touch(&d.join("stats.csv"));
        assert!(holds_run(&d), "manifest.toml beside cells/");
        std::fs::remove_dir_all(d.join("cells")).unwrap();
        touch(&d.join("cells/x/data.csv"));
        std::fs::remove_file(d.join("manifest.toml")).unwrap();
        assert!(!holds_run(&d));
        assert_eq!(
            foreign_entries(&d, false),
            vec![d.join("stats.csv"), d.join("cells")]
        );
        touch(&d.join("manifest.toml"));
        std::fs::remove_dir_all(d.join("cells")).unwrap();
        assert_eq!(foreign_entries(&d, true), vec![d.join("stats.csv")]);
        let _ = std::fs::remove_dir_all(&d);
    }
}
