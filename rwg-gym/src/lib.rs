//! # rwg-gym: any Gymnasium environment through a crash-isolated bridge
//!
//! An environment id `gymnasium:ID` (or `gymnasium:module:ID`, which imports
//! `module` first) runs in Python worker processes: each hosts [`GROUPS`]
//! groups of [`rwg_core::sampler::LANES`] instances of the env, made with
//! `gym.make`, and resets/steps a group in lockstep, one exchange over its
//! stdin/stdout per exchange (one group in flight while rwg works on the
//! other), in the binary format of `docs/bridge-protocol.md`. Everything
//! else — weights, the network's forward pass, reset seeds, statistics —
//! stays in rwg, so a Gymnasium env gives the numbers a built-in env of the
//! same dynamics gives.
//!
//! The worker program ([`WORKER_PY`]) ships inside rwg and is handed to
//! `python -c` after [`BOOT_PY`] and rwg-worker's loader, with the modules it
//! imports ([`MODULES`]); the user installs only Gymnasium and the env's package. A
//! worker that crashes (a segfault in a C extension), hangs (no answer within
//! the timeout) or raises is reported as an error naming what happened, with
//! the Python traceback; rwg itself keeps running.
//!
//! # Example
//!
//! A `gymnasium:` id names a Gymnasium env; opening it starts a worker with
//! the configured Python. This one names no interpreter that exists, so it
//! runs anywhere and shows the error a user without Python gets:
//!
//! ```
//! use rwg_gym::{gym_id, GymConfig, GymError, GymSource};
//!
//! // The id after the prefix is Gymnasium's, and the one that enters the seeds.
//! assert_eq!(gym_id("gymnasium:CartPole-v1"), Some("CartPole-v1"));
//! assert_eq!(gym_id("CartPole-v1"), None);
//!
//! let mut config = GymConfig::new("CartPole-v1");
//! assert_eq!(config.rwg_id(), "gymnasium:CartPole-v1");
//! config.python = "/nonexistent/python3".into();
//! // With a Python that has Gymnasium, `open` starts a worker, checks the env
//! // and its reset, and `run_blocks` samples a cell's blocks with it.
//! let err = GymSource::open(config).unwrap_err();
//! assert!(matches!(err, GymError::NoPython { .. }));
//! assert!(err.to_string().starts_with("cannot run Python '/nonexistent/python3': "));
//! ```
//!
//! This is its own crate (not part of the runner's core) because it owns
//! a Python program and what Gymnasium's spaces and errors mean. The worker
//! processes, the protocol and the host side of the exchanges are `rwg-worker`'s, shared
//! with the isolated plugin workers.

pub use rwg_worker::describe_status;
pub use rwg_worker::protocol;

mod config;
mod error;
mod info;
pub mod kwargs;
mod lanes;
mod source;

pub use config::{
    default_hash_seed, default_python, default_start_timeout, default_timeout, python_setting,
    start_timeout_setting, timeout_setting, GymConfig, MAX_TIMEOUT_S, PYTHON_VAR,
};
pub use error::GymError;
pub use info::{info_differences, GymInfo};
pub use lanes::GymLanes;
pub use source::{make_single, GymSource};

/// The worker program, run by [`BOOT_PY`] through rwg-worker's loader
/// ([`rwg_worker::python::LOAD_PY`]), with [`MODULES`] importable.
pub const WORKER_PY: &str = include_str!("worker.py");

/// The checks of what a Gymnasium env returns (rewards, flags, observations
/// in their spaces, the old Gym API), a module of [`WORKER_PY`]'s.
pub const ENV_VALUES_PY: &str = include_str!("env_values.py");

/// A Gymnasium env's spaces as rwg takes them (the flat observation space,
/// a Discrete or bounded Box action space, each observation flattened or
/// refused), a module of [`WORKER_PY`]'s that imports [`ENV_VALUES_PY`].
pub const ENV_SPACES_PY: &str = include_str!("env_spaces.py");

/// The modules [`WORKER_PY`] imports from rwg (name, source), in the
/// order they are loaded: the pipe to rwg first, each module after those it
/// imports.
pub const MODULES: [(&str, &str); 3] = [
    (rwg_worker::python::PIPE_MODULE, rwg_worker::python::PIPE_PY),
    ("rwg_env_values", ENV_VALUES_PY),
    ("rwg_env_spaces", ENV_SPACES_PY),
];

/// What `python -c` runs, with the loader, [`WORKER_PY`] and [`MODULES`]
/// as its arguments: a check that
/// the interpreter can run the worker, in a text that every Python parses
/// (Python 2 included) and that a POSIX shell named as the interpreter
/// reads as a message and `exit 97` (rather than running the worker's
/// source as shell commands), then the worker itself.
pub const BOOT_PY: &str = include_str!("boot.py");

/// The prefix of a Gymnasium env id in rwg.
pub const PREFIX: &str = "gymnasium:";

/// The largest flat observation accepted (values): rwg's networks take the
/// whole observation as input, so an image is far beyond what RWG measures.
pub const MAX_OBS: usize = 4096;

/// Default time an exchange may take before the worker counts as hung.
pub const DEFAULT_TIMEOUT_S: f64 = 60.0;

/// The environment variable overriding [`DEFAULT_TIMEOUT_S`] (seconds).
pub const TIMEOUT_VAR: &str = "RWG_GYM_TIMEOUT";

/// Default time a worker may take to start (import the env's module and
/// make its instances) before it counts as hung.
pub const DEFAULT_START_TIMEOUT_S: f64 = 300.0;

/// The environment variable overriding [`DEFAULT_START_TIMEOUT_S`] (seconds).
pub const START_TIMEOUT_VAR: &str = "RWG_GYM_START_TIMEOUT";

/// Python's variable fixing the seed of `hash()` of strings and bytes
/// (random per process when unset).
pub const HASH_SEED_VAR: &str = "PYTHONHASHSEED";

/// The [`HASH_SEED_VAR`] workers get unless the user set it: every worker
/// process of a study then hashes strings alike.
pub const DEFAULT_HASH_SEED: &str = "0";

/// Groups of [`LANES`](rwg_core::sampler::LANES) env instances per worker:
/// while the worker steps one group, rwg computes the next actions of the
/// other, so neither waits.
pub const GROUPS: usize = 2;

/// The seed of the determinism check made when a worker starts.
const CHECK_SEED: u64 = 20_200_509;

/// The Gymnasium id in a `gymnasium:` id (`gymnasium:CartPole-v1` ->
/// `CartPole-v1`, `gymnasium:pkg.envs:Maze-v0` -> `pkg.envs:Maze-v0`), or
/// `None` for any other id. This is also the id that enters the seeds, so
/// `gymnasium:CartPole-v1` meets the networks and initial states rwg's
/// built-in `CartPole-v1` meets.
pub fn gym_id(id: &str) -> Option<&str> {
    id.strip_prefix(PREFIX)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rwg_worker::python::{check_load_order, rwg_imports};

    #[test]
    fn each_shipped_module_is_loaded_after_the_modules_it_imports() {
        check_load_order(WORKER_PY, &MODULES).unwrap();
        let worker = rwg_imports(WORKER_PY);
        assert_eq!(worker, ["rwg_pipe", "rwg_env_values", "rwg_env_spaces"]);
    }
}
