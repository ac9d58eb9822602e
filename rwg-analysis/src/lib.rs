//! # rwg-analysis
//!
//! Everything rwg derives from a finished run directory and shows: the
//! paper's tables ([`run_tables`]), rendered as text, Markdown, LaTeX, CSV or
//! HTML ([`table_render`]); its figures ([`plot`]); the self-contained HTML
//! report ([`report`]); the comparison of several runs ([`compare`]).
//! The statistics themselves and the run loader live in
//! [`rwg_study::stats`] and [`rwg_study::rundir::data`].
//!
//! [`write_analysis`] writes all of it into a run directory: what `rwg run`
//! calls when it finishes.
//!
//! # Example
//!
//! A tiny study run through `rwg_study`'s runner (what `rwg run` does), then
//! its finished run directory read back and the paper's tables derived from
//! it (what `rwg stats` does), then the whole analysis written into it:
//!
//! ```
//! use rwg_analysis::{load_cells, render_tables, run_stats, write_analysis, TableFormat};
//! use rwg_analysis::run_tables::run_tables;
//! use rwg_study::manifest::Manifest;
//! use rwg_study::rundir::data::{KeptEpisodes, Run};
//! use rwg_study::runner::{run_study, Progress, RunOptions, RunOutcome};
//! use std::sync::atomic::AtomicBool;
//!
//! /// Reports nothing.
//! struct Quiet;
//! impl Progress for Quiet {
//!     fn start(&mut self, _networks: u64) {}
//!     fn cell(&mut self, _label: &str) {}
//!     fn block(&mut self, _label: &str, _networks: u64, _env_steps: u64) {}
//!     fn finish(&mut self, _ok: bool) {}
//! }
//!
//! let text = r#"
//! seed = 0
//! samples = 64
//! episodes = 2
//! bias = [false]
//! [weights]
//! distribution = "normal"
//! scale = 1.0
//! [[architectures]]
//! name = "0HL"
//! hidden = []
//! [[envs]]
//! id = "CartPole-v1"
//! solved = 195
//! "#;
//! let mut m = Manifest::parse(text, "study.toml", std::path::Path::new("."))?;
//! let dir = std::env::temp_dir().join(format!("rwg-analysis-doc-{}", std::process::id()));
//! let stop = AtomicBool::new(false);
//! let opts = RunOptions {
//!     out: dir.clone(),
//!     shard: None,
//!     force_new: true,
//!     stop: &stop,
//!     keep_episodes: false,
//!     commit_linger: std::time::Duration::ZERO,
//!     manifest_file: None,
//! };
//! let outcome = run_study(&mut m, &opts, &mut Quiet)?;
//! assert!(matches!(outcome, RunOutcome::Finished(_)));
//! drop(outcome); // releases the run directory's lock
//!
//! // The finished run, read back: every cell's episodes and summary.
//! let run = Run::open(&dir)?;
//! let cells = load_cells(&run)?;
//! let stats = run_stats(&run, &cells);
//! let p = stats.cells[0].solved_fraction.expect("a solved score was given");
//! assert_eq!(p.trials, 64);
//! let tables = render_tables(&run_tables(&stats), TableFormat::Markdown);
//! assert!(tables.contains("| CartPole-v1 |"), "{tables}");
//!
//! // Or all of it at once, as `rwg run` ends: stats, figures, report.html.
//! let written = write_analysis(&dir, false, KeptEpisodes::new())?;
//! assert!(written.contains(&dir.join("report.html")));
//! std::fs::remove_dir_all(&dir)?;
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! # Modules
//!
//! - [`run_tables`]: what the tables of a run hold; [`table_render`]: how
//!   any table is written (text, Markdown, LaTeX, CSV, HTML; the one
//!   text-column layout); [`fmt`]: how numbers are written in them.
//! - [`plot`]: the paper's figures and the comparison figures.
//! - [`report`] writes `report.html`.
//! - [`jax_cells`]: how a run's JAX cells computed (device, precision,
//!   matmul precision, lanes, versions), from their `env.json`.
//! - [`compare`]: `rwg compare`: its rows, difficulty ranking
//!   ([`compare::ranking`]), table, CSV, figures and HTML page
//!   ([`compare::page`]).
//! - [`paired`]: `rwg compare --paired`: two implementations of one
//!   benchmark, network by network, with its tests and verdict.
//!
//! Cells are read and summarised and figures drawn on the caller's rayon pool,
//! in a fixed order, so the bytes do not depend on the thread count.

pub mod compare;
#[cfg(test)]
mod fixtures;
pub mod fmt;
pub mod jax_cells;
pub mod paired;
pub mod plot;
pub mod report;
pub mod run_tables;
pub mod table_render;

/// [`run_tables`] under its earlier name, which callers still use.
pub use run_tables as tables;
/// [`table_render`] under its earlier name, which callers still use.
pub use table_render as table;

/// [`compare::page`], also at this path.
pub use compare::page as compare_page;
/// [`compare::ranking`], also at this path.
pub use compare::ranking;

use plot::{ImageFormat, PlotError};
use rayon::prelude::*;
use rwg_study::rundir::data::{write_stats, CellData, KeptEpisodes, Run, RunReadError, RunStats};
use rwg_study::stats::CellSummary;
use std::path::{Path, PathBuf};

pub use table_render::{Table, TableFormat};

/// Renders several tables one after another, separated by blank lines.
pub fn render_tables(tables: &[Table], format: TableFormat) -> String {
    let parts: Vec<String> = tables.iter().map(|t| t.render(format)).collect();
    parts.join("\n")
}

/// Why an analysis could not be written.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum AnalysisError {
    /// The run directory could not be read.
    #[error(transparent)]
    Load(#[from] RunReadError),
    /// Another process is writing the run directory.
    #[error(transparent)]
    Lock(#[from] rwg_study::rundir::lock::LockError),
    /// A figure could not be drawn.
    #[error(transparent)]
    Plot(#[from] PlotError),
    /// An output file could not be written.
    #[error("cannot write {path}")]
    Write {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
}

fn write_file(path: PathBuf, bytes: &[u8]) -> Result<PathBuf, AnalysisError> {
    rwg_study::rundir::export::write_atomic(&path, bytes).map_err(|source| {
        AnalysisError::Write {
            path: path.clone(),
            source,
        }
    })?;
    Ok(path)
}

/// Loads every cell of a run with its summary, in `run.json` order.
///
/// All cells are held in memory at once (12 bytes per episode).
pub fn load_cells(run: &Run) -> Result<Vec<(CellData, CellSummary)>, RunReadError> {
    load_cells_with(run, KeptEpisodes::new())
}

/// [`load_cells`], taking the cells whose episodes `kept` holds from there
/// (as the run that just finalised them kept them: the rows of their
/// `scores.csv`) instead of reading their files back.
pub fn load_cells_with(
    run: &Run,
    mut kept: KeptEpisodes,
) -> Result<Vec<(CellData, CellSummary)>, RunReadError> {
    let jobs: Vec<_> = run
        .meta
        .cells
        .iter()
        .map(|c| (c, kept.remove(&c.id.dir)))
        .collect();
    // Cells are read and summarised on the current rayon pool; the first
    // error in the run's cell order is the one returned, whatever the pool.
    let loaded: Vec<Result<(CellData, CellSummary), RunReadError>> = jobs
        .into_par_iter()
        .map(|(c, kept)| {
            let data = match kept {
                Some((scores, steps)) => {
                    CellData::new(c.clone(), c.episodes as usize, scores, steps)
                }
                None => run.load_cell(c)?,
            };
            let summary = data.summary();
            Ok((data, summary))
        })
        .collect();
    loaded.into_iter().collect()
}

/// The statistics of loaded cells.
pub fn run_stats(run: &Run, cells: &[(CellData, CellSummary)]) -> RunStats {
    RunStats {
        run: run.meta.clone(),
        cells: cells.iter().map(|(_, s)| s.clone()).collect(),
    }
}

/// Writes the whole analysis of a finished run into its directory:
/// `stats.json`, `stats.csv`, `figures/*.svg` (plus `figures/*.png` with
/// `png`), and `report.html`. Returns the files written. This is what
/// `rwg run` calls at the end, with the episodes of the cells it finalised
/// (`kept`, see [`load_cells_with`]; the other cells are read from disk).
pub fn write_analysis(
    run_dir: &Path,
    png: bool,
    kept: KeptEpisodes,
) -> Result<Vec<PathBuf>, AnalysisError> {
    let run = Run::open(run_dir)?;
    let _lock = rwg_study::rundir::lock::RunLock::acquire(run_dir)?;
    let cells = load_cells_with(&run, kept)?;
    let stats = run_stats(&run, &cells);
    write_stats(run_dir, &stats).map_err(|source| AnalysisError::Write {
        path: run_dir.to_path_buf(),
        source,
    })?;
    let mut written = vec![
        run_dir.join(rwg_study::rundir::STATS_JSON),
        run_dir.join(rwg_study::rundir::STATS_CSV),
    ];
    let fig_dir = run_dir.join(rwg_study::rundir::FIGURES);
    std::fs::create_dir_all(&fig_dir).map_err(|source| AnalysisError::Write {
        path: fig_dir.clone(),
        source,
    })?;
    let svgs = plot::run_figures(&cells, ImageFormat::Svg)?;
    for f in &svgs {
        written.push(write_file(fig_dir.join(f.file_name()), &f.bytes)?);
    }
    if png {
        for f in plot::run_figures(&cells, ImageFormat::Png)? {
            written.push(write_file(fig_dir.join(f.file_name()), &f.bytes)?);
        }
    }
    let html = report::report_html(&run, &stats, &svgs);
    written.push(write_file(
        run_dir.join(report::REPORT_HTML),
        html.as_bytes(),
    )?);
    Ok(written)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rwg_study::rundir::data::synthetic::{write_synthetic_run, SyntheticCell, SyntheticRun};

    #[test]
    fn write_analysis_writes_everything() {
        let dir = std::env::temp_dir().join(format!("rwg-analysis-all-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        write_synthetic_run(
            &dir,
            &SyntheticRun {
                samples: 30,
                episodes: 3,
                seed: 2,
                cells: vec![SyntheticCell::cartpole("0HL", &[], false)],
            },
        )
        .unwrap();
        let files = write_analysis(&dir, true, KeptEpisodes::new()).unwrap();
        let names: Vec<String> = files
            .iter()
            .map(|p| p.strip_prefix(&dir).unwrap().display().to_string())
            .collect();
        assert_eq!(
            names,
            [
                "stats.json",
                "stats.csv",
                "figures/overview_nobias.svg",
                "figures/CartPole-v0__0HL__nobias.hist.svg",
                "figures/CartPole-v0__0HL__nobias.scores.svg",
                "figures/CartPole-v0__0HL__nobias.variance.svg",
                "figures/overview_nobias.png",
                "figures/CartPole-v0__0HL__nobias.hist.png",
                "figures/CartPole-v0__0HL__nobias.scores.png",
                "figures/CartPole-v0__0HL__nobias.variance.png",
                "report.html",
            ]
        );
        assert!(files.iter().all(|f| f.is_file()));
        let e = write_analysis(&dir.join("missing"), false, KeptEpisodes::new()).unwrap_err();
        assert!(matches!(e, AnalysisError::Load(_)), "{e}");
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// The cause of a failed write is chained, not also printed: a chain
    /// printer (`rwg`'s `error: a: b`) shows it once.
    #[test]
    fn a_write_error_chains_its_cause_without_printing_it() {
        use std::error::Error;
        let dir = std::env::temp_dir().join(format!("rwg-analysis-write-{}", std::process::id()));
        std::fs::write(&dir, b"a file").unwrap();
        let e = write_file(dir.join("x.svg"), b"").unwrap_err();
        std::fs::remove_file(&dir).unwrap();
        let cause = e.source().expect("the I/O error is the source").to_string();
        assert!(!e.to_string().contains(&cause), "{e} repeats {cause}");
        assert!(e.to_string().starts_with("cannot write "), "{e}");
    }
}
