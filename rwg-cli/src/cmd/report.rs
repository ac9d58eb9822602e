//! `rwg report`: one self-contained HTML page for a run.

use anyhow::{Context, Result};
use rwg_analysis::plot::{run_figures, ImageFormat};
use rwg_analysis::report::{report_html, REPORT_HTML};
use rwg_study::rundir::data::Run;
use rwg_study::rundir::outputs::{Output, OutputKind};
use std::path::PathBuf;

/// Arguments of `rwg report`.
#[derive(clap::Args)]
#[command(after_help = crate::cmd::stats::AT_N_HELP)]
pub struct Args {
    /// Run directory, as written by `rwg run`.
    run_dir: PathBuf,
    /// Output file [default: RUN_DIR/report.html].
    #[arg(long)]
    out: Option<PathBuf>,
    /// Also show, per cell, the spread of the best mean and of the 99.9th
    /// percentile of M at a study of N networks (as `rwg stats --at-n`; see
    /// below).
    #[arg(long, value_name = "N", value_parser = crate::cmd::stats::parse_at_n)]
    at_n: Option<u64>,
}

/// Runs `rwg report`.
pub fn run(args: Args) -> Result<()> {
    let out = args.out.unwrap_or_else(|| args.run_dir.join(REPORT_HTML));
    let page = Output::derived(&out, OutputKind::File, &args.run_dir, REPORT_HTML);
    let _lock = crate::cmd::claim_output(page, "--out FILE writes the report elsewhere")?;
    let run = Run::open(&args.run_dir)?;
    run.require_finished()?;
    crate::cmd::warn_unverified(&run);
    let cells = rwg_analysis::load_cells(&run)?;
    let mut stats = rwg_analysis::run_stats(&run, &cells);
    if let Some(n) = args.at_n {
        for ((data, _), summary) in cells.iter().zip(stats.cells.iter_mut()) {
            summary.at_n = Some(data.spread_at(n).with_context(|| format!("--at-n {n}"))?);
        }
    }
    let figures = run_figures(&cells, ImageFormat::Svg)?;
    let html = report_html(&run, &stats, &figures);
    crate::cmd::write_named_file(&out, html.as_bytes())?;
    crate::outln!("{}", out.display());
    Ok(())
}
