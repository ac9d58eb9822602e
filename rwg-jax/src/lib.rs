//! # rwg-jax: JAX environments (gymnax, Brax, MuJoCo Playground, Jumanji, Craftax, Navix, XLand-MiniGrid, Pgx, a user's own) at JAX's speed
//!
//! An environment id of a JAX family ([`FAMILIES`]: `gymnax:ID`,
//! `brax:NAME`, `playground:NAME`, ..., `jax:module:callable`) runs
//! in Python worker processes that compile rwg's policy and the env's
//! episode into one call over a chunk of networks. Only weights and reset
//! seeds go to Python; only per-episode returns, lengths and fault bits come
//! back.
//!
//! The worker program ([`WORKER_PY`]) ships inside rwg and is handed to
//! `python -c`; it compiles one program per cell: `lanes` episodes at a
//! time, a lane whose episode ended taking the chunk's next (network,
//! episode) inside the compiled loop (`jax_episode.py`); an env whose
//! episodes all end at the same step whatever the actions runs a plain loop
//! instead, with the same bits ([`protocol::EpisodeLoop`]). Every per-episode
//! computation has the lanes' shape, so a network's results are the same
//! bits whatever the chunk that holds it, `networks_per_call`, the threads,
//! devices, shards or a resume. The weights are rwg's draw
//! ([`rwg_core::sampler::draw_block_weights`]); the episode's key is the
//! threefry key of data `[r >> 32, r & 0xFFFFFFFF]` of rwg's reset seed `r`.
//!
//! # Example
//!
//! A JAX env id names its library and env; opening it starts a worker with
//! the configured Python. This one names no interpreter that exists, so it
//! runs anywhere and shows the error a user without Python gets:
//!
//! ```
//! use rwg_jax::{jax_id, JaxConfig, JaxError, JaxKind, JaxSource};
//!
//! let (kind, id) = jax_id("gymnax:CartPole-v1").expect("a JAX env id");
//! assert_eq!(kind, JaxKind::Gymnax);
//! let mut config = JaxConfig::new(kind, id);
//! assert_eq!(config.rwg_id(), "gymnax:CartPole-v1");
//! config.python = "/nonexistent/python3".into();
//! // With a Python that has JAX and gymnax, `open` starts a worker, makes the
//! // env and checks its spaces, and `run_blocks` samples a cell's blocks.
//! let err = JaxSource::open(config).unwrap_err();
//! assert!(matches!(err, JaxError::NoPython { .. }));
//! assert!(err.to_string().starts_with("cannot run Python '/nonexistent/python3': "));
//! ```
//!
//! # Modules
//!
//! - [`family`]: the JAX env sources, one row each (prefix, adapter, package).
//! - [`protocol`]: the messages (hello, cell, chunk, ready, outcome).
//! - The worker's Python: [`WORKER_PY`] and its [`MODULES`].
//! - `worker`: one worker process, its handshake, compiles and chunks.
//! - `config`: [`JaxConfig`], the precisions, the settings from `RWG_*`.
//! - `source`: [`JaxSource`], its workers, a cell's program shape.
//! - [`chunks`]: blocks cut into chunks, outcomes put back into blocks in order.
//! - `run`: the chunks handed to the workers, pipelined.
//! - [`warm_up`]: a cell's workers starting and compiling, told to a
//!   progress display and timed.

pub mod chunks;
mod config;
pub mod family;
pub mod protocol;
mod run;
mod source;
pub mod warm_up;
mod worker;

pub use config::{
    cache_setting, default_python, default_timeout, timeout_setting, JaxConfig, MatmulPrecision,
    Precision,
};
pub use source::{JaxSource, StartingSource};

pub use family::{id_forms, jax_id, Family, JaxKind, FAMILIES};

use rwg_core::sampler::SampleError;
use rwg_env::EnvSpec;
use rwg_worker::protocol::WorkerError;
use std::collections::BTreeMap;
use thiserror::Error;

/// The worker program, run with `python -c` through rwg-worker's loader
/// ([`rwg_worker::python::LOAD_PY`]), with [`MODULES`] importable: the
/// protocol's side of the worker (start-up, device, serving messages).
pub const WORKER_PY: &str = include_str!("jax_worker.py");

/// The fault bits of an episode, failures reported through the pipe, the
/// versions of installed distributions: a module every other one imports.
pub const COMMON_PY: &str = include_str!("jax_common.py");

/// float32 sin and cos on a CPU as array operations XLA vectorises (Cephes'
/// polynomials), instead of a C library call per element.
pub const TRIG_PY: &str = include_str!("jax_trig.py");

/// The env sources (gymnax, Brax, `jax:module:callable`), each adapted to
/// the interface the episode loop drives.
pub const ENVS_PY: &str = include_str!("jax_envs.py");

/// Structured observations: a pytree flattened in one documented order and
/// described leaf by leaf.
pub const OBS_PY: &str = include_str!("jax_obs.py");

/// The families' adapters (Playground, Jumanji, Craftax, Navix,
/// XLand-MiniGrid, Pgx) and the table of every source's maker.
pub const FAMILIES_PY: &str = include_str!("jax_families.py");

/// The env's spaces as rwg takes them, and rwg's policy in JAX.
pub const POLICY_PY: &str = include_str!("jax_policy.py");

/// The compiled program of a cell: lanes that never idle, each taking a
/// chunk's next (network, episode) inside the compiled loop, or a plain loop
/// for an env whose episodes all end at the same step.
pub const EPISODE_PY: &str = include_str!("jax_episode.py");

/// The modules [`WORKER_PY`] imports from rwg (name, source), in the order
/// they are loaded: the pipe to rwg first, each module after those it
/// imports.
pub const MODULES: [(&str, &str); 8] = [
    (rwg_worker::python::PIPE_MODULE, rwg_worker::python::PIPE_PY),
    ("rwg_jax_worker_common", COMMON_PY),
    ("rwg_jax_worker_trig", TRIG_PY),
    ("rwg_jax_worker_envs", ENVS_PY),
    ("rwg_jax_worker_obs", OBS_PY),
    ("rwg_jax_worker_families", FAMILIES_PY),
    ("rwg_jax_worker_policy", POLICY_PY),
    ("rwg_jax_worker_episode", EPISODE_PY),
];

/// The environment variable overriding [`DEFAULT_TIMEOUT_S`] (seconds).
pub const TIMEOUT_VAR: &str = "RWG_JAX_TIMEOUT";

/// Default time a worker's start, one compile or one call may take.
pub const DEFAULT_TIMEOUT_S: f64 = 3600.0;

/// The largest [`TIMEOUT_VAR`] accepted, in seconds (a week).
pub const MAX_TIMEOUT_S: f64 = 604_800.0;

/// `networks_per_call` must be a multiple of this.
pub const NETWORKS_MULTIPLE: u32 = 32;

/// Lanes (episodes run at once) of a cell's program on a CPU.
pub const DEFAULT_LANES_CPU: u32 = 512;

/// Lanes of a cell's program on a GPU or TPU.
pub const DEFAULT_LANES_ACCELERATOR: u32 = 65_536;

/// The default chunk holds this many episodes per lane (fewer when the
/// device's memory is short).
pub const EPISODES_PER_LANE: u32 = 32;

/// The largest default `networks_per_call`.
pub const MAX_DEFAULT_NETWORKS: u32 = 65_536;

/// The share of a GPU's or TPU's memory the default chunks may take (two
/// chunks are in flight per device).
pub const MEMORY_SHARE: f64 = 0.25;

/// The environment variable naming the folder of JAX's persistent
/// compilation cache (`off`: none); see [`cache_setting`].
pub const CACHE_VAR: &str = "RWG_JAX_CACHE";

/// The largest flat observation accepted (values).
pub const MAX_OBS: usize = 4096;

/// The environment variable naming the default Python interpreter.
pub const PYTHON_VAR: &str = "RWG_PYTHON";

/// The environment as the worker described it.
#[derive(Debug, Clone, PartialEq)]
pub struct JaxInfo {
    /// The spec in rwg's terms (id with its prefix, flattened spaces).
    pub spec: EnvSpec,
    /// The library's text of the observation space.
    pub observation_space: String,
    /// The library's text of the action space.
    pub action_space: String,
    /// Versions: `python`, `jax`, `jaxlib`, and the env's library (its
    /// package's name: `gymnax`, `playground`, ...) or `module`.
    pub versions: BTreeMap<String, String>,
    /// The observation's leaves, in the order they are flattened.
    pub observation_leaves: Vec<protocol::Leaf>,
    /// How a discrete action is chosen: `legal` (argmax over the legal
    /// actions), `off` (the family gives them, the manifest turned them
    /// off), `none` (the family gives none, or the actions are a box).
    pub action_mask: String,
    /// Choices made when the env was made (Playground's physics `impl`,
    /// Craftax's `auto_reset`, ...), recorded with the cell.
    pub settings: BTreeMap<String, String>,
    /// The devices used (`cpu:0`, `cuda:0, cuda:1`).
    pub device: String,
    /// How many devices a worker runs (all of one kind).
    pub devices: usize,
    /// The devices' kind (`cpu`, `NVIDIA H200`).
    pub device_kind: String,
    /// JAX's platform (`cpu`, `gpu`, `tpu`).
    pub platform: String,
    /// The precision the worker ran.
    pub precision: Precision,
    /// A device's memory as its allocator reports it (`None`: a CPU).
    pub memory: Option<u64>,
    /// Bytes an episode's start (its observation and state) takes on the
    /// device.
    pub item_bytes: u64,
    /// For a `jax:module:callable` env: what its code is.
    pub source: Option<protocol::ModuleSource>,
    /// Which program runs the episodes, and why.
    pub episode_loop: protocol::EpisodeLoop,
}

/// What can go wrong with a JAX environment.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum JaxError {
    /// The interpreter could not be started.
    #[error(
        "cannot run Python '{python}': {reason}; install Python 3 with JAX ({python} -m pip \
         install jax, or \"jax[cuda12]\" for an NVIDIA GPU) and the env's package, or name the \
         interpreter with `python = \"...\"` in the manifest or the {PYTHON_VAR} environment \
         variable"
    )]
    NoPython {
        /// The interpreter.
        python: String,
        /// Why it did not start (in this text, so not the error's source:
        /// the text is complete where it is shown without its chain).
        reason: std::io::Error,
    },
    /// The worker reported a fatal error (`kind` says which: `import`,
    /// `unknown-env`, `make`, `space`, `device`, `compile`, `oom`, `run`...).
    #[error("{}", worker_error_text(.python, .error))]
    Worker {
        /// The interpreter.
        python: String,
        /// What it reported.
        error: WorkerError,
    },
    /// The worker process ended.
    #[error("the JAX worker {how} while {doing}{}", tail(.stderr))]
    Died {
        /// How it ended ("was killed by signal 11 (SIGSEGV)").
        how: String,
        /// What it was doing (`starting`, `compiling`, `running a chunk`).
        doing: &'static str,
        /// The end of its stderr.
        stderr: String,
    },
    /// The worker did not answer in time.
    #[error("the JAX worker did not answer within {secs} s while {doing} and was killed; set \
             {TIMEOUT_VAR} (seconds) to allow more{}", tail(.stderr))]
    Timeout {
        /// The limit.
        secs: f64,
        /// What it was doing (`starting`, `compiling`, `running a chunk`).
        doing: &'static str,
        /// The end of its stderr (with the traceback of where it hung).
        stderr: String,
    },
    /// A worker started later describes the env otherwise than the first.
    #[error(
        "another JAX worker process of the env reports {0}; the workers of one env must \
             agree (does the env depend on the process?)"
    )]
    OtherInfo(String),
    /// The worker said something unexpected.
    #[error("JAX worker protocol error: {0}")]
    Protocol(String),
}

use rwg_worker::stderr_tail_text as tail;

/// A failure of a JAX env that no episode is to blame for: a worker that
/// could not start or compile the cell, or a compiled call that failed as a
/// whole (the worker's error, death or timeout), named by the call's
/// networks. (An episode's own failure is a [`SampleError`].)
#[derive(Debug, Error)]
#[error("{env}: {}{error}", calls_text(.networks))]
pub struct CallError {
    /// The env's id.
    pub env: String,
    /// The call's first and last network and how many it ran; `None` for a
    /// worker's start or compile.
    pub networks: Option<(u64, u64, usize)>,
    /// What went wrong (in this text, not chained: printed once).
    pub error: JaxError,
}

fn calls_text(networks: &Option<(u64, u64, usize)>) -> String {
    networks.map_or(String::new(), |(first, last, n)| {
        format!(
            "the compiled call of networks {first} to {last} ({n} networks, every episode) \
             failed: "
        )
    })
}

/// Why [`JaxSource::run_blocks`] stopped, for a caller without an error
/// type of its own.
#[derive(Debug, Error)]
pub enum RunError {
    /// An episode failed.
    #[error(transparent)]
    Episode(Box<SampleError>),
    /// A start, compile or whole call failed.
    #[error(transparent)]
    Call(Box<CallError>),
}

impl From<SampleError> for RunError {
    fn from(e: SampleError) -> Self {
        RunError::Episode(Box::new(e))
    }
}

impl From<CallError> for RunError {
    fn from(e: CallError) -> Self {
        RunError::Call(Box::new(e))
    }
}

fn worker_error_text(python: &str, e: &WorkerError) -> String {
    let mut s = format!("{} (Python {python})", e.message);
    if !e.traceback.trim().is_empty() {
        s.push_str("\nPython traceback:\n");
        s.push_str(e.traceback.trim_end());
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_shipped_module_is_loaded_after_the_modules_it_imports() {
        rwg_worker::python::check_load_order(WORKER_PY, &MODULES).unwrap();
    }

    #[test]
    fn jax_ids_name_their_kind_and_seed_id() {
        assert_eq!(
            jax_id("gymnax:CartPole-v1"),
            Some((JaxKind::Gymnax, "CartPole-v1"))
        );
        assert_eq!(
            jax_id("brax:inverted_pendulum"),
            Some((JaxKind::Brax, "inverted_pendulum"))
        );
        assert_eq!(
            jax_id("jax:my_pkg.envs:make_env"),
            Some((JaxKind::Custom, "my_pkg.envs:make_env"))
        );
        assert_eq!(jax_id("gymnasium:CartPole-v1"), None);
        assert_eq!(jax_id("CartPole-v1"), None);
        let cfg = JaxConfig::new(JaxKind::Custom, "m:f");
        assert_eq!(cfg.rwg_id(), "jax:m:f");
        assert_eq!(jax_id(&cfg.rwg_id()), Some((JaxKind::Custom, "m:f")));
    }

    /// A Python that cannot start: the reason is in the text, once, and not
    /// chained as well (a printer of the chain would repeat it).
    #[test]
    fn no_python_says_why_once() {
        use std::error::Error as _;
        let e = JaxError::from_proc(
            rwg_worker::ProcError::Spawn {
                program: "/nonexistent/python3".into(),
                source: std::io::Error::new(std::io::ErrorKind::NotFound, "no such file xyz"),
            },
            "starting",
        );
        let text = e.to_string();
        assert!(
            text.starts_with("cannot run Python '/nonexistent/python3': no such file xyz; install"),
            "{text}"
        );
        assert!(e.source().is_none(), "{:?}", e.source());
    }
}
