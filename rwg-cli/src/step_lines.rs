//! The step-by-step output of `rwg rollout` and `rwg replay --episode`:
//! JSON lines or CSV, floats in shortest round-trip form.

use rwg_env::float::fmt_f64;
use rwg_env::{Action, Step};
use std::io::{self, Write};

/// Writes the lines of one episode.
pub struct StepLines {
    csv: bool,
    act_dim: usize,
    obs_dim: usize,
}

/// JSON number (shortest round-trip), or null for a non-finite value.
fn json_num(x: f64) -> String {
    if x.is_finite() {
        fmt_f64(x)
    } else {
        "null".into()
    }
}

fn join(v: impl Iterator<Item = String>, sep: &str) -> String {
    v.collect::<Vec<_>>().join(sep)
}

impl StepLines {
    /// `format` is `jsonl` or `csv`.
    pub fn new(format: &str, act_dim: usize, obs_dim: usize) -> Self {
        StepLines {
            csv: format == "csv",
            act_dim,
            obs_dim,
        }
    }

    /// The CSV header (nothing for JSON lines).
    pub fn header(&self, out: &mut dyn Write) -> io::Result<()> {
        if !self.csv {
            return Ok(());
        }
        let mut cols = vec!["step".to_string()];
        if self.act_dim == 1 {
            cols.push("action".into());
        } else {
            cols.extend((0..self.act_dim).map(|i| format!("action_{i}")));
        }
        cols.extend((0..self.obs_dim).map(|i| format!("obs_{i}")));
        cols.extend(["reward", "terminated", "truncated"].map(String::from));
        writeln!(out, "{}", cols.join(","))
    }

    /// Line 0: the observation after the reset.
    pub fn reset(&self, out: &mut dyn Write, obs: &[f64]) -> io::Result<()> {
        if self.csv {
            let blanks = ",".repeat(self.act_dim);
            writeln!(
                out,
                "0{blanks},{},,,",
                join(obs.iter().map(|v| fmt_f64(*v)), ",")
            )
        } else {
            writeln!(
                out,
                "{{\"step\":0,\"obs\":[{}]}}",
                join(obs.iter().map(|v| json_num(*v)), ",")
            )
        }
    }

    /// The line of step `step` (1-based).
    pub fn step(
        &self,
        out: &mut dyn Write,
        step: usize,
        action: Action<'_>,
        obs: &[f64],
        s: Step,
    ) -> io::Result<()> {
        if self.csv {
            let action = match action {
                Action::Discrete(d) => d.to_string(),
                Action::Continuous(a) => join(a.iter().map(|v| fmt_f64(*v)), ","),
            };
            writeln!(
                out,
                "{step},{action},{},{},{},{}",
                join(obs.iter().map(|v| fmt_f64(*v)), ","),
                fmt_f64(s.reward),
                s.terminated,
                s.truncated
            )
        } else {
            let action = match action {
                Action::Discrete(d) => d.to_string(),
                Action::Continuous(a) => format!("[{}]", join(a.iter().map(|v| json_num(*v)), ",")),
            };
            writeln!(
                out,
                "{{\"step\":{step},\"action\":{action},\"obs\":[{}],\"reward\":{},\"terminated\":{},\"truncated\":{}}}",
                join(obs.iter().map(|v| json_num(*v)), ","),
                json_num(s.reward),
                s.terminated,
                s.truncated
            )
        }
    }
}
