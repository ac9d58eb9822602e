//! The statistics of a paired comparison, rwg's own code, each checked in
//! its tests against values SciPy 1.17 computes for the same inputs:
//!
//! - [`ks_two_sample`]: the two-sample Kolmogorov–Smirnov test of two equally
//!   large samples, exact: SciPy's `ks_2samp(a, b, method="exact")`
//!   (the reflection-principle count of the lattice paths that leave the
//!   band `|x − y| < h`, Gnedenko and Korolyuk 1951, summed as SciPy's
//!   `_compute_prob_outside_square` sums it).
//! - [`mcnemar_exact`]: McNemar's test of paired binary outcomes, exact: the
//!   two-sided binomial test of the discordant pairs at ½ (SciPy's
//!   `binomtest(b, b + c, 0.5)`, statsmodels' `mcnemar(exact=True)`).
//! - [`fisher_exact`]: Fisher's exact test of a 2 × 2 table, two-sided: the
//!   tables no likelier than the one seen (SciPy's `fisher_exact`; R's
//!   `fisher.test` and its relative tolerance of 1e-7 for ties).
//! - [`spearman`]: Spearman's rank correlation, ties given their average
//!   rank (SciPy's `spearmanr(...).statistic`).
//! - [`holm`]: Holm's step-down correction of several tests (Holm 1979).

/// A test's statistic and two-sided p-value.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct TestResult {
    /// The test's statistic (KS: the largest distance `D` between the two
    /// empirical CDFs; McNemar: the smaller discordant count; Fisher: the
    /// first cell of the table).
    pub statistic: f64,
    /// The two-sided p-value.
    pub p_value: f64,
}

/// The two-sample Kolmogorov–Smirnov test of `a` and `b`, two samples of
/// one size `n` (two-sided, exact). `D` is the largest difference of the
/// empirical CDFs over the pooled values (a tie counted on both sides, as
/// SciPy does); the p-value is `P(D_{n,n} ≥ D)` for two independent samples
/// of one continuous distribution.
///
/// # Panics
/// If the samples are empty or differ in size.
pub fn ks_two_sample(a: &[f64], b: &[f64]) -> TestResult {
    assert!(
        !a.is_empty() && a.len() == b.len(),
        "two samples of one size"
    );
    let n = a.len();
    let mut a = a.to_vec();
    let mut b = b.to_vec();
    a.sort_by(f64::total_cmp);
    b.sort_by(f64::total_cmp);
    // walk the pooled values in order; at each distinct value, the counts
    // of each sample at or below it
    let (mut i, mut j, mut h) = (0usize, 0usize, 0usize);
    while i < n || j < n {
        let v = match (a.get(i), b.get(j)) {
            (Some(x), Some(y)) => {
                if x.total_cmp(y).is_le() {
                    *x
                } else {
                    *y
                }
            }
            (Some(x), None) => *x,
            (None, Some(y)) => *y,
            (None, None) => unreachable!(),
        };
        while i < n && a[i].total_cmp(&v).is_le() {
            i += 1;
        }
        while j < n && b[j].total_cmp(&v).is_le() {
            j += 1;
        }
        h = h.max(i.abs_diff(j));
    }
    TestResult {
        statistic: h as f64 / n as f64,
        p_value: prob_outside_square(n, h),
    }
}

/// `P(D_{n,n} ≥ h/n)`: the share of the lattice paths from `(0, 0)` to
/// `(n, n)` that touch a line `x − y = ±h`,
/// `2 Σ_{k≥1} (−1)^{k−1} C(2n, n − kh) / C(2n, n)`, summed in Horner form
/// from the last term so nothing cancels (SciPy's
/// `_compute_prob_outside_square`).
fn prob_outside_square(n: usize, h: usize) -> f64 {
    if h == 0 {
        return 1.0;
    }
    let (nf, hf) = (n as f64, h as f64);
    let mut p = 0.0;
    for k in (0..=n / h).rev() {
        let kh = k as f64 * hf;
        let mut a = 1.0;
        for j in 0..h {
            let jf = j as f64;
            a = (nf - kh - jf) * a / (nf + kh + jf + 1.0);
        }
        p = a * (1.0 - p);
    }
    (2.0 * p).clamp(0.0, 1.0)
}

/// `ln C(n, k)` for every `k` in `0..=n`, by the ratio of neighbours.
fn ln_binomials(n: u64) -> Vec<f64> {
    let mut out = Vec::with_capacity(n as usize + 1);
    let mut l = 0.0;
    out.push(l);
    for k in 0..n {
        l += ((n - k) as f64).ln() - ((k + 1) as f64).ln();
        out.push(l);
    }
    out
}

/// `ln Σ exp(xs)`, without overflow.
fn ln_sum_exp(xs: impl Iterator<Item = f64> + Clone) -> f64 {
    let top = xs.clone().fold(f64::NEG_INFINITY, f64::max);
    if top == f64::NEG_INFINITY {
        return top;
    }
    top + xs.map(|x| (x - top).exp()).sum::<f64>().ln()
}

/// McNemar's exact test of paired binary outcomes: `b` pairs where only the
/// first is a success, `c` where only the second is. Under the hypothesis
/// that both succeed equally often, `b` is Binomial(`b + c`, ½); the
/// two-sided p-value is `min(1, 2 P(X ≤ min(b, c)))`, 1 when `b = c`.
pub fn mcnemar_exact(b: u64, c: u64) -> TestResult {
    let (k, n) = (b.min(c), b + c);
    let p_value = if 2 * k == n {
        1.0
    } else {
        let ln = ln_binomials(n);
        let cdf = (ln_sum_exp(ln[..=k as usize].iter().copied()) - n as f64 * 2f64.ln()).exp();
        (2.0 * cdf).min(1.0)
    };
    TestResult {
        statistic: k as f64,
        p_value,
    }
}

/// Fisher's exact test of the 2 × 2 table `[[a, b], [c, d]]`, two-sided:
/// with the margins fixed, the top-left cell is hypergeometric, and the
/// p-value sums the probabilities of the tables at most as likely as the
/// one seen (within a relative 1e-7, as R's `fisher.test`, so that tables
/// equally likely in exact arithmetic count alike). A table with an empty
/// row or column has p = 1.
pub fn fisher_exact([[a, b], [c, d]]: [[u64; 2]; 2]) -> TestResult {
    let (r1, r2, k) = (a + b, c + d, a + c);
    let lo = k.saturating_sub(r2);
    let hi = k.min(r1);
    let (l1, l2) = (ln_binomials(r1), ln_binomials(r2));
    let ln_p: Vec<f64> = (lo..=hi)
        .map(|x| l1[x as usize] + l2[(k - x) as usize])
        .collect();
    let seen = ln_p[(a - lo) as usize];
    let total = ln_sum_exp(ln_p.iter().copied());
    let cut = seen + 1e-7f64.ln_1p();
    let tail = ln_sum_exp(ln_p.iter().copied().filter(|&l| l <= cut));
    TestResult {
        statistic: a as f64,
        p_value: (tail - total).exp().min(1.0),
    }
}

/// The ranks of `xs` from 1, ties given the mean of the ranks they span.
fn average_ranks(xs: &[f64]) -> Vec<f64> {
    let mut order: Vec<usize> = (0..xs.len()).collect();
    order.sort_by(|&i, &j| xs[i].total_cmp(&xs[j]));
    let mut ranks = vec![0.0; xs.len()];
    let mut start = 0;
    while start < order.len() {
        let mut end = start + 1;
        while end < order.len() && xs[order[end]] == xs[order[start]] {
            end += 1;
        }
        // positions start..end hold ranks start+1..=end
        let rank = (start + 1 + end) as f64 / 2.0;
        for &i in &order[start..end] {
            ranks[i] = rank;
        }
        start = end;
    }
    ranks
}

/// Pearson's correlation of `x` and `y`; `None` when either is constant.
fn pearson(x: &[f64], y: &[f64]) -> Option<f64> {
    let n = x.len() as f64;
    let (mx, my) = (x.iter().sum::<f64>() / n, y.iter().sum::<f64>() / n);
    let (mut sxy, mut sxx, mut syy) = (0.0, 0.0, 0.0);
    for (a, b) in x.iter().zip(y) {
        let (dx, dy) = (a - mx, b - my);
        sxy += dx * dy;
        sxx += dx * dx;
        syy += dy * dy;
    }
    (sxx > 0.0 && syy > 0.0).then(|| (sxy / (sxx * syy).sqrt()).clamp(-1.0, 1.0))
}

/// Spearman's rank correlation of the pairs `(x[i], y[i])`: Pearson's
/// correlation of their average ranks. `None` when either side is constant
/// or there are fewer than two pairs.
///
/// # Panics
/// If `x` and `y` differ in length.
pub fn spearman(x: &[f64], y: &[f64]) -> Option<f64> {
    assert_eq!(x.len(), y.len(), "pairs");
    if x.len() < 2 {
        return None;
    }
    pearson(&average_ranks(x), &average_ranks(y))
}

/// Holm's step-down procedure: which of the hypotheses with p-values
/// `p` are rejected with a family-wise error rate of `alpha`. The i-th
/// smallest p-value (from 0) is compared with `alpha / (m − i)`; the first
/// that exceeds it, and every larger one, is kept.
pub fn holm(p: &[f64], alpha: f64) -> Vec<bool> {
    let m = p.len();
    let mut order: Vec<usize> = (0..m).collect();
    order.sort_by(|&i, &j| p[i].total_cmp(&p[j]));
    let mut rejected = vec![false; m];
    for (i, &k) in order.iter().enumerate() {
        // a NaN p-value is never rejected
        if p[k].is_nan() || p[k] > alpha / (m - i) as f64 {
            break;
        }
        rejected[k] = true;
    }
    rejected
}

#[cfg(test)]
#[path = "two_sample_tests.rs"]
mod tests;
