//! Remote environments: many instances in another process, reset or stepped
//! together in one exchange, and the sampler loop that drives them.
//!
//! The built-in and plugin environments are stepped one instance at a time
//! ([`crate::sampler::LaneWorker`], static dispatch). An environment hosted
//! elsewhere — a Python process running Gymnasium (the `rwg-gym` crate) —
//! pays a round trip per call, so it implements [`RemoteEnv`] instead: one
//! call resets or steps every lane of a worker at once. [`run_blocks_remote`]
//! is [`crate::sampler::run_blocks`] for such environments, with the same
//! weights, reset seeds, network arithmetic and episode bookkeeping, so the
//! results are identical to running the same environment one episode after
//! the other. [`SingleLane`] runs one instance as a plain environment.

use crate::block::make_failed;
use crate::deal::{Deal, Status};
use crate::policy::PolicyLanes;
use crate::sampler::{BlockResult, CellPlan, EpisodeResult, SampleError, LANES};
use rayon::prelude::*;
use rwg_env::Action;
use rwg_env::{EnvError, EnvSpec, Step};
use std::ops::Range;
use std::sync::Mutex;

/// What one lane does in an exchange.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LaneOp {
    /// Nothing (its observation slot is left alone).
    Idle,
    /// `env.reset(seed=...)`.
    Reset(u64),
    /// `env.step(action)` with the lane's action.
    Step,
}

/// What one lane reported in an exchange.
#[derive(Debug, Clone, PartialEq)]
pub enum LaneOutcome {
    /// The lane was idle.
    Idle,
    /// The reset succeeded; its observation was written.
    Reset,
    /// The step succeeded; its observation was written.
    Step(Step),
    /// The environment failed on this lane.
    Failed(EnvError),
}

/// The actions of one exchange, for the lanes whose op is [`LaneOp::Step`].
#[derive(Debug, Clone, Copy)]
pub struct LaneActions<'a> {
    /// Discrete actions, one per lane (unused for continuous spaces).
    pub discrete: &'a [i64],
    /// Continuous actions, `action_dim` per lane, lane-major (empty for
    /// discrete spaces).
    pub continuous: &'a [f64],
}

/// The whole remote env failed (e.g. the process hosting it died or hung).
#[derive(Debug, Clone, PartialEq)]
pub struct RemoteFailure {
    /// The lane that was running when it happened, if known, counted across
    /// groups (`group * lanes + lane`).
    pub lane: Option<usize>,
    /// Known to have happened between calls: no lane was being reset or
    /// stepped (e.g. a worker process killed from outside while it waited
    /// for the next exchange), so no episode caused it.
    pub between_calls: bool,
    /// What happened.
    pub error: EnvError,
}

impl From<EnvError> for RemoteFailure {
    fn from(error: EnvError) -> Self {
        RemoteFailure {
            lane: None,
            between_calls: false,
            error,
        }
    }
}

/// Many instances of one environment, reset and stepped together.
///
/// The instances form `groups()` groups of `lanes()` lanes. An exchange with
/// a group is split in two, [`RemoteEnv::send`] and [`RemoteEnv::recv`], so
/// that one group can be in flight while the caller works on another (a
/// remote host then never waits for the caller); the groups' answers come
/// back in the order they were sent.
pub trait RemoteEnv {
    /// The environment's description (the same for every lane).
    fn spec(&self) -> &EnvSpec;

    /// Number of lanes (instances) per group.
    fn lanes(&self) -> usize;

    /// Number of groups.
    fn groups(&self) -> usize {
        1
    }

    /// Starts an exchange with `group`: its lane `i` is to do `ops[i]`.
    fn send(
        &mut self,
        group: usize,
        ops: &[LaneOp],
        actions: LaneActions<'_>,
    ) -> Result<(), RemoteFailure>;

    /// Finishes the oldest exchange in flight, which must be `group`'s: lane
    /// `i`'s observation goes into `obs[i * obs_dim..]`, its outcome into
    /// `out[i]`. An `Err` (from either half) means the whole remote env failed
    /// (e.g. the process hosting it died): no lane's outcome is valid and
    /// the remote env must not be used again; the failure names the lane that was
    /// running, if known.
    fn recv(
        &mut self,
        group: usize,
        obs: &mut [f64],
        out: &mut [LaneOutcome],
    ) -> Result<(), RemoteFailure>;

    /// [`RemoteEnv::send`] then [`RemoteEnv::recv`] with group 0.
    fn exchange(
        &mut self,
        ops: &[LaneOp],
        actions: LaneActions<'_>,
        obs: &mut [f64],
        out: &mut [LaneOutcome],
    ) -> Result<(), RemoteFailure> {
        self.send(0, ops, actions)?;
        self.recv(0, obs, out)
    }
}

/// A set of idle remote environments, shared by the worker threads: a worker
/// takes one (or makes a new one) and gives it back when done, so a costly
/// instance (a process) is reused across blocks and cells.
pub struct RemotePool<B> {
    idle: Mutex<Vec<B>>,
}

impl<B> Default for RemotePool<B> {
    fn default() -> Self {
        RemotePool {
            idle: Mutex::new(Vec::new()),
        }
    }
}

impl<B> RemotePool<B> {
    /// Gives `b` back for reuse.
    pub fn put(&self, b: B) {
        self.idle.lock().unwrap_or_else(|p| p.into_inner()).push(b);
    }

    /// An idle instance, if there is one.
    pub fn take(&self) -> Option<B> {
        self.idle.lock().unwrap_or_else(|p| p.into_inner()).pop()
    }

    /// Calls `f` with the idle instances.
    pub fn with_idle<R>(&self, f: impl FnOnce(&[B]) -> R) -> R {
        f(&self.idle.lock().unwrap_or_else(|p| p.into_inner()))
    }

    /// Number of idle instances.
    pub fn idle(&self) -> usize {
        self.idle.lock().unwrap_or_else(|p| p.into_inner()).len()
    }
}

/// What one lane of a [`RemoteLaneWorker`] is doing.
#[derive(Debug, Clone, Copy, PartialEq)]
enum LaneState {
    Free,
    /// Waiting for its reset (with this seed) in the next exchange.
    Resetting(u64),
    Running,
}

impl Status for LaneState {
    const FREE: LaneState = LaneState::Free;
    #[inline(always)]
    fn running(self) -> bool {
        self == LaneState::Running
    }
}

type Lane = crate::deal::Lane<LaneState>;

/// One group of [`LANES`] lanes of a [`RemoteLaneWorker`], with its networks.
struct Group {
    policy: PolicyLanes<LANES>,
    obs: Vec<f64>,
    lanes: [Lane; LANES],
    ops: Vec<LaneOp>,
    out: Vec<LaneOutcome>,
    discrete: Vec<i64>,
    continuous: Vec<f64>,
    in_flight: bool,
}

/// [`crate::sampler::LaneWorker`] for a [`RemoteEnv`]: [`LANES`] episodes side
/// by side in each of the env's groups, one exchange per group and
/// step of the env. A lane whose episode ends is reset in its group's next exchange
/// (while the other lanes step), so every exchange is a single round trip;
/// with several groups, one is in flight while the worker handles another.
pub struct RemoteLaneWorker<B> {
    env: B,
    groups: Vec<Group>,
    action_dim: usize,
    block_weights: Vec<f64>,
    n_weights: usize,
    /// Set when the environment failed: it must not be reused.
    poisoned: bool,
    /// Set when the whole remote env failed: nothing more can be sent.
    dead: bool,
}

impl<B: RemoteEnv> RemoteLaneWorker<B> {
    /// A worker for `plan` on `env`, whose groups must have [`LANES`] lanes.
    pub fn new(env: B, plan: &CellPlan) -> Self {
        assert_eq!(
            env.lanes(),
            LANES,
            "a remote env of {LANES} lanes per group"
        );
        let spec = env.spec();
        let obs_dim = spec.obs_dim();
        let action_dim = match &spec.action_space {
            rwg_env::Space::Discrete { .. } => 0,
            rwg_env::Space::Box(b) => b.dim(),
        };
        let groups = (0..env.groups())
            .map(|_| Group {
                policy: plan.lanes(spec),
                obs: vec![0.0; LANES * obs_dim],
                lanes: [Lane::IDLE; LANES],
                ops: vec![LaneOp::Idle; LANES],
                out: vec![LaneOutcome::Idle; LANES],
                discrete: vec![0; LANES],
                continuous: vec![0.0; LANES * action_dim],
                in_flight: false,
            })
            .collect();
        RemoteLaneWorker {
            n_weights: plan.net_shape(spec).n_weights(),
            env,
            groups,
            action_dim,
            block_weights: Vec::new(),
            poisoned: false,
            dead: false,
        }
    }

    /// The environment back, unless it failed (then it is dropped).
    pub fn into_env(self) -> Option<B> {
        (!self.poisoned).then_some(self.env)
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
        let weights = std::mem::take(&mut self.block_weights);
        let mut deal = Deal::new(plan, samples, self.n_weights, weights, out);
        for group in &mut self.groups {
            for (i, lane) in group.lanes.iter_mut().enumerate() {
                *lane = Lane::IDLE;
                start_next(&mut deal, &mut group.policy, i, lane);
            }
        }
        for g in 0..self.groups.len() {
            self.send(g, &mut deal, out);
        }
        while self.groups.iter().any(|g| g.in_flight) {
            for g in 0..self.groups.len() {
                if !self.groups[g].in_flight {
                    continue;
                }
                self.groups[g].in_flight = false;
                let group = &mut self.groups[g];
                if let Err(f) = self.env.recv(g, &mut group.obs, &mut group.out) {
                    self.whole_env_failed(f, &mut deal);
                    break;
                }
                self.absorb(g, &mut deal, out);
                for group in &mut self.groups {
                    deal.cut_off(&mut group.lanes);
                }
                self.send(g, &mut deal, out);
            }
        }
        deal.finish(&mut self.block_weights)
    }

    /// Sends group `g`'s next exchange, if any of its lanes is busy.
    fn send(&mut self, g: usize, deal: &mut Deal<'_>, out: &mut [EpisodeResult]) {
        if self.dead {
            return;
        }
        let ad = self.action_dim;
        let group = &mut self.groups[g];
        if group.lanes.iter().all(|l| l.status == LaneState::Free) {
            return;
        }
        if group.lanes.iter().any(|l| l.status == LaneState::Running) {
            group.policy.forward(&group.obs);
            let (any, ended) = deal.stop_non_finite(&group.policy, &mut group.lanes, out);
            if ended != 0 {
                start_ended(deal, group, ended);
            }
            if any && group.lanes.iter().all(|l| l.status == LaneState::Free) {
                return;
            }
        }
        for (i, lane) in group.lanes.iter().enumerate() {
            group.ops[i] = match lane.status {
                LaneState::Free => LaneOp::Idle,
                LaneState::Resetting(seed) => LaneOp::Reset(seed),
                LaneState::Running => {
                    match group.policy.action(i) {
                        Action::Discrete(a) => group.discrete[i] = a,
                        Action::Continuous(a) => {
                            group.continuous[i * ad..(i + 1) * ad].copy_from_slice(a)
                        }
                    }
                    LaneOp::Step
                }
            };
        }
        let actions = LaneActions {
            discrete: &group.discrete,
            continuous: &group.continuous,
        };
        match self.env.send(g, &group.ops, actions) {
            Ok(()) => group.in_flight = true,
            Err(f) => self.whole_env_failed(f, deal),
        }
    }

    /// The whole remote env failed: the lane it names failed (or, if unknown,
    /// every busy lane of every group; between calls, the earliest busy
    /// episode with a message saying that none caused it).
    fn whole_env_failed(&mut self, f: RemoteFailure, deal: &mut Deal<'_>) {
        self.poisoned = true;
        self.dead = true;
        if f.lane.is_none() && f.between_calls {
            for group in &mut self.groups {
                group.in_flight = false;
            }
            return self.failed_between_calls(f.error, deal);
        }
        for (h, group) in self.groups.iter_mut().enumerate() {
            group.in_flight = false;
            for (i, lane) in group.lanes.iter().enumerate() {
                let culprit = f.lane.is_none_or(|c| c == h * LANES + i);
                if lane.status != LaneState::Free && culprit {
                    deal.fail(lane.item, lane.failing_step(), f.error.clone());
                }
            }
        }
    }

    /// A whole-env failure that no reset or step caused: recorded at the
    /// earliest busy episode (after its last step), whose message says so
    /// and names the episodes in progress.
    fn failed_between_calls(&mut self, error: EnvError, deal: &mut Deal<'_>) {
        let mut busy: Vec<&Lane> = self
            .groups
            .iter()
            .flat_map(|g| &g.lanes)
            .filter(|l| l.status != LaneState::Free)
            .collect();
        busy.sort_by_key(|l| l.item);
        let Some(first) = busy.first() else { return };
        let e = deal.plan().episodes as usize;
        let name = |l: &Lane| {
            let at = match l.status {
                LaneState::Running if l.steps == 0 => "after its reset".into(),
                LaneState::Running => format!("after step {}", l.steps),
                _ => "its reset not yet made".into(),
            };
            let sample = deal.samples().start + (l.item / e) as u64;
            format!("sample {sample}, episode {} ({at})", l.item % e)
        };
        let mut list: Vec<String> = busy.iter().take(4).map(|l| name(l)).collect();
        if busy.len() > 4 {
            list.push(format!("{} more", busy.len() - 4));
        }
        let text = format!(
            "{error}; no reset or step was in flight (the worker was between calls: killed \
             from outside, or ended by a thread of its own?), so no episode caused this; the \
             episodes in progress were: {}",
            list.join("; ")
        );
        deal.fail(first.item, first.steps, EnvError::Other(text));
    }

    /// Takes group `g`'s outcomes into its lanes: scores, finished episodes
    /// (their lanes get the next episode), failures.
    fn absorb(&mut self, g: usize, deal: &mut Deal<'_>, out: &mut [EpisodeResult]) {
        let group = &mut self.groups[g];
        for (i, lane) in group.lanes.iter_mut().enumerate() {
            match std::mem::replace(&mut group.out[i], LaneOutcome::Idle) {
                LaneOutcome::Idle => {}
                LaneOutcome::Reset => lane.begin(LaneState::Running),
                LaneOutcome::Step(s) => {
                    let ended = s.terminated || s.truncated;
                    if deal.stepped(lane, s.reward, ended, out) {
                        start_next(deal, &mut group.policy, i, lane);
                    }
                }
                LaneOutcome::Failed(err) => {
                    let step = lane.failing_step();
                    lane.stop();
                    if deal.env_failed(lane, step, err, out) {
                        // a value not finite, the episode ended: the env is sound
                        start_next(deal, &mut group.policy, i, lane);
                    } else {
                        self.poisoned = true;
                    }
                }
            }
        }
    }
}

/// Deals lane `i` the next episode of the block (its network's weights and
/// a pending reset), unless all have started or one failed.
fn start_next(deal: &mut Deal<'_>, policy: &mut PolicyLanes<LANES>, i: usize, lane: &mut Lane) {
    if let Some(ep) = deal.next(policy, i, lane) {
        lane.status = LaneState::Resetting(ep.seed);
    }
}

/// Deals the next episodes to the lanes of `ended` (bit `l`: lane `l`) of
/// `group`, whose episodes a network output that was not finite ended.
#[cold]
fn start_ended(deal: &mut Deal<'_>, group: &mut Group, ended: u64) {
    for (i, lane) in group.lanes.iter_mut().enumerate() {
        if ended >> i & 1 == 1 {
            start_next(deal, &mut group.policy, i, lane);
        }
    }
}

/// A worker on loan from a [`RemotePool`], given back when dropped (unless its
/// environment failed).
struct Lease<'p, B: RemoteEnv> {
    pool: &'p RemotePool<B>,
    worker: Option<RemoteLaneWorker<B>>,
}

impl<B: RemoteEnv> Drop for Lease<'_, B> {
    fn drop(&mut self) {
        if let Some(env) = self.worker.take().and_then(RemoteLaneWorker::into_env) {
            self.pool.put(env);
        }
    }
}

/// [`crate::sampler::run_blocks`] for a remote environment: the blocks run
/// in parallel on the current rayon pool, each worker thread on a remote env
/// taken from `pool` (or made by `make` when none is idle) and given back
/// afterwards, so at most one remote env per thread exists. Results, their
/// order and the first error are those of `run_blocks`.
pub fn run_blocks_remote<B, F, G, X>(
    plan: &CellPlan,
    blocks: &[Range<u64>],
    wave: usize,
    pool: &RemotePool<B>,
    make: F,
    mut on_block: G,
) -> Result<(), X>
where
    B: RemoteEnv + Send,
    F: Fn() -> Result<B, EnvError> + Sync,
    G: FnMut(BlockResult) -> Result<(), X>,
    X: From<SampleError> + Send,
{
    let e = plan.episodes as usize;
    for wave_blocks in blocks.chunks(wave.max(1)) {
        let results: Vec<Result<BlockResult, SampleError>> = wave_blocks
            .par_iter()
            .map_init(
                || -> Result<Lease<'_, B>, EnvError> {
                    let env = match pool.take() {
                        Some(b) => b,
                        None => make()?,
                    };
                    Ok(Lease {
                        pool,
                        worker: Some(RemoteLaneWorker::new(env, plan)),
                    })
                },
                |lease, range| {
                    let lease = lease
                        .as_mut()
                        .map_err(|err| make_failed(plan, range, err))?;
                    let worker = lease.worker.as_mut().expect("a leased worker");
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

mod single;
pub use single::SingleLane;

#[cfg(test)]
mod tests;
