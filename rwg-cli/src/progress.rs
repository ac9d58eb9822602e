//! Progress of `rwg run` when stderr is not a terminal (a pipe, `nohup`, a
//! batch scheduler's log): a plain line every few seconds that reads well in
//! a log file, instead of a redrawn bar. On a terminal, `rwg run` draws the
//! bar; `--quiet` silences both.
//!
//! The interval is 5 s; `RWG_PROGRESS_INTERVAL` (seconds, may be fractional,
//! 0 for a line per block) overrides it.

use rwg_study::runner::Progress;
use std::io::Write;
use std::time::{Duration, Instant};

/// Default seconds between two progress lines.
const DEFAULT_INTERVAL_S: f64 = 5.0;

/// `h:mm:ss`.
pub fn hms(secs: f64) -> String {
    let s = if secs.is_finite() {
        secs.max(0.0).round() as u64
    } else {
        0
    };
    format!("{}:{:02}:{:02}", s / 3600, s / 60 % 60, s % 60)
}

/// Plain progress lines on stderr, at most one per interval.
pub struct Lines {
    interval: Duration,
    t0: Instant,
    last: Instant,
    total: u64,
    done: u64,
    steps: u64,
    label: String,
}

impl Lines {
    /// Lines every [`DEFAULT_INTERVAL_S`] seconds, or `RWG_PROGRESS_INTERVAL`.
    pub fn new() -> Self {
        let secs = std::env::var("RWG_PROGRESS_INTERVAL")
            .ok()
            .and_then(|v| v.parse::<f64>().ok())
            .filter(|s| s.is_finite() && *s >= 0.0)
            .unwrap_or(DEFAULT_INTERVAL_S);
        let now = Instant::now();
        Lines {
            interval: Duration::from_secs_f64(secs),
            t0: now,
            last: now,
            total: 0,
            done: 0,
            steps: 0,
            label: String::new(),
        }
    }

    /// The current line: elapsed time, cell, networks done of total,
    /// networks/s, env steps/s and the estimated time left.
    pub fn line(&self) -> String {
        let secs = self.t0.elapsed().as_secs_f64().max(1e-9);
        let nets = self.done as f64 / secs;
        let eta = if self.done == 0 {
            "unknown".into()
        } else {
            hms(self.total.saturating_sub(self.done) as f64 / nets)
        };
        format!(
            "[{}] {}: {}/{} networks ({:.1}%), {:.0} networks/s, {:.3e} env steps/s, ETA {}",
            hms(secs),
            self.label,
            self.done,
            self.total,
            100.0 * self.done as f64 / self.total.max(1) as f64,
            nets,
            self.steps as f64 / secs,
            eta
        )
    }

    fn emit(&self, s: &str) {
        // a closed stderr is no reason to stop the study
        let _ = writeln!(std::io::stderr(), "{s}");
    }
}

impl Default for Lines {
    fn default() -> Self {
        Self::new()
    }
}

impl Progress for Lines {
    fn start(&mut self, networks: u64) {
        self.t0 = Instant::now();
        self.last = self.t0;
        self.total = networks;
        if networks > 0 {
            self.emit(&format!(
                "[0:00:00] {networks} networks to compute; a progress line every {} s",
                self.interval.as_secs_f64()
            ));
        }
    }

    fn cell(&mut self, label: &str) {
        self.label = label.to_string();
    }

    fn block(&mut self, label: &str, networks: u64, env_steps: u64) {
        self.label = label.to_string();
        self.done += networks;
        self.steps += env_steps;
        if self.last.elapsed() >= self.interval {
            self.last = Instant::now();
            self.emit(&self.line());
        }
    }

    fn finish(&mut self, ok: bool) {
        if self.total > 0 {
            let what = if ok { "done" } else { "stopped" };
            self.label = what.into();
            self.emit(&self.line());
        }
    }
}

/// No progress at all (`--quiet`).
pub struct Silent;

impl Progress for Silent {
    fn start(&mut self, _networks: u64) {}
    fn cell(&mut self, _label: &str) {}
    fn block(&mut self, _label: &str, _networks: u64, _env_steps: u64) {}
    fn finish(&mut self, _ok: bool) {}
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn times_and_lines() {
        assert_eq!(hms(0.0), "0:00:00");
        assert_eq!(hms(3725.4), "1:02:05");
        assert_eq!(hms(f64::INFINITY), "0:00:00");
        let mut l = Lines::new();
        l.start(100);
        l.cell("cell 1/2 (0 done): A");
        assert!(
            l.line()
                .ends_with("0/100 networks (0.0%), 0 networks/s, 0.000e0 env steps/s, ETA unknown"),
            "{}",
            l.line()
        );
        l.done = 25;
        assert!(l
            .line()
            .contains("cell 1/2 (0 done): A: 25/100 networks (25.0%)"));
        assert!(!l.line().contains("ETA unknown"));
    }
}
