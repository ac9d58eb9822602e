//! `rwg plot`: the paper's figures for a run.

use anyhow::{Context, Result};
use rwg_analysis::plot::{run_figures, ImageFormat};
use rwg_study::rundir::data::Run;
use rwg_study::rundir::outputs::{Output, OutputKind};
use rwg_study::rundir::FIGURES;
use std::path::PathBuf;

/// Arguments of `rwg plot`.
#[derive(clap::Args)]
pub struct Args {
    /// Run directory, as written by `rwg run`.
    run_dir: PathBuf,
    /// Output directory [default: RUN_DIR/figures].
    #[arg(long)]
    out: Option<PathBuf>,
    /// Write PNG instead of SVG.
    #[arg(long)]
    png: bool,
}

/// Runs `rwg plot`.
pub fn run(args: Args) -> Result<()> {
    let out = args.out.unwrap_or_else(|| args.run_dir.join(FIGURES));
    let figures = Output::derived(&out, OutputKind::Folder, &args.run_dir, FIGURES);
    let _lock = crate::cmd::claim_output(figures, "--out DIR writes the figures elsewhere")?;
    let run = Run::open(&args.run_dir)?;
    crate::cmd::warn_unverified(&run);
    let cells = rwg_analysis::load_cells(&run)?;
    let format = if args.png {
        ImageFormat::Png
    } else {
        ImageFormat::Svg
    };
    std::fs::create_dir_all(&out).with_context(|| format!("cannot create {}", out.display()))?;
    for fig in run_figures(&cells, format)? {
        let path = out.join(fig.file_name());
        rwg_study::rundir::export::write_atomic(&path, &fig.bytes)
            .with_context(|| format!("cannot write {}", path.display()))?;
        crate::outln!("{}", path.display());
    }
    Ok(())
}
