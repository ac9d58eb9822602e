//! Comparing runs: envs from several runs side by side, one row per env ×
//! architecture × bias, with a score normalised so the median random
//! network is 0 and the solved score is 1.
//!
//! Runs are comparable when they used the same episodes per sample, the same
//! weight distribution and scale, and the same architectures;
//! [`settings_differences`] names every difference (the CLI refuses such
//! runs unless forced). The number of samples may differ.

use crate::fmt::{prob_ci, score};
use crate::table::{Cell, Table};
use crate::tables::guesses_cell;
use rwg_env::float::fmt_f64;
use rwg_study::rundir::data::{CellData, Run};
use rwg_study::rundir::export::csv_writer;
use rwg_study::rundir::meta::RunMeta;
use rwg_study::stats::{CellSummary, ExpectedGuesses};
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
    /// ([`crate::ranking`]).
    pub difficulty_rank: usize,
}

/// The rows of a comparison, the runs of each env × architecture × bias
/// side by side: ordered by env, architecture (each in order of first
/// appearance), bias (without first), then run.
pub fn compare_rows(runs: &[CompareRun]) -> Vec<CompareRow> {
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
    let ranks = crate::ranking::difficulty_ranks(&rows);
    for (r, rank) in rows.iter_mut().zip(ranks) {
        r.difficulty_rank = rank;
    }
    rows
}

fn opt_sig(x: Option<f64>) -> Cell {
    Cell::plain(crate::ranking::norm_text(x))
}

/// The episodes per sample of the compared runs, for the table's title:
/// `N episodes per sample` when every run has `N`, else each run's
/// (`episodes per sample: a 3, b 2`), as runs compared with `--force` may.
fn episodes_title(rows: &[CompareRow]) -> String {
    let mut per_run: Vec<(&str, u32)> = vec![];
    for r in rows {
        if !per_run.iter().any(|(run, _)| *run == r.run) {
            per_run.push((&r.run, r.summary.episodes));
        }
    }
    let first = per_run.first().map_or(0, |p| p.1);
    if per_run.iter().all(|p| p.1 == first) {
        return format!("{first} episodes per sample");
    }
    let list: Vec<String> = per_run.iter().map(|(r, e)| format!("{r} {e}")).collect();
    format!("episodes per sample: {}", list.join(", "))
}

/// The comparison table.
pub fn compare_table(rows: &[CompareRow]) -> Table {
    let header = [
        "env",
        "run",
        "arch",
        "bias",
        "samples",
        "p(solved) [95% CI]",
        "1/p",
        "best mean",
        "p99.9 M",
        "median M",
        "norm. best",
        "norm. p99.9",
        "difficulty rank",
    ]
    .into_iter()
    .map(Cell::from)
    .collect();
    let body = rows
        .iter()
        .map(|r| {
            let s = &r.summary;
            vec![
                Cell::plain(s.id.env.clone()),
                Cell::plain(r.run.clone()),
                Cell::plain(s.id.arch.clone()),
                Cell::plain(if s.id.bias { "yes" } else { "no" }),
                Cell::plain(s.samples.to_string()),
                s.solved_fraction.map_or_else(
                    || Cell::plain("no solved score"),
                    |p| prob_ci(p.p, p.lo, p.hi),
                ),
                guesses_cell(s.expected_guesses),
                Cell::plain(score(s.best_mean)),
                Cell::plain(score(s.p99_9_mean)),
                Cell::plain(score(s.median_mean)),
                opt_sig(r.normalised_best),
                opt_sig(r.normalised_p99_9),
                Cell::plain(r.difficulty_rank.to_string()),
            ]
        })
        .collect();
    Table {
        title: format!("Comparison of {} cells, {}", rows.len(), episodes_title(rows)),
        header,
        rows: body,
        notes: vec![
            "norm.: (x − median M) / (solved − median M): 0 is the median random network, 1 the solved score."
                .into(),
        ],
    }
}

/// The columns of [`compare_csv`].
const COMPARE_CSV_HEADER: [&str; 18] = [
    "run",
    "env",
    "arch",
    "bias",
    "samples",
    "episodes",
    "solved",
    "p_solved",
    "p_solved_lo",
    "p_solved_hi",
    "expected_guesses",
    "expected_guesses_lo",
    "best_mean",
    "p99.9_mean",
    "median_mean",
    "normalised_best",
    "normalised_p99.9",
    "difficulty_rank",
];

/// The comparison as CSV, one row per cell, floats in shortest round-trip
/// form; written as rwg writes every CSV (`rundir::export::csv_writer`: a
/// field quoted only when it holds a comma, a quote or a line break).
pub fn compare_csv(rows: &[CompareRow]) -> String {
    let opt = |x: Option<f64>| x.map(fmt_f64).unwrap_or_default();
    let mut out = Vec::new();
    let mut w = csv_writer(&mut out);
    w.write_record(COMPARE_CSV_HEADER)
        .expect("writing to memory");
    for r in rows {
        let s = &r.summary;
        let p = s.solved_fraction;
        let (g, glo) = match s.expected_guesses {
            Some(ExpectedGuesses::Estimate {
                value, lo_bound, ..
            }) => (Some(value), Some(lo_bound)),
            Some(ExpectedGuesses::NoneSeen { at_least }) => (None, Some(at_least)),
            None => (None, None),
        };
        let fields = [
            r.run.clone(),
            s.id.env.clone(),
            s.id.arch.clone(),
            s.id.bias.to_string(),
            s.samples.to_string(),
            s.episodes.to_string(),
            opt(s.solved),
            opt(p.map(|p| p.p)),
            opt(p.map(|p| p.lo)),
            opt(p.map(|p| p.hi)),
            opt(g),
            opt(glo),
            fmt_f64(s.best_mean),
            fmt_f64(s.p99_9_mean),
            fmt_f64(s.median_mean),
            opt(r.normalised_best),
            opt(r.normalised_p99_9),
            r.difficulty_rank.to_string(),
        ];
        w.write_record(&fields).expect("writing to memory");
    }
    drop(w);
    String::from_utf8(out).expect("UTF-8 fields")
}

#[cfg(test)]
mod tests {
    use super::*;
    use rwg_study::rundir::meta::{CellId, CellMeta, WeightsMeta};

    fn meta(episodes: u32, dist: &str, archs: &[&str]) -> RunMeta {
        RunMeta {
            format: 1,
            rwg_version: "t".into(),
            seed: 0,
            samples: 10,
            episodes,
            weights: WeightsMeta {
                distribution: dist.into(),
                scale: 1.0,
            },
            threads: 1,
            start_time: String::new(),
            end_time: None,
            wall_s: 0.0,
            env_steps: 0,
            steps_per_s: 0.0,
            cells: archs
                .iter()
                .map(|a| CellMeta {
                    id: CellId::new("E", a, &[], false),
                    n_weights: 1,
                    obs_dim: 1,
                    max_episode_steps: 1,
                    solved: None,
                    solved_source: None,
                    samples: 10,
                    episodes,
                    wall_s: 0.0,
                    env_steps: 0,
                    steps_per_s: 0.0,
                })
                .collect(),
            block_samples: 10,
            shard: None,
            study: None,
        }
    }

    #[test]
    fn differences_are_named() {
        let a = meta(20, "normal", &["0HL"]);
        assert!(settings_differences(&[("a", &a), ("b", &a.clone())]).is_empty());
        let b = meta(10, "uniform", &["0HL", "1HL-4"]);
        let d = settings_differences(&[("a", &a), ("b", &b)]);
        assert_eq!(d.len(), 3, "{d:?}");
        assert_eq!(d[0], "episodes per sample differ: a has 20, b has 10");
        assert_eq!(
            d[1],
            "weight distributions differ: a has normal, b has uniform"
        );
        assert!(d[2]
            .starts_with("architectures differ: a has 0HL [] nobias; b has 0HL [] nobias, 1HL-4"));
    }

    /// The header and quoting of the hand-written writer this replaced: a
    /// field is quoted only when it holds a comma, a quote or a line break.
    #[test]
    fn csv_keeps_its_header_and_quotes_only_what_must_be() {
        let m = meta(2, "normal", &["0HL"]);
        let data = CellData::new(m.cells[0].clone(), 2, vec![1.0, 2.0, 3.0, 4.0], vec![1; 4]);
        let row = |run: &str| CompareRow {
            run: run.into(),
            summary: data.summary(),
            normalised_best: None,
            normalised_p99_9: Some(0.5),
            difficulty_rank: 1,
        };
        let csv = compare_csv(&[row("plain"), row("a,\"b\""), row("two\nlines")]);
        assert!(csv.ends_with('\n') && !csv.contains('\r'), "{csv:?}");
        let lines: Vec<&str> = csv.lines().collect();
        assert_eq!(
            lines[0],
            "run,env,arch,bias,samples,episodes,solved,p_solved,p_solved_lo,p_solved_hi,\
             expected_guesses,expected_guesses_lo,best_mean,p99.9_mean,median_mean,\
             normalised_best,normalised_p99.9,difficulty_rank"
        );
        assert!(lines[1].starts_with("plain,E,0HL,false,"), "{csv}");
        assert!(lines[1].ends_with(",,0.5,1"), "{csv}");
        assert_eq!(lines[1].split(',').count(), 18, "{csv}");
        assert_eq!(lines[2], lines[1].replacen("plain", "\"a,\"\"b\"\"\"", 1));
        assert_eq!(
            format!("{}\n{}", lines[3], lines[4]),
            lines[1].replacen("plain", "\"two\nlines\"", 1)
        );
    }
}
