//! One module per `rwg` subcommand.

pub mod bench;
pub mod bench_gym;
pub mod bench_peers;
pub mod check;
pub mod compare;
pub mod envs;
pub mod merge;
pub mod plot;
pub mod replay;
pub mod report;
pub mod rollout;
pub mod run;
pub mod slurm;
pub mod stats;
pub mod status;
pub mod top;
