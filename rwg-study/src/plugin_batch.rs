//! Plugin envs with ABI 1.1's batched calls in the sampler: [`PluginLanes`]
//! is a [`ManyEnv`] over a [`PluginBatch`] of [`LANES`] instances, so a
//! worker's lanes reset and step through one `reset_many` / `step_many` call
//! each ([`rwg_core::many`]), and [`run_blocks`] runs a cell's blocks on it.
//!
//! The episodes are those of the single calls bit for bit (the ABI promises
//! it; `rwg check` tests it), so `scores.csv` and `samples.csv` do not
//! depend on the path. They are used only when `RWG_PLUGIN_BATCH=1` is in
//! the environment ([`use_batched_calls`]): measured, they save ~100 CPU
//! instructions per env step over the single calls but still cost 1.1-1.5x
//! the built-in on the cheap classic envs (docs/performance.md), and a fault
//! inside one cannot be traced to its network and step, which the single
//! calls' reports name.

use crate::env_source::PluginSource;
use crate::fault_context::{recorded_batch, recorded_create, Phase};
use rwg_core::many::{run_blocks_many, ManyEnv};
use rwg_core::sampler::{BlockResult, CellPlan, SampleError, LANES};
use rwg_env::{EnvError, EnvSpec};
use rwg_plugin_host::PluginBatch;
use std::ops::Range;

/// The environment variable that turns the batched calls on (`1`).
pub const BATCH_VAR: &str = "RWG_PLUGIN_BATCH";

/// Whether `rwg run` steps `source` through the batched calls: the plugin
/// has them and `RWG_PLUGIN_BATCH` is `1`.
pub fn use_batched_calls(source: &PluginSource) -> bool {
    source.ty.has_batched_calls() && std::env::var(BATCH_VAR).as_deref() == Ok("1")
}

/// [`LANES`] instances of a plugin env, their calls recorded for fault
/// reports ([`crate::fault_context`]).
pub struct PluginLanes {
    batch: PluginBatch,
}

impl PluginLanes {
    /// [`LANES`] instances of `source`'s env, with its config and time limit.
    pub fn new(source: &PluginSource) -> Result<Self, EnvError> {
        let batch = recorded_create(|| {
            source
                .ty
                .make_batch(&source.config, LANES, source.max_episode_steps)
        })?;
        Ok(PluginLanes { batch })
    }
}

impl ManyEnv for PluginLanes {
    fn spec(&self) -> &EnvSpec {
        self.batch.spec()
    }

    fn lanes(&self) -> usize {
        self.batch.len()
    }

    fn reset_many(
        &mut self,
        mask: &[u8],
        seeds: &[u64],
        obs: &mut [f64],
        on_fail: &mut dyn FnMut(usize, EnvError),
    ) {
        let batch = &mut self.batch;
        recorded_batch(Phase::ResetMany, mask.len(), || {
            batch.reset_many(mask, seeds, obs, |f| on_fail(f.lane, f.error))
        })
    }

    fn step_many(
        &mut self,
        mask: &[u8],
        actions: &[f64],
        obs: &mut [f64],
        rewards: &mut [f64],
        terminated: &mut [u8],
        truncated: &mut [u8],
        on_fail: &mut dyn FnMut(usize, EnvError),
    ) {
        let batch = &mut self.batch;
        recorded_batch(Phase::StepMany, mask.len(), || {
            batch.step_many(mask, actions, obs, rewards, terminated, truncated, |f| {
                on_fail(f.lane, f.error)
            })
        })
    }
}

/// Runs `blocks` of a cell on `source`'s env through the batched calls, as
/// [`rwg_core::sampler::run_blocks`] runs them through the single ones (same
/// results, same order, same first error).
pub fn run_blocks<X>(
    source: &PluginSource,
    plan: &CellPlan,
    blocks: &[Range<u64>],
    wave: usize,
    on_block: impl FnMut(BlockResult) -> Result<(), X>,
) -> Result<(), X>
where
    X: From<SampleError> + Send,
{
    run_blocks_many(plan, blocks, wave, || PluginLanes::new(source), on_block)
}
