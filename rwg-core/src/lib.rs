//! # rwg-core
//!
//! Random Weight Guessing itself: the tanh [`policy`] networks (with the
//! numpy-exact [`tanh`]) and the [`sampler`] that draws their weights from
//! seeds and runs them on environments, in blocks of networks and lanes of
//! episodes side by side; [`remote`] and [`many`] are the same loop for
//! environments that step all lanes in one call (a remote Gymnasium worker,
//! a plugin's ABI 1.1 batched calls). The environment contract it runs against is
//! `rwg-env`; the study runner around it (manifest, run directory,
//! statistics) is `rwg-study`.
//!
//! # Example
//!
//! Sampling a tiny cell: 8 networks with no hidden layer, 3 episodes each,
//! on a one-dimensional walk (action 1 steps right, action 0 left; done
//! at ±3 or after 10 steps). The blocks come back in order, and each
//! network's returns are those of running its episodes one by one:
//!
//! ```
//! use rwg_core::policy::Architecture;
//! use rwg_core::sampler::{run_cell, CellPlan, PolicyKind, SampleError, WeightDist, Worker};
//! use rwg_env::env::discrete_action;
//! use rwg_env::{Action, BoxSpace, EnvError, EnvSpec, Environment, Space, Step};
//!
//! struct Walk {
//!     spec: EnvSpec,
//!     x: f64,
//!     t: u32,
//! }
//!
//! impl Environment for Walk {
//!     fn spec(&self) -> &EnvSpec {
//!         &self.spec
//!     }
//!     fn reset(&mut self, seed: u64, obs: &mut [f64]) -> Result<(), EnvError> {
//!         (self.x, self.t) = ((seed % 5) as f64 - 2.0, 0);
//!         obs[0] = self.x;
//!         Ok(())
//!     }
//!     fn step(&mut self, action: Action<'_>, obs: &mut [f64]) -> Result<Step, EnvError> {
//!         self.x += if discrete_action(action, 2)? == 1 { 1.0 } else { -1.0 };
//!         self.t += 1;
//!         obs[0] = self.x;
//!         let terminated = self.x.abs() >= 3.0;
//!         Ok(Step { reward: self.x, terminated, truncated: self.t == 10 })
//!     }
//! }
//!
//! let walk = || Walk {
//!     spec: EnvSpec {
//!         id: "Walk-v0".into(),
//!         observation_space: Space::Box(BoxSpace::symmetric(&[3.0])),
//!         action_space: Space::Discrete { n: 2 },
//!         max_episode_steps: Some(10),
//!         reward_threshold: None,
//!     },
//!     x: 0.0,
//!     t: 0,
//! };
//! let plan = CellPlan {
//!     seed: 0,
//!     env_id: "Walk-v0".into(),
//!     arch: Architecture { hidden: vec![], bias: false },
//!     episodes: 3,
//!     dist: WeightDist::Normal { std: 1.0 },
//!     policy: PolicyKind::Network,
//!     non_finite: Default::default(),
//! };
//! let mut blocks = vec![];
//! run_cell(&plan, 0..8, 4, 2, walk, |block| {
//!     blocks.push(block);
//!     Ok::<(), SampleError>(())
//! })?;
//! assert_eq!(blocks.iter().map(|b| b.samples.clone()).collect::<Vec<_>>(), [0..4, 4..8]);
//! let mut one_by_one = Worker::new(walk(), &plan);
//! for (sample, got) in blocks.iter().flat_map(|b| b.episodes.chunks(3)).enumerate() {
//!     let mut want = got.to_vec();
//!     one_by_one.run_sample(&plan, sample as u64, &mut want)?;
//!     assert_eq!(got, &want[..]);
//!     assert!(got.iter().all(|e| (1..=10).contains(&e.steps)));
//! }
//! # Ok::<(), SampleError>(())
//! ```
//!
//! # Modules
//!
//! - [`policy`]: the tanh networks over SIMD lanes; `actions_into` writes every
//!   stepping lane's action in one pass, as a `ManyEnv` takes them.
//! - [`tanh`]: rwg's own float64 `tanh`, within 2 ulp of glibc's, the same bits
//!   on every x86-64 machine.
//! - `plan` (re-exported by [`sampler`]): a cell's `CellPlan`, the weights and
//!   reset seeds it derives, `EpisodeResult`, `SampleError`.
//! - `block`: a block's weights, its episodes in order with their reset
//!   seeds, the first failure in episode order.
//! - `deal`: what the three loops share: dealing those episodes to lanes
//!   (weights, reset seed), their returns, failures (a network output not
//!   finite included) and the cut-off after the first one.
//! - [`sampler`]: `run_blocks` over lanes of episodes, one env instance per
//!   lane, and `blocks`, cutting a cell's samples into blocks of 32.
//! - [`remote`]: the same over a `RemoteEnv` with exchanges in flight (worker
//!   processes); [`many`]: over a `ManyEnv` stepping all lanes in one call.

mod block;
mod deal;
pub mod many;
mod plan;
pub mod policy;
pub mod remote;
pub mod sampler;
pub mod tanh;
#[cfg(test)]
mod test_envs;
