//! `rwg stats`: the statistics of a run as tables; writes `stats.json` and
//! `stats.csv` into the run directory.

use anyhow::{bail, Context, Result};
use rwg_analysis::jax_cells::{jax_settings, jax_table};
use rwg_analysis::{render_tables, tables::run_tables, TableFormat};
use rwg_study::rundir::data::{
    stats_csv, write_stats, Run, RunReadError, RunStats, SummarizeError,
};
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

/// What `--at-n` computes, for the help text of `rwg stats` and `rwg report`.
pub const AT_N_HELP: &str = "\
--at-n N: the spread of the best mean and of the 99.9th percentile of M at a study of N networks.
A published table gives one best mean and one 99.9th percentile per cell, each from a single
study of N networks; both are extremes and vary widely between studies. rwg cuts each cell's
networks, in sample order, into K = floor(samples / N) disjoint blocks of N (block k: networks
k*N to (k+1)*N - 1; the rest is left out), computes both statistics on every block (numpy's max
and linear percentile, as p99.9_mean), and prints median [min, max] over the blocks. Each block
is an independent study of N networks, so a further study of N lands inside [min, max] with
probability (K - 1)/(K + 1) (82% for K = 10). Disjoint blocks, not a bootstrap: resampling the
cell's own networks can never give a best mean above the cell's best. Needs samples >= 2*N.
stats.json gains each cell's `at_n` (every block's value); stats.csv gains 8 columns at its end.";

/// Arguments of `rwg stats`.
#[derive(clap::Args)]
#[command(after_help = format!("{AT_N_HELP}

Examples:
  rwg run examples/quick.toml --out runs/quick-blocks --samples 1000
  rwg stats runs/quick-blocks --at-n 100   # 10 blocks of 100 networks per cell"))]
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
    /// Also give, per cell, the spread of the best mean and of the 99.9th
    /// percentile of M at a study of N networks: median [min, max] over
    /// disjoint blocks of N networks (see below; needs 2·N networks per cell).
    #[arg(long, value_name = "N", value_parser = parse_at_n)]
    at_n: Option<u64>,
}

/// Parses `--at-n`: a whole number of networks, at least 1.
pub fn parse_at_n(s: &str) -> Result<u64, String> {
    let n: u64 = s
        .trim()
        .parse()
        .map_err(|_| format!("expected a whole number of networks (such as 10000), found `{s}`"))?;
    if n == 0 {
        return Err("the study size N must be at least 1 network, got 0".into());
    }
    if n > rwg_study::limits::MAX_SAMPLES {
        return Err(format!(
            "at most {} networks (rwg's limit on networks per cell), got {n}",
            rwg_study::limits::MAX_SAMPLES
        ));
    }
    Ok(n)
}

/// Loads and summarises a run; with `at_n`, each cell's spread at that
/// study size too.
pub fn load_stats(run_dir: &std::path::Path, at_n: Option<u64>) -> Result<(Run, RunStats)> {
    let run = Run::open(run_dir)?;
    let stats = match at_n {
        None => run.summarize()?,
        Some(n) => run.summarize_at(Some(n)).map_err(|e| match e {
            SummarizeError::Read(e) => anyhow::Error::from(e),
            SummarizeError::Spread(e) => anyhow::Error::from(e).context(format!("--at-n {n}")),
            e => anyhow::Error::from(e),
        })?,
    };
    Ok((run, stats))
}

/// Runs `rwg stats`.
pub fn run(args: Args) -> Result<()> {
    // (Opened first, so a directory that is no run says so.)
    let opened = Run::open(&args.run_dir)?;
    if let Some(progress) = opened.unfinished() {
        if !args.no_write {
            let e = RunReadError::Unfinished {
                dir: args.run_dir.clone(),
                progress,
            };
            bail!(
                "{e}\nstats.json and stats.csv are a finished run's; --no-write prints the \
                 statistics of the cells finished so far without writing them"
            );
        }
        crate::errln!(
            "note: {} is a run {progress}: these statistics cover the finished cells only",
            args.run_dir.display()
        );
    }
    // Writing stats.json and stats.csv makes this a writer of the run.
    let _lock = match args.no_write {
        true => None,
        false => Some(RunLock::acquire(&args.run_dir).with_context(|| {
            format!(
                "rwg stats writes stats.json and stats.csv into {}, so it takes the run's \
                 writer lock; --no-write prints the statistics without writing (or locking) \
                 anything",
                args.run_dir.display()
            )
        })?),
    };
    let (run, stats) = load_stats(&args.run_dir, args.at_n)?;
    crate::cmd::warn_unverified(&run);
    if !args.no_write {
        write_stats(&args.run_dir, &stats)
            .with_context(|| format!("cannot write stats into {}", args.run_dir.display()))?;
    }
    match args.format.table_format() {
        Some(f) => {
            let mut tables = run_tables(&stats);
            let jax = jax_settings(&run.dir, stats.cells.iter().map(|c| c.id.dir.as_str()));
            if !jax.is_empty() {
                tables.push(jax_table(&jax));
            }
            crate::out!("{}", render_tables(&tables, f))
        }
        None if args.format == Format::Csv => crate::out!("{}", stats_csv(&stats)),
        None => crate::outln!("{}", serde_json::to_string_pretty(&stats)?),
    }
    Ok(())
}
