//! [`RunReadError`]: why a run directory could not be read for analysis.

use super::Unfinished;
use crate::rundir::error::{with_causes, RunDirError};
use std::path::{Path, PathBuf};

/// Why a run directory could not be read.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum RunReadError {
    /// A file could not be read (the cause is chained, not printed).
    #[error("cannot read {path}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// `run.json` is not valid.
    #[error("{how}")]
    Json {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: serde_json::Error,
        /// What it is and how to get it back, naming the file
        /// ([`crate::rundir::study::damaged_run_json`]).
        how: String,
    },
    /// The run was written in a layout this rwg does not read.
    #[error("{path}: run format {found}, this rwg reads format {expected}")]
    Format {
        /// The file.
        path: PathBuf,
        /// Format found.
        found: u32,
        /// Format supported ([`RUN_FORMAT`](crate::rundir::meta::RUN_FORMAT)).
        expected: u32,
    },
    /// A CSV line is malformed.
    #[error("{path}:{line}: {message}")]
    Csv {
        /// The file.
        path: PathBuf,
        /// 1-based line number.
        line: usize,
        /// What is wrong.
        message: String,
    },
    /// The directory holds no `run.json`: it is not a run directory.
    #[error(
        "{} is not a run directory ({why}): a run directory is what `rwg run` writes, \
         run.json, manifest.toml and cells/<env>__<arch>__<bias|nobias>/{hint}",
        dir.display()
    )]
    NotARunDir {
        /// The directory given.
        dir: PathBuf,
        /// Why not: it does not exist, or it has no `run.json`.
        why: String,
        /// A hint: nearby run directories, if any (empty or `; ...`).
        hint: String,
    },
    /// A file does not match the checksum recorded in the run's index (or
    /// has none).
    #[error(transparent)]
    Integrity(#[from] RunDirError),
    /// A file does not match its checksum, and reading it shows where.
    #[error("{}\n  first bad row: {}", with_causes(check), with_causes(row.as_ref()))]
    Damaged {
        /// The checksum failure.
        check: RunDirError,
        /// What reading the file found.
        row: Box<RunReadError>,
    },
    /// The run is not finished (in progress, or stopped), and what was
    /// asked needs a finished one.
    #[error(
        "{} is a run {progress}; `rwg status {}` shows how far it got, and \
         `{}` finishes it",
        dir.display(), crate::shell::sh_path(dir), crate::rundir::study::resume_command(dir)
    )]
    Unfinished {
        /// The run directory.
        dir: PathBuf,
        /// How far it has got.
        progress: Unfinished,
    },
    /// The directory holds what a run writes first (its lock, its
    /// manifest) but no `run.json` yet: a run being started.
    #[error(
        "{} is a run being started (or one stopped before it was set up): it has {what} but \
         no run.json yet, which rwg writes once the run is set up; run this again in a moment \
         (`rwg status {}` shows how far it got)",
        dir.display(), crate::shell::sh_path(dir)
    )]
    Starting {
        /// The directory.
        dir: PathBuf,
        /// What it holds (`rwg.lock`, `manifest.toml`).
        what: String,
    },
    /// A file disagrees with `run.json` or with another file.
    #[error("{path}: {message}")]
    Mismatch {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
}

pub(super) fn io_err(path: &Path) -> impl FnOnce(std::io::Error) -> RunReadError + '_ {
    move |source| RunReadError::Io {
        path: path.to_path_buf(),
        source,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_io_error_says_what_it_could_not_read_and_chains_why() {
        let e = io_err(Path::new("run/run.json"))(std::io::Error::other("disk on fire"));
        assert_eq!(e.to_string(), "cannot read run/run.json");
        let cause = std::error::Error::source(&e).map(|s| s.to_string());
        assert_eq!(cause.as_deref(), Some("disk on fire"));
    }
}
