//! The run directory: the one module that knows its layout, file names,
//! headers, and how each file is written and read. The runner, `merge`, the
//! statistics, the report and `rwg replay` all go through it.
//!
//! ```text
//! RUN/manifest.toml            the resolved study
//! RUN/run.json                 run metadata (meta::RunMeta)
//! RUN/cells/CELL/blocks/...    one committed block of networks each (blocks)
//! RUN/cells/CELL/scores.csv    sample,episode,score,steps   (export, data)
//! RUN/cells/CELL/samples.csv   sample,mean,variance,std,min,max,rank
//! RUN/cells/CELL/cell.json     the cell's metadata (meta::CellMeta)
//! RUN/stats.json, stats.csv    the run's statistics (data)
//! ```
//!
//! - [`meta`]: `run.json` / `cell.json` contents and cell directory names.
//! - [`blocks`]: block files, resume, and a cell's finalisation.
//! - [`export`]: the CSV writers and atomic file replacement.
//! - [`data`]: reading a finished run for analysis, writing its statistics.

pub mod blocks;
pub mod data;
pub mod export;
pub mod meta;
