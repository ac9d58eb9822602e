//! The run directory: the one module that knows its layout, file names,
//! headers, and how each file is written and read. The runner, `merge`, the
//! statistics, the report and `rwg replay` all go through it.
//!
//! ```text
//! RUN/manifest.toml            the resolved study
//! RUN/run.json                 run metadata (meta::RunMeta)
//! RUN/cells/CELL/blocks/...    one committed block of networks each (blocks)
//! RUN/cells/CELL/scores.csv    sample,episode,score,steps   (export, data)
//!                              (,non_finite: cells with non_finite = "end")
//! RUN/cells/CELL/samples.csv   sample,mean,variance,std,min,max,rank (,non_finite)
//! RUN/cells/CELL/cell.json     the cell's metadata (meta::CellMeta)
//! RUN/cells/CELL/env.json      the env as the cell started (env_record)
//! RUN/cells/CELL/SHA256SUMS    checksums of the four files above, written last (checksum)
//! RUN/cells/CELL/blocks/SHA256SUMS  checksums of the committed blocks (checksum)
//! RUN/stats.json, stats.csv    the run's statistics (data)
//! RUN/rwg.lock                 the writers' lock (lock)
//! RUN/last-error.txt           the last failed cell's whole message (the `rwg` binary)
//! ```
//!
//! - [`names`]: the cell directory names (injective, portable).
//! - [`lock`]: the exclusive lock every writer takes.
//! - [`checksum`]: the `SHA256SUMS` index of committed files.
//! - [`clear`]: what `--force-new` removes (what rwg wrote, nothing else).
//! - [`verify`]: checking a whole run against it (`rwg verify`).
//! - [`meta`]: `run.json` / `cell.json` contents and cell directory names.
//! - [`env_record`]: a cell's `env.json`, checked by resumes and merges.
//! - [`blocks`]: block files and their index (what a resume skips);
//!   [`block_check`]: the check of a cell's committed blocks (`verify`, `merge`).
//! - [`finalize`]: a cell's blocks turned into its final files.
//! - [`error`]: [`RunDirError`](error::RunDirError), why a cell's files could not be used.
//! - [`export`]: the CSV writers and atomic file replacement.
//! - [`rows`]: the fast path for rwg's own plain numeric CSV rows.
//! - [`data`]: reading a finished run for analysis, writing its statistics;
//!   [`derived`]: whether the statistics files are this run's.
//! - [`status`]: how far a run or a shard has got (read-only, safe while it runs).
//! - [`study`]: the study a run directory holds, and edits of its manifest.
//! - [`outputs`]: where a command may write (no path a user names lands on
//!   a run's own files).

pub mod block_check;
pub mod blocks;
pub mod checksum;
pub mod clear;
pub mod data;
pub mod derived;
pub mod env_record;
pub mod error;
pub mod export;
pub mod finalize;
pub mod lock;
pub mod meta;
pub mod names;
pub mod outputs;
pub mod rows;
pub mod status;
pub mod study;
pub mod verify;

use std::path::{Path, PathBuf};

/// The resolved manifest of the study.
pub const MANIFEST: &str = "manifest.toml";
/// Run metadata ([`meta::RunMeta`]).
pub const RUN_JSON: &str = "run.json";
/// The folder of the cells' folders.
pub const CELLS: &str = "cells";
/// A cell's committed blocks (removed when the cell is finalised).
pub const BLOCKS: &str = "blocks";
/// A cell's episode scores.
pub const SCORES_CSV: &str = "scores.csv";
/// A cell's per-sample statistics.
pub const SAMPLES_CSV: &str = "samples.csv";
/// A finished cell's metadata ([`meta::CellMeta`]).
pub const CELL_JSON: &str = "cell.json";
/// The run's statistics, JSON ([`data::RunStats`]).
pub const STATS_JSON: &str = "stats.json";
/// The run's statistics, CSV (one row per cell).
pub const STATS_CSV: &str = "stats.csv";
/// The run's figures (written by `rwg-analysis`).
pub const FIGURES: &str = "figures";
/// The run's HTML report (written by `rwg-analysis`).
pub const REPORT_HTML: &str = "report.html";
/// The whole message of the last failed cell, its traceback included
/// (written by the `rwg` binary, which prints one line naming it).
pub const LAST_ERROR: &str = "last-error.txt";
/// Header of a cell's `scores.csv` (and of its block files).
pub const SCORES_HEADER: &str = "sample,episode,score,steps";
/// Header of a cell's `samples.csv`.
pub const SAMPLES_HEADER: &str = "sample,mean,variance,std,min,max,rank";
/// Header of the `scores.csv` (and block files) of a cell with
/// `non_finite = "end"`: 1 in `non_finite` marks an episode a value that
/// was not finite ended.
pub const SCORES_HEADER_FLAGGED: &str = "sample,episode,score,steps,non_finite";
/// Header of the `samples.csv` of a cell with `non_finite = "end"`:
/// `non_finite` counts the network's episodes so ended.
pub const SAMPLES_HEADER_FLAGGED: &str = "sample,mean,variance,std,min,max,rank,non_finite";

/// The folder of cell `cell` (its directory name) in run directory `run`.
pub fn cell_dir(run: &Path, cell: &str) -> PathBuf {
    run.join(CELLS).join(cell)
}
