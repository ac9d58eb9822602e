//! # rwg-core
//!
//! The pieces every part of rwg shares: the Gym-like [`Environment`] trait and
//! its [`Space`]s, the [`TimeLimit`] wrapper that applies Gymnasium's
//! truncation rule, and numpy-exact [`seeding`] (plus gym 0.17.2's, built on
//! [`sha512`] and [`mt19937`]).

pub mod env;
pub mod export;
pub mod float;
pub mod manifest;
pub mod mt19937;
pub mod plugin;
pub mod policy;
pub mod run_data;
pub mod run_meta;
pub mod rundir;
pub mod sampler;
pub mod seeding;
pub mod sha512;
pub mod space;
pub mod stats;
pub mod suggest;
pub mod tanh;
pub mod time_limit;

pub use env::{Action, ActionDtype, EnvError, EnvSpec, Environment, Step};
pub use space::{BoxSpace, Space};
pub use time_limit::TimeLimit;
