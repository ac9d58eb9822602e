//! The step-by-step output of `rwg rollout` and `rwg replay --episode`:
//! JSON lines or CSV (through the `csv` crate), floats in shortest
//! round-trip form.

use rwg_env::float::fmt_f64;
use rwg_env::{Action, Step};
use rwg_study::rundir::export::{csv_io_error, csv_writer};
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

/// Writes one CSV record (and flushes it to `out`).
fn csv_line(out: &mut dyn Write, fields: &[String]) -> io::Result<()> {
    let mut w = csv_writer(out);
    w.write_record(fields).map_err(csv_io_error)?;
    w.flush()
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
        csv_line(out, &cols)
    }

    /// Line 0: the observation after the reset.
    pub fn reset(&self, out: &mut dyn Write, obs: &[f64]) -> io::Result<()> {
        if self.csv {
            let mut fields = vec!["0".to_string()];
            fields.extend(std::iter::repeat_n(String::new(), self.act_dim));
            fields.extend(obs.iter().map(|v| fmt_f64(*v)));
            fields.extend(std::iter::repeat_n(String::new(), 3));
            csv_line(out, &fields)
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
            let mut fields = vec![step.to_string()];
            match action {
                Action::Discrete(d) => fields.push(d.to_string()),
                Action::Continuous(a) => fields.extend(a.iter().map(|v| fmt_f64(*v))),
            }
            fields.extend(obs.iter().map(|v| fmt_f64(*v)));
            fields.push(fmt_f64(s.reward));
            fields.push(s.terminated.to_string());
            fields.push(s.truncated.to_string());
            csv_line(out, &fields)
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
