//! The difficulty ranking of `rwg compare`: every cell (env × architecture ×
//! bias) of every run, from the easiest to the hardest for random search.
//!
//! Order: cells where some network reached the solved score come first,
//! sorted by the expected number of random guesses to the first solving
//! network (`1/p`, ascending); then the cells where none did, sorted by the
//! normalised 99.9th percentile of `M` (descending: the closer the best
//! 1 in 1000 networks come to the solved score, the easier); then the cells
//! without a solved score, which cannot be ranked. Ties keep the order of
//! [`super::compare_rows`].

use super::data::CompareRow;
use crate::fmt::{prob_ci, sig};
use crate::run_tables::{bias_label, guesses_cell};
use crate::table_render::{Cell, Table};
use rwg_study::stats::ExpectedGuesses;
use std::cmp::Ordering;

/// How a cell's difficulty is known.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Evidence {
    /// Some network reached the solved score: ranked by `1/p`.
    Solved,
    /// None did: ranked by the normalised 99.9th percentile of `M`.
    NoneSeen,
    /// The cell has no solved score: not ranked.
    NoSolvedScore,
}

/// The evidence class of a comparison row.
pub fn evidence(row: &CompareRow) -> Evidence {
    match row.summary.expected_guesses {
        Some(ExpectedGuesses::Estimate { .. }) => Evidence::Solved,
        Some(ExpectedGuesses::NoneSeen { .. }) => Evidence::NoneSeen,
        None => Evidence::NoSolvedScore,
    }
}

fn guesses(row: &CompareRow) -> f64 {
    match row.summary.expected_guesses {
        Some(ExpectedGuesses::Estimate { value, .. }) => value,
        _ => f64::INFINITY,
    }
}

/// Descending by value, missing or NaN values last.
fn desc(a: Option<f64>, b: Option<f64>) -> Ordering {
    let key = |x: Option<f64>| x.filter(|v| !v.is_nan());
    match (key(a), key(b)) {
        (Some(a), Some(b)) => b.total_cmp(&a),
        (Some(_), None) => Ordering::Less,
        (None, Some(_)) => Ordering::Greater,
        (None, None) => Ordering::Equal,
    }
}

/// The indices of `rows` in difficulty order, easiest first.
pub fn difficulty_order(rows: &[CompareRow]) -> Vec<usize> {
    let mut idx: Vec<usize> = (0..rows.len()).collect();
    idx.sort_by(|&i, &j| {
        let (a, b) = (&rows[i], &rows[j]);
        evidence(a)
            .cmp(&evidence(b))
            .then_with(|| guesses(a).total_cmp(&guesses(b)))
            .then_with(|| desc(a.normalised_p99_9, b.normalised_p99_9))
    });
    idx
}

/// Per row of `rows`, its 1-based difficulty rank.
pub fn difficulty_ranks(rows: &[CompareRow]) -> Vec<usize> {
    let mut ranks = vec![0; rows.len()];
    for (r, i) in difficulty_order(rows).into_iter().enumerate() {
        ranks[i] = r + 1;
    }
    ranks
}

/// A normalised value with three decimals, `–` when missing; never `-0.000`.
pub fn norm_text(x: Option<f64>) -> String {
    match x {
        Some(v) if v.is_finite() => {
            let s = format!("{v:.3}");
            if s == "-0.000" {
                "0.000".into()
            } else {
                s
            }
        }
        Some(v) => format!("{v}"),
        None => "–".into(),
    }
}

/// The ranking as a table, easiest first.
pub fn ranking_table(rows: &[CompareRow]) -> Table {
    let multi = rows
        .first()
        .is_some_and(|r0| rows.iter().any(|r| r.run != r0.run));
    let mut header = vec!["rank", "env", "arch", "bias"];
    if multi {
        header.insert(1, "run");
    }
    header.extend(["1/p [95% CI]", "p(solved) [95% CI]", "norm. p99.9"]);
    let body = difficulty_order(rows)
        .into_iter()
        .enumerate()
        .map(|(k, i)| {
            let r = &rows[i];
            let s = &r.summary;
            let mut cells = vec![
                Cell::plain((k + 1).to_string()),
                Cell::plain(s.id.env.clone()),
                Cell::plain(s.id.arch.clone()),
                Cell::plain(bias_label(s.id.bias)),
            ];
            if multi {
                cells.insert(1, Cell::plain(r.run.clone()));
            }
            cells.push(match s.expected_guesses {
                None => Cell::plain("no solved score"),
                g => guesses_cell(g),
            });
            cells.push(
                s.solved_fraction
                    .map_or_else(|| Cell::plain("–"), |p| prob_ci(p.p, p.lo, p.hi)),
            );
            cells.push(Cell::plain(norm_text(r.normalised_p99_9)));
            cells
        })
        .collect();
    Table {
        title: format!(
            "Difficulty ranking of {} cells, easiest first (by expected random guesses 1/p, \
             then by normalised 99.9th percentile of M)",
            rows.len()
        ),
        header: header.into_iter().map(Cell::from).collect(),
        rows: body,
        notes: vec![
            "1/p: expected random networks to the first whose mean reaches the solved score, \
             95% Wilson interval; none seen: the interval's lower bound."
                .into(),
            "norm. p99.9: the 99.9th percentile of M rescaled so the median random network is 0 \
             and the solved score 1."
                .into(),
        ],
    }
}

/// Short text of a row's `1/p` for figure labels: `27.1`, `≥ 2604`.
pub fn guesses_short(row: &CompareRow) -> String {
    match row.summary.expected_guesses {
        Some(ExpectedGuesses::Estimate { value, .. }) => sig(value, 3),
        Some(ExpectedGuesses::NoneSeen { at_least }) => format!("≥ {}", sig(at_least, 3)),
        None => "–".into(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rwg_study::rundir::meta::CellId;
    use rwg_study::stats::{CellSummary, Proportion};

    fn row(run: &str, env: &str, g: Option<ExpectedGuesses>, norm: Option<f64>) -> CompareRow {
        let summary = CellSummary {
            id: CellId {
                dir: env.into(),
                env: env.into(),
                arch: "0HL".into(),
                hidden: vec![],
                bias: false,
            },
            n_weights: 1,
            samples: 100,
            episodes: 1,
            solved: g.map(|_| 1.0),
            best_mean: 0.0,
            best_sample: 0,
            best_variance: 0.0,
            worst_mean: 0.0,
            mean_of_means: 0.0,
            median_mean: 0.0,
            p99_9_mean: 0.0,
            mean_percentiles: vec![],
            mean_variance: 0.0,
            solved_fraction: g.map(|_| Proportion {
                successes: 1,
                trials: 100,
                p: 0.01,
                lo: 0.001,
                hi: 0.05,
            }),
            expected_guesses: g,
            success_odds: vec![],
            top_episode_threshold: 0.0,
            top_episodes: 0,
            best_episode: 0.0,
            mean_episode_length: 0.0,
            max_episode_length: 0,
            non_finite_episodes: None,
            at_n: None,
        };
        CompareRow {
            run: run.into(),
            summary,
            normalised_best: norm,
            normalised_p99_9: norm,
            difficulty_rank: 0,
        }
    }

    fn est(v: f64) -> Option<ExpectedGuesses> {
        Some(ExpectedGuesses::Estimate {
            value: v,
            lo_bound: v / 2.0,
            hi_bound: Some(v * 2.0),
        })
    }

    #[test]
    fn easiest_first_then_closest_to_solved_then_unranked() {
        let none = Some(ExpectedGuesses::NoneSeen { at_least: 300.0 });
        let rows = vec![
            row("a", "NoScore", None, None),
            row("a", "Hard", none, Some(0.2)),
            row("a", "Easy", est(27.0), Some(1.0)),
            row("b", "Harder", none, Some(-0.1)),
            row("b", "Medium", est(450.0), Some(0.9)),
            row("b", "Close", none, Some(0.95)),
        ];
        let order: Vec<&str> = difficulty_order(&rows)
            .into_iter()
            .map(|i| rows[i].summary.id.env.as_str())
            .collect();
        assert_eq!(
            order,
            ["Easy", "Medium", "Close", "Hard", "Harder", "NoScore"]
        );
        assert_eq!(difficulty_ranks(&rows), [6, 4, 1, 5, 2, 3]);
        let t = ranking_table(&rows);
        assert_eq!(t.header[1].text, "run");
        assert_eq!(t.rows[0][0].text, "1");
        assert_eq!(t.rows[0][2].text, "Easy");
        assert_eq!(t.rows[0][5].text, "27.0 [13.5, 54.0]");
        assert_eq!(t.rows[2][5].text, "none seen (≥ 300)");
        assert_eq!(t.rows[5][5].text, "no solved score");
        assert_eq!(t.rows[4][7].text, "-0.100");
        assert_eq!(norm_text(Some(-0.0001)), "0.000");
    }
}
