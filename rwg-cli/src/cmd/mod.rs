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
use rwg_study::rundir::outputs::{check_output, Output};
use std::path::Path;

/// Checks `out`, a path this command is about to write, against the run
/// directories around it ([`check_output`]: nothing is written over a run's
/// own files), and takes the lock of the run it lies in, if any: writing
/// there makes the command a writer of that run, refused while another rwg
/// writes it (`elsewhere` says how to write it outside the run instead).
/// Hold the lock until the file is written.
pub fn claim_output(out: Output<'_>, elsewhere: &str) -> anyhow::Result<Option<RunLock>> {
    use anyhow::Context;
    let Some(run) = check_output(&out)? else {
        return Ok(None);
    };
    let lock = RunLock::acquire(&run).with_context(|| {
        format!(
            "writing {} into the run directory {} takes that run's writers' lock; {elsewhere}",
            out.path.display(),
            run.display()
        )
    })?;
    Ok(Some(lock))
}

/// `path` made absolute against the working directory now: what a command
/// that runs plugin code resolves its paths with first (a plugin may change
/// the working directory, and nothing rwg reads or writes may follow it).
pub fn absolute(path: &Path) -> anyhow::Result<std::path::PathBuf> {
    use anyhow::Context;
    std::path::absolute(path).with_context(|| {
        format!(
            "cannot resolve {} (the working directory is gone?)",
            path.display()
        )
    })
}

/// Makes the relative paths in the environment variables rwg reads them
/// from absolute, against the working directory rwg started in: run first,
/// before any thread starts or plugin code runs (a plugin may change the
/// working directory, and a plugin folder on `RWG_PLUGIN_PATH` must be the
/// one the user meant). `RWG_PLUGIN_PATH`: every entry; `RWG_PYTHON`: a
/// value with a `/` (a bare name is looked up on `PATH`). Child processes
/// inherit the absolute values.
pub fn pin_env_paths() {
    let Ok(cwd) = std::env::current_dir() else {
        return; // (no working directory: relative paths resolve nowhere)
    };
    let var = rwg_plugin_host::PLUGIN_PATH_VAR;
    if let Some(value) = std::env::var_os(var) {
        let entries: Vec<std::path::PathBuf> = std::env::split_paths(&value)
            .map(|p| match p.as_os_str().is_empty() || p.is_absolute() {
                true => p,
                false => cwd.join(p),
            })
            .collect();
        if let Ok(joined) = std::env::join_paths(entries) {
            std::env::set_var(var, joined);
        }
    }
    if let Some(value) = std::env::var_os(rwg_gym::PYTHON_VAR) {
        let p = Path::new(&value);
        if !p.is_absolute() && p.as_os_str().as_encoded_bytes().contains(&b'/') {
            std::env::set_var(rwg_gym::PYTHON_VAR, cwd.join(p));
        }
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

/// Writes `bytes` to a file named on the command line: atomically (a
/// temporary file renamed over it) when it is a regular file or does not
/// exist yet, and straight into it when it is something else (a device
/// such as `/dev/stdout`, a FIFO), which a rename would replace. A symbolic
/// link is followed: its target is written, the link kept.
pub fn write_named_file(path: &Path, bytes: &[u8]) -> anyhow::Result<()> {
    use anyhow::Context;
    use std::io::Write;
    let target = std::fs::canonicalize(path).unwrap_or_else(|_| path.to_path_buf());
    // A folder (or a name ending in a slash, which names one) is no file.
    if target.is_dir() || path.as_os_str().as_encoded_bytes().ends_with(b"/") {
        anyhow::bail!(
            "cannot write {}: it names a folder, and this writes one file; name a file (in \
             that folder, if you like)",
            path.display()
        );
    }
    // A missing folder is named, not the temporary file that could not be made in it.
    if let Some(parent) = target.parent().filter(|p| !p.as_os_str().is_empty()) {
        if !parent.exists() {
            anyhow::bail!(
                "cannot write {}: the folder {} does not exist (create it first, or name a \
                 file in a folder that exists)",
                path.display(),
                parent.display()
            );
        } else if !parent.is_dir() {
            anyhow::bail!(
                "cannot write {}: {} is not a folder",
                path.display(),
                parent.display()
            );
        }
    }
    match std::fs::metadata(&target) {
        Ok(m) if !m.is_file() && !m.is_dir() => std::fs::OpenOptions::new()
            .write(true)
            .open(&target)
            .and_then(|mut f| f.write_all(bytes)),
        _ => rwg_study::rundir::export::write_atomic(&target, bytes),
    }
    .with_context(|| format!("cannot write {}", path.display()))
}
