//! `rwg verify`: check a run directory against its checksums.

use anyhow::{bail, Result};
use rwg_study::rundir::verify::verify_run;
use std::path::PathBuf;

/// Arguments of `rwg verify`.
#[derive(clap::Args)]
#[command(after_help = "\
Checks every finished cell's scores.csv, samples.csv and cell.json against the
cell's SHA256SUMS (and their rows against run.json), and every committed block
of an unfinished cell or a shard against blocks/SHA256SUMS. Prints one line per
cell and one per problem, naming the file; exits 1 on any problem. Takes no lock:
it can run while the directory is being written (a cell a run changes while it is
checked is checked again, so each is read as one snapshot).

Example:
  rwg verify runs/quick")]
pub struct Args {
    /// Run (or shard) directory.
    run_dir: PathBuf,
}

/// Runs `rwg verify`.
pub fn run(args: Args) -> Result<()> {
    // a folder that is no run at all is said so, with what a run holds
    if let Err(e) = rwg_study::rundir::data::require_run_dir(&args.run_dir) {
        // (a run or merge in its first moments, before its run.json; or
        // one that wrote its run.json just now)
        if !rwg_study::rundir::verify::being_set_up(&args.run_dir) {
            rwg_study::rundir::data::require_run_dir(&args.run_dir).map_err(|_| e)?;
        } else {
            crate::outln!(
                "{}: a run (or merge) being set up, without run.json yet; checking what is \
             committed so far",
                args.run_dir.display()
            );
        }
    }
    if let Ok(Some(progress)) =
        rwg_study::rundir::data::Run::open(&args.run_dir).map(|r| r.unfinished())
    {
        crate::outln!(
            "{}: a run {progress}; checking what is committed so far",
            args.run_dir.display()
        );
    }
    let r = verify_run(&args.run_dir);
    for l in &r.ok {
        crate::outln!("{l}");
    }
    for p in &r.problems {
        crate::outln!("FAILED  {p}");
    }
    if !r.problems.is_empty() {
        bail!(
            "{}: {} problem(s); {} file(s) checked",
            args.run_dir.display(),
            r.problems.len(),
            r.files
        );
    }
    crate::outln!(
        "{}: {} file(s) checked, all match their checksums",
        args.run_dir.display(),
        r.files
    );
    Ok(())
}
