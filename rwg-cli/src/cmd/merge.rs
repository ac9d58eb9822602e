//! `rwg merge`: combine the shards of a study into one run directory (the
//! merge itself is `rwg_study::merge`).

use anyhow::Result;
use rwg_study::merge::merge_shards;
use std::path::PathBuf;

/// Arguments of `rwg merge`.
#[derive(clap::Args)]
#[command(after_help = "\
Checks that the shard directories come from the same study and together hold every
block of networks exactly once, then writes a run directory byte-identical to an
unsharded run's (timing metadata aside).

Example:
  for k in 0 1 2; do rwg run examples/paper.toml --shard $k/3 --out runs/paper-s$k; done
  rwg merge runs/paper-s0 runs/paper-s1 runs/paper-s2 --out runs/paper")]
pub struct Args {
    /// Shard directories written by `rwg run --shard K/N`.
    #[arg(required = true)]
    shards: Vec<PathBuf>,
    /// The merged run directory (must not hold a run).
    #[arg(long)]
    out: PathBuf,
}

/// Runs `rwg merge`.
pub fn run(args: Args) -> Result<()> {
    let report = merge_shards(&args.shards, &args.out, |cell| match cell {
        None => println!("{}", crate::summary::header()),
        Some(l) => println!("{}", crate::summary::line(l)),
    })?;
    println!(
        "\nMerged {} shards ({} env steps) into {}",
        report.shards,
        report.meta.env_steps,
        args.out.display()
    );
    Ok(())
}
