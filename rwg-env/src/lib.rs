//! # rwg-env
//!
//! What an environment author needs, and nothing else: the Gym-like
//! [`Environment`] trait and its [`Space`]s, the [`TimeLimit`] wrapper that
//! applies Gymnasium's truncation rule, float helpers that reproduce numpy's
//! arithmetic and formatting ([`float`]), numpy-exact [`seeding`] (plus gym
//! 0.17.2's, built on [`sha512`] and [`mt19937`]), and the plugin C ABI v1
//! ([`plugin`]: the `#[repr(C)]` types of `include/rwg_plugin.h` and the
//! [`export_plugin!`] macro that exports Rust environments through it).
//!
//! The host side of the ABI (loading and checking plugins) lives in
//! `rwg-plugin-host`; the sampler and the study runner build on this crate.

pub mod env;
pub mod float;
pub mod lanes_math;
pub mod many;
pub mod mt19937;
pub mod plugin;
pub mod seeding;
pub mod sha512;
pub mod space;
pub mod suggest;
pub mod time_limit;

pub use env::{Action, ActionDtype, EnvError, EnvSpec, Environment, Step};
pub use space::{BoxSpace, Space};
pub use time_limit::TimeLimit;
pub mod vars;
