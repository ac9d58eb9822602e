//! The 'batched calls' check (ABI 1.1): `reset_many` / `step_many` give the
//! single calls' results bit for bit, on random seeds, actions and masks,
//! and leave the buffers of masked-out lanes alone.

use super::env_checks::Outcome;
use super::report::CheckStatus::{Failed, Passed};
use super::trajectory::{sample, OwnedAction, Rng, ACTION_SALT, TRAJ_STEPS};
use crate::loader::{PluginEnv, PluginEnvType};
use rwg_env::env::{EnvError, Environment, Step};
use rwg_env::time_limit::TimeLimit;

/// Lanes of the batch under test.
const LANES: usize = 8;
/// What masked-out lanes' buffers hold; a plugin writing there is caught.
const SENTINEL: f64 = 1234.5;

/// One lane's result: the step's (or reset's) outcome and observation bits.
type LaneResult = (Result<Option<Step>, String>, Vec<u64>);

fn bits(obs: &[f64]) -> Vec<u64> {
    obs.iter().map(|x| x.to_bits()).collect()
}

fn same(a: &LaneResult, b: &LaneResult) -> bool {
    let step_bits = |r: &Result<Option<Step>, String>| match r {
        Ok(Some(s)) => Ok(Some((s.reward.to_bits(), s.terminated, s.truncated))),
        Ok(None) => Ok(None),
        Err(e) => Err(e.clone()),
    };
    step_bits(&a.0) == step_bits(&b.0) && (a.0.is_err() || a.1 == b.1)
}

/// The check: [`LANES`] single instances and a batch of as many, driven with
/// the same seeds and actions for [`TRAJ_STEPS`] batched steps.
pub(super) fn batched_calls(ty: &PluginEnvType, config: &str) -> Outcome {
    if !ty.has_batched_calls() {
        return (
            Passed,
            "no batched calls (an ABI 1.0 plugin, or none provided): rwg uses the single calls"
                .into(),
        );
    }
    match compare(ty, config) {
        Ok(n) => (
            Passed,
            format!(
                "reset_many/step_many equal the single calls bit for bit ({n} lane steps on {LANES} lanes, random masks)"
            ),
        ),
        Err(e) => (Failed, e),
    }
}

fn compare(ty: &PluginEnvType, config: &str) -> Result<usize, String> {
    let no_limit = Some(u32::MAX);
    let mut batch = ty
        .make_batch(config, LANES, no_limit)
        .map_err(|e| format!("cannot create the batch: {e}"))?;
    let mut singles: Vec<TimeLimit<PluginEnv>> = (0..LANES)
        .map(|_| ty.make(config, no_limit))
        .collect::<Result<_, _>>()
        .map_err(|e| format!("cannot create an instance: {e}"))?;
    let spec = ty.spec().clone();
    let (d, a) = (spec.obs_dim(), batch.action_len());
    let mut rng = Rng(ACTION_SALT ^ 0xba7c);
    let mut obs = vec![0.0; LANES * d];
    let mut single_obs = vec![0.0; d];
    let (mut rewards, mut term, mut trunc) = ([0.0; LANES], [0u8; LANES], [0u8; LANES]);
    let mut actions = vec![0.0; LANES * a];
    let mut mask = [1u8; LANES];
    let mut seeds = [0u64; LANES];
    let mut alive = [true; LANES];
    let mut compared = 0;
    let mismatch = |what: &str, i: usize, k: usize, s: &LaneResult, b: &LaneResult| {
        format!(
            "lane {i}, {what} {k}: the single call gave {:?} obs bits {:x?}, the batched call {:?} obs bits {:x?}",
            s.0, s.1, b.0, b.1
        )
    };
    for k in 0..=TRAJ_STEPS {
        // Reset every lane at first, then the ended ones and a few at random.
        let resetting: Vec<bool> = (0..LANES)
            .map(|i| alive[i] && (k == 0 || mask[i] == 2 || rng.next() % 64 == 0))
            .collect();
        for i in 0..LANES {
            mask[i] = u8::from(resetting[i]);
            seeds[i] = rng.next();
            if !resetting[i] {
                obs[i * d..(i + 1) * d].fill(SENTINEL);
            }
        }
        let mut failures: Vec<Option<String>> = vec![None; LANES];
        batch.reset_many(&mask, &seeds, &mut obs, |f| {
            failures[f.lane] = Some(f.error.to_string())
        });
        for i in 0..LANES {
            if !resetting[i] {
                if obs[i * d..(i + 1) * d].iter().any(|&x| x != SENTINEL) {
                    return Err(format!(
                        "reset_many wrote lane {i}'s observation though its mask is 0"
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
        let stepping: Vec<bool> = (0..LANES)
            .map(|i| alive[i] && rng.next() % 8 != 0)
            .collect();
        let mut owned = Vec::with_capacity(LANES);
        for i in 0..LANES {
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
        let mut failures: Vec<Option<EnvError>> = vec![None; LANES];
        batch.step_many(
            &mask,
            &actions,
            &mut obs,
            &mut rewards,
            &mut term,
            &mut trunc,
            |f| failures[f.lane] = Some(f.error),
        );
        for i in 0..LANES {
            if !stepping[i] {
                let lane = &obs[i * d..(i + 1) * d];
                if lane.iter().any(|&x| x != SENTINEL) || rewards[i] != SENTINEL {
                    return Err(format!(
                        "step_many wrote lane {i}'s buffers though its mask is 0"
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
