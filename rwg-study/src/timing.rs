//! Where a run's wall time goes, phase by phase (`rwg run --timing`).
//!
//! The runner measures every phase with the wall clock (a few clock reads per
//! cell: no cost worth switching off). The sampling of a cell runs on the
//! worker threads, with the block commits overlapped on I/O threads
//! ([`crate::committer`]); everything else (set-up, waiting for the last
//! commits, finalising a cell, `run.json`, the report) runs on one thread
//! while the workers wait, so it is the run's serial share: what limits the
//! speed-up with more threads (Amdahl).

use std::time::Duration;

/// The phases of one cell.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct CellTiming {
    /// The cell's directory name.
    pub dir: String,
    /// Waves of blocks on the worker threads (parallel), the block commits
    /// that overlap them included.
    pub sampling: Duration,
    /// Waiting, after the sampling, for the last blocks to be committed
    /// (serial).
    pub commit_wait: Duration,
    /// Busy time of the I/O threads committing the blocks (formatting,
    /// writing, syncing, renaming), overlapped with the sampling: not part
    /// of the cell's wall time.
    pub commit_io: Duration,
    /// Finalising the cell: `scores.csv`, per-sample statistics,
    /// `samples.csv`, `cell.json` (serial).
    pub finalize: Duration,
    /// Writing `run.json` after the cell (serial).
    pub run_json: Duration,
}

impl CellTiming {
    /// The cell's whole wall time.
    pub fn total(&self) -> Duration {
        self.sampling + self.serial()
    }

    /// The cell's serial phases.
    pub fn serial(&self) -> Duration {
        self.commit_wait + self.finalize + self.run_json
    }

    /// Serial share of the cell's wall time (0 for an empty cell).
    pub fn serial_share(&self) -> f64 {
        share(self.serial(), self.total())
    }
}

/// The phases of a run (the report, written by the caller, is not included).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RunTiming {
    /// Planning the cells (loading plugins), preparing the run directory,
    /// writing `manifest.toml`, starting the thread pool.
    pub setup: Duration,
    /// The cells computed in this session, in order.
    pub cells: Vec<CellTiming>,
    /// Everything after the last cell (final `run.json`).
    pub wrap_up: Duration,
}

impl RunTiming {
    /// A table of the phases; `report`: the analysis' time if the caller ran it.
    pub fn table(&self, report: Option<Duration>) -> String {
        let ms = |d: Duration| format!("{:.1}", d.as_secs_f64() * 1e3);
        let mut s = format!(
            "{:<44} {:>10} {:>10} {:>10} {:>10} {:>9} {:>10} {:>7}\n",
            "phase (wall ms)",
            "sampling",
            "commit I/O",
            "commit end",
            "finalise",
            "run.json",
            "total",
            "serial"
        );
        let mut sum = CellTiming::default();
        for c in &self.cells {
            s += &format!(
                "{:<44} {:>10} {:>10} {:>10} {:>10} {:>9} {:>10} {:>6.2}%\n",
                c.dir,
                ms(c.sampling),
                ms(c.commit_io),
                ms(c.commit_wait),
                ms(c.finalize),
                ms(c.run_json),
                ms(c.total()),
                100.0 * c.serial_share()
            );
            sum.sampling += c.sampling;
            sum.commit_wait += c.commit_wait;
            sum.finalize += c.finalize;
            sum.run_json += c.run_json;
        }
        let report = report.unwrap_or_default();
        let serial = self.setup + sum.serial() + self.wrap_up + report;
        let total = serial + sum.sampling;
        s += &format!(
            "cells: sampling {} ms, serial {} ms; set-up {} ms, wrap-up {} ms, report {} ms\n",
            ms(sum.sampling),
            ms(sum.serial()),
            ms(self.setup),
            ms(self.wrap_up),
            ms(report)
        );
        s += &format!(
            "whole run: {} ms, serial share {:.2}% (cells alone {:.2}%)\n",
            ms(total),
            100.0 * share(serial, total),
            100.0 * sum.serial_share()
        );
        s
    }
}

fn share(part: Duration, whole: Duration) -> f64 {
    if whole.is_zero() {
        0.0
    } else {
        part.as_secs_f64() / whole.as_secs_f64()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn serial_share_counts_everything_but_sampling() {
        let c = CellTiming {
            dir: "CartPole-v0__0HL__nobias".into(),
            sampling: Duration::from_millis(900),
            commit_wait: Duration::from_millis(60),
            commit_io: Duration::from_millis(500),
            finalize: Duration::from_millis(30),
            run_json: Duration::from_millis(10),
        };
        assert_eq!(c.total(), Duration::from_millis(1000));
        assert!((c.serial_share() - 0.1).abs() < 1e-12);
        let t = RunTiming {
            setup: Duration::from_millis(50),
            cells: vec![c],
            wrap_up: Duration::from_millis(0),
        };
        let table = t.table(Some(Duration::from_millis(50)));
        assert!(table.contains("CartPole-v0__0HL__nobias"), "{table}");
        assert!(table.contains("10.00%"), "{table}");
        // (50 + 100 + 50) / 1100
        assert!(table.contains("serial share 18.18%"), "{table}");
        assert_eq!(CellTiming::default().serial_share(), 0.0);
    }
}
