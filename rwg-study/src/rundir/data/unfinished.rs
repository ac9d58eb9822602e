//! How far a run that is not finished has got: the readers that need a
//! finished run refuse an unfinished one by name, the others say so.

use super::{Run, RunReadError};
use crate::rundir::meta::RunMeta;
use crate::rundir::MANIFEST;
use std::path::Path;

/// How far a run that is not finished has got ([`Run::unfinished`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Unfinished {
    /// Cells finished (listed in `run.json`).
    pub cells_done: usize,
    /// Cells of the study (`None` when its manifest does not read).
    pub cells: Option<usize>,
}

impl std::fmt::Display for Unfinished {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self.cells {
            Some(n) => write!(
                f,
                "in progress (or stopped): {} of {n} cells finished",
                self.cells_done
            ),
            None => write!(
                f,
                "in progress (or stopped): {} cells finished",
                self.cells_done
            ),
        }
    }
}

/// The cells of the study in `dir`: the study `run.json` recorded, else
/// `manifest` (the text of `manifest.toml`).
pub(super) fn study_cells(
    dir: &Path,
    meta: Option<&RunMeta>,
    manifest: Option<&str>,
) -> Option<usize> {
    let text = meta.and_then(|m| m.study.as_deref()).or(manifest)?;
    let m = crate::manifest::Manifest::parse(text, MANIFEST, dir).ok()?;
    Some(crate::rundir::status::cell_dirs(&m).len())
}

impl Run {
    /// `Some` when the run is not finished (`run.json` has no end time: it
    /// is in progress, or was stopped): how many of its cells are.
    pub fn unfinished(&self) -> Option<Unfinished> {
        if self.meta.end_time.is_some() {
            return None;
        }
        Some(Unfinished {
            cells_done: self.meta.cells.len(),
            cells: study_cells(&self.dir, Some(&self.meta), self.manifest.as_deref()),
        })
    }

    /// `Ok` for a finished run, else [`RunReadError::Unfinished`].
    pub fn require_finished(&self) -> Result<(), RunReadError> {
        match self.unfinished() {
            None => Ok(()),
            Some(progress) => Err(RunReadError::Unfinished {
                dir: self.dir.clone(),
                progress,
            }),
        }
    }
}
