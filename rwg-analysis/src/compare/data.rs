//! The data of a comparison: the runs compared, whether their settings
//! allow it, and one row per run × env × architecture × bias with its
//! normalised scores.
//!
//! Runs are comparable when they used the same episodes per sample, the same
//! weight distribution and scale, and the same architectures;
//! [`settings_differences`] names every difference (the CLI refuses such
//! runs unless forced). The number of samples may differ.

use rwg_env::float::fmt_f64;
use rwg_study::rundir::data::{CellData, Run};
use rwg_study::rundir::meta::RunMeta;
use rwg_study::stats::CellSummary;
use serde::Serialize;

/// One run to compare: a label, its metadata, and per cell its summary and
/// sample means.
#[derive(Debug, Clone)]
pub struct CompareRun {
    /// Label of the run in tables and legends (its directory name).
    pub label: String,
    /// The run directory, as given.
    pub dir: String,
    /// The run's `run.json`.
    pub meta: RunMeta,
    /// Per cell: summary and sample means `M`.
    pub cells: Vec<(CellSummary, Vec<f64>)>,
}

impl CompareRun {
    /// Builds the comparison input from an opened run and its loaded cells.
    pub fn new(label: String, run: &Run, cells: &[(CellData, CellSummary)]) -> Self {
        CompareRun {
            label,
            dir: run.dir.display().to_string(),
            meta: run.meta.clone(),
            cells: cells.iter().map(|(c, s)| (s.clone(), c.means())).collect(),
        }
    }
}

/// The architectures of a run as `name [hidden] bias|nobias`, sorted.
fn architectures(meta: &RunMeta) -> Vec<String> {
    let mut a: Vec<String> = meta
        .cells
        .iter()
        .map(|c| {
            format!(
                "{} {:?} {}",
                c.id.arch,
                c.id.hidden,
                if c.id.bias { "bias" } else { "nobias" }
            )
        })
        .collect();
    a.sort();
    a.dedup();
    a
}

/// Every setting in which a run differs from the first: episodes per
/// sample, weight distribution, weight scale, architectures. Empty when the
/// runs are comparable.
pub fn settings_differences(runs: &[(&str, &RunMeta)]) -> Vec<String> {
    let Some(&(first, m0)) = runs.first() else {
        return vec![];
    };
    let mut out = Vec::new();
    for &(label, m) in &runs[1..] {
        if m.episodes != m0.episodes {
            out.push(format!(
                "episodes per sample differ: {first} has {}, {label} has {}",
                m0.episodes, m.episodes
            ));
        }
        if m.weights.distribution != m0.weights.distribution {
            out.push(format!(
                "weight distributions differ: {first} has {}, {label} has {}",
                m0.weights.distribution, m.weights.distribution
            ));
        }
        if m.weights.scale != m0.weights.scale {
            out.push(format!(
                "weight scales differ: {first} has {}, {label} has {}",
                fmt_f64(m0.weights.scale),
                fmt_f64(m.weights.scale)
            ));
        }
        let (a0, a) = (architectures(m0), architectures(m));
        if a0 != a {
            out.push(format!(
                "architectures differ: {first} has {}; {label} has {}",
                a0.join(", "),
                a.join(", ")
            ));
        }
    }
    out
}

/// One row of a comparison.
#[derive(Debug, Clone, Serialize)]
pub struct CompareRow {
    /// Run label.
    pub run: String,
    /// The cell's statistics.
    #[serde(flatten)]
    pub summary: CellSummary,
    /// Best mean, normalised ([`CellSummary::normalise`]).
    pub normalised_best: Option<f64>,
    /// 99.9th percentile of `M`, normalised.
    pub normalised_p99_9: Option<f64>,
    /// Position in the difficulty ranking, 1 the easiest
    /// ([`super::ranking`]).
    pub difficulty_rank: usize,
}

/// The rows of a comparison before ranking (`difficulty_rank` 0), the runs
/// of each env × architecture × bias side by side: ordered by env,
/// architecture (each in order of first appearance), bias (without first),
/// then run.
pub(super) fn side_by_side(runs: &[CompareRun]) -> Vec<CompareRow> {
    let mut rows: Vec<CompareRow> = runs
        .iter()
        .flat_map(|r| {
            r.cells.iter().map(|(s, _)| CompareRow {
                run: r.label.clone(),
                normalised_best: s.normalise(s.best_mean),
                normalised_p99_9: s.normalise(s.p99_9_mean),
                difficulty_rank: 0,
                summary: s.clone(),
            })
        })
        .collect();
    let mut envs: Vec<String> = Vec::new();
    let mut archs: Vec<String> = Vec::new();
    for r in &rows {
        if !envs.contains(&r.summary.id.env) {
            envs.push(r.summary.id.env.clone());
        }
        if !archs.contains(&r.summary.id.arch) {
            archs.push(r.summary.id.arch.clone());
        }
    }
    let pos = |v: &[String], x: &str| v.iter().position(|y| y == x);
    // stable: runs keep their argument order within a group
    rows.sort_by_key(|r| {
        (
            pos(&envs, &r.summary.id.env),
            pos(&archs, &r.summary.id.arch),
            r.summary.id.bias,
        )
    });
    rows
}
