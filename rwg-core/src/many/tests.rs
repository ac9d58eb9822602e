use super::*;
use crate::policy::{Architecture, PolicyKind};
use crate::sampler::{run_blocks, WeightDist};
use crate::test_envs::Toy;
use rwg_env::Space;
use rwg_env::{Action, EnvSpec, Environment};

/// [`LANES`] toys behind the [`ManyEnv`] interface, one call for all lanes.
struct Many {
    envs: Vec<Toy>,
    /// Masks seen (to check that idle lanes are never called).
    calls: usize,
}

impl ManyEnv for Many {
    fn spec(&self) -> &EnvSpec {
        self.envs[0].spec()
    }
    fn lanes(&self) -> usize {
        self.envs.len()
    }
    fn reset_many(
        &mut self,
        mask: &[u8],
        seeds: &[u64],
        obs: &mut [f64],
        on_fail: &mut dyn FnMut(usize, EnvError),
    ) {
        self.calls += 1;
        for (i, env) in self.envs.iter_mut().enumerate() {
            if mask[i] == 1 {
                if let Err(e) = env.reset(seeds[i], &mut obs[i * 2..(i + 1) * 2]) {
                    on_fail(i, e);
                }
            }
        }
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
        self.calls += 1;
        let continuous = matches!(self.envs[0].spec().action_space, Space::Box(_));
        for (i, env) in self.envs.iter_mut().enumerate() {
            if mask[i] != 1 {
                continue;
            }
            let a = if continuous {
                Action::Continuous(&actions[i..i + 1])
            } else {
                Action::Discrete(actions[i] as i64)
            };
            match env.step(a, &mut obs[i * 2..(i + 1) * 2]) {
                Ok(s) => {
                    rewards[i] = s.reward;
                    terminated[i] = u8::from(s.terminated);
                    truncated[i] = u8::from(s.truncated);
                }
                Err(e) => on_fail(i, e),
            }
        }
    }
}

fn plan(episodes: u32) -> CellPlan {
    CellPlan {
        seed: 3,
        env_id: "Toy-v0".into(),
        arch: Architecture {
            hidden: vec![4],
            bias: true,
        },
        episodes,
        dist: WeightDist::Normal { std: 1.0 },
        policy: PolicyKind::Network,
        non_finite: Default::default(),
    }
}

type Outcome = Result<Vec<BlockResult>, SampleError>;

fn collect(
    run: impl FnOnce(&mut dyn FnMut(BlockResult) -> Result<(), SampleError>) -> Result<(), SampleError>,
) -> Outcome {
    let mut blocks = vec![];
    run(&mut |b| {
        blocks.push(b);
        Ok(())
    })?;
    Ok(blocks)
}

#[test]
fn many_lanes_give_the_lane_workers_results_and_first_error() {
    let blocks: Vec<Range<u64>> = vec![0..5, 5..37, 37..40];
    let (mut oks, mut errs) = (0, 0);
    let kinds = [PolicyKind::Network, PolicyKind::Random];
    for (continuous, policy) in [false, true]
        .into_iter()
        .flat_map(|c| kinds.map(|k| (c, k)))
    {
        for episodes in [1, 3] {
            for fail_every in [1 << 40, 97, 13, 5] {
                let toy = Toy::new(fail_every, continuous);
                let p = CellPlan {
                    policy,
                    ..plan(episodes)
                };
                let lanes = collect(|f| run_blocks(&p, &blocks, 2, || toy.clone(), f));
                let many = collect(|f| {
                    run_blocks_many(
                        &p,
                        &blocks,
                        2,
                        || {
                            Ok(Many {
                                envs: vec![toy.clone(); LANES],
                                calls: 0,
                            })
                        },
                        f,
                    )
                });
                assert_eq!(
                    lanes, many,
                    "continuous {continuous}, {episodes} episodes, fail_every {fail_every}"
                );
                match lanes {
                    Ok(_) => oks += 1,
                    Err(_) => errs += 1,
                }
            }
        }
    }
    assert!(oks >= 4 && errs >= 4, "{oks} ok, {errs} failed");
}

#[test]
fn with_end_many_lanes_end_the_episodes_the_lane_workers_end() {
    let blocks: Vec<Range<u64>> = vec![0..5, 5..37, 37..40];
    for continuous in [false, true] {
        let toy = Toy::with_values(1 << 40, continuous);
        let p = CellPlan {
            non_finite: crate::plan::NonFinite::End,
            ..plan(3)
        };
        let lanes = collect(|f| run_blocks(&p, &blocks, 2, || toy.clone(), f));
        let many = collect(|f| {
            run_blocks_many(
                &p,
                &blocks,
                2,
                || {
                    Ok(Many {
                        envs: vec![toy.clone(); LANES],
                        calls: 0,
                    })
                },
                f,
            )
        });
        assert_eq!(lanes, many, "continuous {continuous}");
        let cut = many
            .unwrap()
            .iter()
            .flat_map(|b| b.episodes.clone())
            .filter(|r| r.non_finite)
            .count();
        assert!(cut > 4, "{cut}");
    }
}

#[test]
fn a_worker_makes_one_call_per_step_of_all_lanes() {
    let toy = Toy::new(1 << 40, false);
    let p = plan(2);
    let mut w = ManyLaneWorker::new(
        Many {
            envs: vec![toy; LANES],
            calls: 0,
        },
        &p,
    );
    let mut out = vec![
        EpisodeResult {
            score: 0.0,
            steps: 0,
            non_finite: false,
        };
        64
    ];
    w.run_block(&p, 0..32, &mut out).unwrap();
    let steps: u32 = out.iter().map(|r| r.steps).sum();
    // Far fewer calls than the 64 resets + `steps` steps the single calls make.
    assert!(
        w.env.calls < (64 + steps as usize) / 4,
        "{} calls for {steps} steps",
        w.env.calls
    );
}
