//! The RWG sampler: the paper's Algorithm 1, deterministic by construction.
//!
//! Each cell's networks and episodes are fixed by its [`CellPlan`] (the
//! seeds: `plan.rs`, re-exported here); the loops here run them, one
//! environment instance per lane ([`LaneWorker`]), in blocks of networks
//! over rayon ([`run_blocks`], [`run_cell`]). Nothing depends on
//! scheduling, thread count or on which other cells a manifest contains.

pub use crate::block::draw_block_weights;
use crate::deal::{Deal, Lane};
pub use crate::plan::{
    action_rng, draw_weights, reset_seed, return_within_bound, weight_rng, with_end_hint, CellPlan,
    EpisodeResult, NonFinite, SampleError, WeightDist, MAX_RETURN,
};
pub use crate::policy::PolicyKind;
use crate::policy::{Policy, PolicyLanes};
use rayon::prelude::*;
use rwg_env::env::{EnvError, Environment};
use std::ops::Range;

/// Per-worker buffers: a policy and an observation buffer.
pub struct Worker<E> {
    env: E,
    policy: Policy,
    obs: Vec<f64>,
}

impl<E: Environment> Worker<E> {
    /// A worker for `plan` on `env`.
    pub fn new(env: E, plan: &CellPlan) -> Self {
        let spec = env.spec();
        let policy = plan.policy(spec, 0);
        let obs = vec![0.0; spec.obs_dim()];
        Worker { env, policy, obs }
    }

    /// Draws network `sample`'s weights (or, for random actions, each
    /// episode's generator) and runs its episodes into `out` (length
    /// `plan.episodes`).
    pub fn run_sample(
        &mut self,
        plan: &CellPlan,
        sample: u64,
        out: &mut [EpisodeResult],
    ) -> Result<(), SampleError> {
        let mut rng = weight_rng(plan.seed, &plan.env_id, &plan.arch, sample);
        draw_weights(&mut rng, plan.dist, self.policy.weights_mut());
        for (episode, slot) in out.iter_mut().enumerate() {
            let episode = episode as u32;
            let r = reset_seed(plan.seed, &plan.env_id, sample, episode);
            plan.begin_episode(&mut self.policy, sample, episode);
            let nf = (plan.non_finite, plan.dist.scale());
            *slot = run_episode(&mut self.env, &mut self.policy, &mut self.obs, r, nf).map_err(
                |(step, error)| SampleError {
                    env: plan.env_id.clone(),
                    sample,
                    episode,
                    step,
                    error,
                },
            )?;
        }
        Ok(())
    }

    /// The worker's policy (holding the last sample's weights).
    pub fn policy(&self) -> &Policy {
        &self.policy
    }
}

thread_local! {
    /// (network, episode) of the reset the sampler calls next on this thread.
    static STARTING: std::cell::Cell<(u64, u32)> = const { std::cell::Cell::new((0, 0)) };
}

/// The network (sample index) and episode whose `reset` the sampler is
/// calling on this thread: an environment wrapper reads it in `reset` to
/// name the episode in a crash report (`rwg run`'s plugin fault messages).
/// Set once per episode, so it costs nothing per step.
pub fn starting_episode() -> (u64, u32) {
    STARTING.with(|c| c.get())
}

/// Number of episodes [`run_blocks`] runs side by side in each worker
/// ([`LaneWorker`]).
pub const LANES: usize = 16;

/// A worker that runs `K` episodes side by side, each on its own environment
/// instance, with one [`PolicyLanes`] for their networks.
///
/// The results are exactly those of [`Worker::run_sample`] (same weights,
/// reset seeds and arithmetic), only computed faster: one episode is a chain
/// of dependent operations (policy, then env step, then policy, ...) whose
/// latency leaves the CPU mostly idle, and `K` independent chains overlap.
/// The episodes of a block are handed out in order (sample-major) to the
/// lanes as they become free, so lanes stay busy until the block's last
/// episodes.
pub struct LaneWorker<E, const K: usize> {
    envs: Vec<E>,
    policy: PolicyLanes<K>,
    /// `K` observations, lane-major.
    obs: Vec<f64>,
    obs_dim: usize,
    /// The weights of every sample of the current block, one after the other.
    block_weights: Vec<f64>,
}

impl<E: Environment, const K: usize> LaneWorker<E, K> {
    /// A worker for `plan` with `K` environments from `make_env`.
    pub fn new(mut make_env: impl FnMut() -> E, plan: &CellPlan) -> Self {
        let envs: Vec<E> = (0..K).map(|_| make_env()).collect();
        let spec = envs[0].spec();
        let obs_dim = spec.obs_dim();
        let policy = plan.lanes(spec);
        LaneWorker {
            obs: vec![0.0; K * obs_dim],
            obs_dim,
            policy,
            envs,
            block_weights: Vec::new(),
        }
    }

    /// Runs every episode of the samples `samples` into `out` (length
    /// `samples × plan.episodes`, sample-major), as [`Worker::run_sample`]
    /// would one sample after the other. On failure returns the error of the
    /// first failing episode in that order (the episodes before it are
    /// finished first), as the sequential loop would.
    pub fn run_block(
        &mut self,
        plan: &CellPlan,
        samples: Range<u64>,
        out: &mut [EpisodeResult],
    ) -> Result<(), SampleError> {
        let nw = self.policy.shape().n_weights();
        let weights = std::mem::take(&mut self.block_weights);
        let mut deal = Deal::new(plan, samples, nw, weights, out);
        let mut lanes = [Lane::<bool>::IDLE; K];
        for (i, lane) in lanes.iter_mut().enumerate() {
            self.start_next(&mut deal, i, lane);
        }
        while lanes.iter().any(|l| l.running()) {
            self.policy.forward(&self.obs);
            let (_, ended) = deal.stop_non_finite(&self.policy, &mut lanes, out);
            self.step_lanes(&mut deal, &mut lanes, out);
            if ended != 0 {
                self.start_ended(&mut deal, &mut lanes, ended);
            }
            deal.cut_off(&mut lanes);
        }
        deal.finish(&mut self.block_weights)
    }

    /// Steps every running lane once with its action; a lane whose episode
    /// ended starts the next one.
    #[inline(always)]
    fn step_lanes(
        &mut self,
        deal: &mut Deal<'_>,
        lanes: &mut [Lane<bool>; K],
        out: &mut [EpisodeResult],
    ) {
        let d = self.obs_dim;
        for (i, lane) in lanes.iter_mut().enumerate() {
            if !lane.running() {
                continue;
            }
            let action = self.policy.action(i);
            match self.envs[i].step(action, &mut self.obs[i * d..(i + 1) * d]) {
                Ok(s) => {
                    if deal.stepped(lane, s.reward, s.terminated || s.truncated, out) {
                        self.start_next(deal, i, lane);
                    }
                }
                Err(err) => {
                    lane.stop();
                    if deal.env_failed_cold(lane, lane.steps + 1, err, out) {
                        self.start_next(deal, i, lane);
                    }
                }
            }
        }
    }

    /// Deals the next episodes to the lanes of `ended` (bit `l`: lane `l`),
    /// whose episodes a network output that was not finite ended.
    #[cold]
    fn start_ended(&mut self, deal: &mut Deal<'_>, lanes: &mut [Lane<bool>; K], ended: u64) {
        for (i, lane) in lanes.iter_mut().enumerate() {
            if ended >> i & 1 == 1 {
                self.start_next(deal, i, lane);
            }
        }
    }

    /// Starts the next episode of the block on lane `i` (resetting its env,
    /// loading its network's weights), unless all have started or one failed.
    fn start_next(&mut self, deal: &mut Deal<'_>, i: usize, lane: &mut Lane<bool>) {
        let Some(ep) = deal.next(&mut self.policy, i, lane) else {
            return;
        };
        let d = self.obs_dim;
        STARTING.with(|c| c.set((deal.samples().start + ep.k as u64, ep.episode)));
        match self.envs[i].reset(ep.seed, &mut self.obs[i * d..(i + 1) * d]) {
            Ok(()) => lane.begin(true),
            Err(err) => deal.fail(ep.item, 0, err),
        }
    }
}

/// Runs one episode from `env.reset(seed=reset_seed)` until it terminates or
/// is truncated, as the lane loops do (a value that is not finite fails it
/// or, with [`NonFinite::End`], ends it there, flagged). The loop allocates
/// nothing. On failure returns the step (0 = reset) and the error.
#[inline]
pub fn run_episode<E: Environment>(
    env: &mut E,
    policy: &mut Policy,
    obs: &mut [f64],
    reset_seed: u64,
    (non_finite, scale): (NonFinite, f64),
) -> Result<EpisodeResult, (u32, EnvError)> {
    env.reset(reset_seed, obs).map_err(|e| (0, e))?;
    let end = non_finite == NonFinite::End;
    let mut score = 0.0;
    let mut steps = 0u32;
    loop {
        let action = match policy.act_checked(obs) {
            Ok(a) => a,
            Err(_) if end => return Ok(EpisodeResult::cut(score, steps)),
            Err(v) => return Err((steps + 1, crate::block::non_finite_output(scale, v))),
        };
        let s = match env.step(action, obs) {
            Ok(s) => s,
            Err(EnvError::NonFinite(_)) if end => return Ok(EpisodeResult::cut(score, steps + 1)),
            Err(e) => return Err((steps + 1, crate::plan::stopping(e))),
        };
        let total = score + s.reward;
        steps += 1;
        if !crate::plan::return_within_bound(total) {
            if end {
                return Ok(EpisodeResult::cut(score, steps));
            }
            let err = crate::plan::return_refused(s.reward, total);
            return Err((steps, crate::plan::stopping(err)));
        }
        score = total;
        if s.terminated || s.truncated {
            return Ok(EpisodeResult::new(score, steps));
        }
    }
}

/// The results of a block of consecutive samples.
#[derive(Debug, Clone, PartialEq)]
pub struct BlockResult {
    /// The samples of the block.
    pub samples: Range<u64>,
    /// `episodes` results per sample, sample-major.
    pub episodes: Vec<EpisodeResult>,
}

impl BlockResult {
    /// The block of `samples` with `episodes` results per sample, filled in
    /// by `run` (a lane worker's `run_block`).
    pub fn compute(
        samples: Range<u64>,
        episodes: usize,
        run: impl FnOnce(&mut [EpisodeResult]) -> Result<(), SampleError>,
    ) -> Result<BlockResult, SampleError> {
        let n = (samples.end - samples.start) as usize;
        let mut results = vec![EpisodeResult::EMPTY; n * episodes];
        run(&mut results)?;
        Ok(BlockResult {
            samples,
            episodes: results,
        })
    }
}

/// Runs `samples` of a cell in parallel, in blocks of `block_size` samples;
/// see [`run_blocks`].
pub fn run_cell<E, F, G, X>(
    plan: &CellPlan,
    samples: Range<u64>,
    block_size: u64,
    wave: usize,
    make_env: F,
    on_block: G,
) -> Result<(), X>
where
    E: Environment + Send,
    F: Fn() -> E + Sync,
    G: FnMut(BlockResult) -> Result<(), X>,
    X: From<SampleError> + Send,
{
    run_blocks(plan, &blocks(samples, block_size), wave, make_env, on_block)
}

/// `samples` cut into consecutive blocks of `block_size` samples (at least
/// 1), the last one shorter if need be: the blocks [`run_cell`] runs.
pub fn blocks(samples: Range<u64>, block_size: u64) -> Vec<Range<u64>> {
    let block_size = block_size.max(1);
    (samples.start..samples.end)
        .step_by(block_size as usize)
        .map(|s| s..(s + block_size).min(samples.end))
        .collect()
}

/// Runs the given blocks of samples of a cell in parallel (on the current
/// rayon pool) and hands the finished blocks to `on_block` in the order given.
/// Blocks are computed `wave` at a time, so memory stays bounded by
/// `wave × block × episodes` results. Each worker task runs [`LANES`]
/// episodes side by side ([`LaneWorker`]), so `make_env` is called `LANES`
/// times per worker task (an instance is used by one thread at a time); the
/// results are exactly those of running the episodes one after the other.
/// Stops at the first error (the first failing episode of a block, in
/// order), or the first error `on_block` returns (e.g. on an interrupt);
/// everything handed to `on_block` before stays valid.
pub fn run_blocks<E, F, G, X>(
    plan: &CellPlan,
    blocks: &[Range<u64>],
    wave: usize,
    make_env: F,
    mut on_block: G,
) -> Result<(), X>
where
    E: Environment + Send,
    F: Fn() -> E + Sync,
    G: FnMut(BlockResult) -> Result<(), X>,
    X: From<SampleError> + Send,
{
    let e = plan.episodes as usize;
    for wave_blocks in blocks.chunks(wave.max(1)) {
        let results: Vec<Result<BlockResult, SampleError>> = wave_blocks
            .par_iter()
            .map_init(
                || LaneWorker::<E, LANES>::new(&make_env, plan),
                |worker, range| {
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
mod tests {
    use super::*;
    use crate::policy::Architecture;

    use rwg_env::env::{Action, EnvSpec, Step};
    use rwg_env::space::{BoxSpace, Space};

    /// A toy env: episodes of 1 + (seed % 9) steps, reward = obs; fails at
    /// step 2 of episodes whose reset seed is a multiple of `fail_every`
    /// (and at reset when it is also a multiple of 3).
    struct Flaky {
        spec: EnvSpec,
        seed: u64,
        t: u64,
        fail_every: u64,
    }

    impl Flaky {
        fn new(fail_every: u64) -> Self {
            Flaky {
                spec: EnvSpec {
                    id: "Flaky-v0".into(),
                    observation_space: Space::Box(BoxSpace::symmetric(&[1e9])),
                    action_space: Space::Discrete { n: 2 },
                    max_episode_steps: None,
                    reward_threshold: None,
                },
                seed: 0,
                t: 0,
                fail_every,
            }
        }
    }

    impl Environment for Flaky {
        fn spec(&self) -> &EnvSpec {
            &self.spec
        }
        fn reset(&mut self, seed: u64, obs: &mut [f64]) -> Result<(), EnvError> {
            if seed.is_multiple_of(self.fail_every) && seed.is_multiple_of(3) {
                return Err(EnvError::Other(format!("reset {seed}")));
            }
            self.seed = seed;
            self.t = 0;
            obs[0] = (seed % 1000) as f64 / 1000.0;
            Ok(())
        }
        fn step(&mut self, a: Action<'_>, obs: &mut [f64]) -> Result<Step, EnvError> {
            let a = rwg_env::env::discrete_action(a, 2)?;
            self.t += 1;
            if self.seed.is_multiple_of(self.fail_every) && self.t == 2 {
                return Err(EnvError::Other(format!("step {}", self.seed)));
            }
            obs[0] = obs[0] * 0.5 + a as f64;
            Ok(Step {
                reward: obs[0],
                terminated: self.t > self.seed % 9,
                truncated: false,
            })
        }
    }

    fn flaky_plan(episodes: u32) -> CellPlan {
        CellPlan {
            seed: 1,
            env_id: "Flaky-v0".into(),
            arch: Architecture {
                hidden: vec![3],
                bias: true,
            },
            episodes,
            dist: WeightDist::Normal { std: 1.0 },
            policy: crate::policy::PolicyKind::Network,
            non_finite: Default::default(),
        }
    }

    /// The sequential loop's results (or first error) for `samples`.
    fn sequential(
        plan: &CellPlan,
        fail_every: u64,
        samples: Range<u64>,
    ) -> Result<Vec<EpisodeResult>, SampleError> {
        let mut w = Worker::new(Flaky::new(fail_every), plan);
        let e = plan.episodes as usize;
        let mut out = vec![
            EpisodeResult {
                score: 0.0,
                steps: 0,
                non_finite: false,
            };
            (samples.end - samples.start) as usize * e
        ];
        for (k, s) in samples.enumerate() {
            w.run_sample(plan, s, &mut out[k * e..(k + 1) * e])?;
        }
        Ok(out)
    }

    #[test]
    fn lanes_give_the_sequential_results_and_first_error() {
        let (mut oks, mut step_errs, mut reset_errs) = (0, 0, 0);
        let kinds = [PolicyKind::Network, PolicyKind::Random];
        for (episodes, policy) in [1, 2, 5].into_iter().flat_map(|e| kinds.map(|k| (e, k))) {
            let plan = CellPlan {
                policy,
                ..flaky_plan(episodes)
            };
            // fail_every 1 << 40: no failure; small values: failures in
            // various positions of the block.
            for fail_every in [1 << 40, 2, 5, 11, 37] {
                for samples in [0..1, 0..6, 7..20] {
                    let want = sequential(&plan, fail_every, samples.clone());
                    let mut lw = LaneWorker::<_, 3>::new(|| Flaky::new(fail_every), &plan);
                    let n = (samples.end - samples.start) as usize * episodes as usize;
                    let mut got = vec![
                        EpisodeResult {
                            score: f64::NAN,
                            steps: 0,
                            non_finite: false,
                        };
                        n
                    ];
                    let res = lw.run_block(&plan, samples.clone(), &mut got);
                    match want {
                        Ok(want) => {
                            assert_eq!(res, Ok(()), "{episodes} {fail_every} {samples:?}");
                            assert_eq!(got, want, "{episodes} {fail_every} {samples:?}");
                            oks += 1;
                        }
                        Err(e) => {
                            if e.step == 0 {
                                reset_errs += 1;
                            } else {
                                step_errs += 1;
                            }
                            assert_eq!(res, Err(e), "{episodes} {fail_every} {samples:?}");
                        }
                    }
                }
            }
        }
        assert!(
            oks > 0 && step_errs > 0 && reset_errs > 0,
            "{oks} {step_errs} {reset_errs}"
        );
    }

    /// A random cell's episodes differ from a network's (its actions are
    /// drawn, not computed) and from one seed to another, and do not
    /// depend on how many lanes run them.
    #[test]
    fn random_actions_are_drawn_per_episode() {
        let run = |policy, seed, lanes: bool| {
            let plan = CellPlan {
                policy,
                seed,
                ..flaky_plan(4)
            };
            if lanes {
                let mut got = vec![EpisodeResult::EMPTY; 40];
                let mut lw = LaneWorker::<_, 4>::new(|| Flaky::new(1 << 40), &plan);
                lw.run_block(&plan, 0..10, &mut got).unwrap();
                got
            } else {
                sequential(&plan, 1 << 40, 0..10).unwrap()
            }
        };
        let random = run(PolicyKind::Random, 1, false);
        assert_eq!(random, run(PolicyKind::Random, 1, true));
        assert_ne!(random, run(PolicyKind::Network, 1, false));
        assert_ne!(random, run(PolicyKind::Random, 2, false));
    }

    #[test]
    fn a_total_beyond_the_bound_fails_or_ends_the_episode_at_its_step() {
        use crate::test_envs::Toy;
        // Toy(5): rewards of f64::MAX in episodes whose seed % 5 == 2
        let mut seen = 0;
        for non_finite in [NonFinite::Stop, NonFinite::End] {
            let plan = CellPlan {
                env_id: "Toy-v0".into(),
                non_finite,
                ..flaky_plan(1)
            };
            for n in 0..40 {
                let seed = reset_seed(plan.seed, "Toy-v0", n, 0);
                if seed % 5 != 2 {
                    continue;
                }
                let mut lw = LaneWorker::<_, 3>::new(|| Toy::new(5, false), &plan);
                let mut got = [EpisodeResult::EMPTY];
                let res = lw.run_block(&plan, n..n + 1, &mut got);
                let mut w = Worker::new(Toy::new(5, false), &plan);
                let mut seq = [EpisodeResult::EMPTY];
                assert_eq!(res, w.run_sample(&plan, n, &mut seq), "sample {n}");
                if non_finite == NonFinite::End {
                    assert_eq!(res, Ok(()));
                    assert_eq!(got, [EpisodeResult::cut(0.0, 1)]);
                    assert_eq!(seq, got);
                    continue;
                }
                let e = res.unwrap_err();
                assert_eq!((e.sample, e.episode, e.step), (n, 0, 1));
                let want = "the episode's total reward is 1.7976931348623157e308, beyond ±1e100";
                assert!(e.error.to_string().starts_with(want), "{e}");
                seen += 1;
            }
        }
        assert!(seen > 0, "no episode of f64::MAX rewards");
    }

    #[test]
    fn with_end_values_not_finite_end_episodes_as_the_sequential_loop_does() {
        use crate::test_envs::Toy;
        let (mut cut, mut whole) = (0, 0);
        for continuous in [false, true] {
            let plan = CellPlan {
                env_id: "Toy-v0".into(),
                non_finite: NonFinite::End,
                ..flaky_plan(3)
            };
            let n = 40;
            let mut got = vec![EpisodeResult::EMPTY; n * 3];
            let mut lw = LaneWorker::<_, 4>::new(|| Toy::with_values(1 << 40, continuous), &plan);
            assert_eq!(lw.run_block(&plan, 0..n as u64, &mut got), Ok(()));
            let mut w = Worker::new(Toy::with_values(1 << 40, continuous), &plan);
            let mut seq = vec![EpisodeResult::EMPTY; n * 3];
            for (k, out) in seq.chunks_mut(3).enumerate() {
                w.run_sample(&plan, k as u64, out).unwrap();
            }
            assert_eq!(got, seq, "continuous {continuous}");
            cut += got.iter().filter(|r| r.non_finite).count();
            whole += got.iter().filter(|r| !r.non_finite).count();
        }
        assert!(cut > 4 && whole > cut, "{cut} cut, {whole} whole");
    }

    #[test]
    fn blocks_cut_samples_in_order() {
        assert_eq!(blocks(0..70, 32), [0..32, 32..64, 64..70]);
        assert_eq!(blocks(10..12, 0), [10..11, 11..12]);
        assert!(blocks(5..5, 32).is_empty());
    }
}
