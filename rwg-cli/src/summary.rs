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
        num(Some(l.best_mean), 2, false),
        num(Some(l.median_mean), 2, false),
        l.solved_percent
            .filter(|p| p.is_finite())
            .map_or("-".into(), |p| format!("{p:.2}%")),
        num(l.steps_per_s, 3, true),
    ])
}

/// A summary number: `-` where unknown or not finite (never NaN), `prec`
/// decimals (in scientific notation if `exp`, or if it has 8 digits or more
/// before the point: the column's width), and a negative value that rounds
/// to zero without its sign (as the tables print it: never `-0.00`).
fn num(x: Option<f64>, prec: usize, exp: bool) -> String {
    let s = match x {
        Some(x) if x.is_finite() && (exp || x.abs() >= 1e7) => format!("{x:.prec$e}"),
        Some(x) if x.is_finite() => format!("{x:.prec$}"),
        _ => return "-".into(),
    };
    match s.strip_prefix('-') {
        Some(rest) if rest.bytes().all(|b| b == b'0' || b == b'.') => rest.to_string(),
        _ => s,
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn no_nan_and_no_negative_zero() {
        assert_eq!(super::num(Some(-0.004), 2, false), "0.00");
        assert_eq!(super::num(Some(-0.006), 2, false), "-0.01");
        assert_eq!(super::num(Some(195.0), 2, false), "195.00");
        assert_eq!(super::num(Some(f64::NAN), 2, false), "-");
        assert_eq!(super::num(None, 3, true), "-");
        assert_eq!(super::num(Some(12346.0), 3, true), "1.235e4");
        // returns up to ±1e100 fit the column
        assert_eq!(super::num(Some(9999999.0), 2, false), "9999999.00");
        assert_eq!(super::num(Some(-2.38e99), 2, false), "-2.38e99");
    }
}
