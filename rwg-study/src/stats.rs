//! The statistics of an RWG score tensor, as pure functions.
//!
//! A cell's scores form an `N × E` matrix: `N` sampled networks ("samples"),
//! each run for `E` episodes. From it the paper (Oller, Glasmachers, Cuccu,
//! AAMAS 2020) derives, per sample, the mean score `M` and its variance `V`,
//! and per cell the distribution of `M`: best mean, percentiles, and the
//! fraction of samples whose `M` reaches the env's solved score.
//!
//! Every float here is computed the way numpy computes it, bit for bit, so the
//! numbers match a numpy analysis of the same scores:
//! - sums use numpy's pairwise summation ([`pairwise_sum`]);
//! - `mean = sum / n` and the variance is numpy's `var`:
//!   `sum((x - mean)²) / n`.
//! - percentiles are `numpy.percentile`'s default `linear` method
//!   ([`percentile`]);
//! - ranks follow `numpy.argsort(kind="stable")` ([`ranks`]).
//!
//! **Variance normalisation.** The paper's text prints the variance of a
//! sample's episode scores with a `1/(N+1)` factor, but its reference code
//! computes it with numpy's `var`, whose default (`ddof=0`) is the population
//! variance `1/N`. rwg follows the code: [`variance`] divides by the number of
//! episodes.

use crate::rundir::meta::{CellId, CellMeta};
use serde::{Deserialize, Serialize};
use std::cmp::Ordering;

pub mod spread;
pub use spread::{spread_at_n, BlockSpread, SpreadAtN, SpreadError};

/// Two-sided 95% standard normal quantile, `Φ⁻¹(0.975)`.
pub const Z_95: f64 = 1.959_963_984_540_054;

/// The percentiles of the sample means reported per cell.
pub const MEAN_PERCENTILES: [f64; 9] = [1.0, 5.0, 10.0, 25.0, 50.0, 75.0, 90.0, 99.0, 99.9];

/// The guess counts `n` for which P(at least one solving network in `n`
/// guesses) is reported.
pub const GUESS_COUNTS: [u64; 3] = [10, 100, 1000];

/// Share of episodes, in percent, above the "top episodes" threshold
/// ([`top_episode_threshold`]): the top 0.1%.
pub const TOP_EPISODE_PERCENT: f64 = 0.1;

/// numpy's pairwise summation of float64 values (`numpy.add.reduce` on a
/// contiguous array): blocks of at most 128 values are summed with eight
/// interleaved accumulators, larger arrays are split in halves (rounded down
/// to a multiple of eight) and summed recursively.
pub fn pairwise_sum(xs: &[f64]) -> f64 {
    const BLOCK: usize = 128;
    let n = xs.len();
    if n < 8 {
        let mut res = 0.0;
        for &x in xs {
            res += x;
        }
        res
    } else if n <= BLOCK {
        let mut r = [0.0; 8];
        r.copy_from_slice(&xs[..8]);
        let whole = n - n % 8;
        let mut i = 8;
        while i < whole {
            for (j, acc) in r.iter_mut().enumerate() {
                *acc += xs[i + j];
            }
            i += 8;
        }
        let mut res = ((r[0] + r[1]) + (r[2] + r[3])) + ((r[4] + r[5]) + (r[6] + r[7]));
        for &x in &xs[whole..] {
            res += x;
        }
        res
    } else {
        let mut n2 = n / 2;
        n2 -= n2 % 8;
        pairwise_sum(&xs[..n2]) + pairwise_sum(&xs[n2..])
    }
}

/// Arithmetic mean as `numpy.mean`: pairwise sum divided by the count. `NaN`
/// for an empty slice.
pub fn mean(xs: &[f64]) -> f64 {
    pairwise_sum(xs) / xs.len() as f64
}

/// Population variance as `numpy.var` (`ddof=0`, i.e. divided by the count,
/// not by count − 1 nor count + 1). `NaN` for an empty slice.
pub fn variance(xs: &[f64]) -> f64 {
    let m = mean(xs);
    let sq: Vec<f64> = xs
        .iter()
        .map(|&x| {
            let d = x - m;
            d * d
        })
        .collect();
    pairwise_sum(&sq) / xs.len() as f64
}

/// Minimum as `numpy.min`: `NaN` if any value is `NaN` (or the slice is empty).
pub fn min(xs: &[f64]) -> f64 {
    xs.iter()
        .copied()
        .reduce(|a, b| {
            if a.is_nan() || b.is_nan() {
                f64::NAN
            } else {
                a.min(b)
            }
        })
        .unwrap_or(f64::NAN)
}

/// Maximum as `numpy.max`: `NaN` if any value is `NaN` (or the slice is empty).
pub fn max(xs: &[f64]) -> f64 {
    xs.iter()
        .copied()
        .reduce(|a, b| {
            if a.is_nan() || b.is_nan() {
                f64::NAN
            } else {
                a.max(b)
            }
        })
        .unwrap_or(f64::NAN)
}

/// The statistics of one sample's episode scores (one row of `samples.csv`
/// without the rank).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SampleStats {
    /// Mean score `M`.
    pub mean: f64,
    /// Population variance `V` ([`variance`]).
    pub variance: f64,
    /// `sqrt(V)` (`numpy.std`).
    pub std: f64,
    /// Lowest episode score.
    pub min: f64,
    /// Highest episode score.
    pub max: f64,
}

/// Statistics of one sample's episode scores.
pub fn sample_stats(scores: &[f64]) -> SampleStats {
    let variance = variance(scores);
    SampleStats {
        mean: mean(scores),
        variance,
        std: variance.sqrt(),
        min: min(scores),
        max: max(scores),
    }
}

/// Per-sample statistics of a row-major `N × episodes` score matrix (as
/// `numpy`'s `mean(axis=1)`, `var(axis=1)`, … on it).
///
/// # Panics
/// If `episodes` is 0 or does not divide `scores.len()`.
pub fn per_sample(scores: &[f64], episodes: usize) -> Vec<SampleStats> {
    assert!(episodes > 0, "episodes must be positive");
    assert_eq!(
        scores.len() % episodes,
        0,
        "score matrix is not N × episodes"
    );
    scores.chunks_exact(episodes).map(sample_stats).collect()
}

/// numpy's sort order of floats: ascending, `NaN` last, `-0.0 == 0.0`.
fn numpy_cmp(a: f64, b: f64) -> Ordering {
    match (a.is_nan(), b.is_nan()) {
        (false, false) => a.partial_cmp(&b).expect("not NaN"),
        (true, true) => Ordering::Equal,
        (true, false) => Ordering::Greater,
        (false, true) => Ordering::Less,
    }
}

/// `numpy.argsort(xs, kind="stable")`: the indices that sort `xs` ascending,
/// equal values keeping their order, `NaN` last.
pub fn argsort(xs: &[f64]) -> Vec<usize> {
    let mut idx: Vec<usize> = (0..xs.len()).collect();
    idx.sort_by(|&a, &b| numpy_cmp(xs[a], xs[b]));
    idx
}

/// The rank of every value: its 0-based position in [`argsort`]'s order, so
/// the largest value has rank `len − 1` and ties keep index order
/// (`samples.csv`'s `rank` column, with `xs` the sample means).
pub fn ranks(xs: &[f64]) -> Vec<usize> {
    let mut rank = vec![0; xs.len()];
    for (r, i) in argsort(xs).into_iter().enumerate() {
        rank[i] = r;
    }
    rank
}

/// A copy of `xs` sorted as numpy sorts (ascending, `NaN` last).
pub fn sorted(xs: &[f64]) -> Vec<f64> {
    let mut v = xs.to_vec();
    v.sort_by(|a, b| numpy_cmp(*a, *b));
    v
}

/// `numpy.percentile(xs, q)` with the default `linear` method (Hyndman & Fan
/// type 7) on already [`sorted`] values, bit for bit: the virtual index is
/// `(n − 1)·q/100`, and the two neighbours `a ≤ b` are interpolated as
/// `a + (b − a)·g` for a fraction `g < 0.5`, else `b − (b − a)·(1 − g)`.
/// `NaN` if any value is `NaN` or `sorted` is empty.
///
/// # Panics
/// If `q` is outside `[0, 100]`.
pub fn percentile_sorted(sorted: &[f64], q: f64) -> f64 {
    assert!(
        (0.0..=100.0).contains(&q),
        "percentile {q} outside [0, 100]"
    );
    let n = sorted.len();
    if n == 0 || sorted[n - 1].is_nan() {
        return f64::NAN;
    }
    let virtual_index = (n - 1) as f64 * (q / 100.0);
    if virtual_index >= (n - 1) as f64 {
        return sorted[n - 1];
    }
    let lo = virtual_index.floor();
    let gamma = virtual_index - lo;
    let (a, b) = (sorted[lo as usize], sorted[lo as usize + 1]);
    let diff = b - a;
    if gamma >= 0.5 {
        b - diff * (1.0 - gamma)
    } else {
        a + diff * gamma
    }
}

/// `numpy.percentile(xs, q)` (default `linear` method); see
/// [`percentile_sorted`].
pub fn percentile(xs: &[f64], q: f64) -> f64 {
    percentile_sorted(&sorted(xs), q)
}

/// A binomial proportion with its 95% Wilson score interval.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Proportion {
    /// Successes `k`.
    pub successes: u64,
    /// Trials `n`.
    pub trials: u64,
    /// Point estimate `k / n`.
    pub p: f64,
    /// Lower end of the 95% Wilson interval.
    pub lo: f64,
    /// Upper end of the 95% Wilson interval.
    pub hi: f64,
}

/// The Wilson score interval for `k` successes in `n` trials at normal
/// quantile `z` (use [`Z_95`] for 95%): `(center ∓ half)` with
/// `center = (p̂ + z²/2n) / (1 + z²/n)` and
/// `half = z / (1 + z²/n) · sqrt(p̂(1 − p̂)/n + z²/4n²)`, clamped to `[0, 1]`;
/// exactly 0 at `k = 0` and 1 at `k = n`. `(0, 1)` when `n = 0`.
///
/// Unlike the normal ("Wald") interval it stays informative at `k = 0`: the
/// upper end is then `z² / (n + z²)`, about `3.84 / n`.
pub fn wilson_interval(k: u64, n: u64, z: f64) -> (f64, f64) {
    assert!(k <= n, "more successes ({k}) than trials ({n})");
    if n == 0 {
        return (0.0, 1.0);
    }
    let nf = n as f64;
    let p = k as f64 / nf;
    let z2 = z * z;
    let denom = 1.0 + z2 / nf;
    let center = (p + z2 / (2.0 * nf)) / denom;
    let half = z / denom * (p * (1.0 - p) / nf + z2 / (4.0 * nf * nf)).sqrt();
    let lo = if k == 0 {
        0.0
    } else {
        (center - half).max(0.0)
    };
    let hi = if k == n {
        1.0
    } else {
        (center + half).min(1.0)
    };
    (lo, hi)
}

/// The fraction of `means` at or above `solved` (`M ≥ solved`), with its 95%
/// Wilson interval. `NaN` means never count as solved.
pub fn solved_fraction(means: &[f64], solved: f64) -> Proportion {
    let k = means.iter().filter(|&&m| m >= solved).count() as u64;
    let n = means.len() as u64;
    let (lo, hi) = wilson_interval(k, n, Z_95);
    Proportion {
        successes: k,
        trials: n,
        p: if n == 0 {
            f64::NAN
        } else {
            k as f64 / n as f64
        },
        lo,
        hi,
    }
}

/// Expected number of random guesses until the first solving network: the
/// mean `1/p` of a geometric distribution with success probability `p`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum ExpectedGuesses {
    /// At least one solving sample: `1/p`, with the interval `[1/hi, 1/lo]`
    /// from the proportion's interval (`hi_bound` is `None` when `lo = 0`).
    Estimate {
        /// `1 / p`.
        value: f64,
        /// `1 / hi`.
        lo_bound: f64,
        /// `1 / lo`; `None` when the interval reaches 0.
        hi_bound: Option<f64>,
    },
    /// No sample solved: the expectation is unbounded above, and at least
    /// `1 / hi` (the upper confidence bound's reciprocal) at 95% confidence.
    NoneSeen {
        /// `1 / hi`: a 95% lower bound on the expected guesses.
        at_least: f64,
    },
}

/// Expected guesses to the first success from a solved fraction.
pub fn expected_guesses(prop: &Proportion) -> ExpectedGuesses {
    if prop.successes == 0 {
        ExpectedGuesses::NoneSeen {
            at_least: 1.0 / prop.hi,
        }
    } else {
        ExpectedGuesses::Estimate {
            value: 1.0 / prop.p,
            lo_bound: 1.0 / prop.hi,
            hi_bound: (prop.lo > 0.0).then(|| 1.0 / prop.lo),
        }
    }
}

/// P(at least one success in `n` independent guesses) `= 1 − (1 − p)^n`,
/// computed as `−expm1(n · ln1p(−p))` so tiny `p` keep their precision.
pub fn p_any_success(p: f64, n: u64) -> f64 {
    -(n as f64 * (-p).ln_1p()).exp_m1()
}

/// The top-0.1% episode score threshold: the 99.9th percentile
/// (`numpy.percentile`, linear) of all episode scores of a cell. Episodes
/// scoring at or above it are the "top 0.1%" the paper's scatter plot
/// highlights.
pub fn top_episode_threshold(scores: &[f64]) -> f64 {
    percentile(scores, 100.0 - TOP_EPISODE_PERCENT)
}

/// Mean episode length in steps (`numpy.mean` of the step counts).
pub fn mean_episode_length(steps: &[u32]) -> f64 {
    let v: Vec<f64> = steps.iter().map(|&s| f64::from(s)).collect();
    mean(&v)
}

/// One percentile of a distribution.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Percentile {
    /// The percentile, in `[0, 100]`.
    pub q: f64,
    /// Its value.
    pub value: f64,
}

/// P(at least one solving network in `guesses` random guesses).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct GuessOdds {
    /// Number of guesses `n`.
    pub guesses: u64,
    /// `1 − (1 − p)^n` at the point estimate of `p`.
    pub p: f64,
    /// The same at the lower end of `p`'s interval.
    pub lo: f64,
    /// The same at the upper end of `p`'s interval.
    pub hi: f64,
}

/// Everything rwg reports about one cell (env × architecture × bias): one
/// entry of `stats.json`, one row of `stats.csv`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CellSummary {
    /// Which cell.
    #[serde(flatten)]
    pub id: CellId,
    /// Weights per network.
    pub n_weights: usize,
    /// Samples (networks) `N`.
    pub samples: u64,
    /// Episodes per sample `E`.
    pub episodes: u32,
    /// Solved score, if any.
    pub solved: Option<f64>,
    /// Highest sample mean `max M`.
    pub best_mean: f64,
    /// Index of the best sample (the one with rank `N − 1`).
    pub best_sample: u64,
    /// Variance `V` of the best sample's scores.
    pub best_variance: f64,
    /// Lowest sample mean.
    pub worst_mean: f64,
    /// Mean of the sample means.
    pub mean_of_means: f64,
    /// Median of `M` (50th percentile).
    pub median_mean: f64,
    /// 99.9th percentile of `M` (the paper's Table 3 value in parentheses).
    pub p99_9_mean: f64,
    /// Percentiles of `M` at [`MEAN_PERCENTILES`].
    pub mean_percentiles: Vec<Percentile>,
    /// Mean of the sample variances `V`.
    pub mean_variance: f64,
    /// Fraction of samples with `M ≥ solved` (`None` without a solved score).
    pub solved_fraction: Option<Proportion>,
    /// Expected guesses to the first solving network (`None` without a
    /// solved score).
    pub expected_guesses: Option<ExpectedGuesses>,
    /// P(at least one solving network) in [`GUESS_COUNTS`] guesses (empty
    /// without a solved score).
    pub success_odds: Vec<GuessOdds>,
    /// Top-0.1% episode score threshold ([`top_episode_threshold`]).
    pub top_episode_threshold: f64,
    /// Episodes scoring at or above the threshold.
    pub top_episodes: u64,
    /// Highest episode score.
    pub best_episode: f64,
    /// Mean episode length in steps.
    pub mean_episode_length: f64,
    /// Longest episode in steps.
    pub max_episode_length: u32,
    /// With `non_finite = "end"`: the cell's episodes a value that was not
    /// finite ended (its `cell.json`'s count); absent otherwise.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub non_finite_episodes: Option<u64>,
    /// The spread of `best_mean` and `p99_9_mean` over disjoint blocks of a
    /// chosen study size ([`spread_at_n`]); only when asked for
    /// (`rwg stats --at-n N`), absent from `stats.json` otherwise.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub at_n: Option<SpreadAtN>,
}

impl CellSummary {
    /// The value of `M`'s percentile `q` if it is one of [`MEAN_PERCENTILES`].
    pub fn mean_percentile(&self, q: f64) -> Option<f64> {
        self.mean_percentiles
            .iter()
            .find(|p| p.q == q)
            .map(|p| p.value)
    }

    /// `x` rescaled so the median random network scores 0 and the solved
    /// score 1: `(x − median M) / (solved − median M)`. `None` without a
    /// solved score or when it equals the median.
    pub fn normalise(&self, x: f64) -> Option<f64> {
        let s = self.solved?;
        let span = s - self.median_mean;
        (span != 0.0 && span.is_finite()).then(|| (x - self.median_mean) / span)
    }
}

/// Summarises one cell from its row-major `N × E` scores and step counts.
///
/// `stats` are the per-sample statistics ([`per_sample`]) of `scores`.
///
/// # Panics
/// If the shapes disagree or the cell is empty.
pub fn summarize_cell(
    meta: &CellMeta,
    episodes: usize,
    scores: &[f64],
    steps: &[u32],
    stats: &[SampleStats],
) -> CellSummary {
    assert!(!stats.is_empty(), "cell {} has no samples", meta.id.dir);
    assert_eq!(scores.len(), stats.len() * episodes, "scores are not N × E");
    assert_eq!(
        steps.len(),
        scores.len(),
        "steps and scores differ in length"
    );
    let means: Vec<f64> = stats.iter().map(|s| s.mean).collect();
    let variances: Vec<f64> = stats.iter().map(|s| s.variance).collect();
    let order = argsort(&means);
    let best = *order.last().expect("non-empty");
    let sorted_means: Vec<f64> = order.iter().map(|&i| means[i]).collect();
    let mean_percentiles = MEAN_PERCENTILES
        .iter()
        .map(|&q| Percentile {
            q,
            value: percentile_sorted(&sorted_means, q),
        })
        .collect();
    let solved_fraction = meta.solved.map(|s| solved_fraction(&means, s));
    let success_odds = solved_fraction
        .map(|prop| {
            GUESS_COUNTS
                .iter()
                .map(|&n| GuessOdds {
                    guesses: n,
                    p: p_any_success(prop.p, n),
                    lo: p_any_success(prop.lo, n),
                    hi: p_any_success(prop.hi, n),
                })
                .collect()
        })
        .unwrap_or_default();
    let threshold = top_episode_threshold(scores);
    CellSummary {
        id: meta.id.clone(),
        n_weights: meta.n_weights,
        samples: stats.len() as u64,
        episodes: episodes as u32,
        solved: meta.solved,
        best_mean: means[best],
        best_sample: best as u64,
        best_variance: variances[best],
        worst_mean: min(&means),
        mean_of_means: mean(&means),
        median_mean: percentile_sorted(&sorted_means, 50.0),
        p99_9_mean: percentile_sorted(&sorted_means, 99.9),
        mean_percentiles,
        mean_variance: mean(&variances),
        expected_guesses: solved_fraction.as_ref().map(expected_guesses),
        solved_fraction,
        success_odds,
        top_episode_threshold: threshold,
        top_episodes: scores.iter().filter(|&&s| s >= threshold).count() as u64,
        best_episode: max(scores),
        mean_episode_length: mean_episode_length(steps),
        max_episode_length: steps.iter().copied().max().unwrap_or(0),
        non_finite_episodes: meta.non_finite_episodes,
        at_n: None,
    }
}

#[cfg(test)]
mod tests;
