//! Plugin envs with ABI 1.1's batched calls in the sampler: [`PluginLanes`]
//! is a [`ManyEnv`] over a [`PluginBatch`] of [`LANES`] instances, so a
//! worker's lanes reset and step through one `reset_many` / `step_many` call
//! each ([`rwg_core::many`]), and [`run_blocks`] runs a cell's blocks on it.
//!
//! The episodes are those of the single calls bit for bit (the ABI promises
//! it; `rwg check` tests it), so `scores.csv` and `samples.csv` do not
//! depend on the path. `rwg run` uses them for every in-process plugin env
//! that has them unless `RWG_PLUGIN_BATCH=0` is in the environment
//! ([`use_batched_calls`]): measured, they cost fewer CPU instructions per
//! env step than the single calls on every classic env and architecture
//! (docs/performance.md). What they give up: a crash inside one is reported
//! as the batched call, not the network and step the single calls' reports
//! name (rerun with `RWG_PLUGIN_BATCH=0` for those).

use crate::env_source::PluginSource;
use crate::fault_context::{recorded_batch, recorded_create, Phase};
use rwg_core::many::{run_blocks_many, ManyEnv};
use rwg_core::sampler::{BlockResult, CellPlan, SampleError, LANES};
use rwg_env::{EnvError, EnvSpec};
use rwg_plugin_host::PluginBatch;
use std::ops::Range;

/// The environment variable that turns the batched calls off (`0`: the
/// single calls, for fault reports that name the network and step, or for
/// comparison).
pub const BATCH_VAR: &str = "RWG_PLUGIN_BATCH";

/// Whether `rwg run` steps `source` through the batched calls: the plugin
/// has them and `RWG_PLUGIN_BATCH` is not `0`.
pub fn use_batched_calls(source: &PluginSource) -> bool {
    source.ty.has_batched_calls() && std::env::var(BATCH_VAR).as_deref() != Ok("0")
}

/// [`LANES`] instances of a plugin env, their calls recorded for fault
/// reports ([`crate::fault_context`]). Made for a block, they go back to
/// their [`Spare`] set when dropped unless a lane failed, for the next
/// block (every episode starts with a seeded reset, which fixes all that
/// follows: the ABI's rule, which `rwg check` tests), so a cell creates
/// `LANES` instances per worker thread, not per block.
pub struct PluginLanes<'a> {
    /// `None` only while being dropped.
    batch: Option<PluginBatch>,
    spare: Option<&'a Spare>,
    failed: bool,
}

/// Batches of a cell no longer in use, none with a failed lane.
pub type Spare = std::sync::Mutex<Vec<PluginBatch>>;

impl<'a> PluginLanes<'a> {
    /// [`LANES`] instances of `source`'s env, with its config and time limit.
    pub fn new(source: &PluginSource) -> Result<Self, EnvError> {
        Self::make(source, None)
    }

    /// A batch of `spare` if it has one, else new instances; given back to
    /// `spare` when dropped unless a lane failed.
    pub fn reusing(source: &PluginSource, spare: &'a Spare) -> Result<Self, EnvError> {
        Self::make(source, Some(spare))
    }

    fn make(source: &PluginSource, spare: Option<&'a Spare>) -> Result<Self, EnvError> {
        let reused = spare.and_then(|s| s.lock().unwrap_or_else(|e| e.into_inner()).pop());
        let batch = match reused {
            Some(b) => b,
            None => recorded_create(|| {
                source
                    .ty
                    .make_batch(&source.config, LANES, source.max_episode_steps)
            })?,
        };
        Ok(PluginLanes {
            batch: Some(batch),
            spare,
            failed: false,
        })
    }
}

impl Drop for PluginLanes<'_> {
    fn drop(&mut self) {
        if let (Some(spare), Some(batch), false) = (self.spare, self.batch.take(), self.failed) {
            spare.lock().unwrap_or_else(|e| e.into_inner()).push(batch);
        }
    }
}

impl ManyEnv for PluginLanes<'_> {
    fn spec(&self) -> &EnvSpec {
        self.batch.as_ref().expect("a batch until dropped").spec()
    }

    fn lanes(&self) -> usize {
        self.batch.as_ref().map_or(0, |b| b.len())
    }

    fn reset_many(
        &mut self,
        mask: &[u8],
        seeds: &[u64],
        obs: &mut [f64],
        on_fail: &mut dyn FnMut(usize, EnvError),
    ) {
        let failed = &mut self.failed;
        let batch = self.batch.as_mut().expect("a batch until dropped");
        recorded_batch(Phase::ResetMany, mask.len(), || {
            batch.reset_many(mask, seeds, obs, |f| {
                *failed = true;
                on_fail(f.lane, f.error)
            })
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
        let failed = &mut self.failed;
        let batch = self.batch.as_mut().expect("a batch until dropped");
        recorded_batch(Phase::StepMany, mask.len(), || {
            batch.step_many(mask, actions, obs, rewards, terminated, truncated, |f| {
                *failed = true;
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
    let spare = Spare::default();
    run_blocks_many(
        plan,
        blocks,
        wave,
        || PluginLanes::reusing(source, &spare),
        on_block,
    )
}
