//! # rwg-core
//!
//! Random Weight Guessing itself: the tanh [`policy`] networks (with the
//! numpy-exact [`tanh`]), the [`sampler`] that draws their weights and runs
//! them on environments, and, until they move to the study runner, the
//! manifest, run directory and statistics. The environment contract it runs
//! against is `rwg-env`.

pub mod export;
pub mod manifest;
pub mod policy;
pub mod run_data;
pub mod run_meta;
pub mod rundir;
pub mod sampler;
pub mod stats;
pub mod tanh;
