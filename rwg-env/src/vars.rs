//! The environment variables rwg reads (`RWG_*`), parsed one way: a bad
//! value is an error that names the variable, its value and what is
//! expected, never a silent fallback to the default nor a panic.
//!
//! A variable that is unset takes its default; one set to the empty string
//! is an error (a shell's `VAR= cmd` sets it, it does not unset it).

use std::time::Duration;
use thiserror::Error;

/// A bad value of an environment variable.
#[derive(Debug, Clone, PartialEq, Error)]
#[error("{var}={value}: expected {expected}{}", empty_hint(var, value))]
pub struct VarError {
    /// The variable.
    pub var: &'static str,
    /// Its value (non-UTF-8 bytes shown as U+FFFD).
    pub value: String,
    /// What it may hold, and what it means.
    pub expected: String,
}

/// What to do about a variable set to the empty string: nothing for
/// another value.
fn empty_hint(var: &str, value: &str) -> String {
    if value.is_empty() {
        format!("; {var} is set to the empty string: unset it (`unset {var}`) for the default")
    } else {
        String::new()
    }
}

/// The value of `var`, `None` if it is unset, the empty string if it is set
/// to it; an error if it is not UTF-8. The parsers below refuse an empty
/// value as they refuse any other they cannot read.
pub fn value(var: &'static str) -> Result<Option<String>, VarError> {
    match std::env::var_os(var) {
        None => Ok(None),
        Some(v) => v.into_string().map(Some).map_err(|v| VarError {
            var,
            value: v.to_string_lossy().into_owned(),
            expected: "text in UTF-8".into(),
        }),
    }
}

/// Refuses `var` set to the empty string (any other value, UTF-8 or not, is
/// left to its reader); `expected` says what it may hold, for the error.
pub fn not_empty(var: &'static str, expected: &str) -> Result<(), VarError> {
    match std::env::var_os(var) {
        Some(v) if v.is_empty() => Err(VarError {
            var,
            value: String::new(),
            expected: expected.into(),
        }),
        _ => Ok(()),
    }
}

/// The value of `var`, `None` if it is unset; an error if it is empty or not
/// UTF-8. `expected` says what it may hold, for the error.
pub fn text(var: &'static str, expected: &str) -> Result<Option<String>, VarError> {
    match value(var)? {
        Some(v) if v.is_empty() => Err(VarError {
            var,
            value: v,
            expected: expected.into(),
        }),
        v => Ok(v),
    }
}

/// A switch: `0` (off) or `1` (on); `default` if `var` is unset.
/// `meaning` says what each value does, for the error.
pub fn switch(var: &'static str, default: bool, meaning: &str) -> Result<bool, VarError> {
    match value(var)? {
        None => Ok(default),
        Some(v) => parse_switch(var, &v, meaning),
    }
}

/// `value` of `var` as a switch (see [`switch`]).
pub fn parse_switch(var: &'static str, value: &str, meaning: &str) -> Result<bool, VarError> {
    match value.trim() {
        "0" => Ok(false),
        "1" => Ok(true),
        _ => Err(VarError {
            var,
            value: value.into(),
            expected: format!("0 or 1 ({meaning})"),
        }),
    }
}

/// Seconds from `min` to `max` (a decimal number, may be fractional);
/// `default` if `var` is unset. `meaning` says what the time is,
/// for the error.
pub fn seconds(
    var: &'static str,
    min: f64,
    max: f64,
    default: Duration,
    meaning: &str,
) -> Result<Duration, VarError> {
    match value(var)? {
        None => Ok(default),
        Some(v) => parse_seconds(var, &v, min, max, meaning),
    }
}

/// `value` of `var` as seconds from `min` to `max` (see [`seconds`]).
pub fn parse_seconds(
    var: &'static str,
    value: &str,
    min: f64,
    max: f64,
    meaning: &str,
) -> Result<Duration, VarError> {
    value
        .trim()
        .parse::<f64>()
        .ok()
        .filter(|s| (min..=max).contains(s))
        .and_then(|s| Duration::try_from_secs_f64(s).ok())
        .ok_or_else(|| VarError {
            var,
            value: value.into(),
            expected: format!("seconds from {min} to {max} ({meaning})"),
        })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn seconds_in_range_only() {
        let p = |v| parse_seconds("RWG_T", v, 0.0, 3600.0, "how long");
        assert_eq!(p("0"), Ok(Duration::ZERO));
        assert_eq!(p(" 2.5 "), Ok(Duration::from_millis(2500)));
        assert_eq!(p("3600"), Ok(Duration::from_secs(3600)));
        for bad in [
            "-1", "nan", "NaN", "inf", "1e30", "3600.5", "abc", "1s", "0x10",
        ] {
            let e = p(bad).unwrap_err();
            assert_eq!(
                e.to_string(),
                format!("RWG_T={bad}: expected seconds from 0 to 3600 (how long)")
            );
        }
        let e = parse_seconds("RWG_T", "0", 0.001, 10.0, "x").unwrap_err();
        assert!(e.to_string().contains("from 0.001 to 10"), "{e}");
    }

    #[test]
    fn switches_are_0_or_1() {
        let p = |v| parse_switch("RWG_S", v, "0: off");
        assert_eq!(p("0"), Ok(false));
        assert_eq!(p("1"), Ok(true));
        for bad in ["yes", "true", "2", "00x", "off"] {
            assert_eq!(
                p(bad).unwrap_err().to_string(),
                format!("RWG_S={bad}: expected 0 or 1 (0: off)")
            );
        }
    }

    #[test]
    fn empty_values_are_refused_with_what_to_do() {
        let e = parse_switch("RWG_S", "", "0: off").unwrap_err();
        assert_eq!(
            e.to_string(),
            "RWG_S=: expected 0 or 1 (0: off); RWG_S is set to the empty string: unset it \
             (`unset RWG_S`) for the default"
        );
        let e = parse_seconds("RWG_T", " ", 0.0, 1.0, "x").unwrap_err();
        assert_eq!(e.to_string(), "RWG_T= : expected seconds from 0 to 1 (x)");
    }

    #[test]
    fn unset_takes_the_default() {
        // a name no one sets
        let var = "RWG_VARS_TEST_NEVER_SET";
        assert_eq!(text(var, "x"), Ok(None));
        assert_eq!(value(var), Ok(None));
        assert_eq!(not_empty(var, "x"), Ok(()));
        assert_eq!(switch(var, true, "x"), Ok(true));
        assert_eq!(
            seconds(var, 0.0, 1.0, Duration::from_secs(7), "x"),
            Ok(Duration::from_secs(7))
        );
    }
}
