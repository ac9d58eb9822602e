//! Observation and action spaces, as in Gymnasium (`Box` and `Discrete`).

/// A box in R^n with per-dimension bounds (bounds may be infinite).
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
pub struct BoxSpace {
    /// Lower bound of each dimension.
    pub low: Vec<f64>,
    /// Upper bound of each dimension.
    pub high: Vec<f64>,
}

impl BoxSpace {
    /// A box with the given bounds; `low` and `high` must have the same length.
    pub fn new(low: Vec<f64>, high: Vec<f64>) -> Self {
        assert_eq!(low.len(), high.len(), "Box bounds of different lengths");
        BoxSpace { low, high }
    }

    /// A box with the same bounds `[-b, b]` on every dimension.
    pub fn symmetric(bounds: &[f64]) -> Self {
        BoxSpace::new(bounds.iter().map(|b| -b).collect(), bounds.to_vec())
    }

    /// Number of dimensions.
    pub fn dim(&self) -> usize {
        self.low.len()
    }

    /// Whether `x` lies inside the box (bounds included) and is not NaN.
    pub fn contains(&self, x: &[f64]) -> bool {
        x.len() == self.dim()
            && x.iter()
                .zip(self.low.iter().zip(&self.high))
                .all(|(v, (lo, hi))| *lo <= *v && *v <= *hi)
    }
}

/// An observation or action space.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
#[cfg_attr(feature = "serde", serde(tag = "type"))]
pub enum Space {
    /// Integers `0..n`.
    Discrete {
        /// Number of values.
        n: usize,
    },
    /// Real vectors inside a box.
    Box(BoxSpace),
}

impl Space {
    /// Length of the flat vector that holds one element of the space: `dim` for a
    /// box, 1 for a discrete space (its value).
    pub fn flat_dim(&self) -> usize {
        match self {
            Space::Discrete { .. } => 1,
            Space::Box(b) => b.dim(),
        }
    }

    /// Compact form for tables: `Discrete(2)`, `Box(4)`, or `Box(1, [-2.0, 2.0])`
    /// when every dimension has the same finite bounds.
    pub fn short(&self) -> String {
        match self {
            Space::Discrete { n } => format!("Discrete({n})"),
            Space::Box(b) => {
                let same = b.low.windows(2).all(|w| w[0] == w[1])
                    && b.high.windows(2).all(|w| w[0] == w[1]);
                match (same, b.low.first(), b.high.first()) {
                    (true, Some(lo), Some(hi)) if lo.is_finite() && hi.is_finite() => format!(
                        "Box({}, [{}, {}])",
                        b.dim(),
                        crate::float::fmt_f64(*lo),
                        crate::float::fmt_f64(*hi)
                    ),
                    _ => format!("Box({})", b.dim()),
                }
            }
        }
    }

    /// Human-readable form, e.g. `Discrete(2)` or `Box(4, [-4.8, ...])`.
    pub fn describe(&self) -> String {
        match self {
            Space::Discrete { n } => format!("Discrete({n})"),
            Space::Box(b) => {
                let fmt = |v: &[f64]| {
                    let parts: Vec<String> = v.iter().map(|x| crate::float::fmt_f64(*x)).collect();
                    format!("[{}]", parts.join(", "))
                };
                format!(
                    "Box({}, low={}, high={})",
                    b.dim(),
                    fmt(&b.low),
                    fmt(&b.high)
                )
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn box_contains_checks_bounds_and_nan() {
        let b = BoxSpace::symmetric(&[1.0, 2.0]);
        assert!(b.contains(&[1.0, -2.0]));
        assert!(!b.contains(&[1.5, 0.0]));
        assert!(!b.contains(&[f64::NAN, 0.0]));
        assert!(!b.contains(&[0.0]));
    }

    #[test]
    fn describe_spaces() {
        assert_eq!(Space::Discrete { n: 3 }.describe(), "Discrete(3)");
        let s = Space::Box(BoxSpace::symmetric(&[2.0]));
        assert_eq!(s.describe(), "Box(1, low=[-2.0], high=[2.0])");
        assert_eq!(s.flat_dim(), 1);
        assert_eq!(s.short(), "Box(1, [-2.0, 2.0])");
        assert_eq!(
            Space::Box(BoxSpace::symmetric(&[1.0, 2.0])).short(),
            "Box(2)"
        );
    }
}
