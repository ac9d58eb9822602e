//! # rwg-analysis
//!
//! Everything rwg shows about finished runs: the paper's tables
//! ([`tables`]), rendered as text, Markdown, LaTeX or CSV ([`table`]).
//! The statistics themselves and the run loader live in
//! [`rwg_core::stats`] and [`rwg_core::run_data`].

pub mod fmt;
pub mod plot;
pub mod table;
pub mod tables;

pub use table::{Table, TableFormat};

/// Renders several tables one after another, separated by blank lines.
pub fn render_tables(tables: &[Table], format: TableFormat) -> String {
    let parts: Vec<String> = tables.iter().map(|t| t.render(format)).collect();
    parts.join("\n")
}

/// Loads every cell of a run with its summary, in `run.json` order.
///
/// All cells are held in memory at once (12 bytes per episode).
pub fn load_cells(
    run: &rwg_core::run_data::Run,
) -> Result<
    Vec<(rwg_core::run_data::CellData, rwg_core::stats::CellSummary)>,
    rwg_core::run_data::LoadError,
> {
    run.meta
        .cells
        .iter()
        .map(|c| {
            let data = run.load_cell(c)?;
            let summary = data.summary();
            Ok((data, summary))
        })
        .collect()
}
