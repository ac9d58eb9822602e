//! Reading a run directory for analysis, and writing its derived files
//! (`samples.csv`, `stats.json`, `stats.csv`).
//!
//! [`Run::open`] reads `run.json` (and `manifest.toml` if present);
//! [`Run::load_cell`] reads one cell's `scores.csv` (and checks its
//! `samples.csv` against the scores when present), one cell at a time so a
//! large run never has to fit in memory at once; [`Run::summarize`] gives
//! every cell's [`CellSummary`].
//!
//! Malformed files give a [`RunReadError`] naming the file and, for CSV, the
//! 1-based line.
//!
//! Beside this file: the error (`read_error`), telling a run directory from
//! other folders (`not_a_run`), reading and checking a cell's CSV files
//! (`cell_csv`), writing them from scores in memory (`cell_writers`), the
//! checksummed reads (`verified`), the cell list (`cell_list`), unfinished
//! runs (`unfinished`), `stats.json`/`stats.csv` (`stats_files`), spreads at
//! a study size (`spread`) and synthetic runs ([`synthetic`]).

use crate::rundir::meta::{load_json, CellMeta, JsonFileError, RunMeta, RUN_FORMAT};
use crate::rundir::{cell_dir, MANIFEST, RUN_JSON, SAMPLES_CSV, SCORES_CSV};
use crate::stats::{self, CellSummary, SampleStats};
use read_error::io_err;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// An opened run directory: its metadata, cells not loaded yet.
#[derive(Debug, Clone)]
pub struct Run {
    /// The run directory.
    pub dir: PathBuf,
    /// Contents of `run.json`.
    pub meta: RunMeta,
    /// Contents of `manifest.toml`, if present.
    pub manifest: Option<String>,
    /// Whether the run has checksums (format 2 on): a run written before
    /// them (format 1) is read unverified.
    pub verified: bool,
}

/// Cells' episodes already in memory, by cell directory name: every
/// episode's score and length, row-major `samples × episodes`, as the cell's
/// `scores.csv` holds them ([`crate::runner::RunReport::episodes`]).
pub type KeptEpisodes = std::collections::BTreeMap<String, (Vec<f64>, Vec<u32>)>;

/// One cell's scores with the per-sample statistics derived from them.
#[derive(Debug, Clone)]
pub struct CellData {
    /// The cell's entry in `run.json`.
    pub meta: CellMeta,
    /// Episodes per sample `E`.
    pub episodes: usize,
    /// Episode scores, row-major `N × E` (sample, then episode).
    pub scores: Vec<f64>,
    /// Episode lengths in steps, same layout as `scores`.
    pub steps: Vec<u32>,
    /// Per-sample statistics ([`stats::per_sample`]).
    pub stats: Vec<SampleStats>,
    /// Per-sample rank by mean ([`stats::ranks`]).
    pub ranks: Vec<usize>,
    /// In a cell with `non_finite = "end"`: per sample, its episodes a value
    /// that was not finite ended (flagged in `scores.csv`); else `None`.
    pub non_finite: Option<Vec<u32>>,
}

impl CellData {
    /// Builds a cell from its scores and steps (row-major `N × episodes`),
    /// computing the per-sample statistics.
    ///
    /// # Panics
    /// If the lengths are not a positive multiple of `episodes` or differ.
    pub fn new(meta: CellMeta, episodes: usize, scores: Vec<f64>, steps: Vec<u32>) -> Self {
        assert_eq!(
            scores.len(),
            steps.len(),
            "scores and steps differ in length"
        );
        let stats = stats::per_sample(&scores, episodes);
        let ranks = stats::ranks(&stats.iter().map(|s| s.mean).collect::<Vec<_>>());
        CellData {
            meta,
            episodes,
            scores,
            steps,
            stats,
            ranks,
            non_finite: None,
        }
    }

    /// With the episodes' flags (row-major, as the scores: whether a value
    /// that was not finite ended each), counted per sample.
    pub fn with_non_finite(mut self, cut: &[bool]) -> Self {
        let counts = cut
            .chunks(self.episodes.max(1))
            .map(|c| c.iter().filter(|&&f| f).count() as u32)
            .collect();
        self.non_finite = Some(counts);
        self
    }

    /// Number of samples `N`.
    pub fn samples(&self) -> usize {
        self.stats.len()
    }

    /// The episode scores of sample `i`.
    pub fn sample_scores(&self, i: usize) -> &[f64] {
        &self.scores[i * self.episodes..(i + 1) * self.episodes]
    }

    /// The sample means `M`.
    pub fn means(&self) -> Vec<f64> {
        self.stats.iter().map(|s| s.mean).collect()
    }

    /// The sample variances `V`.
    pub fn variances(&self) -> Vec<f64> {
        self.stats.iter().map(|s| s.variance).collect()
    }

    /// The cell's summary ([`stats::summarize_cell`]).
    pub fn summary(&self) -> CellSummary {
        stats::summarize_cell(
            &self.meta,
            self.episodes,
            &self.scores,
            &self.steps,
            &self.stats,
        )
    }
}

/// The statistics of a whole run: contents of `stats.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunStats {
    /// The run's metadata (`run.json`).
    pub run: RunMeta,
    /// One summary per cell, in `run.json` order.
    pub cells: Vec<CellSummary>,
}

impl Run {
    /// Opens a run directory: reads and checks `run.json`, reads
    /// `manifest.toml` if present.
    pub fn open(dir: impl AsRef<Path>) -> Result<Run, RunReadError> {
        let dir = dir.as_ref().to_path_buf();
        let path = dir.join(RUN_JSON);
        let meta: RunMeta = load_json(&path).map_err(|e| match e {
            // (a file given for the directory: ENOTDIR)
            JsonFileError::Io(e)
                if e.kind() == std::io::ErrorKind::NotFound
                    || e.kind() == std::io::ErrorKind::NotADirectory =>
            {
                not_a_run_dir(&dir)
            }
            JsonFileError::Io(e) => io_err(&path)(e),
            JsonFileError::Json(source) => RunReadError::Json {
                path: path.clone(),
                source,
                how: crate::rundir::study::damaged_run_json(&dir),
            },
        })?;
        if !(1..=RUN_FORMAT).contains(&meta.format) {
            return Err(RunReadError::Format {
                path,
                found: meta.format,
                expected: RUN_FORMAT,
            });
        }
        if let Some(sh) = meta.shard {
            return Err(RunReadError::Mismatch {
                path,
                message: format!(
                    "this directory holds shard {}/{} of a study, not every network: \
                     combine the shards with `rwg merge` first",
                    sh.index, sh.count
                ),
            });
        }
        let mpath = dir.join(MANIFEST);
        let max = crate::limits::MAX_RESOLVED_MANIFEST_BYTES;
        let manifest = match crate::limits::read_own_text(&mpath, max) {
            Ok(m) => Some(m),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => None,
            Err(e) => return Err(io_err(&mpath)(e)),
        };
        check_cell_list(&dir, &meta, manifest.as_deref())?;
        Ok(Run {
            dir,
            verified: meta.format >= 2,
            meta,
            manifest,
        })
    }

    /// The directory of a cell.
    pub fn cell_dir(&self, cell: &CellMeta) -> PathBuf {
        cell_dir(&self.dir, &cell.id.dir)
    }

    /// Reads one cell's `scores.csv`, checks its shape against `run.json`,
    /// and checks `samples.csv` (when present) against the scores.
    pub fn load_cell(&self, cell: &CellMeta) -> Result<CellData, RunReadError> {
        let dir = self.cell_dir(cell);
        let episodes = cell.episodes as usize;
        let spath = dir.join(SCORES_CSV);
        if episodes == 0 || cell.samples == 0 {
            return Err(RunReadError::Mismatch {
                path: self.dir.join(RUN_JSON),
                message: format!("cell {} has no episodes to analyse", cell.id.dir),
            });
        }
        let read = self.read_scores_verified(cell, &dir)?;
        let (scores, steps) = (read.scores, read.steps);
        let expected = cell.samples as usize * episodes;
        if scores.len() != expected {
            return Err(RunReadError::Mismatch {
                path: spath,
                message: format!(
                    "{} episode rows, but run.json says {} samples × {} episodes = {expected}",
                    scores.len(),
                    cell.samples,
                    episodes
                ),
            });
        }
        // Rows an episode cannot have are refused whatever the checksums say.
        let limit = cell.max_episode_steps.max(1);
        let cut = |i: usize| read.cut.get(i).copied().unwrap_or(false);
        let bad = scores
            .iter()
            .zip(&steps)
            .enumerate()
            .find_map(|(i, (&s, &st))| {
                crate::rundir::finalize::check_episode(s, u64::from(st), limit, cut(i))
                    .err()
                    .map(|m| (i, m))
            });
        if let Some((i, message)) = bad {
            return Err(RunReadError::Csv {
                path: spath,
                line: i + 2,
                message,
            });
        }
        let mut data = CellData::new(cell.clone(), episodes, scores, steps);
        if let Some(want) = cell.non_finite_episodes {
            let got = read.cut.iter().filter(|&&c| c).count() as u64;
            if got != want {
                return Err(RunReadError::Mismatch {
                    path: spath,
                    message: format!("{got} episodes flagged non_finite, but run.json says {want}"),
                });
            }
            data = data.with_non_finite(&read.cut);
        }
        let path = dir.join(SAMPLES_CSV);
        if self.verified || path.exists() {
            self.check_samples_verified(&dir, &data)?;
        }
        Ok(data)
    }

    /// Loads every cell in turn and summarises it.
    pub fn summarize(&self) -> Result<RunStats, RunReadError> {
        let cells = self
            .meta
            .cells
            .iter()
            .map(|c| self.load_cell(c).map(|d| d.summary()))
            .collect::<Result<_, _>>()?;
        Ok(RunStats {
            run: self.meta.clone(),
            cells,
        })
    }
}

mod cell_csv;
mod cell_list;
mod cell_writers;
mod not_a_run;
mod read_error;
mod spread;
mod stats_files;
pub mod synthetic;
mod unfinished;
mod verified;

use cell_csv::check_samples_csv;
pub use cell_csv::{
    read_cell_scores, read_sample_scores, read_samples_csv, read_scores_csv, SampleRow, ScoreRows,
};
pub use cell_list::check_cell_list;
pub use cell_writers::{
    samples_csv, scores_csv, write_cell_files, write_run_json, write_samples_csv,
};
use not_a_run::not_a_run_dir;
pub use not_a_run::{require_run_dir, run_above};
pub use read_error::RunReadError;
use unfinished::study_cells;
pub use unfinished::Unfinished;

pub use stats_files::{
    stats_csv, stats_csv_header, stats_csv_row, write_stats, NON_FINITE_CSV_COLUMN,
};

pub use spread::{spread_csv_fields, CellSpreadError, SummarizeError, SPREAD_CSV_COLUMNS};

#[cfg(test)]
mod tests;
