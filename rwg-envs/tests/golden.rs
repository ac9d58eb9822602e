//! Replays every golden trajectory (recorded from Gymnasium 1.4, and from a
//! verified port of gym 0.17.2 for Pendulum-v0) and requires bit-identical
//! states, observations, rewards and flags: the files `tests/data/*.json`
//! (each says how it was recorded in its header fields).

use rwg_env::{Action, ActionDtype, Environment};
use rwg_envs::{make, EnvOptions};
use serde::Deserialize;
use std::path::PathBuf;

#[derive(Deserialize)]
struct Golden {
    env_id: String,
    max_episode_steps: u32,
    reward_threshold: Option<f64>,
    trajectories: Vec<Trajectory>,
}

#[derive(Deserialize)]
struct Trajectory {
    seed: u64,
    action_dtype: String,
    reset_state: Vec<f64>,
    reset_obs: Vec<f64>,
    length: usize,
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

fn data_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../tests/data")
}

fn load(id: &str) -> Golden {
    let path = data_dir().join(format!("{id}.json"));
    let text = std::fs::read_to_string(&path)
        .unwrap_or_else(|e| panic!("cannot read {}: {e}", path.display()));
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// Distance in float32 ulps between two f32-representable values.
fn ulps32(a: f64, b: f64) -> u32 {
    let (a, b) = (a as f32, b as f32);
    let key = |x: f32| {
        let i = x.to_bits() as i32;
        if i < 0 {
            i32::MIN - i
        } else {
            i
        }
    };
    key(a).abs_diff(key(b))
}

fn same_bits(ours: &[f64], theirs: &[f64]) -> bool {
    ours.len() == theirs.len()
        && ours
            .iter()
            .zip(theirs)
            .all(|(a, b)| a.to_bits() == b.to_bits())
}

/// Replays every trajectory of `id` from `reset(seed)`; returns the number of
/// steps checked. Panics at the first mismatch, naming env, seed, step, field.
fn replay(id: &str) -> usize {
    let g = load(id);
    assert_eq!(g.env_id, id);
    let mut checked = 0;
    for tr in &g.trajectories {
        let dtype: ActionDtype = match tr.action_dtype.as_str() {
            "int" => ActionDtype::F64,
            other => other.parse().unwrap(),
        };
        let mut env = make(
            id,
            &EnvOptions {
                action_dtype: dtype,
                max_episode_steps: None,
            },
        )
        .unwrap_or_else(|e| panic!("{e}"));
        let spec = env.spec().clone();
        assert_eq!(
            spec.max_episode_steps,
            Some(g.max_episode_steps),
            "{id}: time limit"
        );
        assert_eq!(
            spec.reward_threshold, g.reward_threshold,
            "{id}: reward threshold"
        );
        let ctx = |step: usize, field: &str| format!("{id} seed {} step {step}: {field}", tr.seed);

        let mut obs = vec![0.0; spec.obs_dim()];
        let mut state = vec![0.0; env.state_len()];
        env.reset(tr.seed, &mut obs).unwrap();
        env.state(&mut state).unwrap();
        assert!(
            same_bits(&state, &tr.reset_state),
            "{}: {state:?} != {:?}",
            ctx(0, "reset_state"),
            tr.reset_state
        );
        if id == "Acrobot-v1" {
            // numpy's float32 SIMD cos/sin may be 1 ulp off the correctly
            // rounded value, which rwg computes.
            for (k, (a, b)) in obs.iter().zip(&tr.reset_obs).enumerate() {
                assert!(
                    ulps32(*a, *b) <= 1,
                    "{}[{k}]: {a:?} vs {b:?}",
                    ctx(0, "reset_obs")
                );
            }
        } else {
            assert!(
                same_bits(&obs, &tr.reset_obs),
                "{}: {obs:?} != {:?}",
                ctx(0, "reset_obs"),
                tr.reset_obs
            );
        }

        for (t, st) in tr.steps.iter().enumerate() {
            let t = t + 1;
            let s = match &st.action {
                GoldenAction::Discrete(a) => env.step(Action::Discrete(*a), &mut obs),
                GoldenAction::Continuous(a) => env.step(Action::Continuous(a), &mut obs),
            }
            .unwrap_or_else(|e| panic!("{}: {e}", ctx(t, "step")));
            env.state(&mut state).unwrap();
            assert!(
                same_bits(&state, &st.state),
                "{}: {state:?} != {:?}",
                ctx(t, "state"),
                st.state
            );
            assert!(
                same_bits(&obs, &st.obs),
                "{}: {obs:?} != {:?}",
                ctx(t, "obs"),
                st.obs
            );
            assert_eq!(
                s.reward.to_bits(),
                st.reward.to_bits(),
                "{}: {:?} != {:?}",
                ctx(t, "reward"),
                s.reward,
                st.reward
            );
            assert_eq!(s.terminated, st.terminated, "{}", ctx(t, "terminated"));
            assert_eq!(s.truncated, st.truncated, "{}", ctx(t, "truncated"));
            checked += 1;
        }
        assert_eq!(tr.steps.len(), tr.length);
        let last = tr.steps.last().unwrap();
        assert!(
            last.terminated || last.truncated,
            "{id} seed {}: trajectory does not end",
            tr.seed
        );
    }
    checked
}

#[test]
fn golden_cartpole_v0() {
    assert!(replay("CartPole-v0") > 0);
}

#[test]
fn golden_cartpole_v1() {
    assert!(replay("CartPole-v1") > 0);
}

#[test]
fn golden_acrobot_v1() {
    assert!(replay("Acrobot-v1") > 0);
}

#[test]
fn golden_mountaincar_v0() {
    assert!(replay("MountainCar-v0") > 0);
}

#[test]
fn golden_mountaincarcontinuous_v0() {
    assert!(replay("MountainCarContinuous-v0") > 0);
}

#[test]
fn golden_pendulum_v0() {
    assert!(replay("Pendulum-v0") > 0);
}

#[test]
fn golden_pendulum_v1() {
    assert!(replay("Pendulum-v1") > 0);
}
