//! Plugin envs with ABI 1.1's batched calls in the sampler: [`PluginLanes`]
//! is a [`BatchEnv`] over a [`PluginBatch`] of [`LANES`] instances, so the
//! sampler's lanes reset and step through one `reset_many` / `step_many`
//! call each, and [`run_blocks`] runs a cell's blocks on it.
//!
//! The episodes are those of the single calls bit for bit (the ABI promises
//! it; `rwg check` tests it), so `scores.csv` and `samples.csv` do not
//! depend on the path. `RWG_PLUGIN_BATCH=0` in the environment makes `rwg
//! run` use the single calls anyway ([`use_batched_calls`]).

use crate::env_source::PluginSource;
use crate::fault_context::{recorded_batch, recorded_create, Phase};
use rwg_core::batch::{
    run_blocks_batched, BatchEnv, BatchFailure, BatchPool, LaneActions, LaneOp, LaneOutcome,
};
use rwg_core::sampler::{BlockResult, CellPlan, SampleError, LANES};
use rwg_env::plugin::abi::MAX_DISCRETE_N;
use rwg_env::{EnvError, EnvSpec, Step};
use rwg_plugin_host::PluginBatch;
use std::ops::Range;

/// The environment variable that turns the batched calls off (`0`).
pub const BATCH_VAR: &str = "RWG_PLUGIN_BATCH";

/// Whether `rwg run` steps `source` through the batched calls: the plugin
/// has them and `RWG_PLUGIN_BATCH` is not `0`.
pub fn use_batched_calls(source: &PluginSource) -> bool {
    source.ty.has_batched_calls() && std::env::var(BATCH_VAR).as_deref() != Ok("0")
}

/// [`LANES`] instances of a plugin env as one [`BatchEnv`] group: an
/// exchange is one `reset_many` for the lanes to reset and one `step_many`
/// for the lanes to step.
pub struct PluginLanes {
    batch: PluginBatch,
    ops: [LaneOp; LANES],
    /// The actions of the exchange as the ABI takes them (doubles).
    actions: Vec<f64>,
    reset_mask: [u8; LANES],
    step_mask: [u8; LANES],
    seeds: [u64; LANES],
    rewards: [f64; LANES],
    terminated: [u8; LANES],
    truncated: [u8; LANES],
    /// A lane whose discrete action could not cross the ABI.
    bad_action: Option<(usize, EnvError)>,
}

impl PluginLanes {
    /// [`LANES`] instances of `source`'s env, with its config and time limit.
    pub fn new(source: &PluginSource) -> Result<Self, EnvError> {
        let batch = recorded_create(|| {
            source
                .ty
                .make_batch(&source.config, LANES, source.max_episode_steps)
        })?;
        Ok(PluginLanes {
            actions: vec![0.0; LANES * batch.action_len()],
            batch,
            ops: [LaneOp::Idle; LANES],
            reset_mask: [0; LANES],
            step_mask: [0; LANES],
            seeds: [0; LANES],
            rewards: [0.0; LANES],
            terminated: [0; LANES],
            truncated: [0; LANES],
            bad_action: None,
        })
    }
}

impl BatchEnv for PluginLanes {
    fn spec(&self) -> &EnvSpec {
        self.batch.spec()
    }

    fn lanes(&self) -> usize {
        LANES
    }

    fn send(
        &mut self,
        _group: usize,
        ops: &[LaneOp],
        actions: LaneActions<'_>,
    ) -> Result<(), BatchFailure> {
        self.ops.copy_from_slice(ops);
        let a = self.batch.action_len();
        self.bad_action = None;
        for (i, op) in ops.iter().enumerate() {
            if *op != LaneOp::Step {
                continue;
            }
            if actions.continuous.is_empty() {
                let d = actions.discrete[i];
                // Exactly representable, as the single path checks.
                if d.unsigned_abs() > MAX_DISCRETE_N && self.bad_action.is_none() {
                    let e = EnvError::InvalidAction(format!(
                        "{}: discrete action {d} is out of range",
                        self.batch.spec().id
                    ));
                    self.bad_action = Some((i, e));
                }
                self.actions[i] = d as f64;
            } else {
                self.actions[i * a..(i + 1) * a]
                    .copy_from_slice(&actions.continuous[i * a..(i + 1) * a]);
            }
        }
        Ok(())
    }

    fn recv(
        &mut self,
        _group: usize,
        obs: &mut [f64],
        out: &mut [LaneOutcome],
    ) -> Result<(), BatchFailure> {
        let (mut resets, mut steps) = (false, false);
        for (i, op) in self.ops.iter().enumerate() {
            self.reset_mask[i] = 0;
            self.step_mask[i] = 0;
            out[i] = match *op {
                LaneOp::Idle => LaneOutcome::Idle,
                LaneOp::Reset(seed) => {
                    self.seeds[i] = seed;
                    self.reset_mask[i] = 1;
                    resets = true;
                    LaneOutcome::Reset
                }
                LaneOp::Step => {
                    self.step_mask[i] = 1;
                    steps = true;
                    LaneOutcome::Idle // replaced below
                }
            };
        }
        if let Some((i, e)) = self.bad_action.take() {
            self.step_mask[i] = 0;
            out[i] = LaneOutcome::Failed(e);
        }
        let batch = &mut self.batch;
        if resets {
            let (mask, seeds) = (&self.reset_mask, &self.seeds);
            recorded_batch(Phase::ResetMany, LANES, || {
                batch.reset_many(mask, seeds, obs, |f| {
                    out[f.lane] = LaneOutcome::Failed(f.error)
                })
            });
        }
        if steps {
            let mut failed = [false; LANES];
            recorded_batch(Phase::StepMany, LANES, || {
                batch.step_many(
                    &self.step_mask,
                    &self.actions,
                    obs,
                    &mut self.rewards,
                    &mut self.terminated,
                    &mut self.truncated,
                    |f| {
                        failed[f.lane] = true;
                        out[f.lane] = LaneOutcome::Failed(f.error);
                    },
                )
            });
            for i in 0..LANES {
                if self.step_mask[i] == 1 && !failed[i] {
                    out[i] = LaneOutcome::Step(Step {
                        reward: self.rewards[i],
                        terminated: self.terminated[i] == 1,
                        truncated: self.truncated[i] == 1,
                    });
                }
            }
        }
        Ok(())
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
    let pool = BatchPool::default();
    run_blocks_batched(
        plan,
        blocks,
        wave,
        &pool,
        || PluginLanes::new(source),
        on_block,
    )
}
