//! `run.json`'s cell list against the study it records: a list edited by
//! hand (a cell twice, a cell dropped, a cell of another study) would have
//! every reader summarise the wrong cells, so every reader refuses it, says
//! what is wrong and how to rebuild the file from the cells' own files.

use super::RunReadError;
use crate::manifest::Manifest;
use crate::rundir::meta::RunMeta;
use crate::rundir::{MANIFEST, RUN_JSON};
use std::path::Path;

/// `n cell` or `n cells`.
fn cells(n: usize) -> String {
    if n == 1 {
        "1 cell".into()
    } else {
        format!("{n} cells")
    }
}

/// What is wrong with `listed` (the cell directories `run.json` lists) for
/// a study of the cells `study`, one entry each (empty: nothing). A run that
/// is `finished` must list every cell of the study once; an unfinished one
/// the cells finished so far, each once.
pub fn cell_list_problems(listed: &[&str], study: &[String], finished: bool) -> Vec<String> {
    use std::collections::{HashMap, HashSet};
    let in_study: HashSet<&str> = study.iter().map(String::as_str).collect();
    let mut seen: HashMap<&str, usize> = HashMap::new();
    let mut out = vec![];
    for &c in listed {
        let n = seen.entry(c).or_default();
        *n += 1;
        if *n == 2 {
            out.push(format!("lists cell {c} more than once"));
        } else if *n == 1 && !in_study.contains(c) {
            out.push(format!("lists cell {c}, which is not a cell of the study"));
        }
    }
    if finished {
        for s in study {
            if !seen.contains_key(s.as_str()) {
                out.push(format!("lacks cell {s}"));
            }
        }
    }
    out
}

/// Checks the cells `meta` lists against the study of the run in `dir`: the
/// study `run.json` records, else `manifest` (the text of `manifest.toml`).
/// A study that does not read is left to the checks that read it.
pub fn check_cell_list(
    dir: &Path,
    meta: &RunMeta,
    manifest: Option<&str>,
) -> Result<(), RunReadError> {
    let Some(text) = meta.study.as_deref().or(manifest) else {
        return Ok(());
    };
    let Ok(m) = Manifest::parse(text, MANIFEST, dir) else {
        return Ok(());
    };
    let study = crate::rundir::status::cell_dirs(&m);
    let listed: Vec<&str> = meta.cells.iter().map(|c| c.id.dir.as_str()).collect();
    let problems = cell_list_problems(&listed, &study, meta.end_time.is_some());
    if problems.is_empty() {
        return Ok(());
    }
    Err(RunReadError::Mismatch {
        path: dir.join(RUN_JSON),
        message: format!(
            "its cell list does not match the study it records: it lists {} and the study \
             has {} ({}). run.json was edited or damaged; the cells' own files are what the \
             run holds, and resuming rebuilds run.json from them: delete it, then run {}",
            cells(listed.len()),
            cells(study.len()),
            problems.join("; "),
            crate::rundir::study::resume_command(dir)
        ),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn twice_dropped_and_foreign_cells_are_named() {
        let study: Vec<String> = ["a", "b", "c"].iter().map(|s| s.to_string()).collect();
        assert!(cell_list_problems(&["a", "b", "c"], &study, true).is_empty());
        assert!(cell_list_problems(&["a"], &study, false).is_empty());
        assert_eq!(
            cell_list_problems(&["a", "a", "a", "c"], &study, true),
            ["lists cell a more than once", "lacks cell b"]
        );
        assert_eq!(
            cell_list_problems(&["a", "x"], &study, false),
            ["lists cell x, which is not a cell of the study"]
        );
    }
}
