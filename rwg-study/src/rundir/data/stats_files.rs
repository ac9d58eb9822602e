//! `stats.json` and `stats.csv`: the columns of `stats.csv`, its rows from
//! each cell's [`CellSummary`], and the writer of both files.

use super::spread::{spread_csv_fields, SPREAD_CSV_COLUMNS};
use super::RunStats;
use crate::rundir::export::csv_writer;
use crate::rundir::{STATS_CSV, STATS_JSON};
use crate::stats::{self, CellSummary, ExpectedGuesses, MEAN_PERCENTILES};
use rwg_env::float::fmt_f64;
use std::path::Path;

fn opt(x: Option<f64>) -> String {
    x.map(fmt_f64).unwrap_or_default()
}

/// The columns of `stats.csv`.
pub fn stats_csv_header() -> Vec<String> {
    let mut h: Vec<String> = [
        "dir",
        "env",
        "arch",
        "hidden",
        "bias",
        "n_weights",
        "samples",
        "episodes",
        "solved",
        "best_mean",
        "best_sample",
        "best_variance",
        "worst_mean",
        "mean_of_means",
        "median_mean",
        "p99.9_mean",
    ]
    .map(String::from)
    .to_vec();
    h.extend(MEAN_PERCENTILES.iter().map(|q| format!("mean_p{q}")));
    h.extend(
        [
            "mean_variance",
            "solved_count",
            "p_solved",
            "p_solved_lo",
            "p_solved_hi",
            "expected_guesses",
            "expected_guesses_lo",
            "expected_guesses_hi",
        ]
        .map(String::from),
    );
    h.extend(
        stats::GUESS_COUNTS
            .iter()
            .map(|n| format!("p_success_in_{n}")),
    );
    h.extend(
        [
            "top_episode_threshold",
            "top_episodes",
            "best_episode",
            "mean_episode_length",
            "max_episode_length",
        ]
        .map(String::from),
    );
    h
}

/// One `stats.csv` row (columns of [`stats_csv_header`]; empty fields for
/// values that do not apply, e.g. p(solved) without a solved score;
/// `expected_guesses` is empty and `expected_guesses_lo` is the 95% lower
/// bound when no sample solved).
pub fn stats_csv_row(s: &CellSummary) -> Vec<String> {
    let hidden: Vec<String> = s.id.hidden.iter().map(|h| h.to_string()).collect();
    let mut r = vec![
        s.id.dir.clone(),
        s.id.env.clone(),
        s.id.arch.clone(),
        hidden.join(" "),
        s.id.bias.to_string(),
        s.n_weights.to_string(),
        s.samples.to_string(),
        s.episodes.to_string(),
        opt(s.solved),
        fmt_f64(s.best_mean),
        s.best_sample.to_string(),
        fmt_f64(s.best_variance),
        fmt_f64(s.worst_mean),
        fmt_f64(s.mean_of_means),
        fmt_f64(s.median_mean),
        fmt_f64(s.p99_9_mean),
    ];
    r.extend(MEAN_PERCENTILES.iter().map(|&q| opt(s.mean_percentile(q))));
    r.push(fmt_f64(s.mean_variance));
    let p = s.solved_fraction;
    r.push(p.map(|p| p.successes.to_string()).unwrap_or_default());
    r.push(opt(p.map(|p| p.p)));
    r.push(opt(p.map(|p| p.lo)));
    r.push(opt(p.map(|p| p.hi)));
    let (g, lo, hi) = match s.expected_guesses {
        Some(ExpectedGuesses::Estimate {
            value,
            lo_bound,
            hi_bound,
        }) => (Some(value), Some(lo_bound), hi_bound),
        Some(ExpectedGuesses::NoneSeen { at_least }) => (None, Some(at_least), None),
        None => (None, None, None),
    };
    r.extend([opt(g), opt(lo), opt(hi)]);
    for n in stats::GUESS_COUNTS {
        r.push(opt(s
            .success_odds
            .iter()
            .find(|o| o.guesses == n)
            .map(|o| o.p)));
    }
    r.extend([
        fmt_f64(s.top_episode_threshold),
        s.top_episodes.to_string(),
        fmt_f64(s.best_episode),
        fmt_f64(s.mean_episode_length),
        s.max_episode_length.to_string(),
    ]);
    r
}

/// The column of `stats.csv` that counts the episodes a value that was not
/// finite ended: present when a cell has `non_finite = "end"` (empty for
/// the other cells).
pub const NON_FINITE_CSV_COLUMN: &str = "non_finite_episodes";

/// The text of `stats.csv`: one row per cell. [`NON_FINITE_CSV_COLUMN`]
/// comes after [`stats_csv_header`]'s columns when a cell has
/// `non_finite = "end"`; the [`SPREAD_CSV_COLUMNS`] come last, and only
/// when a cell has a spread.
pub fn stats_csv(stats: &RunStats) -> String {
    let spread = stats.cells.iter().any(|c| c.at_n.is_some());
    let non_finite = stats.cells.iter().any(|c| c.non_finite_episodes.is_some());
    let mut w = csv_writer(Vec::new());
    let mut header = stats_csv_header();
    if non_finite {
        header.push(NON_FINITE_CSV_COLUMN.to_string());
    }
    if spread {
        header.extend(SPREAD_CSV_COLUMNS.map(String::from));
    }
    w.write_record(header).expect("writing to memory");
    for c in &stats.cells {
        let mut row = stats_csv_row(c);
        if non_finite {
            row.push(
                c.non_finite_episodes
                    .map(|n| n.to_string())
                    .unwrap_or_default(),
            );
        }
        if spread {
            row.extend(spread_csv_fields(c));
        }
        w.write_record(row).expect("writing to memory");
    }
    String::from_utf8(w.into_inner().expect("writing to memory")).expect("UTF-8 fields")
}

/// Writes `stats.json` and `stats.csv` into `dir`; an error names the file.
pub fn write_stats(dir: &Path, stats: &RunStats) -> std::io::Result<()> {
    let write = |name: &str, text: String| {
        let p = dir.join(name);
        crate::rundir::export::write_atomic(&p, text.as_bytes())
            .map_err(|e| std::io::Error::new(e.kind(), format!("{}: {e}", p.display())))
    };
    let json = serde_json::to_string_pretty(stats).map_err(std::io::Error::other)?;
    write(STATS_JSON, json + "\n")?;
    write(STATS_CSV, stats_csv(stats))
}
