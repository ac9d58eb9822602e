use super::*;
use crate::policy::Architecture;
use crate::policy::PolicyKind;
use crate::sampler::{LaneWorker, WeightDist};
use crate::test_envs::Toy;
use rwg_env::Environment;

/// An exchange in flight: group, ops, discrete and continuous actions.
type Sent = (usize, Vec<LaneOp>, Vec<i64>, Vec<f64>);

/// `groups` × `LANES` plain envs behind the remote interface, as a bridge
/// would host them; exchanges are answered in the order sent.
struct Hosted {
    envs: Vec<Toy>,
    groups: usize,
    queue: std::collections::VecDeque<Sent>,
}

impl Hosted {
    fn new(toy: Toy, groups: usize) -> Self {
        Hosted {
            envs: vec![toy; groups * LANES],
            groups,
            queue: Default::default(),
        }
    }
}

impl RemoteEnv for Hosted {
    fn spec(&self) -> &EnvSpec {
        self.envs[0].spec()
    }
    fn lanes(&self) -> usize {
        LANES
    }
    fn groups(&self) -> usize {
        self.groups
    }
    fn send(
        &mut self,
        group: usize,
        ops: &[LaneOp],
        actions: LaneActions<'_>,
    ) -> Result<(), RemoteFailure> {
        self.queue.push_back((
            group,
            ops.to_vec(),
            actions.discrete.to_vec(),
            actions.continuous.to_vec(),
        ));
        Ok(())
    }
    fn recv(
        &mut self,
        group: usize,
        obs: &mut [f64],
        out: &mut [LaneOutcome],
    ) -> Result<(), RemoteFailure> {
        let (g, ops, discrete, continuous) = self.queue.pop_front().expect("in flight");
        assert_eq!(g, group, "answers come back in the order sent");
        for i in 0..LANES {
            let env = &mut self.envs[g * LANES + i];
            let o = &mut obs[i * 2..(i + 1) * 2];
            out[i] = match ops[i] {
                LaneOp::Idle => LaneOutcome::Idle,
                LaneOp::Reset(s) => match env.reset(s, o) {
                    Ok(()) => LaneOutcome::Reset,
                    Err(e) => LaneOutcome::Failed(e),
                },
                LaneOp::Step => {
                    let a = if continuous.is_empty() {
                        Action::Discrete(discrete[i])
                    } else {
                        Action::Continuous(&continuous[i..i + 1])
                    };
                    match env.step(a, o) {
                        Ok(s) => LaneOutcome::Step(s),
                        Err(e) => LaneOutcome::Failed(e),
                    }
                }
            };
        }
        Ok(())
    }
}

#[test]
fn remote_lanes_give_the_lane_workers_results_and_first_error() {
    let (mut oks, mut errs) = (0, 0);
    let kinds = [PolicyKind::Network, PolicyKind::Random];
    for (continuous, policy) in [false, true]
        .into_iter()
        .flat_map(|c| kinds.map(|k| (c, k)))
    {
        for episodes in [1, 3] {
            let plan = CellPlan {
                seed: 5,
                env_id: "Toy-v0".into(),
                arch: Architecture {
                    hidden: vec![3],
                    bias: true,
                },
                episodes,
                dist: WeightDist::Normal { std: 1.0 },
                policy,
                non_finite: Default::default(),
            };
            for fail_every in [1 << 40, 3, 13, 41] {
                for samples in [0..1, 0..9, 20..40] {
                    let n = (samples.end - samples.start) as usize * episodes as usize;
                    let blank = EpisodeResult {
                        score: f64::NAN,
                        steps: 0,
                        non_finite: false,
                    };
                    let mut want = vec![blank; n];
                    let mut lw =
                        LaneWorker::<_, LANES>::new(|| Toy::new(fail_every, continuous), &plan);
                    let r_want = lw.run_block(&plan, samples.clone(), &mut want);
                    for groups in [1, 2, 3] {
                        let hosted = Hosted::new(Toy::new(fail_every, continuous), groups);
                        let mut bw = RemoteLaneWorker::new(hosted, &plan);
                        let mut got = vec![blank; n];
                        let r_got = bw.run_block(&plan, samples.clone(), &mut got);
                        assert_eq!(
                            r_got, r_want,
                            "{continuous} {fail_every} {samples:?} {groups}"
                        );
                        if r_want.is_ok() {
                            assert_eq!(got, want);
                            oks += 1;
                        } else {
                            errs += 1;
                        }
                        // the worker runs the next block on the same env
                        if groups == 2 && r_want.is_ok() {
                            let mut again = vec![blank; n];
                            assert_eq!(bw.run_block(&plan, samples.clone(), &mut again), Ok(()));
                            assert_eq!(again, want);
                        }
                    }
                }
            }
        }
    }
    assert!(oks > 0 && errs > 0, "{oks} {errs}");
}

#[test]
fn with_end_remote_lanes_end_the_episodes_the_lane_workers_end() {
    for continuous in [false, true] {
        let plan = CellPlan {
            seed: 5,
            env_id: "Toy-v0".into(),
            arch: Architecture {
                hidden: vec![3],
                bias: true,
            },
            episodes: 3,
            dist: WeightDist::Normal { std: 1.0 },
            policy: crate::policy::PolicyKind::Network,
            non_finite: crate::plan::NonFinite::End,
        };
        let n = 40 * 3;
        let mut want = vec![EpisodeResult::EMPTY; n];
        let toy = || Toy::with_values(1 << 40, continuous);
        let mut lw = LaneWorker::<_, LANES>::new(toy, &plan);
        assert_eq!(lw.run_block(&plan, 0..40, &mut want), Ok(()));
        assert!(want.iter().filter(|r| r.non_finite).count() > 4);
        for groups in [1, 2] {
            let mut bw = RemoteLaneWorker::new(Hosted::new(toy(), groups), &plan);
            let mut got = vec![EpisodeResult::EMPTY; n];
            assert_eq!(bw.run_block(&plan, 0..40, &mut got), Ok(()));
            assert_eq!(got, want, "continuous {continuous}, {groups} groups");
            // episodes ended by a value not finite leave the env sound
            assert!(bw.into_env().is_some());
        }
    }
}

#[test]
fn pool_reuses_and_drops_failed_envs() {
    let plan = CellPlan {
        seed: 1,
        env_id: "Toy-v0".into(),
        arch: Architecture {
            hidden: vec![],
            bias: false,
        },
        episodes: 2,
        dist: WeightDist::Normal { std: 1.0 },
        policy: crate::policy::PolicyKind::Network,
        non_finite: Default::default(),
    };
    let pool = RemotePool::default();
    let made = std::sync::atomic::AtomicUsize::new(0);
    let make = || {
        made.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
        Ok(Hosted::new(Toy::new(1 << 40, false), 2))
    };
    let blocks = [0..4, 4..8, 8..12];
    let mut n = 0;
    let pool_ref = &pool;
    rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap()
        .install(|| {
            run_blocks_remote(&plan, &blocks, 2, pool_ref, make, |b| {
                n += b.episodes.len();
                Ok::<(), SampleError>(())
            })
        })
        .unwrap();
    assert_eq!(n, 24);
    assert_eq!(pool.idle(), 1);
    assert_eq!(made.load(std::sync::atomic::Ordering::SeqCst), 1);
}

/// [`Hosted`] whose `dies_at`-th answer is a whole-env failure between
/// calls (its process killed while it waited).
struct DiesBetweenCalls {
    hosted: Hosted,
    answers: usize,
    dies_at: usize,
}

impl RemoteEnv for DiesBetweenCalls {
    fn spec(&self) -> &EnvSpec {
        self.hosted.spec()
    }
    fn lanes(&self) -> usize {
        LANES
    }
    fn groups(&self) -> usize {
        self.hosted.groups()
    }
    fn send(
        &mut self,
        group: usize,
        ops: &[LaneOp],
        actions: LaneActions<'_>,
    ) -> Result<(), RemoteFailure> {
        self.hosted.send(group, ops, actions)
    }
    fn recv(
        &mut self,
        group: usize,
        obs: &mut [f64],
        out: &mut [LaneOutcome],
    ) -> Result<(), RemoteFailure> {
        self.answers += 1;
        if self.answers == self.dies_at {
            return Err(RemoteFailure {
                lane: None,
                between_calls: true,
                error: EnvError::Other("the worker was killed by signal 9".into()),
            });
        }
        self.hosted.recv(group, obs, out)
    }
}

/// A failure between calls is recorded at the earliest busy episode after
/// its last step (not at a step it did not take), saying that no episode
/// caused it and naming the episodes in progress.
#[test]
fn a_failure_between_calls_blames_no_episode() {
    let plan = CellPlan {
        seed: 1,
        env_id: "Toy-v0".into(),
        arch: Architecture {
            hidden: vec![],
            bias: false,
        },
        episodes: 2,
        dist: WeightDist::Normal { std: 1.0 },
        policy: crate::policy::PolicyKind::Network,
        non_finite: Default::default(),
    };
    let env = DiesBetweenCalls {
        hosted: Hosted::new(Toy::new(1 << 40, false), 1),
        answers: 0,
        dies_at: 3,
    };
    let mut bw = RemoteLaneWorker::new(env, &plan);
    let mut out = vec![
        EpisodeResult {
            score: f64::NAN,
            steps: 0,
            non_finite: false,
        };
        2 * 32
    ];
    let e = bw.run_block(&plan, 32..64, &mut out).unwrap_err();
    // answers 1 (resets) and 2 (step 1) came back: step 1 is the last taken
    // (sample 32's episode 0 ended there; the earliest busy one is episode 1)
    assert_eq!((e.sample, e.episode, e.step), (32, 1, 1), "{e}");
    let text = e.error.to_string();
    assert!(
        text.starts_with("the worker was killed by signal 9; no reset or step was in flight"),
        "{text}"
    );
    assert!(
        text.contains(
            "the episodes in progress were: sample 32, episode 1 (after step 1); \
             sample 33, episode 0 (after step 1)"
        ),
        "{text}"
    );
    assert!(text.contains("12 more"), "{text}");
    assert!(bw.into_env().is_none(), "a dead remote env is not reused");
}
