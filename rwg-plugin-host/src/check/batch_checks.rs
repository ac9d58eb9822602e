//! The 'batched calls' (ABI 1.1: `reset_many` / `step_many`) and 'vector
//! env' (ABI 1.2: `vec_reset` / `vec_step`) checks: they give the single
//! calls' results bit for bit, on random seeds, actions and masks, and leave
//! the buffers of masked-out lanes alone.

use super::env_checks::Outcome;
use super::report::CheckStatus::{Failed, Passed};
use super::trajectory::{sample, OwnedAction, Rng, ACTION_SALT, TRAJ_STEPS};
use crate::loader::{LaneCalls, PluginEnv, PluginEnvType};
use rwg_env::env::{EnvError, Environment, Step};
use rwg_env::time_limit::TimeLimit;

/// Lanes of the batch under test.
const LANES: usize = 8;
/// Lane counts of the vector envs under test: one smaller and one larger
/// than a plugin's natural width is likely to be (8 or 16), neither a
/// multiple of it.
const VEC_LANES: [usize; 2] = [7, 19];
/// What masked-out lanes' buffers hold; a plugin writing there is caught.
const SENTINEL: f64 = 1234.5;

/// One lane's result: the step's (or reset's) outcome and observation bits.
type LaneResult = (Result<Option<Step>, String>, Vec<u64>);

fn bits(obs: &[f64]) -> Vec<u64> {
    obs.iter().map(|x| x.to_bits()).collect()
}

/// Whether two lanes' results agree: the same step bits and observation
/// bits, or both an error (the texts differ: a vector env's name the lane).
fn same(a: &LaneResult, b: &LaneResult) -> bool {
    let step_bits = |r: &Result<Option<Step>, String>| match r {
        Ok(Some(s)) => Ok(Some((s.reward.to_bits(), s.terminated, s.truncated))),
        Ok(None) => Ok(None),
        Err(_) => Err(()),
    };
    step_bits(&a.0) == step_bits(&b.0) && (a.0.is_err() || a.1 == b.1)
}

/// The 'batched calls' check: [`LANES`] single instances and a batch of as
/// many, driven with the same seeds and actions for [`TRAJ_STEPS`] batched
/// steps.
pub(super) fn batched_calls(ty: &PluginEnvType, config: &str) -> Outcome {
    if !ty.has_batched_calls() {
        return (
            Passed,
            "no batched calls (an ABI 1.0 plugin, or none provided): rwg uses the single calls"
                .into(),
        );
    }
    match compare(ty, config, LaneCalls::Batched, LANES) {
        Ok(n) => (
            Passed,
            format!(
                "reset_many/step_many equal the single calls bit for bit ({n} lane steps on {LANES} lanes, random masks)"
            ),
        ),
        Err(e) => (Failed, e),
    }
}

/// The 'vector env' check: vector envs of each of [`VEC_LANES`] lanes
/// against as many single instances, as [`batched_calls`] does.
pub(super) fn vec_env(ty: &PluginEnvType, config: &str) -> Outcome {
    if !ty.has_vec_env() {
        return (
            Passed,
            "no vector env (a plugin before ABI 1.2, or none provided): rwg uses the batched or single calls"
                .into(),
        );
    }
    let mut steps = 0;
    for lanes in VEC_LANES {
        match compare(ty, config, LaneCalls::Vec, lanes) {
            Ok(n) => steps += n,
            Err(e) => return (Failed, format!("a vector env of {lanes} lanes: {e}")),
        }
    }
    (
        Passed,
        format!(
            "vec_reset/vec_step equal the single calls bit for bit ({steps} lane steps on vector envs of {} and {} lanes, random masks)",
            VEC_LANES[0], VEC_LANES[1]
        ),
    )
}

/// Drives `n` lanes through `calls` and `n` single instances with the same
/// seeds and actions; the lane steps compared, or the first difference.
fn compare(ty: &PluginEnvType, config: &str, calls: LaneCalls, n: usize) -> Result<usize, String> {
    let no_limit = Some(u32::MAX);
    let mut batch = ty
        .make_lanes(calls, config, n, no_limit)
        .map_err(|e| format!("cannot create the {}: {e}", calls.name()))?;
    let (reset_call, step_call) = match calls {
        LaneCalls::Batched => ("reset_many", "step_many"),
        LaneCalls::Vec => ("vec_reset", "vec_step"),
    };
    let mut singles: Vec<TimeLimit<PluginEnv>> = (0..n)
        .map(|_| ty.make(config, no_limit))
        .collect::<Result<_, _>>()
        .map_err(|e| format!("cannot create an instance: {e}"))?;
    let spec = ty.spec().clone();
    let d = spec.obs_dim();
    let a = spec.action_space.flat_dim();
    let mut rng = Rng(ACTION_SALT ^ 0xba7c ^ n as u64);
    let mut obs = vec![0.0; n * d];
    let mut single_obs = vec![0.0; d];
    let (mut rewards, mut term, mut trunc) = (vec![0.0; n], vec![0u8; n], vec![0u8; n]);
    let mut actions = vec![0.0; n * a];
    let mut mask = vec![1u8; n];
    let mut seeds = vec![0u64; n];
    let mut alive = vec![true; n];
    let mut compared = 0;
    let mismatch = |what: &str, i: usize, k: usize, s: &LaneResult, b: &LaneResult| {
        format!(
            "lane {i}, {what} {k}: the single call gave {:?} obs bits {:x?}, the {} {:?} obs bits {:x?}",
            s.0, s.1, calls.name(), b.0, b.1
        )
    };
    for k in 0..=TRAJ_STEPS {
        // Reset every lane at first, then the ended ones and a few at random.
        let resetting: Vec<bool> = (0..n)
            .map(|i| alive[i] && (k == 0 || mask[i] == 2 || rng.next().is_multiple_of(64)))
            .collect();
        for i in 0..n {
            mask[i] = u8::from(resetting[i]);
            seeds[i] = rng.next();
            if !resetting[i] {
                obs[i * d..(i + 1) * d].fill(SENTINEL);
            }
        }
        let mut failures: Vec<Option<String>> = vec![None; n];
        batch.reset_many(&mask, &seeds, &mut obs, |f| {
            failures[f.lane] = Some(f.error.to_string())
        });
        for i in 0..n {
            if !resetting[i] {
                if obs[i * d..(i + 1) * d].iter().any(|&x| x != SENTINEL) {
                    return Err(format!(
                        "{reset_call} wrote lane {i}'s observation though its mask is 0"
                    ));
                }
                continue;
            }
            let s = singles[i].reset(seeds[i], &mut single_obs);
            let single: LaneResult = (
                s.map(|()| None).map_err(|e| e.to_string()),
                bits(&single_obs),
            );
            let batched: LaneResult = (
                failures[i].clone().map_or(Ok(None), Err),
                bits(&obs[i * d..(i + 1) * d]),
            );
            if !same(&single, &batched) {
                return Err(mismatch("reset at step", i, k, &single, &batched));
            }
            alive[i] = single.0.is_ok();
        }
        if k == TRAJ_STEPS {
            break;
        }
        // Step a random ~7/8 of the live lanes.
        let stepping: Vec<bool> = (0..n)
            .map(|i| alive[i] && !rng.next().is_multiple_of(8))
            .collect();
        let mut owned = Vec::with_capacity(n);
        for i in 0..n {
            mask[i] = u8::from(stepping[i]);
            let act = sample(&spec.action_space, &mut rng);
            match &act {
                OwnedAction::Discrete(x) => actions[i] = *x as f64,
                OwnedAction::Continuous(v) => actions[i * a..(i + 1) * a].copy_from_slice(v),
            }
            owned.push(act);
            if !stepping[i] {
                obs[i * d..(i + 1) * d].fill(SENTINEL);
                rewards[i] = SENTINEL;
            }
        }
        let mut failures: Vec<Option<EnvError>> = vec![None; n];
        batch.step_many(
            &mask,
            &actions,
            &mut obs,
            &mut rewards,
            &mut term,
            &mut trunc,
            |f| failures[f.lane] = Some(f.error),
        );
        for i in 0..n {
            if !stepping[i] {
                let lane = &obs[i * d..(i + 1) * d];
                if lane.iter().any(|&x| x != SENTINEL) || rewards[i] != SENTINEL {
                    return Err(format!(
                        "{step_call} wrote lane {i}'s buffers though its mask is 0"
                    ));
                }
                continue;
            }
            let s = singles[i].step(owned[i].as_action(), &mut single_obs);
            let single: LaneResult = (s.map(Some).map_err(|e| e.to_string()), bits(&single_obs));
            let batched: LaneResult = (
                match failures[i].take() {
                    Some(e) => Err(e.to_string()),
                    None => Ok(Some(Step {
                        reward: rewards[i],
                        terminated: term[i] == 1,
                        truncated: trunc[i] == 1,
                    })),
                },
                bits(&obs[i * d..(i + 1) * d]),
            );
            if !same(&single, &batched) {
                return Err(mismatch("step", i, k + 1, &single, &batched));
            }
            compared += 1;
            match &single.0 {
                Err(_) => alive[i] = false,
                // Ended: reset in the next round (marked 2).
                Ok(Some(s)) if s.terminated || s.truncated => mask[i] = 2,
                _ => {}
            }
        }
    }
    Ok(compared)
}
