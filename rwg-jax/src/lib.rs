//! # rwg-jax: JAX environments (gymnax, Brax, a user's own) at JAX's speed
//!
//! An environment id `gymnax:ID`, `brax:NAME` or `jax:module:callable` runs
//! in Python worker processes that compile rwg's policy and the env's
//! episode into one call over a chunk of networks. Only weights and reset
//! seeds go to Python; only per-episode returns, lengths and fault bits come
//! back.

use rwg_core::sampler::{BlockResult, CellPlan, SampleError};
use rwg_env::EnvSpec;
use rwg_worker::protocol::WorkerError;
use std::collections::BTreeMap;
use std::ops::Range;
use std::time::Duration;
use thiserror::Error;

/// The worker program, run with `python -c`.
pub const WORKER_PY: &str = include_str!("jax_worker.py");

/// The prefixes of JAX env ids, in [`JaxKind`] order.
pub const PREFIXES: [&str; 3] = ["gymnax:", "brax:", "jax:"];

/// The environment variable overriding [`DEFAULT_TIMEOUT_S`] (seconds).
pub const TIMEOUT_VAR: &str = "RWG_JAX_TIMEOUT";

/// Default time a worker's start, one compile or one call may take.
pub const DEFAULT_TIMEOUT_S: f64 = 3600.0;

/// The largest [`TIMEOUT_VAR`] accepted, in seconds (a week).
pub const MAX_TIMEOUT_S: f64 = 604_800.0;

/// `networks_per_call` must be a multiple of this.
pub const NETWORKS_MULTIPLE: u32 = 32;

/// Default networks per compiled call on a CPU device.
pub const DEFAULT_NETWORKS_CPU: u32 = 256;

/// Default networks per compiled call on a GPU or TPU device.
pub const DEFAULT_NETWORKS_ACCELERATOR: u32 = 4096;

/// Which library an env comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum JaxKind {
    /// `gymnax:ID`: `gymnax.make(ID)`.
    Gymnax,
    /// `brax:NAME`: `brax.envs.get_environment(NAME)`.
    Brax,
    /// `jax:module:callable`: a user's function returning `(env, params)`.
    Custom,
}

impl JaxKind {
    /// The id prefix (`gymnax:`).
    pub fn prefix(self) -> &'static str {
        unimplemented!()
    }

    /// The source's name in the worker protocol (`gymnax`, `brax`, `jax`).
    pub fn source(self) -> &'static str {
        unimplemented!()
    }
}

/// The kind and seed id of a JAX env id (`gymnax:CartPole-v1` ->
/// `(Gymnax, "CartPole-v1")`), or `None` for any other id.
pub fn jax_id(id: &str) -> Option<(JaxKind, &str)> {
    let _ = id;
    unimplemented!()
}

/// The float type the policy and the env compute in.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum Precision {
    /// `float32` (JAX's default).
    #[default]
    F32,
    /// `float64` (`jax_enable_x64`).
    F64,
}

impl Precision {
    /// The manifest's names, in variant order.
    pub const NAMES: [&'static str; 2] = ["float32", "float64"];

    /// `float32` or `float64`.
    pub fn name(self) -> &'static str {
        unimplemented!()
    }

    /// The precision named `name` ([`Precision::NAMES`]).
    pub fn from_name(name: &str) -> Option<Precision> {
        let _ = name;
        unimplemented!()
    }
}

/// Everything that determines a JAX environment source.
#[derive(Debug, Clone, PartialEq)]
pub struct JaxConfig {
    /// Which library.
    pub kind: JaxKind,
    /// The id after the prefix (`CartPole-v1`, `my_pkg.envs:make_env`).
    pub id: String,
    /// The Python interpreter.
    pub python: String,
    /// Keyword arguments (gymnax: env params fields; brax:
    /// `get_environment` kwargs; jax: the callable's), encoded as
    /// `rwg_gym::kwargs` does (nan/inf as `{"$rwg": "nan"}`).
    pub kwargs: serde_json::Map<String, serde_json::Value>,
    /// The manifest's time limit override.
    pub max_episode_steps: Option<u32>,
    /// The precision.
    pub precision: Precision,
    /// The JAX device (`cpu`, `gpu:1`); `None`: `jax.devices()[0]`.
    pub device: Option<String>,
    /// Networks per compiled call; `None`: by platform
    /// ([`DEFAULT_NETWORKS_CPU`], [`DEFAULT_NETWORKS_ACCELERATOR`]).
    pub networks_per_call: Option<u32>,
    /// How long a start, a compile or a call may take.
    pub timeout: Duration,
}

impl JaxConfig {
    /// A config for `id` (without the prefix) of `kind` with defaults: the
    /// Python from [`default_python`], no kwargs, the env's own time limit,
    /// float32, the default device and call size, [`default_timeout`].
    pub fn new(kind: JaxKind, id: &str) -> Self {
        let _ = (kind, id);
        unimplemented!()
    }

    /// The full rwg id (`gymnax:CartPole-v1`).
    pub fn rwg_id(&self) -> String {
        unimplemented!()
    }
}

/// `RWG_PYTHON` if set, else `python3` (as for `gymnasium:` envs).
pub fn default_python() -> String {
    unimplemented!()
}

/// [`TIMEOUT_VAR`] (seconds from 0.001 to [`MAX_TIMEOUT_S`]) if set, else
/// [`DEFAULT_TIMEOUT_S`]; an error naming the variable for any other value.
pub fn timeout_setting() -> Result<Duration, rwg_env::vars::VarError> {
    unimplemented!()
}

/// [`timeout_setting`], or [`DEFAULT_TIMEOUT_S`] if that is an error (the
/// `rwg` binary checks the variable before it runs a command).
pub fn default_timeout() -> Duration {
    unimplemented!()
}

/// The environment as the worker described it.
#[derive(Debug, Clone, PartialEq)]
pub struct JaxInfo {
    /// The spec in rwg's terms (id with its prefix, flattened spaces).
    pub spec: EnvSpec,
    /// The library's text of the observation space.
    pub observation_space: String,
    /// The library's text of the action space.
    pub action_space: String,
    /// Versions: `python`, `jax`, `jaxlib`, and `gymnax`, `brax` or `module`.
    pub versions: BTreeMap<String, String>,
    /// The device used (`cpu:0`, `cuda:0`).
    pub device: String,
    /// The device's kind (`cpu`, `NVIDIA H200`).
    pub device_kind: String,
    /// JAX's platform (`cpu`, `gpu`, `tpu`).
    pub platform: String,
    /// The precision the worker ran.
    pub precision: Precision,
}

/// What can go wrong with a JAX environment.
#[derive(Debug, Error)]
pub enum JaxError {
    /// The interpreter could not be started.
    #[error("cannot run Python '{python}': {source}")]
    NoPython {
        /// The interpreter.
        python: String,
        /// Why it did not start.
        source: std::io::Error,
    },
    /// The worker reported a fatal error.
    #[error("{}", error.message)]
    Worker {
        /// The interpreter.
        python: String,
        /// What it reported.
        error: WorkerError,
    },
    /// The worker process ended.
    #[error("the JAX worker {how}")]
    Died {
        /// How it ended.
        how: String,
        /// The end of its stderr.
        stderr: String,
    },
    /// The worker did not answer in time.
    #[error("the JAX worker did not answer within {secs} s")]
    Timeout {
        /// The limit.
        secs: f64,
        /// The end of its stderr.
        stderr: String,
    },
    /// The worker said something unexpected.
    #[error("JAX worker protocol error: {0}")]
    Protocol(String),
}

/// One JAX environment of a study: its config, its description, and the
/// worker processes kept between cells.
pub struct JaxSource {
    config: JaxConfig,
    info: JaxInfo,
}

impl std::fmt::Debug for JaxSource {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("JaxSource")
            .field("config", &self.config)
            .finish()
    }
}

impl JaxSource {
    /// Starts one worker (imports, makes the env, checks its spaces and the
    /// device) and keeps it for the run.
    pub fn open(config: JaxConfig) -> Result<JaxSource, JaxError> {
        let _ = config;
        unimplemented!()
    }

    /// The environment as the worker described it.
    pub fn info(&self) -> &JaxInfo {
        &self.info
    }

    /// The config.
    pub fn config(&self) -> &JaxConfig {
        &self.config
    }

    /// Networks per compiled call: the config's, else the platform's default.
    pub fn networks_per_call(&self) -> u32 {
        unimplemented!()
    }

    /// Worker processes a run with `threads` threads uses: `threads` on a
    /// CPU device, 1 on a GPU or TPU.
    pub fn workers_for(&self, threads: usize) -> usize {
        let _ = threads;
        unimplemented!()
    }

    /// CPU seconds used so far by the idle worker processes, where the OS
    /// reports it.
    pub fn workers_cpu_seconds(&self) -> Option<f64> {
        unimplemented!()
    }

    /// Runs `blocks` of a cell on [`JaxSource::workers_for`]`(threads)`
    /// workers, in chunks of [`JaxSource::networks_per_call`] networks, and
    /// hands the results to `on_block` in block order.
    pub fn run_blocks<G, X>(
        &self,
        plan: &CellPlan,
        blocks: &[Range<u64>],
        threads: usize,
        on_block: G,
    ) -> Result<(), X>
    where
        G: FnMut(BlockResult) -> Result<(), X>,
        X: From<SampleError> + Send,
    {
        let _ = (plan, blocks, threads, on_block);
        unimplemented!()
    }
}
