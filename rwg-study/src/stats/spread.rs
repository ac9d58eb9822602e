//! The spread of the best mean and of the 99.9th percentile of `M` at a
//! chosen study size `N` (`rwg stats --at-n N`).
//!
//! A published RWG table gives one best mean and one 99.9th percentile per
//! cell, each from a single study of `N` networks. Both are extremes of the
//! distribution of `M` and vary a lot from one study of `N` networks to the
//! next, so one published number can only be compared with the spread of
//! that statistic over many studies of the same `N`.
//!
//! **Method: disjoint blocks.** The cell's networks, in sample order, are
//! cut into `K = ⌊samples / N⌋` disjoint blocks of `N` consecutive networks
//! (block `k` holds networks `k·N … (k+1)·N − 1`; the last `samples − K·N`
//! networks are left out). Networks are i.i.d. draws, so each block *is* an
//! independent study of `N` networks, and the statistic computed on it (best
//! mean: `numpy.max`; 99.9th percentile: `numpy.percentile`, linear, as
//! `p99.9_mean`) is one draw of what a published study would report. rwg
//! gives the minimum, median (`numpy.median` of the `K` values) and maximum
//! over the blocks, and every block's value.
//!
//! Why blocks and not a bootstrap: resampling `N` of the cell's networks with
//! replacement cannot produce a best mean above the cell's own best, and at
//! `N` equal to the cell size it repeats the cell's best in about 63% of the
//! resamples, so a bootstrap interval of an extreme is too narrow exactly
//! where a published value lies outside it. Disjoint blocks need no
//! assumption beyond independence and are exact (no random resampling, so the
//! same cell gives the same bytes), at the price of `samples ≥ 2·N`.
//!
//! **What the range means.** For `K` i.i.d. draws of a continuous statistic,
//! a further independent draw falls between their minimum and maximum with
//! probability `(K − 1)/(K + 1)` ([`SpreadAtN::coverage`]): 82% for 10
//! blocks, 90% for 20, 98% for 100 (with ties, as CartPole's 200, at least
//! that).

use super::{max, percentile_sorted, sorted};
use serde::{Deserialize, Serialize};

/// The statistic over the disjoint blocks of one cell.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BlockSpread {
    /// Lowest value over the blocks.
    pub min: f64,
    /// Median over the blocks (`numpy.median`, i.e. the linear 50th
    /// percentile).
    pub median: f64,
    /// Highest value over the blocks.
    pub max: f64,
    /// Every block's value, block 0 first.
    pub blocks: Vec<f64>,
}

impl BlockSpread {
    fn new(blocks: Vec<f64>) -> Self {
        let s = sorted(&blocks);
        BlockSpread {
            min: s[0],
            median: percentile_sorted(&s, 50.0),
            max: s[s.len() - 1],
            blocks,
        }
    }

    /// How many blocks reach `x` (value `≥ x`): where a published value
    /// falls among the blocks.
    pub fn blocks_at_or_above(&self, x: f64) -> usize {
        self.blocks.iter().filter(|&&b| b >= x).count()
    }
}

/// The spread of a cell's best mean and 99.9th percentile of `M` at a study
/// size of `n` networks, over disjoint blocks (see the module doc).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SpreadAtN {
    /// Networks per block `N` (the study size asked for).
    pub n: u64,
    /// Number of disjoint blocks `K = ⌊samples / N⌋` (at least 2).
    pub blocks: u64,
    /// Networks after the last whole block, left out (`samples − K·N`).
    pub unused: u64,
    /// `(K − 1)/(K + 1)`: the probability that a further independent study
    /// of `N` networks gives a value inside `[min, max]`.
    pub coverage: f64,
    /// The best mean `max M` of each block.
    pub best_mean: BlockSpread,
    /// The 99.9th percentile of `M` of each block.
    pub p99_9_mean: BlockSpread,
}

/// Why a spread cannot be computed.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum SpreadError {
    /// `N = 0`.
    #[error("the study size N must be at least 1 network, got 0")]
    Zero,
    /// Fewer than two whole blocks of `N` networks.
    #[error(
        "{samples} networks hold fewer than 2 disjoint blocks of {n} \
         (2 × {n} = {needed} are needed); {}",
        advice(*largest, *needed)
    )]
    TooFewSamples {
        /// The study size asked for.
        n: u64,
        /// Networks in the cell.
        samples: u64,
        /// `2·n`.
        needed: u64,
        /// The largest `N` the cell allows: `samples / 2`.
        largest: u64,
    },
}

fn advice(largest: u64, needed: u64) -> String {
    let more = format!("run more networks (rwg run MANIFEST --samples {needed} --out NEW_DIR)");
    match largest {
        0 => more,
        _ => format!("choose N ≤ {largest} or {more}"),
    }
}

/// The spread at `n` networks of the best mean and the 99.9th percentile of
/// the sample means `means` (in sample order), over `⌊len / n⌋` disjoint
/// blocks of `n` consecutive networks (see the module doc).
pub fn spread_at_n(means: &[f64], n: u64) -> Result<SpreadAtN, SpreadError> {
    if n == 0 {
        return Err(SpreadError::Zero);
    }
    let samples = means.len() as u64;
    let k = samples / n;
    if k < 2 {
        return Err(SpreadError::TooFewSamples {
            n,
            samples,
            needed: n.saturating_mul(2),
            largest: samples / 2,
        });
    }
    let size = n as usize;
    let (mut best, mut p999) = (
        Vec::with_capacity(k as usize),
        Vec::with_capacity(k as usize),
    );
    for block in means.chunks_exact(size) {
        best.push(max(block));
        p999.push(percentile_sorted(&sorted(block), 99.9));
    }
    Ok(SpreadAtN {
        n,
        blocks: k,
        unused: samples - k * n,
        coverage: (k - 1) as f64 / (k + 1) as f64,
        best_mean: BlockSpread::new(best),
        p99_9_mean: BlockSpread::new(p999),
    })
}
