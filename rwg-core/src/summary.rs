//! Per-sample summaries of episode scores, computed exactly as numpy does.
//!
//! `mean` and `variance` reproduce `np.mean(x)` and `np.var(x)` bit for bit
//! (numpy's pairwise summation; population variance, 1/N), so a Python user
//! who loads `scores.csv` gets the same numbers as `samples.csv`.

use serde::Serialize;

/// numpy's pairwise summation (`pairwise_sum` in numpy's loops), used by
/// `np.sum`/`np.mean` on contiguous float64 data.
pub fn numpy_sum(x: &[f64]) -> f64 {
    let n = x.len();
    if n < 8 {
        // numpy starts from -0.0 so that a sum of negative zeros stays -0.0
        let mut s = -0.0;
        for v in x {
            s += v;
        }
        s
    } else if n <= 128 {
        let mut r = [0.0; 8];
        r.copy_from_slice(&x[..8]);
        let mut i = 8;
        while i < n - (n % 8) {
            for k in 0..8 {
                r[k] += x[i + k];
            }
            i += 8;
        }
        let mut res = ((r[0] + r[1]) + (r[2] + r[3])) + ((r[4] + r[5]) + (r[6] + r[7]));
        for v in &x[i..] {
            res += v;
        }
        res
    } else {
        let mut n2 = n / 2;
        n2 -= n2 % 8;
        numpy_sum(&x[..n2]) + numpy_sum(&x[n2..])
    }
}

/// Statistics of one sample's episode scores.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct SampleSummary {
    /// `np.mean(scores)`.
    pub mean: f64,
    /// `np.var(scores)`: population variance (1/N).
    pub variance: f64,
    /// `np.std(scores)` = sqrt(variance).
    pub std: f64,
    /// Lowest episode score.
    pub min: f64,
    /// Highest episode score.
    pub max: f64,
}

impl SampleSummary {
    /// Summarises a sample's episode scores (at least one). `scratch` is
    /// reused to avoid allocating.
    pub fn of(scores: &[f64], scratch: &mut Vec<f64>) -> Self {
        let n = scores.len() as f64;
        let mean = numpy_sum(scores) / n;
        scratch.clear();
        scratch.extend(scores.iter().map(|x| {
            let d = x - mean;
            d * d
        }));
        let variance = numpy_sum(scratch) / n;
        let min = scores.iter().copied().fold(f64::INFINITY, f64::min);
        let max = scores.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        SampleSummary {
            mean,
            variance,
            std: variance.sqrt(),
            min,
            max,
        }
    }
}

/// Rank of every sample by mean: its 0-based position when sorted ascending,
/// ties keeping sample order (`np.argsort(means, kind="stable")`, inverted).
/// The best sample has rank N−1. NaN means sort last.
pub fn ranks_by_mean(means: &[f64]) -> Vec<u64> {
    let mut order: Vec<usize> = (0..means.len()).collect();
    order.sort_by(|&a, &b| means[a].total_cmp(&means[b]).then(a.cmp(&b)));
    let mut rank = vec![0u64; means.len()];
    for (r, &i) in order.iter().enumerate() {
        rank[i] = r as u64;
    }
    rank
}

#[cfg(test)]
mod tests {
    use super::*;

    // Expected values from numpy 2.4:
    //   x = np.array([((i * 7919) % 1000) / 7.0 - 50 for i in range(n)])
    //   repr(np.sum(x)), repr(np.mean(x)), repr(np.var(x))
    fn data(n: usize) -> Vec<f64> {
        (0..n)
            .map(|i| ((i * 7919) % 1000) as f64 / 7.0 - 50.0)
            .collect()
    }

    #[test]
    fn sums_match_numpy_pairwise() {
        assert_eq!(numpy_sum(&data(5)), NP_SUM_5);
        assert_eq!(numpy_sum(&data(20)), NP_SUM_20);
        assert_eq!(numpy_sum(&data(1000)), NP_SUM_1000);
    }

    #[test]
    fn mean_and_var_match_numpy() {
        let mut scratch = vec![];
        let s = SampleSummary::of(&data(20), &mut scratch);
        assert_eq!(s.mean, NP_MEAN_20);
        assert_eq!(s.variance, NP_VAR_20);
        assert_eq!(s.std, NP_VAR_20.sqrt());
        assert_eq!(s.min, -50.0);
    }

    #[test]
    fn ranks_are_stable_ascending() {
        assert_eq!(ranks_by_mean(&[3.0, 1.0, 3.0, 2.0]), [2, 0, 3, 1]);
    }

    const NP_SUM_5: f64 = 205.71428571428567;
    const NP_SUM_20: f64 = 515.7142857142857;
    const NP_SUM_1000: f64 = 21357.142857142855;
    const NP_MEAN_20: f64 = 25.785714285714285;
    const NP_VAR_20: f64 = 1686.8010204081625;
}
