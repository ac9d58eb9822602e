//! Dealing a block's episodes to the lanes of the three lane loops
//! ([`crate::sampler::LaneWorker`], [`crate::many::ManyLaneWorker`],
//! [`crate::remote::RemoteLaneWorker`]): which network and episode a free lane
//! takes next (its weights loaded, its reset seed), the return of each
//! episode, the failure of one that breaks (its reset, a step, a network
//! output that is not finite) and the cut-off of the episodes after the
//! first failure. The loops differ only in how they step their lanes; what
//! is here is why their results are the same.

use crate::block::{non_finite_output, record_failure, BlockRun, Episode};
use crate::plan::{
    action_rng, return_refused, return_within_bound, stopping, CellPlan, EpisodeResult, NonFinite,
    SampleError,
};
use crate::policy::PolicyLanes;
use rwg_env::EnvError;
use std::ops::Range;

/// Whether a lane is running an episode: `bool` for the loops whose lanes
/// either run or not, a richer state for one with resets in flight.
pub(crate) trait Status: Copy {
    /// A lane with nothing to do (stopped, or cut off).
    const FREE: Self;
    /// Whether the lane is running an episode (its network is stepped).
    fn running(self) -> bool;
}

impl Status for bool {
    const FREE: bool = false;
    #[inline(always)]
    fn running(self) -> bool {
        self
    }
}

/// One lane of a lane loop: what it is doing and the episode it was dealt.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Lane<S> {
    /// Whether (and how) the lane is busy.
    pub status: S,
    /// The episode: `sample_in_block * episodes + episode`.
    pub item: usize,
    /// Which sample of the block the lane's weights belong to.
    pub weights_of: usize,
    /// The episode's return so far.
    pub score: f64,
    /// The episode's steps so far.
    pub steps: u32,
}

impl<S: Status> Lane<S> {
    /// A lane with no episode and no network's weights.
    pub const IDLE: Self = Lane {
        status: S::FREE,
        item: 0,
        weights_of: usize::MAX,
        score: 0.0,
        steps: 0,
    };

    /// Whether the lane is running an episode.
    #[inline(always)]
    pub fn running(&self) -> bool {
        self.status.running()
    }

    /// Stops the lane (its episode is over, failed or cut off).
    #[inline(always)]
    pub fn stop(&mut self) {
        self.status = S::FREE;
    }

    /// The episode's reset succeeded: the lane runs it from step 0.
    #[inline]
    pub fn begin(&mut self, running: S) {
        self.status = running;
        self.score = 0.0;
        self.steps = 0;
    }

    /// The step at which a failure of the lane's env now happens: its next
    /// step while it runs, else its reset (0).
    #[inline]
    pub fn failing_step(&self) -> u32 {
        if self.running() {
            self.steps + 1
        } else {
            0
        }
    }
}

/// A block being dealt to a loop's lanes: its networks' weights, how far its
/// episodes have been handed out, and the first failure in episode order.
pub(crate) struct Deal<'a> {
    run: BlockRun<'a>,
    /// The weights of every network of the block, one after the other.
    weights: Vec<f64>,
    /// Weights per network.
    nw: usize,
}

impl<'a> Deal<'a> {
    /// The block `samples` of `plan`'s cell, nothing dealt, its networks'
    /// weights (`nw` each) drawn into `weights` (a loop's buffer, given back
    /// by [`Deal::finish`]); `out` is where its results go.
    pub fn new(
        plan: &'a CellPlan,
        samples: Range<u64>,
        nw: usize,
        mut weights: Vec<f64>,
        out: &[EpisodeResult],
    ) -> Self {
        let e = plan.episodes as usize;
        let n = (samples.end - samples.start) as usize;
        assert_eq!(out.len(), n * e, "results of {n} samples x {e} episodes");
        crate::block::draw_block_weights(plan, &samples, nw, &mut weights);
        Deal {
            run: BlockRun::new(plan, samples),
            weights,
            nw,
        }
    }

    /// The cell.
    pub fn plan(&self) -> &'a CellPlan {
        self.run.plan
    }

    /// The block's networks.
    pub fn samples(&self) -> &Range<u64> {
        &self.run.samples
    }

    /// Deals the next episode to lane `i` (its network's weights loaded into
    /// `policy`, or a random policy's lane seeded for the episode; its `item` set), unless all have been dealt or one failed;
    /// the caller resets its env with the episode's seed.
    #[inline]
    pub fn next<const K: usize, S: Status>(
        &mut self,
        policy: &mut PolicyLanes<K>,
        i: usize,
        lane: &mut Lane<S>,
    ) -> Option<Episode> {
        if self.run.failure.is_some() {
            return None;
        }
        let ep = self.run.next_episode()?;
        if policy.is_random() {
            let plan = self.run.plan;
            let sample = self.run.samples.start + ep.k as u64;
            policy.seed_lane(i, action_rng(plan.seed, &plan.env_id, sample, ep.episode));
        } else if lane.weights_of != ep.k {
            let nw = self.nw;
            policy.set_weights(i, &self.weights[ep.k * nw..(ep.k + 1) * nw]);
            lane.weights_of = ep.k;
        }
        lane.item = ep.item;
        Some(ep)
    }

    /// Counts a successful step of `lane` (its `reward`, whether its episode
    /// `ended`); an ended episode stops the lane and has its return written
    /// to `out`. A reward that is not finite, or that takes the return
    /// beyond [`MAX_RETURN`](crate::plan::MAX_RETURN), fails the episode or (with
    /// [`NonFinite::End`]) ends it, flagged, with the return before it.
    /// True when the lane is free for the next episode.
    #[inline(always)]
    pub fn stepped<S: Status>(
        &mut self,
        lane: &mut Lane<S>,
        reward: f64,
        ended: bool,
        out: &mut [EpisodeResult],
    ) -> bool {
        let score = lane.score + reward;
        lane.steps += 1;
        if !return_within_bound(score) {
            lane.stop();
            let err = return_refused(reward, score);
            return self.env_failed_cold(lane, lane.steps, err, out);
        }
        lane.score = score;
        if !ended {
            return false;
        }
        lane.stop();
        out[lane.item] = EpisodeResult::new(score, lane.steps);
        true
    }

    /// [`Deal::env_failed`] off the hot path of a loop's stepping.
    #[cold]
    #[inline(never)]
    pub fn env_failed_cold<S: Status>(
        &mut self,
        lane: &Lane<S>,
        step: u32,
        err: EnvError,
        out: &mut [EpisodeResult],
    ) -> bool {
        self.env_failed(lane, step, err, out)
    }

    /// The env failed `lane`'s episode at `step` (0: its reset) with `err`
    /// (the caller stops the lane). An [`EnvError::NonFinite`] of a step,
    /// with [`NonFinite::End`], ends the episode instead, flagged, with the
    /// return before the step; then true: the lane is free for the next.
    #[inline]
    pub fn env_failed<S: Status>(
        &mut self,
        lane: &Lane<S>,
        step: u32,
        err: EnvError,
        out: &mut [EpisodeResult],
    ) -> bool {
        let err = match err {
            EnvError::NonFinite(_) if self.run.plan.non_finite == NonFinite::End && step > 0 => {
                out[lane.item] = EpisodeResult::cut(lane.score, step);
                return true;
            }
            e if step > 0 => stopping(e),
            e => e,
        };
        self.fail(lane.item, step, err);
        false
    }

    /// Episode `item` failed at `step` (0: its reset) with `err`; the
    /// earliest failing episode's error is kept.
    #[inline]
    pub fn fail(&mut self, item: usize, step: u32, err: EnvError) {
        record_failure(&mut self.run.failure, item, step, err);
    }

    /// Stops the lanes whose episodes come after the first failing one:
    /// their results do not matter any more.
    #[inline]
    pub fn cut_off<S: Status>(&self, lanes: &mut [Lane<S>]) {
        if let Some((first, _, _)) = &self.run.failure {
            for lane in lanes.iter_mut().filter(|l| l.item > *first) {
                lane.stop();
            }
        }
    }

    /// After `policy`'s forward pass: every running lane whose network
    /// outputs are not finite fails its episode (at its next step) and
    /// stops, or (with [`NonFinite::End`]) ends it, flagged, before that
    /// step, its return and length those of the steps before. True if any
    /// did; the ended lanes are in the second mask (bit `l`: lane `l`) to
    /// be dealt their next episode.
    #[inline]
    pub fn stop_non_finite<const K: usize, S: Status>(
        &mut self,
        policy: &PolicyLanes<K>,
        lanes: &mut [Lane<S>; K],
        out: &mut [EpisodeResult],
    ) -> (bool, u64) {
        let bad = policy.non_finite_outputs();
        if bad == 0 {
            return (false, 0);
        }
        self.fail_non_finite(policy, bad, lanes, out)
    }

    /// [`Deal::stop_non_finite`] for the lanes of `mask` (not all finite).
    #[cold]
    fn fail_non_finite<const K: usize, S: Status>(
        &mut self,
        policy: &PolicyLanes<K>,
        mask: u64,
        lanes: &mut [Lane<S>; K],
        out: &mut [EpisodeResult],
    ) -> (bool, u64) {
        let mut any = false;
        let mut ended = 0u64;
        for (l, lane) in lanes.iter_mut().enumerate() {
            if mask >> l & 1 == 0 || !lane.running() {
                continue;
            }
            let Some(v) = policy.non_finite_output(l) else {
                continue;
            };
            lane.stop();
            any = true;
            if self.run.plan.non_finite == NonFinite::End {
                out[lane.item] = EpisodeResult::cut(lane.score, lane.steps);
                ended |= 1 << l;
            } else {
                let err = non_finite_output(self.run.plan.dist.scale(), v);
                self.fail(lane.item, lane.steps + 1, err);
            }
        }
        (any, ended)
    }

    /// The block's result (`Ok`, or the earliest failure with where it
    /// happened); the weights buffer goes back to `weights`.
    pub fn finish(self, weights: &mut Vec<f64>) -> Result<(), SampleError> {
        *weights = self.weights;
        self.run.into_result()
    }
}

#[cfg(test)]
mod tests;
