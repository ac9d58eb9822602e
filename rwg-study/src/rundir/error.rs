//! [`RunDirError`]: why a cell's files in a run directory could not be
//! written, read or trusted (I/O, damaged rows, checksums, missing blocks).

use std::io;
use std::path::{Path, PathBuf};
use thiserror::Error;

/// Errors reading or writing a cell's files.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum RunDirError {
    /// An I/O error on a file (the cause is chained, not printed: rwg
    /// prints an error with its causes).
    #[error("{path}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The error.
        source: io::Error,
    },
    /// A file's contents are not what rwg wrote.
    #[error("{path}:{line}: {message}")]
    Corrupt {
        /// The file.
        path: PathBuf,
        /// 1-based line.
        line: usize,
        /// What is wrong.
        message: String,
    },
    /// A file does not have the checksum its index records.
    #[error(
        "{path}: checksum mismatch: the run's index records sha256 {recorded}, the file has \
         {found}; it was changed, truncated or damaged after rwg wrote it (a block: or it did \
         not reach the disk before a crash of the machine). Running the study (or shard) again \
         computes a damaged block again; for a finished cell's file, delete the cell's \
         directory first"
    )]
    Checksum {
        /// The file.
        path: PathBuf,
        /// The digest recorded when the file was committed.
        recorded: String,
        /// The digest of the file now.
        found: String,
    },
    /// A file has no checksum recorded, so it cannot count as committed.
    #[error("{path}: unverified: {message}")]
    Unverified {
        /// The file.
        path: PathBuf,
        /// Why.
        message: String,
    },
    /// A block listed as committed in the cell's block index is gone.
    #[error(
        "{path}: missing: listed in {index} as committed, but the file is gone (deleted, or \
         not written to disk before a crash of the machine); running the study (or shard) \
         again computes it again"
    )]
    ListedMissing {
        /// The block's file.
        path: PathBuf,
        /// The index that lists it.
        index: PathBuf,
    },
    /// A block is missing when the cell is finalised.
    #[error("{path}: missing (block {block} of the cell)")]
    MissingBlock {
        /// The block's file.
        path: PathBuf,
        /// Block index.
        block: u64,
    },
}

/// A [`RunDirError::Io`] on `path`, for `map_err`.
pub(crate) fn io_err(path: &Path) -> impl FnOnce(io::Error) -> RunDirError + '_ {
    move |source| RunDirError::Io {
        path: path.to_path_buf(),
        source,
    }
}

/// An error with its causes, `context: cause: ...` (a cause whose text the
/// message already holds is not repeated): the text of an error that is
/// kept as a line of a report rather than returned with its chain.
pub(crate) fn with_causes(e: &dyn std::error::Error) -> String {
    let mut text = e.to_string();
    let mut source = e.source();
    while let Some(s) = source {
        let s_text = s.to_string();
        if !text.contains(&s_text) {
            text = format!("{text}: {s_text}");
        }
        source = s.source();
    }
    text
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_io_error_prints_its_file_and_chains_its_cause() {
        let e = io_err(Path::new("cells/a/scores.csv"))(io::Error::other("disk on fire"));
        assert_eq!(e.to_string(), "cells/a/scores.csv");
        let cause = std::error::Error::source(&e).map(|s| s.to_string());
        assert_eq!(cause.as_deref(), Some("disk on fire"));
        assert_eq!(with_causes(&e), "cells/a/scores.csv: disk on fire");
    }
}
