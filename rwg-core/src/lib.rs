//! # rwg-core
//!
//! Random Weight Guessing itself: the tanh [`policy`] networks (with the
//! numpy-exact [`tanh`]) and the [`sampler`] that draws their weights from
//! seeds and runs them on environments, in blocks of networks and lanes of
//! episodes side by side; [`batch`] and [`many`] are the same loop for
//! environments that step all lanes in one call (a remote Gymnasium worker,
//! a plugin's ABI 1.1 batched calls). The environment contract it runs against is
//! `rwg-env`; the study runner around it (manifest, run directory,
//! statistics) is `rwg-study`.
//!
//! # Modules
//!
//! - [`policy`]: the tanh networks over SIMD lanes; `actions_into` writes every
//!   stepping lane's action in one pass, as a `ManyEnv` takes them.
//! - [`tanh`]: rwg's own float64 `tanh`, within 2 ulp of glibc's, the same bits
//!   on every x86-64 machine.
//! - `plan` (re-exported by [`sampler`]): a cell's `CellPlan`, the weights and
//!   reset seeds it derives, `EpisodeResult`, `SampleError`.
//! - `block`: what the three loops share: a block's weights, its episodes handed
//!   out in order with their reset seeds, the first failure in episode order.
//! - [`sampler`]: `run_blocks` over lanes of episodes, one env instance per
//!   lane, and `blocks`, cutting a cell's samples into blocks of 32.
//! - [`batch`]: the same over a `BatchEnv` with exchanges in flight (worker
//!   processes); [`many`]: over a `ManyEnv` stepping all lanes in one call.

pub mod batch;
mod block;
pub mod many;
mod plan;
pub mod policy;
pub mod sampler;
pub mod tanh;
#[cfg(test)]
mod test_envs;
