//! The 'batched calls' (ABI 1.1: `reset_many` / `step_many`) and 'vector
//! env' (ABI 1.2: `vec_reset` / `vec_step`) checks: they give the single
//! calls' results bit for bit, on random seeds, actions and masks, and leave
//! the buffers of masked-out lanes alone.

use super::env_checks::Outcome;
use super::report::CheckStatus::{Failed, Passed};
use super::trajectory::{sample, OwnedAction, Rng, ACTION_SALT, TRAJ_STEPS};
use crate::loader::{LaneCalls, PluginEnv, PluginEnvType, PluginLanes};
use rwg_env::env::{EnvError, Environment, Step};
use rwg_env::space::Space;
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
    let mut drive = Drive::new(ty, config, calls, n)?;
    let mut compared = 0;
    for k in 0..=TRAJ_STEPS {
        drive.reset_round(k)?;
        if k == TRAJ_STEPS {
            break;
        }
        compared += drive.step_round(k)?;
    }
    Ok(compared)
}

/// One comparison: the lanes under test, as many single instances, the
/// buffers of the lane calls and the random choices that drive both.
struct Drive {
    calls: LaneCalls,
    batch: PluginLanes,
    singles: Vec<TimeLimit<PluginEnv>>,
    action_space: Space,
    /// Lanes, observation length, flat action length.
    n: usize,
    d: usize,
    a: usize,
    rng: Rng,
    obs: Vec<f64>,
    single_obs: Vec<f64>,
    rewards: Vec<f64>,
    term: Vec<u8>,
    trunc: Vec<u8>,
    actions: Vec<f64>,
    /// The lane calls' mask; 2 marks a lane whose episode ended (reset in
    /// the next round).
    mask: Vec<u8>,
    seeds: Vec<u64>,
    /// Lanes whose last call succeeded (a failed lane is left alone).
    alive: Vec<bool>,
}

impl Drive {
    /// The lanes and single instances, without a time limit, and the buffers.
    fn new(ty: &PluginEnvType, config: &str, calls: LaneCalls, n: usize) -> Result<Drive, String> {
        let no_limit = Some(u32::MAX);
        let batch = ty
            .make_lanes(calls, config, n, no_limit)
            .map_err(|e| format!("cannot create the {}: {e}", calls.name()))?;
        let singles: Vec<TimeLimit<PluginEnv>> = (0..n)
            .map(|_| ty.make(config, no_limit))
            .collect::<Result<_, _>>()
            .map_err(|e| format!("cannot create an instance: {e}"))?;
        let spec = ty.spec();
        let (d, a) = (spec.obs_dim(), spec.action_space.flat_dim());
        Ok(Drive {
            calls,
            batch,
            singles,
            action_space: spec.action_space.clone(),
            n,
            d,
            a,
            rng: Rng(ACTION_SALT ^ 0xba7c ^ n as u64),
            obs: vec![0.0; n * d],
            single_obs: vec![0.0; d],
            rewards: vec![0.0; n],
            term: vec![0u8; n],
            trunc: vec![0u8; n],
            actions: vec![0.0; n * a],
            mask: vec![1u8; n],
            seeds: vec![0u64; n],
            alive: vec![true; n],
        })
    }

    /// The names of the reset and step calls under test.
    fn call_names(&self) -> (&'static str, &'static str) {
        match self.calls {
            LaneCalls::Batched => ("reset_many", "step_many"),
            LaneCalls::Vec => ("vec_reset", "vec_step"),
        }
    }

    /// Lane `i`'s observation in the lane calls' buffer.
    fn lane_obs(&self, i: usize) -> &[f64] {
        &self.obs[i * self.d..(i + 1) * self.d]
    }

    /// The text of a difference between the single call and the lane call.
    fn mismatch(&self, what: &str, i: usize, k: usize, s: &LaneResult, b: &LaneResult) -> String {
        format!(
            "lane {i}, {what} {k}: the single call gave {:?} obs bits {:x?}, the {} {:?} obs bits {:x?}",
            s.0,
            s.1,
            self.calls.name(),
            b.0,
            b.1
        )
    }

    /// Round `k`'s resets: every lane at first, then the ended ones and a
    /// few at random, compared with the single instances' resets.
    fn reset_round(&mut self, k: usize) -> Result<(), String> {
        let resetting = self.choose_resets(k);
        let mut failures: Vec<Option<String>> = vec![None; self.n];
        self.batch
            .reset_many(&self.mask, &self.seeds, &mut self.obs, |f| {
                failures[f.lane] = Some(f.error.to_string())
            });
        for i in 0..self.n {
            if !resetting[i] {
                if self.lane_obs(i).iter().any(|&x| x != SENTINEL) {
                    let (reset_call, _) = self.call_names();
                    return Err(format!(
                        "{reset_call} wrote lane {i}'s observation though its mask is 0"
                    ));
                }
                continue;
            }
            self.compare_reset(i, k, failures[i].take())?;
        }
        Ok(())
    }

    /// Which lanes reset in round `k`: sets their mask and every lane's
    /// seed, and fills the others' observations with [`SENTINEL`].
    fn choose_resets(&mut self, k: usize) -> Vec<bool> {
        let (mask, alive, rng) = (&self.mask, &self.alive, &mut self.rng);
        let resetting: Vec<bool> = (0..self.n)
            .map(|i| alive[i] && (k == 0 || mask[i] == 2 || rng.next().is_multiple_of(64)))
            .collect();
        for (i, &reset) in resetting.iter().enumerate() {
            self.mask[i] = u8::from(reset);
            self.seeds[i] = self.rng.next();
            if !reset {
                self.obs[i * self.d..(i + 1) * self.d].fill(SENTINEL);
            }
        }
        resetting
    }

    /// Resets single instance `i` as lane `i` was and compares the two.
    fn compare_reset(&mut self, i: usize, k: usize, failure: Option<String>) -> Result<(), String> {
        let s = self.singles[i].reset(self.seeds[i], &mut self.single_obs);
        let single: LaneResult = (
            s.map(|()| None).map_err(|e| e.to_string()),
            bits(&self.single_obs),
        );
        let batched: LaneResult = (failure.map_or(Ok(None), Err), bits(self.lane_obs(i)));
        if !same(&single, &batched) {
            return Err(self.mismatch("reset at step", i, k, &single, &batched));
        }
        self.alive[i] = single.0.is_ok();
        Ok(())
    }

    /// Round `k`'s steps: a random ~7/8 of the live lanes, compared with
    /// the single instances' steps; the lane steps compared.
    fn step_round(&mut self, k: usize) -> Result<usize, String> {
        let (stepping, owned) = self.choose_steps();
        let mut failures: Vec<Option<EnvError>> = vec![None; self.n];
        self.batch.step_many(
            &self.mask,
            &self.actions,
            &mut self.obs,
            &mut self.rewards,
            &mut self.term,
            &mut self.trunc,
            |f| failures[f.lane] = Some(f.error),
        );
        let mut compared = 0;
        for i in 0..self.n {
            if !stepping[i] {
                if self.lane_obs(i).iter().any(|&x| x != SENTINEL) || self.rewards[i] != SENTINEL {
                    let (_, step_call) = self.call_names();
                    return Err(format!(
                        "{step_call} wrote lane {i}'s buffers though its mask is 0"
                    ));
                }
                continue;
            }
            self.compare_step(i, k, &owned[i], failures[i].take())?;
            compared += 1;
        }
        Ok(compared)
    }

    /// Which lanes step: sets the mask and every lane's action (the actions
    /// returned), and fills the others' buffers with [`SENTINEL`].
    fn choose_steps(&mut self) -> (Vec<bool>, Vec<OwnedAction>) {
        let (alive, rng) = (&self.alive, &mut self.rng);
        let stepping: Vec<bool> = (0..self.n)
            .map(|i| alive[i] && !rng.next().is_multiple_of(8))
            .collect();
        let (d, a) = (self.d, self.a);
        let mut owned = Vec::with_capacity(self.n);
        for (i, &step) in stepping.iter().enumerate() {
            self.mask[i] = u8::from(step);
            let act = sample(&self.action_space, &mut self.rng);
            match &act {
                OwnedAction::Discrete(x) => self.actions[i] = *x as f64,
                OwnedAction::Continuous(v) => self.actions[i * a..(i + 1) * a].copy_from_slice(v),
            }
            owned.push(act);
            if !step {
                self.obs[i * d..(i + 1) * d].fill(SENTINEL);
                self.rewards[i] = SENTINEL;
            }
        }
        (stepping, owned)
    }

    /// Steps single instance `i` with lane `i`'s action and compares the
    /// two; an ended episode marks the lane for a reset.
    fn compare_step(
        &mut self,
        i: usize,
        k: usize,
        action: &OwnedAction,
        failure: Option<EnvError>,
    ) -> Result<(), String> {
        let s = self.singles[i].step(action.as_action(), &mut self.single_obs);
        let single: LaneResult = (
            s.map(Some).map_err(|e| e.to_string()),
            bits(&self.single_obs),
        );
        let batched: LaneResult = (
            match failure {
                Some(e) => Err(e.to_string()),
                None => Ok(Some(Step {
                    reward: self.rewards[i],
                    terminated: self.term[i] == 1,
                    truncated: self.trunc[i] == 1,
                })),
            },
            bits(self.lane_obs(i)),
        );
        if !same(&single, &batched) {
            return Err(self.mismatch("step", i, k + 1, &single, &batched));
        }
        match &single.0 {
            Err(_) => self.alive[i] = false,
            // Ended: reset in the next round (marked 2).
            Ok(Some(s)) if s.terminated || s.truncated => self.mask[i] = 2,
            _ => {}
        }
        Ok(())
    }
}
