//! `rwg merge`: combine the shards of a study into one run directory (the
//! merge itself is `rwg_study::merge`).

use super::run::write_report;
use anyhow::Result;
use rwg_study::merge::merge_shards;
use rwg_study::rundir::outputs::{Output, OutputKind};
use std::path::PathBuf;

/// Arguments of `rwg merge`.
#[derive(clap::Args)]
#[command(after_help = "\
Checks that the shard directories come from the same study and together hold every
block of networks exactly once, then writes a run directory byte-identical to an
unsharded run's (timing metadata aside), with its stats.csv, figures and report.html.
An interrupted merge is finished by running the same command again.

Example:
  for k in 0 1 2; do rwg run examples/paper.toml --shard $k/3 --out runs/paper-s$k; done
  rwg merge runs/paper-s0 runs/paper-s1 runs/paper-s2 --out runs/paper-merged")]
pub struct Args {
    /// Shard directories written by `rwg run --shard K/N`.
    #[arg(required = true)]
    shards: Vec<PathBuf>,
    /// The merged run directory: empty, or holding an unfinished merge of the
    /// same study (which this finishes).
    #[arg(long)]
    out: PathBuf,
    /// Skip the analysis at the end (stats.json, stats.csv, figures/, report.html;
    /// `rwg report` writes them later).
    #[arg(long)]
    no_report: bool,
}

/// Runs `rwg merge`.
pub fn run(args: Args) -> Result<()> {
    // a folder that is no shard at all is said so, with what one holds
    for d in &args.shards {
        rwg_study::rundir::data::require_run_dir(d)?;
    }
    crate::cmd::claim_output(Output::new(&args.out, OutputKind::RunDir), "")?;
    let out = &crate::cmd::absolute(&args.out)?;
    let report = merge_shards(&args.shards, out, |cell| match cell {
        None => crate::outln!("{}", crate::summary::header()),
        Some(l) => crate::outln!("{}", crate::summary::line(l)),
    })?;
    if report.already_complete {
        crate::outln!(
            "{} already holds this study, merged and complete; nothing to do.",
            out.display()
        );
        if !args.no_report && !out.join(rwg_study::rundir::REPORT_HTML).exists() {
            write_report(out, Default::default())?;
        }
        return Ok(());
    }
    if report.cells_kept > 0 {
        crate::outln!(
            "({} cells were merged by an earlier, interrupted merge)",
            report.cells_kept
        );
    }
    crate::outln!(
        "\nMerged {} shards ({} env steps) into {}",
        report.shards,
        report.meta.env_steps,
        out.display()
    );
    if !args.no_report {
        write_report(out, Default::default())?;
    }
    Ok(())
}
