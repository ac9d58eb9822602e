//! A comparison's rows written out: the table of `rwg compare` (and of the
//! page's "All cells" section) and the CSV of `rwg compare --format csv`.

use super::data::CompareRow;
use super::ranking::norm_text;
use crate::fmt::{prob_ci, score};
use crate::run_tables::guesses_cell;
use crate::table_render::{Cell, Table};
use rwg_env::float::fmt_f64;
use rwg_study::rundir::export::csv_writer;
use rwg_study::stats::ExpectedGuesses;

fn opt_sig(x: Option<f64>) -> Cell {
    Cell::plain(norm_text(x))
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
const COMPARE_CSV_HEADER: [&str; 19] = [
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
    "non_finite_episodes",
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
            s.non_finite_episodes
                .map(|n| n.to_string())
                .unwrap_or_default(),
        ];
        w.write_record(&fields).expect("writing to memory");
    }
    drop(w);
    String::from_utf8(out).expect("UTF-8 fields")
}
