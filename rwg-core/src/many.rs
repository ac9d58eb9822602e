//! Environments that reset and step many instances in one in-process call
//! over structure-of-arrays buffers ([`ManyEnv`]; a plugin's ABI 1.1
//! `reset_many` / `step_many`), and the sampler loop that drives them
//! ([`ManyLaneWorker`], [`run_blocks_many`]).
//!
//! It is [`crate::sampler::LaneWorker`] with one call per step for all
//! lanes instead of one per lane: the same weights, reset seeds, network
//! arithmetic and episode bookkeeping, so the results are identical. Unlike
//! [`crate::batch::BatchEnv`] (built for a remote host, with exchanges that
//! can be in flight), the call is synchronous and the buffers are the
//! worker's own, so nothing is copied or wrapped per lane.

use crate::block::{
    draw_block_weights, make_failed, record_failure, stop_non_finite, BlockRun, Lane,
};
use crate::policy::{NetShape, PolicyLanes};
use crate::sampler::{BlockResult, CellPlan, EpisodeResult, SampleError, LANES};
use rayon::prelude::*;
pub use rwg_env::many::ManyEnv;
use rwg_env::EnvError;
use std::ops::Range;

/// [`crate::sampler::LaneWorker`] over a [`ManyEnv`] of [`LANES`] lanes:
/// one `step_many` per step of all running episodes, one `reset_many` per
/// step in which episodes start.
pub struct ManyLaneWorker<M> {
    env: M,
    policy: PolicyLanes<LANES>,
    obs: Vec<f64>,
    actions: Vec<f64>,
    step_mask: [u8; LANES],
    reset_mask: [u8; LANES],
    seeds: [u64; LANES],
    rewards: [f64; LANES],
    terminated: [u8; LANES],
    truncated: [u8; LANES],
    block_weights: Vec<f64>,
}

impl<M: ManyEnv> ManyLaneWorker<M> {
    /// A worker for `plan` on `env`, which must have [`LANES`] lanes.
    pub fn new(env: M, plan: &CellPlan) -> Self {
        assert_eq!(env.lanes(), LANES, "a ManyEnv of {LANES} lanes");
        let spec = env.spec();
        let obs_dim = spec.obs_dim();
        let shape = NetShape::new(
            obs_dim,
            &plan.arch,
            NetShape::outputs_for(&spec.action_space),
        );
        let action_len = spec.action_space.flat_dim();
        ManyLaneWorker {
            policy: PolicyLanes::new(shape, &spec.action_space),
            obs: vec![0.0; LANES * obs_dim],
            actions: vec![0.0; LANES * action_len],
            step_mask: [0; LANES],
            reset_mask: [0; LANES],
            seeds: [0; LANES],
            rewards: [0.0; LANES],
            terminated: [0; LANES],
            truncated: [0; LANES],
            block_weights: Vec::new(),
            env,
        }
    }

    /// Runs every episode of `samples` into `out`, exactly as
    /// [`crate::sampler::LaneWorker::run_block`] does (same results, same
    /// first failing episode).
    pub fn run_block(
        &mut self,
        plan: &CellPlan,
        samples: Range<u64>,
        out: &mut [EpisodeResult],
    ) -> Result<(), SampleError> {
        let e = plan.episodes as usize;
        let n = (samples.end - samples.start) as usize;
        assert_eq!(out.len(), n * e, "results of {n} samples x {e} episodes");
        let nw = self.policy.shape().n_weights();
        draw_block_weights(plan, &samples, nw, &mut self.block_weights);
        let mut lanes = [Lane::IDLE; LANES];
        let mut run = BlockRun::new(plan, samples);
        for (i, lane) in lanes.iter_mut().enumerate() {
            self.start_next(&mut run, i, lane);
        }
        self.reset_pending(&mut run, &mut lanes);
        while lanes.iter().any(|l| l.active) {
            self.policy.forward(&self.obs);
            stop_non_finite(&self.policy, plan, &mut run.failure, &mut lanes);
            if !lanes.iter().any(|l| l.active) {
                break;
            }
            for (m, lane) in self.step_mask.iter_mut().zip(&lanes) {
                *m = u8::from(lane.active);
            }
            self.policy.actions_into(&self.step_mask, &mut self.actions);
            let mut failed = [false; LANES];
            let failure = &mut run.failure;
            self.env.step_many(
                &self.step_mask,
                &self.actions,
                &mut self.obs,
                &mut self.rewards,
                &mut self.terminated,
                &mut self.truncated,
                &mut |i, err| {
                    failed[i] = true;
                    record_failure(failure, lanes[i].item, lanes[i].steps + 1, err);
                },
            );
            for (i, lane) in lanes.iter_mut().enumerate() {
                if !lane.active {
                    continue;
                }
                if failed[i] {
                    lane.active = false;
                    continue;
                }
                lane.score += self.rewards[i];
                lane.steps += 1;
                if self.terminated[i] == 1 || self.truncated[i] == 1 {
                    lane.active = false;
                    match EpisodeResult::finished(lane.score, lane.steps) {
                        Ok(r) => {
                            out[lane.item] = r;
                            self.start_next(&mut run, i, lane);
                        }
                        Err(err) => record_failure(&mut run.failure, lane.item, lane.steps, err),
                    }
                }
            }
            self.reset_pending(&mut run, &mut lanes);
            if let Some((first, _, _)) = &run.failure {
                // Episodes after the failing one do not matter any more.
                for lane in lanes.iter_mut().filter(|l| l.item > *first) {
                    lane.active = false;
                }
            }
        }
        run.into_result()
    }

    /// Gives lane `i` the next episode of the block (its network's weights,
    /// its reset seed, marked for the next `reset_many`), unless all have
    /// started or one failed.
    fn start_next(&mut self, run: &mut BlockRun<'_>, i: usize, lane: &mut Lane) {
        if run.failure.is_some() {
            return;
        }
        let Some(ep) = run.next_episode() else {
            return;
        };
        if lane.weights_of != ep.k {
            let nw = self.policy.shape().n_weights();
            self.policy
                .set_weights(i, &self.block_weights[ep.k * nw..(ep.k + 1) * nw]);
            lane.weights_of = ep.k;
        }
        self.seeds[i] = ep.seed;
        self.reset_mask[i] = 1;
        lane.item = ep.item;
    }

    /// Resets the lanes [`Self::start_next`] marked, in one call.
    fn reset_pending(&mut self, run: &mut BlockRun<'_>, lanes: &mut [Lane; LANES]) {
        if !self.reset_mask.contains(&1) {
            return;
        }
        let mut failed = [false; LANES];
        let failure = &mut run.failure;
        self.env.reset_many(
            &self.reset_mask,
            &self.seeds,
            &mut self.obs,
            &mut |i, err| {
                failed[i] = true;
                record_failure(failure, lanes[i].item, 0, err);
            },
        );
        for (i, lane) in lanes.iter_mut().enumerate() {
            if self.reset_mask[i] == 1 {
                self.reset_mask[i] = 0;
                if !failed[i] {
                    lane.active = true;
                    lane.score = 0.0;
                    lane.steps = 0;
                }
            }
        }
    }
}

/// [`crate::sampler::run_blocks`] for a [`ManyEnv`]: the blocks run in
/// parallel on the current rayon pool, each worker thread on one env made by
/// `make` (reused for its blocks while no lane fails). Results, their order
/// and the first error are those of `run_blocks`.
pub fn run_blocks_many<M, F, G, X>(
    plan: &CellPlan,
    blocks: &[Range<u64>],
    wave: usize,
    make: F,
    mut on_block: G,
) -> Result<(), X>
where
    M: ManyEnv + Send,
    F: Fn() -> Result<M, EnvError> + Sync,
    G: FnMut(BlockResult) -> Result<(), X>,
    X: From<SampleError> + Send,
{
    let e = plan.episodes as usize;
    for wave_blocks in blocks.chunks(wave.max(1)) {
        let results: Vec<Result<BlockResult, SampleError>> = wave_blocks
            .par_iter()
            .map_init(
                || make().map(|env| ManyLaneWorker::new(env, plan)),
                |worker, range| {
                    let worker = worker
                        .as_mut()
                        .map_err(|err| make_failed(plan, range, err))?;
                    BlockResult::compute(range.clone(), e, |out| {
                        worker.run_block(plan, range.clone(), out)
                    })
                },
            )
            .collect();
        for r in results {
            on_block(r?)?;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests;
