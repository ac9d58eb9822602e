//! Where a command may write: every path rwg writes that a user named (a
//! report, a figure, a comparison page, an exported network, a run
//! directory) is checked by [`check_output`] against the run directories
//! around it, so that nothing lands on a run's own files.
//!
//! A path inside a run directory is fine when it names no entry of the run's
//! layout ([`RESERVED`]); the writer then takes that run's lock (so nothing
//! is written into a run another rwg is writing). An entry of the layout is
//! written only by the command that owns it: a run's report and figures by
//! `rwg report`/`rwg plot` of that run, a run directory by `rwg run` and
//! `rwg merge` (shards under `shards/`, as `rwg slurm` lays them out).
//! Symbolic links are followed, as the writers follow them.

use crate::rundir::lock::LOCK_FILE;
use crate::rundir::{CELLS, FIGURES, MANIFEST, REPORT_HTML, RUN_JSON, STATS_CSV, STATS_JSON};
use std::ffi::OsStr;
use std::path::{Component, Path, PathBuf};

/// The entries of a run directory's layout, with what each holds.
pub const RESERVED: &[(&str, &str)] = &[
    (MANIFEST, "the study"),
    (RUN_JSON, "the run's metadata"),
    (LOCK_FILE, "the writers' lock"),
    (CELLS, "the cells' results"),
    (STATS_JSON, "the run's statistics"),
    (STATS_CSV, "the run's statistics"),
    (
        REPORT_HTML,
        "the run's report, written by rwg report of that run",
    ),
    (
        FIGURES,
        "the run's figures, written by rwg plot of that run",
    ),
    (SLURM, "rwg slurm's scripts and plan"),
    (SHARDS, "the shards' run directories"),
];

/// The folder of `rwg slurm`'s scripts, plan and logs in a study's directory.
pub const SLURM: &str = "slurm";
/// The folder of the shards' run directories in `rwg slurm`'s layout.
pub const SHARDS: &str = "shards";

/// What a command writes at a path.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum OutputKind {
    /// A file (a report, a figure, a page, an exported network).
    File,
    /// A folder the command fills with files of its own (figures).
    Folder,
    /// A run directory (`rwg run`, `rwg merge`) or a sharded study's
    /// directory (`rwg slurm`): it may hold a run already (which is resumed
    /// or refused by the runner), or be a shard's folder under another
    /// study's `shards/`.
    RunDir,
}

/// A path a command writes, checked by [`check_output`].
#[derive(Debug, Clone, Copy)]
pub struct Output<'a> {
    /// The path as the user gave it (relative to the working directory).
    pub path: &'a Path,
    /// What is written there.
    pub kind: OutputKind,
    /// The run this command reads whose own entry `.1` (such as
    /// [`REPORT_HTML`] or [`FIGURES`]) it writes: the one entry of a run's
    /// layout a `File` or `Folder` may be.
    pub derived_of: Option<(&'a Path, &'a str)>,
}

impl<'a> Output<'a> {
    /// A path of `kind` that is no run's own entry.
    pub fn new(path: &'a Path, kind: OutputKind) -> Output<'a> {
        Output {
            path,
            kind,
            derived_of: None,
        }
    }

    /// Entry `name` of the run `run` (its report, its figures), written
    /// by the command that owns it.
    pub fn derived(path: &'a Path, kind: OutputKind, run: &'a Path, name: &'a str) -> Output<'a> {
        Output {
            path,
            kind,
            derived_of: Some((run, name)),
        }
    }
}

/// Why a path may not be written.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum OutputError {
    /// The path is (or lies in) an entry of a run directory's layout.
    #[error(
        "{}: refused: it {} {entry}{} of the run directory {} ({what}); rwg writes nothing \
         over a run's own files. Name a path outside {}, or a new name beside its files",
        path.display(),
        if *inside { "lies in" } else { "is" },
        if *inside { "/" } else { "" },
        run.display(),
        run.display()
    )]
    RunEntry {
        /// The path as given.
        path: PathBuf,
        /// The run directory.
        run: PathBuf,
        /// The entry of the layout (`cells`, `run.json`, ...).
        entry: String,
        /// What the entry holds.
        what: &'static str,
        /// Whether the path lies below the entry (rather than being it).
        inside: bool,
    },
    /// A file or folder would be written over a whole run directory.
    #[error(
        "{}: refused: it is the run directory {}, which holds a run; name a path outside it",
        path.display(),
        run.display()
    )]
    IsRun {
        /// The path as given.
        path: PathBuf,
        /// The run directory it resolves to.
        run: PathBuf,
    },
    /// The path could not be resolved.
    #[error("cannot resolve {}", path.display())]
    Io {
        /// The path as given.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
}

/// Whether `dir` holds a run (or is becoming one, or is a sharded study's
/// directory): `run.json`, the writers' lock, `manifest.toml` beside
/// `cells/`, or `rwg slurm`'s plan.
pub fn is_run_dir(dir: &Path) -> bool {
    dir.join(RUN_JSON).is_file()
        || dir.join(LOCK_FILE).symlink_metadata().is_ok()
        || (dir.join(MANIFEST).is_file() && dir.join(CELLS).is_dir())
        || dir.join(SLURM).join("plan.json").is_file()
}

/// `path` made absolute, with the symbolic links of the part of it that
/// exists resolved (the file a writer that follows links reaches).
pub fn resolve(path: &Path) -> std::io::Result<PathBuf> {
    let abs = std::path::absolute(path)?;
    let mut rest = Vec::new();
    let mut head = abs.as_path();
    loop {
        match std::fs::canonicalize(head) {
            Ok(real) => {
                let mut out = real;
                out.extend(rest.iter().rev());
                return Ok(out);
            }
            Err(_) => match (head.parent(), head.file_name()) {
                (Some(parent), Some(name)) => {
                    rest.push(name.to_os_string());
                    head = parent;
                }
                // `..` or the root: nothing more to resolve
                _ => return Ok(abs),
            },
        }
    }
}

/// Checks that `out` may be written: it is no entry of a run directory's
/// layout but the one the command owns (see the module's docs). Returns the
/// run directory it lies in, if any: the writer takes that run's lock
/// before writing (none for a `RunDir`, which takes its own).
pub fn check_output(out: &Output<'_>) -> Result<Option<PathBuf>, OutputError> {
    let target = resolve(out.path).map_err(|source| OutputError::Io {
        path: out.path.to_path_buf(),
        source,
    })?;
    let Some(run) = target.ancestors().find(|a| is_run_dir(a)) else {
        return Ok(None);
    };
    let rel = target.strip_prefix(run).unwrap_or(Path::new(""));
    let first = rel.components().next().and_then(|c| match c {
        Component::Normal(n) => Some(n),
        _ => None,
    });
    let Some(first) = first else {
        // the run directory itself
        return match out.kind {
            OutputKind::RunDir => Ok(None),
            _ => Err(OutputError::IsRun {
                path: out.path.to_path_buf(),
                run: run.to_path_buf(),
            }),
        };
    };
    let Some(&(entry, what)) = RESERVED.iter().find(|(n, _)| OsStr::new(n) == first) else {
        return Ok(match out.kind {
            OutputKind::RunDir => None,
            _ => Some(run.to_path_buf()),
        });
    };
    let inside = rel.components().count() > 1;
    let owned = match (out.kind, out.derived_of) {
        (OutputKind::RunDir, _) => entry == SHARDS && inside,
        (_, Some((of, name))) => !inside && name == entry && resolve(of).is_ok_and(|of| of == run),
        _ => false,
    };
    if owned {
        return Ok(match out.kind {
            OutputKind::RunDir => None,
            _ => Some(run.to_path_buf()),
        });
    }
    Err(OutputError::RunEntry {
        path: out.path.to_path_buf(),
        run: run.to_path_buf(),
        entry: entry.to_string(),
        what,
        inside,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fresh(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("rwg-outputs-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d.canonicalize().unwrap()
    }

    /// A run directory as `rwg run` leaves it, in `dir/name`.
    fn run(dir: &Path, name: &str) -> PathBuf {
        let r = dir.join(name);
        std::fs::create_dir_all(r.join("cells/c")).unwrap();
        std::fs::write(r.join(RUN_JSON), "{}").unwrap();
        std::fs::write(r.join(MANIFEST), "").unwrap();
        std::fs::write(r.join("cells/c/samples.csv"), "").unwrap();
        r
    }

    fn check(path: &Path, kind: OutputKind) -> Result<Option<PathBuf>, String> {
        check_output(&Output::new(path, kind)).map_err(|e| e.to_string())
    }

    #[test]
    fn an_entry_of_a_runs_layout_is_refused_and_a_new_name_beside_it_takes_its_lock() {
        let d = fresh("layout");
        let r = run(&d, "r");
        for p in [
            "run.json",
            "manifest.toml",
            "cells/c/samples.csv",
            "cells/new.svg",
        ] {
            let err = check(&r.join(p), OutputKind::File).unwrap_err();
            assert!(err.contains("refused"), "{p}: {err}");
            assert!(
                err.contains(&format!("of the run directory {}", r.display())),
                "{err}"
            );
        }
        let err = check(&r.join("cells/c/samples.csv"), OutputKind::File).unwrap_err();
        assert!(
            err.contains("it lies in cells/ of the run directory"),
            "{err}"
        );
        assert!(err.contains("(the cells' results)"), "{err}");
        assert_eq!(
            check(&r.join("notes.html"), OutputKind::File),
            Ok(Some(r.clone()))
        );
        assert!(check(&r, OutputKind::Folder)
            .unwrap_err()
            .contains("is the run directory"));
        assert_eq!(check(&d.join("elsewhere.html"), OutputKind::File), Ok(None));
        let _ = std::fs::remove_dir_all(&d);
    }

    #[test]
    fn a_runs_report_and_figures_are_written_only_for_that_run() {
        let d = fresh("derived");
        let (a, b) = (run(&d, "a"), run(&d, "b"));
        let report = a.join(REPORT_HTML);
        let own = Output::derived(&report, OutputKind::File, &a, REPORT_HTML);
        assert_eq!(check_output(&own).unwrap(), Some(a.clone()));
        let other = Output::derived(&report, OutputKind::File, &b, REPORT_HTML);
        assert!(check_output(&other).is_err());
        let figures = a.join(FIGURES);
        let own = Output::derived(&figures, OutputKind::Folder, &a, FIGURES);
        assert!(check_output(&own).is_ok());
        let wrong = Output::derived(&figures, OutputKind::Folder, &a, REPORT_HTML);
        assert!(check_output(&wrong).is_err());
        let _ = std::fs::remove_dir_all(&d);
    }

    #[test]
    fn a_run_directory_may_be_a_run_or_a_shard_of_a_sharded_study_but_not_inside_cells() {
        let d = fresh("rundir");
        let r = run(&d, "r");
        assert_eq!(check(&r, OutputKind::RunDir), Ok(None));
        assert_eq!(check(&r.join("shards/3"), OutputKind::RunDir), Ok(None));
        assert_eq!(check(&r.join("sub"), OutputKind::RunDir), Ok(None));
        assert!(check(&r.join("cells/x"), OutputKind::RunDir).is_err());
        assert!(check(&r.join("figures"), OutputKind::RunDir).is_err());
        assert!(check(&r.join("shards"), OutputKind::RunDir).is_err());
        let _ = std::fs::remove_dir_all(&d);
    }

    #[cfg(unix)]
    #[test]
    fn a_link_is_checked_where_it_leads() {
        let d = fresh("links");
        let r = run(&d, "r");
        let link = d.join("page.html");
        std::os::unix::fs::symlink(r.join(RUN_JSON), &link).unwrap();
        assert!(check(&link, OutputKind::File).is_err());
        let dir_link = d.join("into");
        std::os::unix::fs::symlink(r.join(CELLS), &dir_link).unwrap();
        assert!(check(&dir_link.join("new.svg"), OutputKind::File).is_err());
        // a link to nothing is replaced by the writer, not followed
        let dangling = d.join("dangling.html");
        std::os::unix::fs::symlink(d.join("nothing"), &dangling).unwrap();
        assert_eq!(check(&dangling, OutputKind::File), Ok(None));
        let _ = std::fs::remove_dir_all(&d);
    }
}
