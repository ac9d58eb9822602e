//! [`StudyError`]: why planning, running or merging a study failed.

use crate::manifest::ManifestError;
use crate::rundir::error::RunDirError;
use rwg_core::sampler::SampleError;
use std::path::PathBuf;
use thiserror::Error;

/// Why a study could not be planned, run or merged. Every message names the
/// file or directory and, where there is one, what to do.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum StudyError {
    /// The manifest is invalid (the message points into it).
    #[error(transparent)]
    Manifest(#[from] ManifestError),
    /// A manifest file could not be read or is invalid.
    #[error(transparent)]
    ManifestFile(#[from] crate::manifest::ManifestLoadError),
    /// A directory given as a run (or shard) has no readable manifest.
    #[error("{} is not an rwg run directory", dir.display())]
    NotARunDir {
        /// The directory.
        dir: PathBuf,
        /// Why its `manifest.toml` could not be read.
        source: crate::manifest::ManifestLoadError,
    },
    /// An environment id is not built in (cells are planned with known ids).
    #[error(transparent)]
    UnknownEnv(#[from] rwg_envs::UnknownEnv),
    /// An environment could not be created.
    #[error(transparent)]
    Env(#[from] rwg_env::EnvError),
    /// An I/O error, with what was being done.
    #[error("{context}")]
    Io {
        /// What failed, naming the file.
        context: String,
        /// The cause.
        source: std::io::Error,
    },
    /// A JSON file (`run.json`, `cell.json`) could not be read or written.
    #[error("{context}")]
    Json {
        /// What failed, naming the file.
        context: String,
        /// The cause.
        source: serde_json::Error,
    },
    /// A cell's files could not be read or written.
    #[error("{context}")]
    RunDir {
        /// What failed, naming the cell.
        context: String,
        /// The cause.
        source: RunDirError,
    },
    /// The run directory or the shards given do not fit the request (the
    /// message says why and what to do).
    #[error("{0}")]
    Refused(String),
    /// A cell failed while running; the blocks and cells finished before are
    /// saved.
    #[error(
        "cell {cell}{}{} failed; the blocks and cells finished before are saved in {}",
        plugin.as_ref().map_or(String::new(), |p| format!(" (plugin {})", p.display())),
        gym.as_ref().map_or(String::new(), |g| format!(" ({g})")),
        out.display()
    )]
    Cell {
        /// The cell's directory name.
        cell: String,
        /// The plugin file of the cell's env, if it is a plugin env.
        plugin: Option<PathBuf>,
        /// For a Gymnasium or JAX env: its id and the Python that runs it.
        gym: Option<String>,
        /// The run directory.
        out: PathBuf,
        /// The cause.
        source: Box<CellError>,
    },
    /// Another process is writing the run directory.
    #[error(transparent)]
    Lock(#[from] crate::rundir::lock::LockError),
    /// Stopped on request (the stop flag was set): every finished block is
    /// saved.
    #[error("interrupted")]
    Interrupted,
}

/// Why a cell stopped while running.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum CellError {
    /// The sampler failed (an env error naming the sample and episode).
    #[error(transparent)]
    Sample(#[from] SampleError),
    /// A JAX env's worker failed to start or compile, or a compiled call
    /// failed as a whole (naming its networks).
    #[error(transparent)]
    Call(Box<rwg_jax::CallError>),
    /// A block could not be committed.
    #[error(transparent)]
    Store(#[from] RunDirError),
    /// The stop flag was set.
    #[error("interrupted")]
    Interrupted,
}

impl From<rwg_jax::CallError> for CellError {
    fn from(e: rwg_jax::CallError) -> Self {
        CellError::Call(Box::new(e))
    }
}

impl StudyError {
    /// An [`StudyError::Io`] with its context.
    pub fn io(context: impl Into<String>) -> impl FnOnce(std::io::Error) -> StudyError {
        let context = context.into();
        move |source| StudyError::Io { context, source }
    }
}
