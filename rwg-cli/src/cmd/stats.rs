//! `rwg stats`: the statistics of a run as tables; writes `stats.json` and
//! `stats.csv` into the run directory.

use anyhow::{Context, Result};
use rwg_analysis::{render_tables, tables::run_tables, TableFormat};
use rwg_study::rundir::data::{stats_csv, write_stats, Run, RunStats};
use rwg_study::rundir::lock::RunLock;
use std::path::PathBuf;

/// Output formats of `rwg stats` and `rwg compare`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Format {
    /// Aligned text tables.
    Table,
    /// Markdown tables.
    Markdown,
    /// LaTeX tables (booktabs), ready to paste.
    Latex,
    /// One CSV row per cell with every statistic.
    Csv,
    /// Every statistic as JSON.
    Json,
}

impl Format {
    /// The table format, for the tabular formats.
    pub fn table_format(self) -> Option<TableFormat> {
        match self {
            Format::Table => Some(TableFormat::Text),
            Format::Markdown => Some(TableFormat::Markdown),
            Format::Latex => Some(TableFormat::Latex),
            Format::Csv | Format::Json => None,
        }
    }
}

/// Arguments of `rwg stats`.
#[derive(clap::Args)]
pub struct Args {
    /// Run directory, as written by `rwg run`.
    run_dir: PathBuf,
    /// Output format: tables (the paper's Table 3 per bias setting, p(solved),
    /// expected guesses, per-cell details), or every statistic as CSV or JSON.
    #[arg(long, value_enum, default_value_t = Format::Table)]
    format: Format,
    /// Do not write stats.json and stats.csv into the run directory.
    #[arg(long)]
    no_write: bool,
}

/// Loads and summarises a run.
pub fn load_stats(run_dir: &std::path::Path) -> Result<(Run, RunStats)> {
    let run = Run::open(run_dir)?;
    let stats = run.summarize()?;
    Ok((run, stats))
}

/// Runs `rwg stats`.
pub fn run(args: Args) -> Result<()> {
    // Writing stats.json and stats.csv makes this a writer of the run.
    // (Opened first, so a directory that is no run says so.)
    let _lock = match args.no_write {
        true => None,
        false => Run::open(&args.run_dir)
            .map(|_| RunLock::acquire(&args.run_dir))??
            .into(),
    };
    let (run, stats) = load_stats(&args.run_dir)?;
    crate::cmd::warn_unverified(&run);
    if !args.no_write {
        write_stats(&args.run_dir, &stats)
            .with_context(|| format!("cannot write stats into {}", args.run_dir.display()))?;
    }
    match args.format.table_format() {
        Some(f) => crate::out!("{}", render_tables(&run_tables(&stats), f)),
        None if args.format == Format::Csv => crate::out!("{}", stats_csv(&stats)),
        None => crate::outln!("{}", serde_json::to_string_pretty(&stats)?),
    }
    Ok(())
}
