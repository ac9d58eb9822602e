//! Environments that reset and step many instances in one in-process call
//! over structure-of-arrays buffers ([`ManyEnv`]; a plugin's ABI 1.1
//! `reset_many` / `step_many`), and the sampler loop that drives them
//! ([`ManyLaneWorker`], [`run_blocks_many`]).
//!
//! It is [`crate::sampler::LaneWorker`] with one call per step for all
//! lanes instead of one per lane: the same weights, reset seeds, network
//! arithmetic and episode bookkeeping, so the results are identical. Unlike
//! [`crate::remote::RemoteEnv`] (built for a remote host, with exchanges that
//! can be in flight), the call is synchronous and the buffers are the
//! worker's own, so nothing is copied or wrapped per lane.

use crate::block::make_failed;
use crate::deal::{Deal, Lane};
use crate::policy::PolicyLanes;
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
        let action_len = spec.action_space.flat_dim();
        ManyLaneWorker {
            policy: plan.lanes(spec),
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
        let nw = self.policy.shape().n_weights();
        let weights = std::mem::take(&mut self.block_weights);
        let mut deal = Deal::new(plan, samples, nw, weights, out);
        let mut lanes = [Lane::<bool>::IDLE; LANES];
        for (i, lane) in lanes.iter_mut().enumerate() {
            self.start_next(&mut deal, i, lane);
        }
        self.reset_pending(&mut deal, &mut lanes);
        while lanes.iter().any(|l| l.running()) {
            self.policy.forward(&self.obs);
            let (_, ended) = deal.stop_non_finite(&self.policy, &mut lanes, out);
            if lanes.iter().any(|l| l.running()) {
                self.step_lanes(&mut deal, &mut lanes, out);
            } else if ended == 0 {
                break;
            }
            if ended != 0 {
                self.start_ended(&mut deal, &mut lanes, ended);
            }
            self.reset_pending(&mut deal, &mut lanes);
            deal.cut_off(&mut lanes);
        }
        deal.finish(&mut self.block_weights)
    }

    /// Steps every running lane once, in one `step_many`; a lane whose
    /// episode ended is dealt the next one.
    fn step_lanes(
        &mut self,
        deal: &mut Deal<'_>,
        lanes: &mut [Lane<bool>; LANES],
        out: &mut [EpisodeResult],
    ) {
        for (m, lane) in self.step_mask.iter_mut().zip(lanes.iter()) {
            *m = u8::from(lane.running());
        }
        self.policy.actions_into(&self.step_mask, &mut self.actions);
        // per lane: 0 stepped, 1 failed, 2 ended by a value not finite
        let mut failed = [0u8; LANES];
        self.env.step_many(
            &self.step_mask,
            &self.actions,
            &mut self.obs,
            &mut self.rewards,
            &mut self.terminated,
            &mut self.truncated,
            &mut |i, err| {
                let ended = deal.env_failed(&lanes[i], lanes[i].steps + 1, err, out);
                failed[i] = 1 + u8::from(ended);
            },
        );
        for (i, lane) in lanes.iter_mut().enumerate() {
            if !lane.running() {
                continue;
            }
            if failed[i] != 0 {
                lane.stop();
                if failed[i] == 2 {
                    self.start_next(deal, i, lane);
                }
                continue;
            }
            let ended = self.terminated[i] == 1 || self.truncated[i] == 1;
            if deal.stepped(lane, self.rewards[i], ended, out) {
                self.start_next(deal, i, lane);
            }
        }
    }

    /// Deals lane `i` the next episode of the block (its network's weights,
    /// its reset seed, marked for the next `reset_many`), unless all have
    /// started or one failed.
    fn start_next(&mut self, deal: &mut Deal<'_>, i: usize, lane: &mut Lane<bool>) {
        if let Some(ep) = deal.next(&mut self.policy, i, lane) {
            self.seeds[i] = ep.seed;
            self.reset_mask[i] = 1;
        }
    }

    /// Deals the next episodes to the lanes of `ended` (bit `l`: lane `l`),
    /// whose episodes a network output that was not finite ended.
    #[cold]
    fn start_ended(&mut self, deal: &mut Deal<'_>, lanes: &mut [Lane<bool>; LANES], ended: u64) {
        for (i, lane) in lanes.iter_mut().enumerate() {
            if ended >> i & 1 == 1 {
                self.start_next(deal, i, lane);
            }
        }
    }

    /// Resets the lanes [`Self::start_next`] marked, in one call.
    fn reset_pending(&mut self, deal: &mut Deal<'_>, lanes: &mut [Lane<bool>; LANES]) {
        if !self.reset_mask.contains(&1) {
            return;
        }
        let mut failed = [false; LANES];
        self.env.reset_many(
            &self.reset_mask,
            &self.seeds,
            &mut self.obs,
            &mut |i, err| {
                failed[i] = true;
                deal.fail(lanes[i].item, 0, err);
            },
        );
        for (i, lane) in lanes.iter_mut().enumerate() {
            if self.reset_mask[i] == 1 {
                self.reset_mask[i] = 0;
                if !failed[i] {
                    lane.begin(true);
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
