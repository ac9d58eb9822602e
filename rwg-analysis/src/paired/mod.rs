//! Two implementations of one benchmark, compared network by network
//! (`rwg compare --paired`): an env of one run against an env of the same
//! or another run, one row per architecture × bias setting both have.
//!
//! Network `n` of a cell has weights drawn from the manifest seed, the
//! env's seed id (the id after a prefix such as `gymnax:`), the
//! architecture and `n` only. So when the two cells share these (and the
//! network shape), network `n` is one network in both and its two means are
//! a pair: `gymnax:CartPole-v1` against the built-in `CartPole-v1`, for
//! example. Otherwise the two cells are two independent samples of random
//! networks, and only what does not need pairs is computed.
//!
//! Networks `0..n` of each cell are compared, `n` the smaller cell's count.
//! Per row:
//!
//! - the two-sample Kolmogorov–Smirnov test of the networks' means
//!   ([`two_sample::ks_two_sample`]): are they drawn from one distribution,
//!   the distribution every figure and statistic of a cell is made of? Made
//!   when both cells have the same solved score, or neither has one (other
//!   solved scores mean other scales). Its p-value assumes two independent
//!   samples; the same networks make the two samples alike, so with pairs
//!   it is conservative (slower to say "different"), and ties (returns that
//!   take few values) make it more so.
//! - the solved flags (`M ≥ solved`): with pairs, McNemar's exact test
//!   ([`two_sample::mcnemar_exact`]) of the networks solved in one cell and
//!   not the other: is p(solved) the same? Without pairs, Fisher's exact
//!   test ([`two_sample::fisher_exact`]) of the two counts. Made when both
//!   cells have a solved score.
//! - with pairs, Spearman's rank correlation of the two means
//!   ([`two_sample::spearman`]): does a network good in one implementation
//!   do well in the other? A description, not a test: two implementations
//!   of one benchmark can rank networks differently (observations in
//!   another order, other initial states) and still be equally hard.
//!
//! The verdict: Holm's procedure ([`two_sample::holm`]) over every test of
//! the comparison, family-wise error 0.05. A row is "different" when one of
//! its tests is rejected, "one benchmark" when none is, "untested" when no
//! test applied; the comparison is "different" when any row is. "One
//! benchmark" means that no test found a difference at this sample size,
//! not that there is none: the p(solved) intervals say how much could hide.

mod figure;
mod pairing;
mod rows;
mod table_csv;
pub mod two_sample;

pub use figure::paired_figure;
pub use pairing::{cell_pairs, pair_differences, CellPair, PairSide};
pub use rows::{overall, verdict_text, PairedRow, SolvedPairs, SolvedTest, Verdict, ALPHA};
pub use table_csv::{paired_csv, paired_table, verdict_line, PAIRED_CSV_HEADER};

use serde::Serialize;

/// A whole paired comparison.
#[derive(Debug, Clone, Serialize)]
pub struct PairedComparison {
    /// How the first side is named in headers and the verdict: its env, or
    /// its run when both sides are one env.
    pub label_a: String,
    /// How the second side is named.
    pub label_b: String,
    /// One row per architecture × bias setting of both sides.
    pub rows: Vec<PairedRow>,
    /// The verdict of the whole comparison ([`overall`]).
    pub verdict: Verdict,
    /// What else a reader must know (networks left out of the larger cell).
    pub notes: Vec<String>,
}

/// Why two sides cannot be compared.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum PairedError {
    /// The two sides share no architecture × bias setting.
    #[error("{a} and {b} share no architecture and bias setting ({a}: {list_a}; {b}: {list_b})")]
    NoCommonCells {
        /// The first side.
        a: String,
        /// The second side.
        b: String,
        /// The first side's settings.
        list_a: String,
        /// The second side's.
        list_b: String,
    },
}

fn settings(side: &PairSide) -> String {
    let v: Vec<String> = side
        .cells
        .iter()
        .map(|c| {
            format!(
                "{} {}",
                c.meta.id.arch,
                crate::run_tables::bias_label(c.meta.id.bias)
            )
        })
        .collect();
    v.join(", ")
}

/// Compares `a` with `b`, cell pair by cell pair ([`cell_pairs`]).
pub fn paired_comparison(a: &PairSide, b: &PairSide) -> Result<PairedComparison, PairedError> {
    let (label_a, label_b) = if a.env == b.env {
        (a.run.clone(), b.run.clone())
    } else {
        (a.env.clone(), b.env.clone())
    };
    let pairs = cell_pairs(a, b);
    if pairs.is_empty() {
        return Err(PairedError::NoCommonCells {
            a: label_a,
            b: label_b,
            list_a: settings(a),
            list_b: settings(b),
        });
    }
    let mut notes = Vec::new();
    let mut rows = Vec::new();
    for pair in pairs {
        let (na, nb) = (pair.a.samples(), pair.b.samples());
        if na != nb {
            notes.push(format!(
                "{}: the cells hold {na} and {nb} networks; networks 0 to {} of each are compared",
                pair.a.meta.id.arch,
                na.min(nb) - 1
            ));
        }
        rows.push(rows::row(a, b, pair));
    }
    rows::decide(&mut rows);
    Ok(PairedComparison {
        label_a,
        label_b,
        verdict: overall(&rows),
        rows,
        notes,
    })
}

#[cfg(test)]
mod tests;
