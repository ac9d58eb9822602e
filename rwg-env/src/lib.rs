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
//!
//! # Features
//!
//! Both off by default.
//!
//! - `serde`: `Serialize` for the spec types (`EnvSpec`, `Space`, ...).
//! - `glibc-sincos`: the vector `sin`/`cos` of [`lanes_math`] (a port of
//!   glibc's, in the LGPL-2.1-or-later crate `rwg-glibc-sincos`). Without it
//!   this crate is MIT OR Apache-2.0 throughout and [`lanes_math`] calls libm
//!   once per `sin`/`cos` element: the same bits, more slowly. A plugin
//!   should leave it off unless it steps many lanes through `lanes_math` and
//!   accepts the LGPL for its library.

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
