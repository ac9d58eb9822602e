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

/// The phases of a run (the report, written by the caller, is not included);
/// `rwg run --timing` prints them as a table.
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
    /// The cells' phases added up (`dir` empty; `commit_io` is not added:
    /// it overlaps the sampling).
    pub fn cells_sum(&self) -> CellTiming {
        let mut sum = CellTiming::default();
        for c in &self.cells {
            sum.sampling += c.sampling;
            sum.commit_wait += c.commit_wait;
            sum.finalize += c.finalize;
            sum.run_json += c.run_json;
        }
        sum
    }

    /// The run's serial time (set-up, the cells' serial phases, wrap-up and
    /// `report`, the analysis' time if the caller ran it) and its whole
    /// wall time (the serial time plus the cells' sampling).
    pub fn serial_and_total(&self, report: Duration) -> (Duration, Duration) {
        let sum = self.cells_sum();
        let serial = self.setup + sum.serial() + self.wrap_up + report;
        (serial, serial + sum.sampling)
    }
}

/// `part / whole` (0 when `whole` is zero).
pub fn share(part: Duration, whole: Duration) -> f64 {
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
            cells: vec![c.clone(), c],
            wrap_up: Duration::from_millis(0),
        };
        assert_eq!(t.cells_sum().sampling, Duration::from_millis(1800));
        assert_eq!(t.cells_sum().commit_io, Duration::ZERO);
        let (serial, total) = t.serial_and_total(Duration::from_millis(50));
        // 50 + 2 * 100 + 50 of 2100
        assert_eq!(
            (serial, total),
            (Duration::from_millis(300), Duration::from_millis(2100))
        );
        assert!((share(serial, total) - 1.0 / 7.0).abs() < 1e-12);
        assert_eq!(CellTiming::default().serial_share(), 0.0);
    }
}
