//! Plugin envs with ABI 1.1's batched calls or 1.2's vector env in the
//! sampler: [`SamplerLanes`] is a [`ManyEnv`] over [`LANES`] lanes of a
//! plugin env (a [`rwg_plugin_host::PluginLanes`]: a vector env, one plugin
//! object stepping its lanes together, or a batch of `LANES` instances), so
//! a worker's lanes reset and step through one call each
//! ([`rwg_core::many`]), and [`run_blocks`] runs a cell's blocks on it.
//!
//! The episodes are those of the single calls bit for bit (the ABI promises
//! it; `rwg check` tests it), so `scores.csv` and `samples.csv` do not
//! depend on the path. `rwg run` uses the vector env of every in-process
//! plugin env that has one, else its batched calls ([`calls_for`]):
//! `RWG_PLUGIN_VEC=0` turns the vector env off, `RWG_PLUGIN_BATCH=0` both
//! (the single calls). Measured, each costs fewer CPU instructions per env
//! step than the one after it (docs/benchmarks.md). What they give up: a
//! crash inside one is reported as the call, not the network and step the
//! single calls' reports name (rerun with `RWG_PLUGIN_BATCH=0` for those).

use crate::env_source::PluginSource;
use crate::fault_context::{recorded_batch, recorded_create, Phase};
use rwg_core::many::{run_blocks_many, ManyEnv};
use rwg_core::sampler::{BlockResult, CellPlan, SampleError, LANES};
use rwg_env::{EnvError, EnvSpec};
use rwg_plugin_host::{LaneCalls, PluginLanes as Lanes};
use std::ops::Range;

/// The environment variable that turns the batched calls and the vector
/// env off (`0`: the single calls, for fault reports that name the network
/// and step, or for comparison).
pub const BATCH_VAR: &str = "RWG_PLUGIN_BATCH";

/// The environment variable that turns the vector env off (`0`: the
/// batched calls), for comparison.
pub const VEC_VAR: &str = "RWG_PLUGIN_VEC";

/// Whether [`BATCH_VAR`] and [`VEC_VAR`] allow the batched calls and the
/// vector env (`1` or unset: yes, `0`: no); an error naming the variable
/// for any other value.
pub fn calls_settings() -> Result<(bool, bool), rwg_env::vars::VarError> {
    Ok((
        rwg_env::vars::switch(
            BATCH_VAR,
            true,
            "0: a plugin's single calls, no batched calls or vector env",
        )?,
        rwg_env::vars::switch(VEC_VAR, true, "0: a plugin's batched calls, no vector env")?,
    ))
}

/// The calls `rwg run` uses for `source`: the vector env if the plugin has
/// one and `RWG_PLUGIN_VEC` is not `0`, else the batched calls if it has
/// them; `None` (the single calls, one instance per lane) if it has neither
/// or `RWG_PLUGIN_BATCH` is `0`.
pub fn calls_for(source: &PluginSource) -> Option<LaneCalls> {
    let (batch, vec) = calls_settings().unwrap_or((true, true));
    if !batch {
        None
    } else if source.ty.has_vec_env() && vec {
        Some(LaneCalls::Vec)
    } else if source.ty.has_batched_calls() {
        Some(LaneCalls::Batched)
    } else {
        None
    }
}

/// [`LANES`] lanes of a plugin env ([`Lanes`]), their calls recorded
/// for fault reports ([`crate::fault_context`]). Made for a block, they go
/// back to their [`Spare`] set when dropped unless a lane failed, for the
/// next block (every episode starts with a seeded reset, which fixes all
/// that follows: the ABI's rule, which `rwg check` tests), so a cell
/// creates `LANES` lanes per worker thread, not per block.
pub struct SamplerLanes<'a> {
    /// `None` only while being dropped.
    batch: Option<Lanes>,
    spare: Option<&'a Spare>,
    failed: bool,
}

/// Lanes of a cell no longer in use, none with a failed lane.
pub type Spare = std::sync::Mutex<Vec<Lanes>>;

impl<'a> SamplerLanes<'a> {
    /// [`LANES`] lanes of `source`'s env through `calls`, with its config
    /// and time limit.
    pub fn new(source: &PluginSource, calls: LaneCalls) -> Result<Self, EnvError> {
        Self::make(source, calls, None)
    }

    /// Lanes of `spare` if it has some, else new ones; given back to
    /// `spare` when dropped unless a lane failed.
    pub fn reusing(
        source: &PluginSource,
        calls: LaneCalls,
        spare: &'a Spare,
    ) -> Result<Self, EnvError> {
        Self::make(source, calls, Some(spare))
    }

    fn make(
        source: &PluginSource,
        calls: LaneCalls,
        spare: Option<&'a Spare>,
    ) -> Result<Self, EnvError> {
        let reused = spare.and_then(|s| s.lock().unwrap_or_else(|e| e.into_inner()).pop());
        let batch = match reused {
            Some(b) => b,
            None => recorded_create(|| {
                source
                    .ty
                    .make_lanes(calls, &source.config, LANES, source.max_episode_steps)
            })?,
        };
        Ok(SamplerLanes {
            batch: Some(batch),
            spare,
            failed: false,
        })
    }
}

impl Drop for SamplerLanes<'_> {
    fn drop(&mut self) {
        if let (Some(spare), Some(batch), false) = (self.spare, self.batch.take(), self.failed) {
            spare.lock().unwrap_or_else(|e| e.into_inner()).push(batch);
        }
    }
}

impl ManyEnv for SamplerLanes<'_> {
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
        let phase = match batch {
            Lanes::Vec(_) => Phase::VecReset,
            Lanes::Batch(_) => Phase::ResetMany,
        };
        recorded_batch(phase, mask.len(), || {
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
        let phase = match batch {
            Lanes::Vec(_) => Phase::VecStep,
            Lanes::Batch(_) => Phase::StepMany,
        };
        recorded_batch(phase, mask.len(), || {
            batch.step_many(mask, actions, obs, rewards, terminated, truncated, |f| {
                *failed = true;
                on_fail(f.lane, f.error)
            })
        })
    }
}

/// Runs `blocks` of a cell on `source`'s env through `calls` (the vector
/// env or the batched calls), as [`rwg_core::sampler::run_blocks`] runs
/// them through the single ones (same results, same order, same first
/// error).
pub fn run_blocks<X>(
    source: &PluginSource,
    calls: LaneCalls,
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
        || SamplerLanes::reusing(source, calls, &spare),
        on_block,
    )
}
