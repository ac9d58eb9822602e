//! The lockstep envs (`rwg_envs::lockstep`) against their scalar twins:
//! every lane gives the observations, rewards, flags, states and errors of a
//! `TimeLimit`-wrapped scalar env bit for bit, under random schedules
//! (masks with holes, episodes ending at different times, lanes reset
//! mid-episode, steps before any reset, invalid and non-finite actions), and
//! lanes outside the mask are left untouched. Then the golden trajectories
//! replayed through the lockstep envs, one trajectory per lane.

use rwg_env::seeding::Pcg64;
use rwg_env::{Action, ActionDtype, EnvError, Environment, Space};
use rwg_envs::{make, visit_lockstep, EnvOptions, LockstepEnv, LockstepVisitor, REGISTRY};
use serde::Deserialize;
use std::path::PathBuf;

/// Builds the lockstep env and runs `f` on it.
struct With<F>(F);

impl<F: FnOnce(&mut dyn LockstepEnv)> LockstepVisitor for With<F> {
    type Output = ();
    fn visit<M: LockstepEnv + Clone + Send + Sync + 'static>(self, mut env: M) {
        (self.0)(&mut env)
    }
}

fn with_lockstep<const N: usize>(
    id: &str,
    opts: &EnvOptions,
    f: impl FnOnce(&mut dyn LockstepEnv),
) {
    if visit_lockstep::<N, _>(id, opts, With(f)).is_err() {
        panic!("{id} has no lockstep version");
    }
}

/// The option sets each env is checked with.
fn option_sets(dtype_sensitive: bool) -> Vec<EnvOptions> {
    let dtypes: &[ActionDtype] = if dtype_sensitive {
        &[ActionDtype::F64, ActionDtype::F32]
    } else {
        &[ActionDtype::F64]
    };
    let mut out = Vec::new();
    for &action_dtype in dtypes {
        for max_episode_steps in [None, Some(23)] {
            out.push(EnvOptions {
                action_dtype,
                max_episode_steps,
            });
        }
    }
    out
}

/// A random action for lane `i` of `space`, sometimes invalid or extreme.
fn random_action(rng: &mut Pcg64, space: &Space) -> f64 {
    let u = rng.uniform(0.0, 1.0);
    match space {
        Space::Discrete { n } => {
            if u < 0.01 {
                *n as f64 // out of range
            } else if u < 0.015 {
                -1.0
            } else if u < 0.02 {
                0.5 // not integral
            } else {
                (rng.uniform(0.0, *n as f64) as u64).min(*n as u64 - 1) as f64
            }
        }
        Space::Box(_) => {
            if u < 0.005 {
                f64::NAN
            } else if u < 0.01 {
                f64::INFINITY
            } else if u < 0.015 {
                -1e200
            } else if u < 0.3 {
                rng.uniform(-3.0, 3.0)
            } else {
                // Policy-like: tanh of a network output, scaled to the box.
                2.0 * rng.uniform(-3.0, 3.0).tanh()
            }
        }
    }
}

const SENTINEL: f64 = -12345.678;

/// Runs `rounds` rounds of a random schedule on `N` lanes of `id` and
/// compares every lane with a scalar env; returns the steps compared.
fn compare<const N: usize>(id: &str, opts: &EnvOptions, seed: u64, rounds: usize) -> usize {
    let mut scalars: Vec<_> = (0..N).map(|_| make(id, opts).unwrap()).collect();
    let spec = scalars[0].spec().clone();
    let d = spec.obs_dim();
    let a_len = match &spec.action_space {
        Space::Discrete { .. } => 1,
        Space::Box(b) => b.dim(),
    };
    assert_eq!(a_len, 1, "the lockstep envs have one-dimensional actions");
    let mut compared = 0;
    with_lockstep::<N>(id, opts, |many| {
        assert_eq!(many.spec(), &spec, "{id}: spec");
        assert_eq!(many.lanes(), N);
        let sl = many.state_len();
        let mut rng = Pcg64::from_seed(seed);
        let mut obs = vec![SENTINEL; N * d];
        let mut want_obs = vec![0.0; d];
        let (mut st, mut want_st) = (vec![0.0; sl], vec![0.0; sl]);
        // Per lane: whether an episode runs.
        let mut running = [false; N];
        let mut ever_reset = [false; N];
        for round in 0..rounds {
            let ctx = |i: usize, what: &str| {
                format!("{id} {opts:?} seed {seed} round {round} lane {i}: {what}")
            };
            // Resets: lanes without an episode mostly, now and then one mid-episode.
            let mut mask = vec![0u8; N];
            let mut seeds = vec![0u64; N];
            for i in 0..N {
                let u = rng.uniform(0.0, 1.0);
                if (!running[i] && u < 0.7) || u < 0.02 {
                    mask[i] = 1;
                    seeds[i] = rng.next_u64() % 1_000_000;
                }
            }
            if mask.contains(&1) {
                let before = obs.clone();
                let mut errs = Vec::new();
                many.reset_many(&mask, &seeds, &mut obs, &mut |i, e| errs.push((i, e)));
                assert!(errs.is_empty(), "{id}: reset errors {errs:?}");
                for i in 0..N {
                    let o = &obs[i * d..(i + 1) * d];
                    if mask[i] == 1 {
                        scalars[i].reset(seeds[i], &mut want_obs).unwrap();
                        assert_bits(o, &want_obs, &ctx(i, "reset obs"));
                        running[i] = true;
                        ever_reset[i] = true;
                    } else {
                        assert_bits(o, &before[i * d..(i + 1) * d], &ctx(i, "untouched obs"));
                    }
                }
            }
            // A step: running lanes with holes, and now and then a lane that
            // was never reset or has finished (stepping on past the end).
            let mut actions = vec![0.0; N * a_len];
            for i in 0..N {
                let u = rng.uniform(0.0, 1.0);
                mask[i] = u8::from((running[i] && u < 0.85) || u < 0.03);
                actions[i] = random_action(&mut rng, &spec.action_space);
            }
            let before = obs.clone();
            let mut rewards = [SENTINEL; N];
            let mut term = [7u8; N];
            let mut trunc = [7u8; N];
            let mut errs: Vec<(usize, EnvError)> = Vec::new();
            many.step_many(
                &mask,
                &actions,
                &mut obs,
                &mut rewards,
                &mut term,
                &mut trunc,
                &mut |i, e| errs.push((i, e)),
            );
            let mut errs = errs.into_iter().peekable();
            for i in 0..N {
                let o = &obs[i * d..(i + 1) * d];
                if mask[i] == 0 {
                    assert_bits(o, &before[i * d..(i + 1) * d], &ctx(i, "untouched obs"));
                    assert_eq!(
                        rewards[i].to_bits(),
                        SENTINEL.to_bits(),
                        "{}",
                        ctx(i, "untouched reward")
                    );
                    assert_eq!((term[i], trunc[i]), (7, 7), "{}", ctx(i, "untouched flags"));
                    continue;
                }
                let action = match spec.action_space {
                    Space::Discrete { .. } => Action::Discrete(actions[i] as i64),
                    Space::Box(_) => Action::Continuous(&actions[i..i + 1]),
                };
                let non_integral = matches!(spec.action_space, Space::Discrete { .. })
                    && actions[i].fract() != 0.0;
                let want = if non_integral {
                    // The sampler never makes one; the lockstep env refuses
                    // it after the reset check, as the scalar env orders its
                    // checks (the text is the lockstep env's own).
                    if ever_reset[i] {
                        Err(EnvError::InvalidAction(String::new()))
                    } else {
                        Err(EnvError::ResetNeeded)
                    }
                } else {
                    want_obs.copy_from_slice(&before[i * d..(i + 1) * d]);
                    scalars[i].step(action, &mut want_obs)
                };
                match want {
                    Ok(s) => {
                        assert!(
                            errs.peek().map(|e| e.0) != Some(i),
                            "{}: {:?}",
                            ctx(i, "unexpected error"),
                            errs.peek()
                        );
                        assert_bits(o, &want_obs, &ctx(i, "obs"));
                        assert_eq!(
                            rewards[i].to_bits(),
                            s.reward.to_bits(),
                            "{}: {} vs {}",
                            ctx(i, "reward"),
                            rewards[i],
                            s.reward
                        );
                        assert_eq!(term[i], u8::from(s.terminated), "{}", ctx(i, "terminated"));
                        assert_eq!(trunc[i], u8::from(s.truncated), "{}", ctx(i, "truncated"));
                        many.lane_state(i, &mut st);
                        scalars[i].state(&mut want_st).unwrap();
                        assert_bits(&st, &want_st, &ctx(i, "state"));
                        if s.terminated || s.truncated {
                            running[i] = false;
                        }
                        compared += 1;
                    }
                    Err(want_err) => {
                        let (j, e) = errs.next().unwrap_or_else(|| {
                            panic!("{}: no error, expected {want_err}", ctx(i, "error"))
                        });
                        assert_eq!(j, i, "{}", ctx(i, "error lane"));
                        if non_integral {
                            assert_eq!(
                                std::mem::discriminant(&e),
                                std::mem::discriminant(&want_err),
                                "{}: {e}",
                                ctx(i, "error")
                            );
                        } else {
                            assert_eq!(
                                e.to_string(),
                                want_err.to_string(),
                                "{}",
                                ctx(i, "error text")
                            );
                        }
                        assert_bits(
                            o,
                            &before[i * d..(i + 1) * d],
                            &ctx(i, "obs after an error"),
                        );
                        // A failed lane is not used again until reset.
                        running[i] = false;
                    }
                }
            }
            assert!(
                errs.next().is_none(),
                "{id}: errors of lanes outside the mask"
            );
        }
    });
    compared
}

fn assert_bits(ours: &[f64], theirs: &[f64], what: &str) {
    let same = ours.len() == theirs.len()
        && ours
            .iter()
            .zip(theirs)
            .all(|(a, b)| a.to_bits() == b.to_bits());
    assert!(same, "{what}: {ours:?} != {theirs:?}");
}

#[test]
fn every_lockstep_env_matches_the_scalar_env_lane_by_lane() {
    for r in REGISTRY {
        for opts in option_sets(r.dtype_sensitive) {
            for seed in 0..3 {
                let n = compare::<16>(r.id, &opts, seed, 700);
                assert!(n > 3000, "{}: only {n} steps compared", r.id);
            }
            // Another lane count (the envs are generic over it).
            assert!(compare::<3>(r.id, &opts, 99, 300) > 100);
        }
    }
}

/// Policy-like trajectories from a state where the scalar env's libm and
/// pow paths all occur: long episodes of every env (no time limit override).
#[test]
fn long_episodes_match() {
    for r in REGISTRY {
        let opts = EnvOptions::default();
        assert!(compare::<16>(r.id, &opts, 1234, 3000) > 20_000, "{}", r.id);
    }
}

// ---- golden trajectories through the lockstep envs ----

#[derive(Deserialize)]
struct Golden {
    trajectories: Vec<Trajectory>,
}

#[derive(Deserialize)]
struct Trajectory {
    seed: u64,
    action_dtype: String,
    reset_state: Vec<f64>,
    reset_obs: Vec<f64>,
    steps: Vec<GoldenStep>,
}

#[derive(Deserialize)]
#[serde(untagged)]
enum GoldenAction {
    Discrete(i64),
    Continuous(Vec<f64>),
}

#[derive(Deserialize)]
struct GoldenStep {
    action: GoldenAction,
    state: Vec<f64>,
    obs: Vec<f64>,
    reward: f64,
    terminated: bool,
    truncated: bool,
}

/// Distance in float32 ulps between two f32-representable values.
fn ulps32(a: f64, b: f64) -> u32 {
    let key = |x: f32| {
        let i = x.to_bits() as i32;
        if i < 0 {
            i32::MIN - i
        } else {
            i
        }
    };
    key(a as f32).abs_diff(key(b as f32))
}

/// Replays `id`'s golden trajectories of one action dtype side by side, one
/// per lane (lanes finish at different steps); returns the steps checked.
fn replay_lockstep(id: &str) -> usize {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join(format!("../tests/data/{id}.json"));
    let g: Golden = serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    let mut checked = 0;
    for dtype in ["int", "float64", "float32"] {
        let trs: Vec<&Trajectory> = g
            .trajectories
            .iter()
            .filter(|t| t.action_dtype == dtype)
            .collect();
        if trs.is_empty() {
            continue;
        }
        assert!(trs.len() <= 16);
        let opts = EnvOptions {
            action_dtype: if dtype == "int" {
                ActionDtype::F64
            } else {
                dtype.parse().unwrap()
            },
            max_episode_steps: None,
        };
        with_lockstep::<16>(id, &opts, |many| {
            let d = many.spec().obs_dim();
            let mut obs = vec![0.0; 16 * d];
            let mut mask = vec![0u8; 16];
            let mut seeds = vec![0u64; 16];
            for (i, t) in trs.iter().enumerate() {
                mask[i] = 1;
                seeds[i] = t.seed;
            }
            many.reset_many(&mask, &seeds, &mut obs, &mut |i, e| panic!("lane {i}: {e}"));
            let mut st = vec![0.0; many.state_len()];
            for (i, t) in trs.iter().enumerate() {
                many.lane_state(i, &mut st);
                assert_bits(
                    &st,
                    &t.reset_state,
                    &format!("{id} seed {} reset state", t.seed),
                );
                for (k, (a, b)) in obs[i * d..(i + 1) * d].iter().zip(&t.reset_obs).enumerate() {
                    // numpy's float32 SIMD cos/sin may be 1 ulp off (golden.rs).
                    let tol = if id == "Acrobot-v1" { 1 } else { 0 };
                    assert!(ulps32(*a, *b) <= tol, "{id} seed {} reset obs[{k}]", t.seed);
                }
            }
            let longest = trs.iter().map(|t| t.steps.len()).max().unwrap();
            for step in 0..longest {
                let mut actions = vec![0.0; 16];
                for (i, t) in trs.iter().enumerate() {
                    mask[i] = u8::from(step < t.steps.len());
                    if mask[i] == 1 {
                        actions[i] = match &t.steps[step].action {
                            GoldenAction::Discrete(a) => *a as f64,
                            GoldenAction::Continuous(v) => v[0],
                        };
                    }
                }
                let (mut rewards, mut term, mut trunc) = ([0.0; 16], [0u8; 16], [0u8; 16]);
                many.step_many(
                    &mask,
                    &actions,
                    &mut obs,
                    &mut rewards,
                    &mut term,
                    &mut trunc,
                    &mut |i, e| panic!("lane {i}: {e}"),
                );
                for (i, t) in trs.iter().enumerate() {
                    if mask[i] == 0 {
                        continue;
                    }
                    let gs = &t.steps[step];
                    let what = format!("{id} {dtype} seed {} step {}", t.seed, step + 1);
                    many.lane_state(i, &mut st);
                    assert_bits(&st, &gs.state, &format!("{what}: state"));
                    assert_bits(&obs[i * d..(i + 1) * d], &gs.obs, &format!("{what}: obs"));
                    assert_eq!(rewards[i].to_bits(), gs.reward.to_bits(), "{what}: reward");
                    assert_eq!(term[i], u8::from(gs.terminated), "{what}: terminated");
                    assert_eq!(trunc[i], u8::from(gs.truncated), "{what}: truncated");
                    checked += 1;
                }
            }
        });
    }
    checked
}

#[test]
fn golden_trajectories_through_lockstep() {
    for r in REGISTRY {
        assert!(replay_lockstep(r.id) > 0, "{}", r.id);
    }
}

/// The tests above, again in a child process per SIMD level this CPU has
/// (`RWG_SIMD=scalar`, `avx2`, `avx512`; the level is read once per
/// process), so the baseline, AVX2 and AVX-512 step bodies are each checked
/// against the scalar envs, whatever level this process runs.
#[test]
fn the_step_bodies_of_every_simd_level_match_too() {
    let exe = std::env::current_exe().unwrap();
    let levels = rwg_env::simd::Simd::available_levels();
    assert_eq!(levels[0], rwg_env::simd::Simd::Scalar);
    for level in levels {
        for name in [
            "every_lockstep_env_matches_the_scalar_env_lane_by_lane",
            "long_episodes_match",
            "golden_trajectories_through_lockstep",
        ] {
            let out = std::process::Command::new(&exe)
                .args(["--exact", name, "--test-threads=1"])
                .env(rwg_env::simd::VAR, level.name())
                .output()
                .unwrap();
            let stdout = String::from_utf8_lossy(&out.stdout);
            assert!(
                out.status.success() && stdout.contains("1 passed"),
                "{name} with RWG_SIMD={level}:\n{stdout}\n{}",
                String::from_utf8_lossy(&out.stderr)
            );
        }
    }
}
