//! Where a run's wall time goes, phase by phase (`rwg run --timing`).
//!
//! The runner measures every phase with the wall clock (a few clock reads per
//! cell: no cost worth switching off). The sampling of a cell runs on the
//! worker threads, with the block commits overlapped on I/O threads
//! ([`crate::committer`]); the cell's end (its last commits, finalising it,
//! `run.json`) runs on threads of its own while the next cell samples
//! (`recorder`). What the runner's thread does for a cell outside
//! its sampling (starting the cell's I/O threads, handing the cell's end
//! over, waiting when too many cells are still ending) keeps the workers
//! waiting: that is the cell's serial time, and with set-up, the wait for the
//! last cells' ends and the report, the run's serial share: what limits the
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
    /// Of the sampling, for a JAX env: its workers starting and compiling
    /// the cell, until the last one is ready to run (wall time); `None` for
    /// the envs that compile nothing. The rest of the sampling is running.
    pub warm_up: Option<Duration>,
    /// The runner's thread busy with the cell, or waiting, outside its
    /// sampling, while the workers wait (serial).
    pub serial: Duration,
    /// Busy time of the I/O threads committing the blocks (formatting,
    /// writing, syncing, renaming), overlapped with the sampling.
    pub commit_io: Duration,
    /// From the end of the sampling until the last block was committed
    /// (overlapped with the next cell's sampling).
    pub commit_end: Duration,
    /// Finalising the cell: `scores.csv`, per-sample statistics,
    /// `samples.csv`, `cell.json` (overlapped with the next cell's sampling).
    pub finalize: Duration,
    /// Writing `run.json` after the cell (overlapped with the next cell's
    /// sampling).
    pub run_json: Duration,
}

impl CellTiming {
    /// The cell's wall time on the runner's thread: from its start to the
    /// next cell's (its end, overlapped, is not part of it).
    pub fn total(&self) -> Duration {
        self.sampling + self.serial
    }

    /// Serial share of the cell's wall time (0 for an empty cell).
    pub fn serial_share(&self) -> f64 {
        share(self.serial, self.total())
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
    /// After the last cell's sampling, waiting for the ends of the cells
    /// still ending (the last cell's commits, finalisation and `run.json`,
    /// nothing left to overlap them with).
    pub drain: Duration,
    /// Everything after that (final `run.json`).
    pub wrap_up: Duration,
}

impl RunTiming {
    /// The cells' sampling, warm-up (`None` when no cell compiled) and
    /// serial time added up (`dir` empty; the overlapped phases are not
    /// added).
    pub fn cells_sum(&self) -> CellTiming {
        let mut sum = CellTiming::default();
        for c in &self.cells {
            sum.sampling += c.sampling;
            sum.serial += c.serial;
            if let Some(w) = c.warm_up {
                *sum.warm_up.get_or_insert(Duration::ZERO) += w;
            }
        }
        sum
    }

    /// The run's serial time (set-up, the cells' serial time, the wait for
    /// the last cells' ends, wrap-up and `report`, the analysis' time if the
    /// caller ran it) and its whole wall time (the serial time plus the
    /// cells' sampling).
    pub fn serial_and_total(&self, report: Duration) -> (Duration, Duration) {
        let sum = self.cells_sum();
        let serial = self.setup + sum.serial + self.drain + self.wrap_up + report;
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
    fn serial_share_counts_everything_but_sampling_and_the_overlapped_ends() {
        let c = CellTiming {
            dir: "CartPole-v0__0HL__nobias".into(),
            sampling: Duration::from_millis(900),
            warm_up: None,
            serial: Duration::from_millis(100),
            commit_io: Duration::from_millis(500),
            commit_end: Duration::from_millis(60),
            finalize: Duration::from_millis(30),
            run_json: Duration::from_millis(10),
        };
        assert_eq!(c.total(), Duration::from_millis(1000));
        assert!((c.serial_share() - 0.1).abs() < 1e-12);
        let t = RunTiming {
            setup: Duration::from_millis(50),
            cells: vec![c.clone(), c],
            drain: Duration::from_millis(40),
            wrap_up: Duration::from_millis(10),
        };
        assert_eq!(t.cells_sum().sampling, Duration::from_millis(1800));
        assert_eq!(t.cells_sum().serial, Duration::from_millis(200));
        assert_eq!(t.cells_sum().finalize, Duration::ZERO);
        assert_eq!(t.cells_sum().warm_up, None);
        let mut jax = t.clone();
        jax.cells[0].warm_up = Some(Duration::from_millis(300));
        jax.cells[1].warm_up = Some(Duration::from_millis(200));
        assert_eq!(jax.cells_sum().warm_up, Some(Duration::from_millis(500)));
        let (serial, total) = t.serial_and_total(Duration::from_millis(50));
        // 50 + 2 * 100 + 40 + 10 + 50 of 2150
        assert_eq!(
            (serial, total),
            (Duration::from_millis(350), Duration::from_millis(2150))
        );
        assert!((share(serial, total) - 350.0 / 2150.0).abs() < 1e-12);
        assert_eq!(CellTiming::default().serial_share(), 0.0);
    }
}
