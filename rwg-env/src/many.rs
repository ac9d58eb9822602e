//! Many instances of one environment stepped in lockstep by one call
//! ([`ManyEnv`]): the contract shared by plugins' batched calls (ABI 1.1
//! `reset_many` / `step_many`) and the built-in envs' lockstep versions
//! (`rwg-envs`' `lockstep`). The sampler loop that drives a `ManyEnv` is
//! `rwg_core::many`, which re-exports this trait.

use crate::env::{EnvError, EnvSpec};

/// Many instances of one environment (lanes), reset and stepped together.
///
/// Buffers are lane-major: lane `i`'s observation is
/// `obs[i * obs_dim..(i + 1) * obs_dim]`, its action
/// `actions[i * action_len..]` with `action_len` 1 for a Discrete space (the
/// action as an integral double) and the dimension of a Box. Only lanes with
/// `mask[i] == 1` take part; the others' slots are left alone. A lane that
/// fails goes to `on_fail` (the others are done all the same); a failed
/// lane is not used again.
///
/// An implementation with a fixed number of lanes `N` is best written over
/// arrays: convert the per-lane slices once (`<&mut [f64; N]>::try_from`)
/// and index those. Behind a plugin's vector env the buffers are the host's,
/// of a length known at run time only, and a loop indexing the slices pays
/// a bounds check per lane (`rwg-envs`' lockstep envs do this in
/// `lockstep::lane_arrays`).
pub trait ManyEnv {
    /// The environment's description (with its time limit).
    fn spec(&self) -> &EnvSpec;

    /// Number of lanes.
    fn lanes(&self) -> usize;

    /// Resets each masked lane `i` with `seeds[i]` (Gymnasium's
    /// `reset(seed=...)`), writing its first observation.
    fn reset_many(
        &mut self,
        mask: &[u8],
        seeds: &[u64],
        obs: &mut [f64],
        on_fail: &mut dyn FnMut(usize, EnvError),
    );

    /// Steps each masked lane with its action: observation, reward and flags
    /// (0 or 1; `truncated` includes the time limit) into lane `i`'s slots.
    #[expect(
        clippy::too_many_arguments,
        reason = "one argument per buffer, as the C ABI's batched call has them"
    )]
    fn step_many(
        &mut self,
        mask: &[u8],
        actions: &[f64],
        obs: &mut [f64],
        rewards: &mut [f64],
        terminated: &mut [u8],
        truncated: &mut [u8],
        on_fail: &mut dyn FnMut(usize, EnvError),
    );
}
