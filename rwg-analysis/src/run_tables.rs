//! What the tables of a run hold: the paper's Table 3 (best mean and 99.9th
//! percentile of the sample means), p(solved), expected guesses, and a
//! per-cell detail table, built from a run's statistics as [`Table`]s
//! ([`run_tables`]), plus the cell texts other tables share.
//!
//! How a table is written out (text, Markdown, LaTeX, CSV, HTML) is
//! [`crate::table_render`]'s job.

use crate::fmt::{prob, prob_ci, score, sig, sig_latex};
use crate::table_render::{Cell, Table};
use rwg_study::rundir::data::RunStats;
use rwg_study::stats::{BlockSpread, CellSummary, ExpectedGuesses, SpreadAtN, GUESS_COUNTS};

/// "with bias" / "no bias".
pub fn bias_label(bias: bool) -> &'static str {
    if bias {
        "with bias"
    } else {
        "no bias"
    }
}

/// Distinct values in order of first appearance.
fn distinct<T: PartialEq + Clone>(xs: impl IntoIterator<Item = T>) -> Vec<T> {
    let mut out = Vec::new();
    for x in xs {
        if !out.contains(&x) {
            out.push(x);
        }
    }
    out
}

/// The bias settings present, in order of appearance.
pub fn bias_settings(cells: &[CellSummary]) -> Vec<bool> {
    distinct(cells.iter().map(|c| c.id.bias))
}

/// A grid: rows envs, columns architectures, for one bias setting; `None`
/// when no cell has that bias.
fn grid(
    cells: &[CellSummary],
    bias: bool,
    title: String,
    notes: Vec<String>,
    value: impl Fn(&CellSummary) -> Cell,
) -> Option<Table> {
    let cells: Vec<&CellSummary> = cells.iter().filter(|c| c.id.bias == bias).collect();
    if cells.is_empty() {
        return None;
    }
    let envs = distinct(cells.iter().map(|c| c.id.env.clone()));
    let archs = distinct(cells.iter().map(|c| c.id.arch.clone()));
    let mut header = vec![Cell::plain("env")];
    header.extend(archs.iter().map(|a| Cell::plain(a.clone())));
    let rows = envs
        .iter()
        .map(|env| {
            let mut row = vec![Cell::plain(env.clone())];
            row.extend(archs.iter().map(|arch| {
                cells
                    .iter()
                    .find(|c| &c.id.env == env && &c.id.arch == arch)
                    .map_or_else(|| Cell::plain("–"), |c| value(c))
            }));
            row
        })
        .collect();
    Some(Table {
        title,
        header,
        rows,
        notes,
    })
}

fn shape(cells: &[CellSummary]) -> String {
    match cells.first() {
        Some(c) => format!("{} samples × {} episodes", c.samples, c.episodes),
        None => String::new(),
    }
}

/// The paper's Table 3 for one bias setting: "best mean (99.9th percentile)"
/// of the sample means `M`, rows envs, columns architectures.
pub fn best_mean_table(cells: &[CellSummary], bias: bool) -> Option<Table> {
    grid(
        cells,
        bias,
        format!(
            "Best sample mean (99.9th percentile of sample means), {}, {}",
            bias_label(bias),
            shape(cells)
        ),
        vec![],
        |c| Cell::plain(format!("{} ({})", score(c.best_mean), score(c.p99_9_mean))),
    )
}

/// Which statistic a spread table shows.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SpreadStat {
    /// The best mean `max M`.
    BestMean,
    /// The 99.9th percentile of `M`.
    P999,
}

impl SpreadStat {
    fn pick(self, a: &SpreadAtN) -> &BlockSpread {
        match self {
            SpreadStat::BestMean => &a.best_mean,
            SpreadStat::P999 => &a.p99_9_mean,
        }
    }

    fn label(self) -> &'static str {
        match self {
            SpreadStat::BestMean => "Best sample mean",
            SpreadStat::P999 => "99.9th percentile of sample means",
        }
    }
}

/// `median [min, max]` of a statistic over the blocks.
pub fn spread_text(b: &BlockSpread) -> String {
    format!("{} [{}, {}]", score(b.median), score(b.min), score(b.max))
}

/// The spread at a study size `N` of the best mean or of the 99.9th
/// percentile of `M`, for one bias setting: `median [min, max]` over the
/// disjoint blocks of `N` networks (cells without a spread show `–`). `None`
/// when no cell of that bias setting has a spread.
pub fn spread_table(cells: &[CellSummary], bias: bool, stat: SpreadStat) -> Option<Table> {
    let spreads: Vec<&SpreadAtN> = cells
        .iter()
        .filter(|c| c.id.bias == bias)
        .filter_map(|c| c.at_n.as_ref())
        .collect();
    let first = spreads.first()?;
    let uniform = spreads
        .iter()
        .all(|a| (a.n, a.blocks) == (first.n, first.blocks));
    let over = if uniform {
        format!("over {} disjoint blocks", first.blocks)
    } else {
        "over disjoint blocks".into()
    };
    let mut notes = vec![format!(
        "Block k holds networks k·N to (k+1)·N − 1: each block is an independent study of N networks, \
         and a further study of N networks lands inside [min, max] with probability (K − 1)/(K + 1){}.",
        if uniform {
            format!(" = {:.2} for K = {}", first.coverage, first.blocks)
        } else {
            String::new()
        }
    )];
    if !uniform {
        notes.push("(K blocks of N networks) follows each cell: the cells differ.".into());
    }
    grid(
        cells,
        bias,
        format!(
            "{} at N = {} networks, median [min, max] {over}, {}",
            stat.label(),
            first.n,
            bias_label(bias)
        ),
        notes,
        |c| match &c.at_n {
            None => Cell::plain("–"),
            Some(a) if uniform => Cell::plain(spread_text(stat.pick(a))),
            Some(a) => Cell::plain(format!(
                "{} ({} blocks of {})",
                spread_text(stat.pick(a)),
                a.blocks,
                a.n
            )),
        },
    )
}

/// p(solved) with its 95% Wilson interval for one bias setting.
pub fn solved_table(cells: &[CellSummary], bias: bool) -> Option<Table> {
    grid(
        cells,
        bias,
        format!(
            "Fraction of samples with mean ≥ solved score, 95% Wilson interval, {}",
            bias_label(bias)
        ),
        vec![],
        |c| match c.solved_fraction {
            Some(p) => prob_ci(p.p, p.lo, p.hi),
            None => Cell::plain("no solved score"),
        },
    )
}

/// The expected-guesses cell: `1/p [lo, hi]`, or `none seen (≥ x)`.
pub fn guesses_cell(g: Option<ExpectedGuesses>) -> Cell {
    match g {
        None => Cell::plain("–"),
        Some(ExpectedGuesses::Estimate {
            value,
            lo_bound,
            hi_bound,
        }) => {
            let (hi_t, hi_l) = match hi_bound {
                Some(h) => (sig(h, 3), sig_latex(h, 3)),
                None => ("∞".into(), "$\\infty$".into()),
            };
            Cell {
                text: format!("{} [{}, {}]", sig(value, 3), sig(lo_bound, 3), hi_t),
                latex: format!(
                    "{} [{}, {}]",
                    sig_latex(value, 3),
                    sig_latex(lo_bound, 3),
                    hi_l
                ),
            }
        }
        Some(ExpectedGuesses::NoneSeen { at_least }) => Cell {
            text: format!("none seen (≥ {})", sig(at_least, 3)),
            latex: format!("none seen ($\\geq$ {})", sig_latex(at_least, 3)),
        },
    }
}

/// Expected guesses to the first solving network `1/p` for one bias setting.
pub fn guesses_table(cells: &[CellSummary], bias: bool) -> Option<Table> {
    grid(
        cells,
        bias,
        format!(
            "Expected random guesses to the first solving network (1/p, 95% interval), {}",
            bias_label(bias)
        ),
        if cells.iter().any(|c| {
            c.id.bias == bias
                && matches!(c.expected_guesses, Some(ExpectedGuesses::NoneSeen { .. }))
        }) {
            vec![
                "none seen: no sample solved; the bound is 1 / (upper end of p's interval).".into(),
            ]
        } else {
            vec![]
        },
        |c| guesses_cell(c.expected_guesses),
    )
}

/// Gives every plain decimal number of column `col` the same number of
/// decimals (the most any has: `1.00` next to `0.999` becomes `1.000`), so a
/// column reads in one format. A column holding anything else (scientific
/// notation, text other than `–`) is left as it is.
pub fn uniform_decimals(rows: &mut [Vec<Cell>], col: usize) {
    let plain = |t: &str| {
        let t = t.strip_prefix('-').unwrap_or(t);
        !t.is_empty()
            && t.chars().all(|c| c.is_ascii_digit() || c == '.')
            && t.matches('.').count() <= 1
    };
    let texts: Vec<&str> = rows
        .iter()
        .filter_map(|r| r.get(col))
        .map(|c| c.text.as_str())
        .filter(|t| *t != "–")
        .collect();
    if texts.is_empty() || !texts.iter().all(|t| plain(t)) {
        return;
    }
    let decimals = texts
        .iter()
        .map(|t| t.split_once('.').map_or(0, |(_, d)| d.len()))
        .max()
        .unwrap_or(0);
    for r in rows.iter_mut() {
        if let Some(c) = r.get_mut(col) {
            if c.text != "–" {
                let v: f64 = c.text.parse().expect("a plain decimal");
                *c = Cell::plain(format!("{v:.decimals$}"));
            }
        }
    }
}

/// One row per cell with every headline number.
pub fn detail_table(cells: &[CellSummary]) -> Table {
    let mut header: Vec<Cell> = [
        "env",
        "arch",
        "bias",
        "best mean",
        "p99.9 M",
        "median M",
        "p(solved)",
        "1/p",
    ]
    .into_iter()
    .map(Cell::from)
    .collect();
    header.extend(
        GUESS_COUNTS
            .iter()
            .map(|n| Cell::plain(format!("P(≥1 in {n})"))),
    );
    header.extend(["top 0.1% ep.", "mean len"].into_iter().map(Cell::from));
    let rows = cells
        .iter()
        .map(|c| {
            let mut r = vec![
                Cell::plain(c.id.env.clone()),
                Cell::plain(c.id.arch.clone()),
                Cell::plain(if c.id.bias { "yes" } else { "no" }),
                Cell::plain(score(c.best_mean)),
                Cell::plain(score(c.p99_9_mean)),
                Cell::plain(score(c.median_mean)),
                c.solved_fraction
                    .map_or_else(|| Cell::plain("–"), |p| prob(p.p)),
                guesses_cell(c.expected_guesses),
            ];
            r.extend(GUESS_COUNTS.iter().map(|&n| {
                c.success_odds
                    .iter()
                    .find(|o| o.guesses == n)
                    .map_or_else(|| Cell::plain("–"), |o| prob(o.p))
            }));
            r.push(Cell::plain(score(c.top_episode_threshold)));
            r.push(Cell::plain(format!("{:.1}", c.mean_episode_length)));
            r
        })
        .collect::<Vec<_>>();
    let mut rows = rows;
    // the probability columns: p(solved) and P(≥1 in n)
    for col in (6..7).chain(8..8 + GUESS_COUNTS.len()) {
        uniform_decimals(&mut rows, col);
    }
    Table {
        title: format!("Per cell, {}", shape(cells)),
        header,
        rows,
        notes: vec![],
    }
}

/// Where episodes ended at a value that was not finite: one row per cell
/// with `non_finite = "end"`, its count and share of the cell's episodes;
/// `None` when no cell has the choice.
pub fn non_finite_table(cells: &[CellSummary]) -> Option<Table> {
    let rows: Vec<Vec<Cell>> = cells
        .iter()
        .filter_map(|c| {
            let n = c.non_finite_episodes?;
            let total = c.samples * u64::from(c.episodes);
            let share = 100.0 * n as f64 / total.max(1) as f64;
            Some(vec![
                Cell::plain(c.id.env.clone()),
                Cell::plain(c.id.arch.clone()),
                Cell::plain(if c.id.bias { "yes" } else { "no" }),
                Cell::plain(n.to_string()),
                Cell::plain(total.to_string()),
                Cell::plain(format!("{share:.2}%")),
            ])
        })
        .collect();
    if rows.is_empty() {
        return None;
    }
    let header = ["env", "arch", "bias", "ended", "episodes", "share"]
        .into_iter()
        .map(Cell::from)
        .collect();
    Some(Table {
        title: "Episodes ended at a value not finite (cells with non_finite = \"end\")".into(),
        header,
        rows,
        notes: vec![
            "An episode that met a NaN or infinite observation or reward, a network output \
             that was not finite, or a return beyond ±1e100 ended there, its return that of \
             the steps before; scores.csv flags it (non_finite = 1), samples.csv counts each \
             network's."
                .into(),
        ],
    })
}

/// Every table of a run, in order: Table 3 per bias setting, (when the
/// cells have a spread at a study size) the best mean's and the 99.9th
/// percentile's spread per bias setting, p(solved) per bias setting,
/// expected guesses per bias setting, the detail table, and (when a cell
/// has `non_finite = "end"`) where episodes ended at a value not finite.
pub fn run_tables(stats: &RunStats) -> Vec<Table> {
    let cells = &stats.cells;
    let biases = bias_settings(cells);
    let mut out = Vec::new();
    for &b in &biases {
        out.extend(best_mean_table(cells, b));
    }
    for &b in &biases {
        for stat in [SpreadStat::BestMean, SpreadStat::P999] {
            out.extend(spread_table(cells, b, stat));
        }
    }
    let any_solved = cells.iter().any(|c| c.solved.is_some());
    if any_solved {
        for &b in &biases {
            out.extend(solved_table(cells, b));
        }
        for &b in &biases {
            out.extend(guesses_table(cells, b));
        }
    }
    out.push(detail_table(cells));
    out.extend(non_finite_table(cells));
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_column_reads_in_one_format() {
        let col =
            |ts: &[&str]| -> Vec<Vec<Cell>> { ts.iter().map(|t| vec![Cell::plain(*t)]).collect() };
        let mut rows = col(&["1.00", "0.999", "–", "0"]);
        uniform_decimals(&mut rows, 0);
        let t: Vec<&str> = rows.iter().map(|r| r[0].text.as_str()).collect();
        assert_eq!(t, ["1.000", "0.999", "–", "0.000"]);
        let mut rows = col(&["1.00", "3.84e-4"]);
        uniform_decimals(&mut rows, 0);
        assert_eq!(rows[0][0].text, "1.00");
    }
}
