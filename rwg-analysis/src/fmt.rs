//! Number formatting for tables: plain text and LaTeX.

use crate::table_render::Cell;

/// A score with two decimals (`195.35`), a negative value that rounds to
/// zero as `0.00`; `NaN`, `inf` as such.
pub fn score(x: f64) -> String {
    if x.is_finite() {
        let s = format!("{x:.2}");
        if s == "-0.00" {
            "0.00".into()
        } else {
            s
        }
    } else {
        format!("{x}")
    }
}

/// A number with `sig` significant digits, in scientific notation
/// (`1.23e-5`) below 1e-3 or from 1e6 on; 0 as `0`.
pub fn sig(x: f64, sig: usize) -> String {
    if x == 0.0 {
        return "0".into();
    }
    if !x.is_finite() {
        return format!("{x}");
    }
    let a = x.abs();
    if !(1e-3..1e6).contains(&a) {
        let s = format!("{:.*e}", sig.saturating_sub(1), x);
        return s;
    }
    let digits = a.log10().floor() as i32;
    let decimals = (sig as i32 - 1 - digits).max(0) as usize;
    format!("{x:.decimals$}")
}

/// The LaTeX form of [`sig`]: scientific notation as `$1.23\times10^{-5}$`.
pub fn sig_latex(x: f64, digits: usize) -> String {
    let s = sig(x, digits);
    match s.split_once('e') {
        Some((m, e)) => format!("${m}\\times10^{{{}}}$", e.trim_start_matches('+')),
        None => s,
    }
}

/// A probability cell, 3 significant digits.
pub fn prob(p: f64) -> Cell {
    Cell {
        text: sig(p, 3),
        latex: sig_latex(p, 3),
    }
}

/// A probability with its interval: `0.0123 [0.0101, 0.0149]`.
pub fn prob_ci(p: f64, lo: f64, hi: f64) -> Cell {
    Cell {
        text: format!("{} [{}, {}]", sig(p, 3), sig(lo, 3), sig(hi, 3)),
        latex: format!(
            "{} [{}, {}]",
            sig_latex(p, 3),
            sig_latex(lo, 3),
            sig_latex(hi, 3)
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn formats() {
        assert_eq!(score(195.349), "195.35");
        assert_eq!(score(-0.004), "0.00");
        assert_eq!(score(-0.006), "-0.01");
        assert_eq!(sig(0.012345, 3), "0.0123");
        assert_eq!(sig(0.5, 3), "0.500");
        assert_eq!(sig(81.234, 3), "81.2");
        assert_eq!(sig(12345.6, 3), "12346");
        assert_eq!(sig(1.234e-5, 3), "1.23e-5");
        assert_eq!(sig(2.5e7, 3), "2.50e7");
        assert_eq!(sig_latex(1.234e-5, 3), "$1.23\\times10^{-5}$");
        assert_eq!(prob_ci(0.0, 0.0, 0.0369).text, "0 [0, 0.0369]");
    }
}
