//! Each cell's spread at a chosen study size ([`crate::stats::spread`]) in
//! a run's statistics: [`Run::summarize_at`], and its `stats.csv` columns.

use super::{CellData, Run, RunReadError, RunStats};
use crate::stats::{self, CellSummary};
use rwg_env::float::fmt_f64;

impl CellData {
    /// The spread of the cell's best mean and 99.9th percentile of `M` at a
    /// study size of `n` networks ([`stats::spread_at_n`]); the error names
    /// the cell.
    pub fn spread_at(&self, n: u64) -> Result<stats::SpreadAtN, CellSpreadError> {
        stats::spread_at_n(&self.means(), n).map_err(|source| CellSpreadError {
            cell: self.meta.id.dir.clone(),
            source,
        })
    }
}

/// A cell whose spread at a study size cannot be computed
/// ([`CellData::spread_at`]).
#[derive(Debug, Clone, thiserror::Error)]
#[error("cell {cell}")]
pub struct CellSpreadError {
    /// The cell's directory name.
    pub cell: String,
    /// Why (chained, not printed).
    pub source: stats::SpreadError,
}

/// Why [`Run::summarize_at`] failed.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum SummarizeError {
    /// A cell could not be read.
    #[error(transparent)]
    Read(#[from] RunReadError),
    /// A cell is too small for the study size asked for.
    #[error(transparent)]
    Spread(#[from] CellSpreadError),
}

impl Run {
    /// [`Run::summarize`], and with `at_n = Some(n)` every cell's spread at
    /// `n` networks ([`CellData::spread_at`]) in its summary's `at_n`. Cells
    /// are loaded one at a time.
    pub fn summarize_at(&self, at_n: Option<u64>) -> Result<RunStats, SummarizeError> {
        let mut cells = Vec::with_capacity(self.meta.cells.len());
        for c in &self.meta.cells {
            let data = self.load_cell(c)?;
            let mut summary = data.summary();
            if let Some(n) = at_n {
                summary.at_n = Some(data.spread_at(n)?);
            }
            cells.push(summary);
        }
        Ok(RunStats {
            run: self.meta.clone(),
            cells,
        })
    }
}

/// The columns `stats.csv` gains, after all others, when the spread at a
/// study size was asked for (`rwg stats --at-n N`): `N`, the number of
/// blocks, and min / median / max over the blocks of the best mean and of
/// the 99.9th percentile of `M`.
pub const SPREAD_CSV_COLUMNS: [&str; 8] = [
    "at_n",
    "at_n_blocks",
    "best_mean_at_n_min",
    "best_mean_at_n_median",
    "best_mean_at_n_max",
    "p99.9_mean_at_n_min",
    "p99.9_mean_at_n_median",
    "p99.9_mean_at_n_max",
];

/// The [`SPREAD_CSV_COLUMNS`] of one cell (empty fields without a spread).
pub fn spread_csv_fields(s: &CellSummary) -> Vec<String> {
    match &s.at_n {
        None => vec![String::new(); SPREAD_CSV_COLUMNS.len()],
        Some(a) => vec![
            a.n.to_string(),
            a.blocks.to_string(),
            fmt_f64(a.best_mean.min),
            fmt_f64(a.best_mean.median),
            fmt_f64(a.best_mean.max),
            fmt_f64(a.p99_9_mean.min),
            fmt_f64(a.p99_9_mean.median),
            fmt_f64(a.p99_9_mean.max),
        ],
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_cell_spread_error_names_the_cell_and_chains_why() {
        let e = CellSpreadError {
            cell: "CartPole-v1__1HL__nobias".into(),
            source: stats::SpreadError::Zero,
        };
        assert_eq!(e.to_string(), "cell CartPole-v1__1HL__nobias");
        let cause = std::error::Error::source(&e).map(|s| s.to_string());
        assert_eq!(cause, Some(stats::SpreadError::Zero.to_string()));
    }
}
