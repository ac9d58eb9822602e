//! # rwg-study
//!
//! The RWG study runner as a library. A TOML [`manifest`] expands into
//! [`cells`] (environment × architecture × bias), each cell's networks are
//! split into blocks that the [`runner`] hands to `rwg_core`'s sampler and
//! commits one by one into a run directory ([`rundir`]), so a run resumes
//! where it stopped and shards ([`merge`]) combine into the same bytes.
//! [`stats`] summarises a finished run (`stats.json`, `stats.csv`, and the
//! runner's console summary). Environments come from an [`env_source`]:
//! built in (`rwg-envs`), a plugin (`rwg-plugin-host`), a Gymnasium env
//! run by Python worker processes (`rwg-gym`, see [`gym_source`]), or a JAX
//! env run by Python workers in compiled calls (`rwg-jax`, see
//! [`jax_source`]); a plugin
//! env may run isolated in worker processes of its own ([`isolate`]).
//!
//! # Example
//!
//! Running a study from Rust, then reading its run directory back (what
//! `rwg run` and `rwg stats` do):
//!
//! ```
//! use rwg_study::manifest::Manifest;
//! use rwg_study::rundir::data::Run;
//! use rwg_study::runner::{run_study, Progress, RunOptions, RunOutcome};
//! use std::sync::atomic::AtomicBool;
//!
//! /// Reports nothing.
//! struct Quiet;
//! impl Progress for Quiet {
//!     fn start(&mut self, _networks: u64) {}
//!     fn cell(&mut self, _label: &str) {}
//!     fn block(&mut self, _label: &str, _networks: u64, _env_steps: u64) {}
//!     fn finish(&mut self, _ok: bool) {}
//! }
//!
//! let text = r#"
//! seed = 0
//! samples = 64
//! episodes = 2
//! bias = [false]
//! [weights]
//! distribution = "normal"
//! scale = 1.0
//! [[architectures]]
//! name = "0HL"
//! hidden = []
//! [[envs]]
//! id = "CartPole-v1"
//! "#;
//! let mut m = Manifest::parse(text, "study.toml", std::path::Path::new("."))?;
//! let dir = std::env::temp_dir().join(format!("rwg-study-doc-{}", std::process::id()));
//! let stop = AtomicBool::new(false);
//! let opts = RunOptions {
//!     out: dir.clone(),
//!     shard: None,
//!     force_new: true,
//!     stop: &stop,
//!     keep_episodes: false,
//!     commit_linger: std::time::Duration::ZERO,
//!     manifest_file: None,
//! };
//! let outcome = run_study(&mut m, &opts, &mut Quiet)?;
//! assert!(matches!(outcome, RunOutcome::Finished(_)));
//! drop(outcome); // releases the run directory's lock
//!
//! let stats = Run::open(&dir)?.summarize()?;
//! let cell = &stats.cells[0];
//! assert_eq!((cell.id.env.as_str(), cell.samples), ("CartPole-v1", 64));
//! assert!(cell.best_mean >= cell.median_mean && cell.median_mean >= cell.worst_mean);
//! std::fs::remove_dir_all(&dir)?;
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! # Modules
//!
//! - [`manifest`] (with [`manifest_text`]: bytes to text, located messages;
//!   [`limits`]: every maximum), [`cells`]: manifest to cells, `CellId`.
//! - [`env_source`]: built-in, plugin, Gymnasium ([`gym_source`]) or JAX
//!   ([`jax_source`]); [`isolate`]:
//!   a plugin env in `rwg __plugin-worker` processes, both sides;
//!   [`plugin_batch`]: an in-process plugin's lanes through its vector env or
//!   batched calls as a `ManyEnv`; [`plugin_path`]: what `plugin = "..."` must name.
//! - [`runner`]: blocks to run directory, resume, shards (`runner/setup`:
//!   the directory and the blocks owed; `runner/cell_loop`: cell by cell);
//!   [`fault_context`] names
//!   the plugin call in flight; [`committer`]: block commits on I/O threads,
//!   gathered up to 2 s; `recorder`: a cell's end off the sampling path;
//!   [`timing`]: `rwg run --timing`.
//! - [`merge`]: shards into one run.
//! - [`rundir`]: the run directory's one owner: names, cell directory names,
//!   the writer lock, SHA-256 index and `rwg verify`, block files, CSV writers,
//!   `run.json`/`cell.json`, readers (`data`), progress (`status`).
//! - [`shell`]: quoting for the `rwg ...` commands rwg prints.
//! - [`stats`]: every statistic, numpy-exact; `stats/spread`: `--at-n`.

pub mod cells;
pub mod committer;
pub mod env_source;
pub mod error;
pub mod fault_context;
pub mod gym_source;
pub mod isolate;
pub mod jax_source;
pub mod limits;
pub mod manifest;
pub mod manifest_text;
pub mod merge;
pub mod plugin_batch;
pub mod plugin_path;
mod recorder;
pub mod rundir;
pub mod runner;
pub mod shell;
pub mod stats;
pub mod timing;

pub use error::StudyError;
