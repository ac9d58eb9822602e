//! One module per `rwg` subcommand.

pub mod compare;
pub mod envs;
pub mod merge;
pub mod replay;
pub mod plot;
pub mod report;
pub mod rollout;
pub mod run;
pub mod top;
pub mod stats;
