//! One module per `rwg` subcommand.

pub mod envs;
pub mod rollout;
pub mod run;
