//! Comparing runs (`rwg compare`): envs from several runs side by side, one
//! row per run × env × architecture × bias, with a score normalised so the
//! median random network is 0 and the solved score is 1, and every row's
//! place in the difficulty ranking.
//!
//! One file per job, each using only those listed before it:
//!
//! - `data`: the runs compared ([`CompareRun`]), whether their settings allow
//!   it ([`settings_differences`]), the rows ([`CompareRow`]);
//! - [`ranking`]: the difficulty order of the rows and its table;
//! - `table_csv`: the rows as a table ([`compare_table`]) and as CSV
//!   ([`compare_csv`]);
//! - `figures`: the performance profiles ([`profiles_figure`]) and the
//!   ranking figure ([`ranking_figure`]);
//! - [`page`]: the self-contained HTML page of `rwg compare --html`.
//!
//! [`compare_rows`], here, joins the first two: the rows side by side, ranked.

mod data;
mod figures;
pub mod page;
pub mod ranking;
mod table_csv;
#[cfg(test)]
mod tests;

pub use data::{settings_differences, CompareRow, CompareRun};
pub use figures::{profiles_figure, ranking_figure};
pub use table_csv::{compare_csv, compare_table};

/// The rows of a comparison, the runs of each env × architecture × bias
/// side by side: ordered by env, architecture (each in order of first
/// appearance), bias (without first), then run; each with its
/// `difficulty_rank` ([`ranking::difficulty_ranks`]).
pub fn compare_rows(runs: &[CompareRun]) -> Vec<CompareRow> {
    let mut rows = data::side_by_side(runs);
    let ranks = ranking::difficulty_ranks(&rows);
    for (r, rank) in rows.iter_mut().zip(ranks) {
        r.difficulty_rank = rank;
    }
    rows
}
