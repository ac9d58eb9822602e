//! The rows of a paired comparison: per architecture × bias setting, the
//! two cells' networks side by side, the tests made, and the verdict.

use super::pairing::{not_same_networks, CellPair, PairSide};
use super::two_sample::{fisher_exact, holm, ks_two_sample, mcnemar_exact, spearman, TestResult};
use crate::plot::panels::tick;
use rwg_study::stats::{solved_fraction, Proportion};
use serde::Serialize;

/// The family-wise error rate of a comparison's tests.
pub const ALPHA: f64 = 0.05;

/// Which test compared the solved flags.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum SolvedTest {
    /// McNemar's exact test: the same networks, paired flags.
    Mcnemar,
    /// Fisher's exact test: different networks, two independent samples.
    Fisher,
}

impl SolvedTest {
    /// Its name in tables.
    pub fn name(self) -> &'static str {
        match self {
            SolvedTest::Mcnemar => "McNemar",
            SolvedTest::Fisher => "Fisher",
        }
    }
}

/// The verdict on one pair of cells, or on a whole comparison.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Verdict {
    /// No test tells the two apart.
    OneBenchmark,
    /// At least one test tells them apart.
    Different,
    /// No test applies.
    Untested,
}

/// How many of the networks solve in both cells, in one only, in neither.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct SolvedPairs {
    /// Networks solved in both.
    pub both: u64,
    /// Networks solved in the first cell only.
    pub only_a: u64,
    /// Networks solved in the second cell only.
    pub only_b: u64,
    /// Networks solved in neither.
    pub neither: u64,
}

/// One architecture × bias setting of a paired comparison.
#[derive(Debug, Clone, Serialize)]
pub struct PairedRow {
    /// The first run's label.
    pub run_a: String,
    /// The first env.
    pub env_a: String,
    /// The second run's label.
    pub run_b: String,
    /// The second env.
    pub env_b: String,
    /// Architecture name.
    pub arch: String,
    /// Hidden layer sizes.
    pub hidden: Vec<usize>,
    /// Bias inputs.
    pub bias: bool,
    /// Networks compared: networks `0..n` of each cell, `n` the smaller
    /// cell's count.
    pub networks: u64,
    /// Episodes per network (the first cell's).
    pub episodes: u32,
    /// Whether network `n` is the same network in both cells.
    pub paired: bool,
    /// Why not, when not.
    pub unpaired_reason: Option<String>,
    /// The first cell's solved score.
    pub solved_a: Option<f64>,
    /// The second cell's solved score.
    pub solved_b: Option<f64>,
    /// The fraction of the compared networks solved in the first cell.
    pub p_solved_a: Option<Proportion>,
    /// The same in the second cell.
    pub p_solved_b: Option<Proportion>,
    /// Networks solved in both, one or neither (the same networks only).
    pub solved_pairs: Option<SolvedPairs>,
    /// Median of the first cell's means.
    pub median_a: f64,
    /// Median of the second cell's means.
    pub median_b: f64,
    /// Spearman's rank correlation of network `n`'s means (the same networks
    /// only).
    pub spearman: Option<f64>,
    /// The two-sample Kolmogorov–Smirnov test of the means.
    pub ks: Option<TestResult>,
    /// Why it was not made, when not.
    pub ks_skipped: Option<String>,
    /// Which test compared the solved flags.
    pub solved_test: Option<SolvedTest>,
    /// Its result.
    pub solved_result: Option<TestResult>,
    /// Whether Holm's procedure rejects the KS test's hypothesis.
    pub ks_rejected: bool,
    /// Whether it rejects the solved test's.
    pub solved_rejected: bool,
    /// The verdict.
    pub verdict: Verdict,
}

fn median(xs: &[f64]) -> f64 {
    let mut v = xs.to_vec();
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n == 0 {
        f64::NAN
    } else if n % 2 == 1 {
        v[n / 2]
    } else {
        (v[n / 2 - 1] + v[n / 2]) / 2.0
    }
}

/// The flags of networks solved in both cells, one only, neither.
fn solved_pairs(a: &[f64], b: &[f64], sa: f64, sb: f64) -> SolvedPairs {
    let mut out = SolvedPairs {
        both: 0,
        only_a: 0,
        only_b: 0,
        neither: 0,
    };
    for (x, y) in a.iter().zip(b) {
        match (*x >= sa, *y >= sb) {
            (true, true) => out.both += 1,
            (true, false) => out.only_a += 1,
            (false, true) => out.only_b += 1,
            (false, false) => out.neither += 1,
        }
    }
    out
}

/// One row, its tests made, before Holm's procedure (nothing rejected,
/// verdict [`Verdict::Untested`]).
pub(super) fn row(a: &PairSide, b: &PairSide, pair: CellPair) -> PairedRow {
    let n = pair.a.samples().min(pair.b.samples());
    let ma = &pair.a.means()[..n];
    let mb = &pair.b.means()[..n];
    let unpaired_reason = not_same_networks(a, b, pair);
    let paired = unpaired_reason.is_none();
    let (sa, sb) = (pair.a.meta.solved, pair.b.meta.solved);
    let ks_skipped = match (sa, sb) {
        (Some(x), Some(y)) if x != y => Some(format!(
            "the solved scores differ ({} and {}): the means are on different scales",
            tick(&x),
            tick(&y)
        )),
        (Some(_), None) | (None, Some(_)) => {
            Some("one cell has a solved score and the other none".into())
        }
        _ => None,
    };
    let ks = ks_skipped.is_none().then(|| ks_two_sample(ma, mb));
    let flags = sa.zip(sb).map(|(x, y)| solved_pairs(ma, mb, x, y));
    let (solved_test, solved_result) = match flags {
        Some(f) if paired => (
            Some(SolvedTest::Mcnemar),
            Some(mcnemar_exact(f.only_a, f.only_b)),
        ),
        Some(f) => {
            let (ka, kb) = (f.both + f.only_a, f.both + f.only_b);
            let n = n as u64;
            (
                Some(SolvedTest::Fisher),
                Some(fisher_exact([[ka, n - ka], [kb, n - kb]])),
            )
        }
        None => (None, None),
    };
    let id = &pair.a.meta.id;
    PairedRow {
        run_a: a.run.clone(),
        env_a: a.env.clone(),
        run_b: b.run.clone(),
        env_b: b.env.clone(),
        arch: id.arch.clone(),
        hidden: id.hidden.clone(),
        bias: id.bias,
        networks: n as u64,
        episodes: pair.a.episodes as u32,
        paired,
        unpaired_reason,
        solved_a: sa,
        solved_b: sb,
        p_solved_a: sa.map(|s| solved_fraction(ma, s)),
        p_solved_b: sb.map(|s| solved_fraction(mb, s)),
        solved_pairs: flags.filter(|_| paired),
        median_a: median(ma),
        median_b: median(mb),
        spearman: if paired { spearman(ma, mb) } else { None },
        ks,
        ks_skipped,
        solved_test,
        solved_result,
        ks_rejected: false,
        solved_rejected: false,
        verdict: Verdict::Untested,
    }
}

/// Applies Holm's procedure at [`ALPHA`] to every test of every row at
/// once, and gives each row its verdict.
pub(super) fn decide(rows: &mut [PairedRow]) {
    let mut p = Vec::new();
    for r in rows.iter() {
        p.extend(r.ks.map(|t| t.p_value));
        p.extend(r.solved_result.map(|t| t.p_value));
    }
    let rejected = holm(&p, ALPHA);
    let mut next = rejected.into_iter();
    for r in rows.iter_mut() {
        if r.ks.is_some() {
            r.ks_rejected = next.next().expect("one decision per test");
        }
        if r.solved_result.is_some() {
            r.solved_rejected = next.next().expect("one decision per test");
        }
        r.verdict = if r.ks_rejected || r.solved_rejected {
            Verdict::Different
        } else if r.ks.is_none() && r.solved_result.is_none() {
            Verdict::Untested
        } else {
            Verdict::OneBenchmark
        };
    }
}

/// The verdict of a whole comparison: [`Verdict::Different`] if any row
/// differs, else [`Verdict::OneBenchmark`] if any was tested.
pub fn overall(rows: &[PairedRow]) -> Verdict {
    if rows.iter().any(|r| r.verdict == Verdict::Different) {
        Verdict::Different
    } else if rows.iter().any(|r| r.verdict == Verdict::OneBenchmark) {
        Verdict::OneBenchmark
    } else {
        Verdict::Untested
    }
}

/// The verdict of a row in words: what was found, with the p-values that
/// decided it.
pub fn verdict_text(r: &PairedRow) -> String {
    let p = |t: Option<TestResult>| t.map_or_else(String::new, |t| crate::fmt::sig(t.p_value, 2));
    match r.verdict {
        Verdict::OneBenchmark => "one benchmark: no test tells them apart".into(),
        Verdict::Untested => "untested: no test applies".into(),
        Verdict::Different => {
            let mut why = Vec::new();
            if r.ks_rejected {
                why.push(format!(
                    "the means are distributed differently (KS p = {})",
                    p(r.ks)
                ));
            }
            if r.solved_rejected {
                let name = r.solved_test.map_or("", SolvedTest::name);
                why.push(format!(
                    "p(solved) differs ({name} p = {})",
                    p(r.solved_result)
                ));
            }
            format!("different: {}", why.join("; "))
        }
    }
}
