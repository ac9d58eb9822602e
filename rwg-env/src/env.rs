//! The Gym-like environment interface.
//!
//! An [`Environment`] writes observations into a buffer the caller owns, so a
//! step allocates nothing. Built-in environments are concrete types and are
//! used through generics (static dispatch); plugin environments implement the
//! same trait behind the C ABI.

use crate::space::Space;
use thiserror::Error;

/// The numpy dtype of the continuous action array handed to Gymnasium's
/// `step()`. Pendulum-v1 and MountainCarContinuous-v0 compute differently for
/// the two (numpy 2's promotion rules; `tests/data/` holds golden
/// trajectories with both dtypes, `rwg-envs/tests/golden.rs` replays them). rwg's policies
/// produce float64 actions, so [`ActionDtype::F64`] is the default.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
#[cfg_attr(feature = "serde", serde(rename_all = "lowercase"))]
pub enum ActionDtype {
    /// `np.float64` actions (what a numpy policy produces).
    #[default]
    #[cfg_attr(feature = "serde", serde(rename = "float64"))]
    F64,
    /// `np.float32` actions (the action space's own dtype).
    #[cfg_attr(feature = "serde", serde(rename = "float32"))]
    F32,
}

impl ActionDtype {
    /// The numpy name: `float64` or `float32`.
    pub fn name(self) -> &'static str {
        match self {
            ActionDtype::F64 => "float64",
            ActionDtype::F32 => "float32",
        }
    }
}

impl std::str::FromStr for ActionDtype {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "float64" | "f64" => Ok(ActionDtype::F64),
            "float32" | "f32" => Ok(ActionDtype::F32),
            _ => Err(format!(
                "unknown action dtype '{s}' (expected float64 or float32)"
            )),
        }
    }
}

/// What an environment is: its id, spaces, time limit and solved score.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
pub struct EnvSpec {
    /// Gymnasium-style id, e.g. `CartPole-v0`.
    pub id: String,
    /// Observation space (always a box).
    pub observation_space: Space,
    /// Action space.
    pub action_space: Space,
    /// Episode length limit applied by [`crate::TimeLimit`]; `None` = no limit.
    pub max_episode_steps: Option<u32>,
    /// Gymnasium's `reward_threshold`: the score at which the env counts as solved.
    pub reward_threshold: Option<f64>,
}

impl EnvSpec {
    /// Length of the observation vector.
    pub fn obs_dim(&self) -> usize {
        self.observation_space.flat_dim()
    }
}

/// An action handed to [`Environment::step`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Action<'a> {
    /// A discrete action; must lie in `0..n`.
    Discrete(i64),
    /// A continuous action vector of the action space's length.
    Continuous(&'a [f64]),
}

/// What a step returns besides the observation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Step {
    /// Reward of this transition.
    pub reward: f64,
    /// The episode ended inside the MDP (goal reached, pole fell, ...).
    pub terminated: bool,
    /// The episode was cut by the time limit. May be true together with `terminated`.
    pub truncated: bool,
}

/// Errors an environment reports. None of them aborts the process.
#[derive(Debug, Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum EnvError {
    /// The action is not an element of the action space.
    #[error("invalid action: {0}")]
    InvalidAction(String),
    /// `step` was called before `reset`.
    #[error("step called before reset")]
    ResetNeeded,
    /// A state vector of the wrong length was given to `set_state`.
    #[error("state has {got} values, {expected} expected")]
    StateLength {
        /// Length the env needs.
        expected: usize,
        /// Length given.
        got: usize,
    },
    /// The environment does not support the operation.
    #[error("unsupported: {0}")]
    Unsupported(String),
    /// Any other failure (e.g. reported by a plugin).
    #[error("{0}")]
    Other(String),
    /// A step returned an observation or reward that is not finite (NaN or
    /// infinite), or one that takes the episode's return beyond what rwg
    /// takes: with a manifest's `non_finite = "end"` the episode ends there
    /// instead of failing. The message says which value.
    #[error("{0}")]
    NonFinite(String),
}

/// A Gym-like environment.
///
/// Contract (Gymnasium's): `reset` starts an episode and writes the first
/// observation; `step` applies an action and writes the next observation into
/// `obs` (length [`EnvSpec::obs_dim`]). Neither may allocate in the built-in
/// environments. An instance is used by one thread at a time.
pub trait Environment {
    /// The environment's description.
    fn spec(&self) -> &EnvSpec;

    /// Starts an episode exactly as Gymnasium's `env.reset(seed=seed)` does and
    /// writes the first observation into `obs`.
    fn reset(&mut self, seed: u64, obs: &mut [f64]) -> Result<(), EnvError>;

    /// Applies `action`, writes the next observation into `obs`.
    fn step(&mut self, action: Action<'_>, obs: &mut [f64]) -> Result<Step, EnvError>;

    /// Length of the internal state vector (Gymnasium's `env.unwrapped.state`),
    /// or 0 if the env does not expose it.
    fn state_len(&self) -> usize {
        0
    }

    /// Copies the internal state into `out` (length [`Environment::state_len`]).
    fn state(&self, _out: &mut [f64]) -> Result<(), EnvError> {
        Err(EnvError::Unsupported(
            "this environment does not expose its state".into(),
        ))
    }

    /// Starts an episode from the given internal state instead of a seeded
    /// reset, as if `reset` had produced it, and writes its observation.
    fn set_state(&mut self, _state: &[f64], _obs: &mut [f64]) -> Result<(), EnvError> {
        Err(EnvError::Unsupported(
            "this environment cannot start from a given state".into(),
        ))
    }
}

/// Checks a discrete action against `0..n` and returns it as an index.
#[inline]
pub fn discrete_action(action: Action<'_>, n: usize) -> Result<usize, EnvError> {
    match action {
        Action::Discrete(a) if a >= 0 && (a as u64) < n as u64 => Ok(a as usize),
        Action::Discrete(a) => Err(EnvError::InvalidAction(format!(
            "{a} is outside the action space Discrete({n}) (valid: 0..={})",
            n - 1
        ))),
        Action::Continuous(_) => Err(EnvError::InvalidAction(format!(
            "a continuous action was given to a Discrete({n}) action space"
        ))),
    }
}

/// Checks a continuous action's length and returns it.
#[inline]
pub fn continuous_action<'a>(action: Action<'a>, dim: usize) -> Result<&'a [f64], EnvError> {
    match action {
        Action::Continuous(a) if a.len() == dim => Ok(a),
        Action::Continuous(a) => Err(EnvError::InvalidAction(format!(
            "action has {} values, the action space has {dim}",
            a.len()
        ))),
        Action::Discrete(a) => Err(EnvError::InvalidAction(format!(
            "discrete action {a} given to a continuous action space"
        ))),
    }
}

/// Checks a state vector's length.
#[inline]
pub fn check_state_len(state: &[f64], expected: usize) -> Result<(), EnvError> {
    if state.len() == expected {
        Ok(())
    } else {
        Err(EnvError::StateLength {
            expected,
            got: state.len(),
        })
    }
}

impl<E: Environment + ?Sized> Environment for Box<E> {
    fn spec(&self) -> &EnvSpec {
        (**self).spec()
    }
    fn reset(&mut self, seed: u64, obs: &mut [f64]) -> Result<(), EnvError> {
        (**self).reset(seed, obs)
    }
    fn step(&mut self, action: Action<'_>, obs: &mut [f64]) -> Result<Step, EnvError> {
        (**self).step(action, obs)
    }
    fn state_len(&self) -> usize {
        (**self).state_len()
    }
    fn state(&self, out: &mut [f64]) -> Result<(), EnvError> {
        (**self).state(out)
    }
    fn set_state(&mut self, state: &[f64], obs: &mut [f64]) -> Result<(), EnvError> {
        (**self).set_state(state, obs)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn discrete_action_range() {
        assert_eq!(discrete_action(Action::Discrete(1), 2), Ok(1));
        assert!(discrete_action(Action::Discrete(2), 2).is_err());
        assert!(discrete_action(Action::Discrete(-1), 2).is_err());
        assert!(discrete_action(Action::Continuous(&[0.0]), 2).is_err());
    }

    #[test]
    fn continuous_action_length() {
        assert!(continuous_action(Action::Continuous(&[0.0]), 1).is_ok());
        assert!(continuous_action(Action::Continuous(&[0.0, 1.0]), 1).is_err());
    }

    #[test]
    fn dtype_parse() {
        assert_eq!("float32".parse::<ActionDtype>(), Ok(ActionDtype::F32));
        assert!("int8".parse::<ActionDtype>().is_err());
    }
}
