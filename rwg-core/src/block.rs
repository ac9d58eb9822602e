//! A block of a cell's networks: their weights, its episodes in order
//! (sample-major) with their reset seeds, and the first failure in episode
//! order with where it happened. The lane loops deal them out through
//! `crate::deal`.

use crate::plan::{draw_weights, reset_seed, weight_rng, CellPlan, SampleError};
use rwg_env::EnvError;
use std::ops::Range;

/// Draws the weights of the block's networks `samples`, network `k`'s at
/// `out[k * nw..(k + 1) * nw]` (`out` resized to fit): the draw every
/// source uses (also the sources outside this crate that run networks
/// their own way, such as rwg-jax's compiled calls).
pub fn draw_block_weights(plan: &CellPlan, samples: &Range<u64>, nw: usize, out: &mut Vec<f64>) {
    let n = (samples.end - samples.start) as usize;
    out.resize(n * nw, 0.0);
    for (k, w) in out.chunks_exact_mut(nw.max(1)).take(n).enumerate() {
        let mut rng = weight_rng(
            plan.seed,
            &plan.env_id,
            &plan.arch,
            samples.start + k as u64,
        );
        draw_weights(&mut rng, plan.dist, &mut w[..nw]);
    }
}

/// One episode of the block, as [`BlockRun::next_episode`] hands it out.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Episode {
    /// Index in the block's results (sample-major: `k * episodes + episode`).
    pub item: usize,
    /// The network's index in the block.
    pub k: usize,
    /// The episode's number within its network.
    pub episode: u32,
    /// Its reset seed ([`reset_seed`]).
    pub seed: u64,
}

/// The block being run: how far its episodes have been handed out, and the
/// first failure in episode order.
pub(crate) struct BlockRun<'a> {
    /// The cell.
    pub plan: &'a CellPlan,
    /// The block's networks.
    pub samples: Range<u64>,
    next: usize,
    total: usize,
    /// The failure of the earliest failing episode: (item, step, error).
    pub failure: Option<(usize, u32, EnvError)>,
}

impl<'a> BlockRun<'a> {
    /// The block `samples` of `plan`'s cell, nothing started.
    pub fn new(plan: &'a CellPlan, samples: Range<u64>) -> Self {
        let n = (samples.end - samples.start) as usize;
        BlockRun {
            plan,
            total: n * plan.episodes as usize,
            samples,
            next: 0,
            failure: None,
        }
    }

    /// The next episode in order, or `None` once all have been handed out.
    pub fn next_episode(&mut self) -> Option<Episode> {
        if self.next >= self.total {
            return None;
        }
        let item = self.next;
        self.next += 1;
        let e = self.plan.episodes as usize;
        let (k, episode) = (item / e, (item % e) as u32);
        let sample = self.samples.start + k as u64;
        Some(Episode {
            item,
            k,
            episode,
            seed: reset_seed(self.plan.seed, &self.plan.env_id, sample, episode),
        })
    }

    /// The block's result: `Ok`, or the earliest failure with where it
    /// happened.
    pub fn into_result(self) -> Result<(), SampleError> {
        match self.failure {
            None => Ok(()),
            Some((item, step, error)) => {
                let e = self.plan.episodes as usize;
                Err(SampleError {
                    env: self.plan.env_id.clone(),
                    sample: self.samples.start + (item / e) as u64,
                    episode: (item % e) as u32,
                    step,
                    error,
                })
            }
        }
    }
}

/// The error of a network whose output is `v` (not finite), its weights
/// drawn at `scale`.
pub(crate) fn non_finite_output(scale: f64, v: f64) -> EnvError {
    EnvError::Other(format!(
        "the network's output is {v}: its weights (drawn with [weights] scale = {scale:e}) \
         times the observation overflow a 64-bit float, so its actions mean nothing; lower \
         the scale in [weights], or scale the observations down (they are given to the \
         network as they are), or set non_finite = \"end\" on the env's [[envs]] entry to \
         end such an episode there"
    ))
}

/// Keeps the failure of the earliest episode.
pub(crate) fn record_failure(
    failure: &mut Option<(usize, u32, EnvError)>,
    item: usize,
    step: u32,
    err: EnvError,
) {
    if failure.as_ref().is_none_or(|(first, _, _)| item < *first) {
        *failure = Some((item, step, err));
    }
}

/// The error of a worker whose environment could not be made, for the
/// block `range` it was to run.
pub(crate) fn make_failed(plan: &CellPlan, range: &Range<u64>, err: &EnvError) -> SampleError {
    SampleError {
        env: plan.env_id.clone(),
        sample: range.start,
        episode: 0,
        step: 0,
        error: err.clone(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plan::WeightDist;
    use crate::policy::Architecture;

    fn plan() -> CellPlan {
        CellPlan {
            seed: 7,
            env_id: "Toy-v0".into(),
            arch: Architecture {
                hidden: vec![4],
                bias: true,
            },
            episodes: 3,
            dist: WeightDist::Normal { std: 1.0 },
            policy: crate::policy::PolicyKind::Network,
            non_finite: Default::default(),
        }
    }

    #[test]
    fn episodes_come_in_sample_major_order_with_their_seeds() {
        let plan = plan();
        let mut run = BlockRun::new(&plan, 10..12);
        let mut got = vec![];
        while let Some(ep) = run.next_episode() {
            got.push(ep);
        }
        assert_eq!(got.len(), 6);
        for (i, ep) in got.iter().enumerate() {
            assert_eq!((ep.item, ep.k, ep.episode), (i, i / 3, (i % 3) as u32));
            let sample = 10 + (i / 3) as u64;
            assert_eq!(ep.seed, reset_seed(7, "Toy-v0", sample, ep.episode));
        }
        assert!(run.next_episode().is_none());
    }

    #[test]
    fn the_earliest_failure_is_kept_and_reported_where_it_happened() {
        let plan = plan();
        let mut run = BlockRun::new(&plan, 10..12);
        record_failure(&mut run.failure, 4, 9, EnvError::Other("later".into()));
        record_failure(&mut run.failure, 5, 1, EnvError::Other("after".into()));
        record_failure(&mut run.failure, 2, 3, EnvError::Other("first".into()));
        let err = run.into_result().unwrap_err();
        assert_eq!((err.sample, err.episode, err.step), (10, 2, 3));
        assert_eq!(err.error, EnvError::Other("first".into()));
        assert!(BlockRun::new(&plan, 0..1).into_result().is_ok());
    }

    #[test]
    fn block_weights_are_each_networks_own() {
        let plan = plan();
        let nw = 3 * 4 + 5; // not checked here: any width works
        let mut block = vec![];
        draw_block_weights(&plan, &(20..23), nw, &mut block);
        assert_eq!(block.len(), 3 * nw);
        for k in 0..3 {
            let mut rng = weight_rng(7, "Toy-v0", &plan.arch, 20 + k as u64);
            let mut w = vec![0.0; nw];
            draw_weights(&mut rng, plan.dist, &mut w);
            assert_eq!(&block[k * nw..(k + 1) * nw], &w[..]);
        }
    }
}
