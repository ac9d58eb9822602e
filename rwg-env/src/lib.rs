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
//! # Example
//!
//! An environment author implements [`Environment`]; [`TimeLimit`] adds
//! Gymnasium's truncation at the spec's step limit. A counter that action 1
//! raises, done at 3:
//!
//! ```
//! use rwg_env::env::discrete_action;
//! use rwg_env::{Action, BoxSpace, EnvError, EnvSpec, Environment, Space, Step, TimeLimit};
//!
//! struct Counter {
//!     spec: EnvSpec,
//!     count: f64,
//! }
//!
//! impl Environment for Counter {
//!     fn spec(&self) -> &EnvSpec {
//!         &self.spec
//!     }
//!     fn reset(&mut self, _seed: u64, obs: &mut [f64]) -> Result<(), EnvError> {
//!         self.count = 0.0;
//!         obs[0] = self.count;
//!         Ok(())
//!     }
//!     fn step(&mut self, action: Action<'_>, obs: &mut [f64]) -> Result<Step, EnvError> {
//!         let a = discrete_action(action, 2)? as f64;
//!         self.count += a;
//!         obs[0] = self.count;
//!         let terminated = self.count >= 3.0;
//!         Ok(Step { reward: a, terminated, truncated: false })
//!     }
//! }
//!
//! let spec = EnvSpec {
//!     id: "Counter-v0".into(),
//!     observation_space: Space::Box(BoxSpace::symmetric(&[10.0])),
//!     action_space: Space::Discrete { n: 2 },
//!     max_episode_steps: Some(5),
//!     reward_threshold: None,
//! };
//! let mut env = TimeLimit::new(Counter { spec, count: 0.0 }, Some(5));
//! let mut obs = [0.0];
//! env.reset(0, &mut obs)?;
//! // Action 0 never reaches 3: the time limit ends the episode.
//! let mut steps = 0;
//! loop {
//!     let s = env.step(Action::Discrete(0), &mut obs)?;
//!     steps += 1;
//!     if s.terminated || s.truncated {
//!         assert!(s.truncated && !s.terminated);
//!         break;
//!     }
//! }
//! assert_eq!(steps, 5);
//! // Action 1 three times: the env itself ends it.
//! env.reset(1, &mut obs)?;
//! let ends: Vec<bool> = (0..3)
//!     .map(|_| env.step(Action::Discrete(1), &mut obs).map(|s| s.terminated))
//!     .collect::<Result<_, _>>()?;
//! assert_eq!(ends, [false, false, true]);
//! assert!(env.step(Action::Discrete(2), &mut obs).is_err(), "2 is outside Discrete(2)");
//! # Ok::<(), EnvError>(())
//! ```
//!
//! Exported from a `cdylib` with [`export_plugin!`], the same type becomes a
//! plugin `rwg run` loads (`examples/plugin-rust`).
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
//!
//! # Modules
//!
//! - [`mod@env`], [`space`], [`time_limit`]: the `Environment` trait, its spaces, and
//!   Gymnasium's truncation rule as a wrapper.
//! - [`float`]: numpy-exact float helpers (its `sin_cos` is Python's
//!   `math.sin`/`math.cos`, never glibc's `sincos`; `pow2` is glibc's `pow(x, 2)`).
//! - [`lanes_math`]: glibc-exact `sin`/`cos` and `pow(x, 2)` over lanes of
//!   arguments for the envs stepped in lockstep: four lanes with AVX2+FMA or
//!   eight with AVX-512 (the vector `sin`/`cos` from `rwg-glibc-sincos` behind
//!   the `glibc-sincos` feature, `pow` in `lanes_math/pow_fma.rs` and
//!   `pow_avx512.rs`), each used only after a
//!   one-time self-check against the process's libm, else one libm call per
//!   element.
//! - [`many`]: the `ManyEnv` contract, many instances reset and stepped by one
//!   call over structure-of-arrays buffers (plugins' batched calls and vector
//!   envs, the lockstep built-in envs).
//! - [`seeding`], [`mt19937`], [`sha512`]: numpy's `SeedSequence`/`PCG64`, and gym
//!   0.17's seeding for Pendulum-v0.
//! - [`plugin`]: the C ABI's `#[repr(C)]` mirrors (`plugin/abi.rs`, checked
//!   against `include/rwg_plugin.h`) and the export side (`PluginBuilder`,
//!   [`export_plugin!`], the `extern "C"` trampolines, the batched calls and the
//!   vector env, instantiated per concrete env type so its `step` inlines).
//! - [`simd`]: the SIMD level every vector path runs (`RWG_SIMD`: `avx2` by
//!   default where the CPU has it, `scalar`, or `avx512` when asked for; the
//!   bits never differ).
//! - `vars`: parsing of `RWG_*` environment variables with messages naming them;
//!   [`suggest`]: did-you-mean hints; [`text`]: text from outside rwg made safe
//!   to print (control characters escaped).

pub mod env;
pub mod float;
pub mod lanes_math;
pub mod many;
pub mod mt19937;
pub mod plugin;
pub mod seeding;
pub mod sha512;
pub mod simd;
pub mod space;
pub mod suggest;
pub mod text;
pub mod time_limit;
pub mod vars;

pub use env::{Action, ActionDtype, EnvError, EnvSpec, Environment, Step};
pub use space::{BoxSpace, Space};
pub use time_limit::TimeLimit;
