//! One instance of a remote environment as a plain [`rwg_env::Environment`]
//! ([`SingleLane`]), for what steps one episode at a time outside the
//! sampler: rollouts, checks, replays.

use super::{LaneActions, LaneOp, LaneOutcome, RemoteEnv};
use rwg_env::{Action, EnvError, EnvSpec, Step};

/// Runs one instance of a remote environment as a plain [`rwg_env::Environment`]
/// (lane 0 only): for rollouts, checks and replays outside the sampler.
pub struct SingleLane<B: RemoteEnv> {
    env: B,
    ops: Vec<LaneOp>,
    out: Vec<LaneOutcome>,
    discrete: Vec<i64>,
    continuous: Vec<f64>,
    obs: Vec<f64>,
    dead: Option<EnvError>,
}

impl<B: RemoteEnv> SingleLane<B> {
    /// Wraps `env` (any number of lanes; lane 0 is used).
    pub fn new(env: B) -> Self {
        let n = env.lanes();
        let d = env.spec().obs_dim();
        SingleLane {
            ops: vec![LaneOp::Idle; n],
            out: vec![LaneOutcome::Idle; n],
            discrete: vec![0; n],
            continuous: vec![
                0.0;
                n * match &env.spec().action_space {
                    rwg_env::Space::Box(b) => b.dim(),
                    rwg_env::Space::Discrete { .. } => 0,
                }
            ],
            obs: vec![0.0; n * d],
            env,
            dead: None,
        }
    }

    /// The remote environment.
    pub fn inner(&self) -> &B {
        &self.env
    }

    fn run(&mut self, op: LaneOp, obs: &mut [f64]) -> Result<LaneOutcome, EnvError> {
        if let Some(e) = &self.dead {
            return Err(e.clone());
        }
        self.ops[0] = op;
        let actions = LaneActions {
            discrete: &self.discrete,
            continuous: &self.continuous,
        };
        if let Err(f) = self
            .env
            .exchange(&self.ops, actions, &mut self.obs, &mut self.out)
        {
            self.dead = Some(f.error.clone());
            return Err(f.error);
        }
        let d = obs.len();
        obs.copy_from_slice(&self.obs[..d]);
        Ok(std::mem::replace(&mut self.out[0], LaneOutcome::Idle))
    }
}

impl<B: RemoteEnv> rwg_env::Environment for SingleLane<B> {
    fn spec(&self) -> &EnvSpec {
        self.env.spec()
    }

    fn reset(&mut self, seed: u64, obs: &mut [f64]) -> Result<(), EnvError> {
        match self.run(LaneOp::Reset(seed), obs)? {
            LaneOutcome::Failed(e) => Err(e),
            _ => Ok(()),
        }
    }

    fn step(&mut self, action: Action<'_>, obs: &mut [f64]) -> Result<Step, EnvError> {
        let dim = self.continuous.len() / self.env.lanes();
        match action {
            Action::Discrete(a) if dim == 0 => self.discrete[0] = a,
            Action::Discrete(a) => {
                return Err(EnvError::InvalidAction(format!(
                    "discrete action {a} given to a continuous action space"
                )))
            }
            Action::Continuous(a) => {
                if a.len() != dim {
                    return Err(EnvError::InvalidAction(format!(
                        "action has {} values, the action space has {dim}",
                        a.len()
                    )));
                }
                self.continuous[..dim].copy_from_slice(a);
            }
        }
        match self.run(LaneOp::Step, obs)? {
            LaneOutcome::Step(s) => Ok(s),
            LaneOutcome::Failed(e) => Err(e),
            other => Err(EnvError::Other(format!("unexpected outcome {other:?}"))),
        }
    }
}
