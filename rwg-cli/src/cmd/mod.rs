//! One module per `rwg` subcommand.

pub mod bench;
pub mod check;
pub mod compare;
pub mod envs;
pub mod merge;
pub mod plot;
pub mod plugin_worker;
pub mod replay;
pub mod report;
pub mod rollout;
pub mod run;
pub mod slurm;
pub mod stats;
pub mod status;
pub mod top;
pub mod verify;

use rwg_study::rundir::data::Run;
use rwg_study::rundir::lock::RunLock;
use std::path::Path;

/// Takes the lock of `run_dir` if `out` (a file or folder about to be
/// written) lies inside it: writing there makes the command a writer of the run.
pub fn lock_if_inside(run_dir: &Path, out: &Path) -> anyhow::Result<Option<RunLock>> {
    let abs = |p: &Path| std::path::absolute(p).unwrap_or_else(|_| p.to_path_buf());
    let (dir, out) = (abs(run_dir), abs(out));
    let inside = out
        .ancestors()
        .any(|a| a == dir || (a.exists() && dir.exists() && same_file(a, &dir)));
    if inside && dir.is_dir() {
        return Ok(Some(RunLock::acquire(run_dir)?));
    }
    Ok(None)
}

fn same_file(a: &Path, b: &Path) -> bool {
    match (std::fs::canonicalize(a), std::fs::canonicalize(b)) {
        (Ok(x), Ok(y)) => x == y,
        _ => false,
    }
}

/// Warns (stderr) when a run predates checksums and is read unverified.
pub fn warn_unverified(run: &Run) {
    if !run.verified {
        crate::errln!(
            "warning: {} was written by an older rwg (run format {}) without checksums: its \
             files are read unverified",
            run.dir.display(),
            run.meta.format
        );
    }
}
