//! # rwg-study
//!
//! The RWG study runner as a library. A TOML [`manifest`] expands into
//! [`cells`] (environment × architecture × bias), each cell's networks are
//! split into blocks that the [`runner`] hands to `rwg_core`'s sampler and
//! commits one by one into a run directory ([`rundir`]), so a run resumes
//! where it stopped and shards ([`merge`]) combine into the same bytes.
//! [`stats`] summarises a finished run (`stats.json`, `stats.csv`, and the
//! runner's console summary). Environments come from an [`env_source`]:
//! built in (`rwg-envs`), a plugin (`rwg-plugin-host`), or a Gymnasium env
//! run by Python worker processes (`rwg-gym`, see [`gym_source`]); a plugin
//! env may run isolated in worker processes of its own ([`isolate`]).

pub mod cells;
pub mod committer;
pub mod env_source;
pub mod error;
pub mod fault_context;
pub mod gym_source;
pub mod isolate;
pub mod limits;
pub mod manifest;
pub mod manifest_text;
pub mod merge;
pub mod plugin_batch;
mod recorder;
pub mod rundir;
pub mod runner;
pub mod stats;
pub mod timing;

pub use error::StudyError;
