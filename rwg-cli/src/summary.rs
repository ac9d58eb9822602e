//! The end-of-run summary table of `rwg run` and `rwg merge`: one line per
//! finished cell.

use rwg_analysis::table::{Align, TextColumns};
use rwg_study::cells::SummaryLine;

fn columns() -> TextColumns {
    use Align::{Left, Right};
    TextColumns::new(
        &[
            (44, Left),
            (11, Right),
            (12, Right),
            (8, Right),
            (11, Right),
        ],
        " ",
    )
}

/// The header line.
pub fn header() -> String {
    columns().line(&["cell", "best mean", "median mean", "solved", "steps/s"])
}

/// A cell's line.
pub fn line(l: &SummaryLine) -> String {
    columns().line(&[
        l.dir.clone(),
        format!("{:.2}", l.best_mean),
        format!("{:.2}", l.median_mean),
        l.solved_percent.map_or("-".into(), |p| format!("{p:.2}%")),
        format!("{:.3e}", l.steps_per_s),
    ])
}
