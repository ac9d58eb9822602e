//! What determines a Gymnasium environment ([`GymConfig`]) and the
//! environment variables that give its defaults.

use crate::{
    DEFAULT_HASH_SEED, DEFAULT_START_TIMEOUT_S, DEFAULT_TIMEOUT_S, HASH_SEED_VAR, PREFIX,
    START_TIMEOUT_VAR, TIMEOUT_VAR,
};
use rwg_env::ActionDtype;
use std::time::Duration;

/// Everything that determines a Gymnasium environment.
#[derive(Debug, Clone, PartialEq)]
pub struct GymConfig {
    /// The id after `gymnasium:` (`CartPole-v1`, `module:Id`).
    pub id: String,
    /// The Python interpreter.
    pub python: String,
    /// Keyword arguments of `gym.make`, as JSON with nan/inf and objects
    /// whose only key is `"$rwg"` encoded as [`crate::kwargs`] says.
    pub kwargs: serde_json::Map<String, serde_json::Value>,
    /// The manifest's time-limit override (passed to `gym.make`).
    pub max_episode_steps: Option<u32>,
    /// dtype of the continuous action arrays handed to `step()`.
    pub action_dtype: ActionDtype,
    /// How long one exchange may take (and one reset or step of the
    /// checks made when a worker starts).
    pub timeout: Duration,
    /// How long a worker may take to import the env and make its instances.
    pub start_timeout: Duration,
    /// The workers' `PYTHONHASHSEED` ([`HASH_SEED_VAR`]).
    pub hash_seed: String,
    /// Whether every episode gets a fresh `gym.make` instance; `None`: the
    /// worker finds out (it runs an episode on a used and on a fresh
    /// instance and compares them).
    pub fresh_per_episode: Option<bool>,
    /// The manifest's `non_finite = "end"`: a NaN or infinite value that
    /// random actions give while the worker probes the env at start-up
    /// ends the probe's episode instead of refusing the env (the run ends
    /// such episodes too).
    pub non_finite_ends: bool,
}

impl GymConfig {
    /// A config for `id` (without the prefix) with defaults: the Python from
    /// [`default_python`], no kwargs, the env's own time limit, float64
    /// actions and the timeout from [`default_timeout`].
    pub fn new(id: &str) -> Self {
        GymConfig {
            id: id.to_string(),
            python: default_python(),
            kwargs: Default::default(),
            max_episode_steps: None,
            action_dtype: ActionDtype::F64,
            timeout: default_timeout(),
            start_timeout: default_start_timeout(),
            hash_seed: default_hash_seed(),
            fresh_per_episode: None,
            non_finite_ends: false,
        }
    }

    /// The full rwg id, `gymnasium:ID`.
    pub fn rwg_id(&self) -> String {
        format!("{PREFIX}{}", self.id)
    }
}

/// The environment variable naming the default Python interpreter.
pub const PYTHON_VAR: &str = "RWG_PYTHON";

/// The largest [`TIMEOUT_VAR`] accepted, in seconds (a week).
pub const MAX_TIMEOUT_S: f64 = 604_800.0;

/// What [`PYTHON_VAR`] may hold, for its errors.
pub const PYTHON_EXPECTED: &str =
    "a Python interpreter, a name on PATH or a path (the Python of envs without a `python` key)";

/// `RWG_PYTHON` if set, else `python3`; an error if it is empty or not
/// UTF-8.
pub fn python_setting() -> Result<String, rwg_env::vars::VarError> {
    Ok(rwg_env::vars::text(PYTHON_VAR, PYTHON_EXPECTED)?.unwrap_or_else(|| "python3".into()))
}

/// [`python_setting`], or `python3` if that is an error (the `rwg` binary
/// checks the variable before it runs a command).
pub fn default_python() -> String {
    python_setting().unwrap_or_else(|_| "python3".into())
}

/// [`TIMEOUT_VAR`] (seconds from 0.001 to [`MAX_TIMEOUT_S`]) if set, else
/// [`DEFAULT_TIMEOUT_S`]; an error naming the variable for any other value.
pub fn timeout_setting() -> Result<Duration, rwg_env::vars::VarError> {
    rwg_env::vars::seconds(
        TIMEOUT_VAR,
        0.001,
        MAX_TIMEOUT_S,
        Duration::from_secs_f64(DEFAULT_TIMEOUT_S),
        "how long a Gymnasium worker may take to answer",
    )
}

/// [`timeout_setting`], or [`DEFAULT_TIMEOUT_S`] if that is an error (the
/// `rwg` binary checks the variable before it runs a command).
pub fn default_timeout() -> Duration {
    timeout_setting().unwrap_or(Duration::from_secs_f64(DEFAULT_TIMEOUT_S))
}

/// [`start_timeout_setting`], or [`DEFAULT_START_TIMEOUT_S`] if that is an
/// error (the `rwg` binary checks the variable before it runs a command).
pub fn default_start_timeout() -> Duration {
    start_timeout_setting().unwrap_or(Duration::from_secs_f64(DEFAULT_START_TIMEOUT_S))
}

/// [`START_TIMEOUT_VAR`] (seconds from 0.001 to [`MAX_TIMEOUT_S`]) if set,
/// else [`DEFAULT_START_TIMEOUT_S`]; an error naming the variable for any
/// other value.
pub fn start_timeout_setting() -> Result<Duration, rwg_env::vars::VarError> {
    rwg_env::vars::seconds(
        START_TIMEOUT_VAR,
        0.001,
        MAX_TIMEOUT_S,
        Duration::from_secs_f64(DEFAULT_START_TIMEOUT_S),
        "how long a Gymnasium worker may take to import the env and make its instances",
    )
}

/// The user's [`HASH_SEED_VAR`] if set, else [`DEFAULT_HASH_SEED`].
pub fn default_hash_seed() -> String {
    std::env::var(HASH_SEED_VAR)
        .ok()
        .filter(|s| !s.is_empty())
        .unwrap_or_else(|| DEFAULT_HASH_SEED.into())
}
