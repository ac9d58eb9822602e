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
//! `python -c`; it compiles `jit(vmap(networks, vmap(episodes, episode)))`
//! once per cell at one shape (`networks_per_call` networks; a short chunk
//! is padded), so a network's results are the same bits whatever the
//! chunking of blocks, the threads, shards or a resume. The weights are
//! rwg's draw ([`rwg_core::sampler::draw_block_weights`]); the episode's key
//! is the threefry key of data `[r >> 32, r & 0xFFFFFFFF]` of rwg's reset
//! seed `r`.
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
//! - [`chunks`]: blocks cut into chunks, outcomes put back into blocks in order.
//! - `run`: the chunks handed to the workers, one in flight each.
//! - [`warm_up`]: a cell's workers starting and compiling, told to a
//!   progress display and timed.

pub mod chunks;
pub mod family;
pub mod protocol;
mod run;
pub mod warm_up;
mod worker;

use worker::JaxWorker;

pub use family::{id_forms, jax_id, Family, JaxKind, FAMILIES};

use rwg_core::sampler::{BlockResult, CellPlan, SampleError};
use rwg_env::EnvSpec;
use rwg_worker::protocol::WorkerError;
use std::collections::BTreeMap;
use std::ops::Range;
use std::time::Duration;
use thiserror::Error;

/// The worker program, run with `python -c` through rwg-worker's loader
/// ([`rwg_worker::python::LOAD_PY`]), with [`MODULES`] importable: the
/// protocol's side of the worker (start-up, device, serving messages).
pub const WORKER_PY: &str = include_str!("jax_worker.py");

/// The fault bits of an episode, failures reported through the pipe, the
/// versions of installed distributions: a module every other one imports.
pub const COMMON_PY: &str = include_str!("jax_common.py");

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

/// The compiled program of a cell: the episode loop, vmapped over episodes
/// and networks, and a chunk of networks run through it.
pub const EPISODE_PY: &str = include_str!("jax_episode.py");

/// The modules [`WORKER_PY`] imports from rwg (name, source), in the order
/// they are loaded: the pipe to rwg first, each module after those it
/// imports.
pub const MODULES: [(&str, &str); 7] = [
    (rwg_worker::python::PIPE_MODULE, rwg_worker::python::PIPE_PY),
    ("rwg_jax_worker_common", COMMON_PY),
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

/// Default networks per compiled call on a CPU device.
pub const DEFAULT_NETWORKS_CPU: u32 = 256;

/// Default networks per compiled call on a GPU or TPU device.
pub const DEFAULT_NETWORKS_ACCELERATOR: u32 = 4096;

/// The largest flat observation accepted (values).
pub const MAX_OBS: usize = 4096;

/// The environment variable naming the default Python interpreter.
pub const PYTHON_VAR: &str = "RWG_PYTHON";

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
        Self::NAMES[self as usize]
    }

    /// The precision named `name` ([`Precision::NAMES`]).
    pub fn from_name(name: &str) -> Option<Precision> {
        match name {
            "float32" => Some(Precision::F32),
            "float64" => Some(Precision::F64),
            _ => None,
        }
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
    /// Whether a discrete action is the argmax over the legal actions where
    /// the family gives them (`true`), or over all actions.
    pub action_mask: bool,
    /// How long a start, a compile or a call may take.
    pub timeout: Duration,
}

impl JaxConfig {
    /// A config for `id` (without the prefix) of `kind` with defaults: the
    /// Python from [`default_python`], no kwargs, the env's own time limit,
    /// float32, the default device and call size, [`default_timeout`].
    pub fn new(kind: JaxKind, id: &str) -> Self {
        JaxConfig {
            kind,
            id: id.to_string(),
            python: default_python(),
            kwargs: Default::default(),
            max_episode_steps: None,
            precision: Precision::F32,
            device: None,
            networks_per_call: None,
            action_mask: true,
            timeout: default_timeout(),
        }
    }

    /// The full rwg id (`gymnax:CartPole-v1`).
    pub fn rwg_id(&self) -> String {
        format!("{}{}", self.kind.prefix(), self.id)
    }
}

/// `RWG_PYTHON` if set, else `python3` (as for `gymnasium:` envs).
pub fn default_python() -> String {
    rwg_env::vars::text(PYTHON_VAR, "a Python interpreter")
        .ok()
        .flatten()
        .unwrap_or_else(|| "python3".into())
}

/// [`TIMEOUT_VAR`] (seconds from 0.001 to [`MAX_TIMEOUT_S`]) if set, else
/// [`DEFAULT_TIMEOUT_S`]; an error naming the variable for any other value.
pub fn timeout_setting() -> Result<Duration, rwg_env::vars::VarError> {
    rwg_env::vars::seconds(
        TIMEOUT_VAR,
        0.001,
        MAX_TIMEOUT_S,
        Duration::from_secs_f64(DEFAULT_TIMEOUT_S),
        "how long a JAX worker may take to start, to compile a cell or to run one call",
    )
}

/// [`timeout_setting`], or [`DEFAULT_TIMEOUT_S`] if that is an error (the
/// `rwg` binary checks the variable before it runs a command).
pub fn default_timeout() -> Duration {
    timeout_setting().unwrap_or(Duration::from_secs_f64(DEFAULT_TIMEOUT_S))
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
    /// The device used (`cpu:0`, `cuda:0`).
    pub device: String,
    /// The device's kind (`cpu`, `NVIDIA H200`).
    pub device_kind: String,
    /// JAX's platform (`cpu`, `gpu`, `tpu`).
    pub platform: String,
    /// The precision the worker ran.
    pub precision: Precision,
    /// For a `jax:module:callable` env: what its code is.
    pub source: Option<protocol::ModuleSource>,
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

/// One JAX environment of a study: its config, its description, and the
/// worker processes kept between cells.
pub struct JaxSource {
    config: JaxConfig,
    info: JaxInfo,
    pool: std::sync::Mutex<Vec<JaxWorker>>,
    warm_ups: warm_up::WarmUps,
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
        let (first, info) = JaxWorker::spawn(&config)?;
        Ok(JaxSource {
            config,
            info,
            pool: std::sync::Mutex::new(vec![first]),
            warm_ups: warm_up::WarmUps::default(),
        })
    }

    /// Tells `observer` when the workers of each cell run from now on warm
    /// up (start, compile) and when they are ready.
    pub fn observe(&self, observer: std::sync::Arc<dyn warm_up::WarmUpObserver>) {
        self.warm_ups.observe(observer);
    }

    /// The wall time of every cell's warm-up so far, added up: from the
    /// start of [`JaxSource::run_blocks`] until its last worker has started
    /// (if it was not idle) and compiled the cell.
    pub fn warm_up_time(&self) -> Duration {
        self.warm_ups.total()
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
        self.config.networks_per_call.unwrap_or(if self.on_cpu() {
            DEFAULT_NETWORKS_CPU
        } else {
            DEFAULT_NETWORKS_ACCELERATOR
        })
    }

    fn on_cpu(&self) -> bool {
        self.info.platform == "cpu"
    }

    /// Worker processes a run with `threads` threads uses: `threads` on a
    /// CPU device, 1 on a GPU or TPU.
    pub fn workers_for(&self, threads: usize) -> usize {
        if self.on_cpu() {
            threads.max(1)
        } else {
            1
        }
    }

    /// CPU seconds used so far by the idle worker processes, where the OS
    /// reports it.
    pub fn workers_cpu_seconds(&self) -> Option<f64> {
        self.lock_pool().iter().map(|w| w.cpu_seconds()).sum()
    }

    fn lock_pool(&self) -> std::sync::MutexGuard<'_, Vec<JaxWorker>> {
        self.pool.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// An idle worker, or a new one (which must describe the env as the
    /// first did).
    fn take_worker(&self) -> Result<JaxWorker, JaxError> {
        if let Some(w) = self.lock_pool().pop() {
            return Ok(w);
        }
        let (w, info) = JaxWorker::spawn(&self.config)?;
        if info != self.info {
            return Err(JaxError::OtherInfo(format!(
                "{info:?} where the first reported {:?}",
                self.info
            )));
        }
        Ok(w)
    }

    /// Runs `blocks` of a cell on [`JaxSource::workers_for`]`(threads)`
    /// workers (kept between calls), in chunks of
    /// [`JaxSource::networks_per_call`] networks of consecutive blocks, one
    /// chunk in flight per worker, and hands the results to `on_block` in
    /// block order. Stops at the first failure in network order (an
    /// episode's fault bit: a [`SampleError`]; a worker's error, death or
    /// timeout: a [`CallError`]) or the first error `on_block` returns; the
    /// blocks handed out before stay valid.
    pub fn run_blocks<G, X>(
        &self,
        plan: &CellPlan,
        blocks: &[Range<u64>],
        threads: usize,
        on_block: G,
    ) -> Result<(), X>
    where
        G: FnMut(BlockResult) -> Result<(), X>,
        X: From<SampleError> + From<CallError> + Send,
    {
        run::run_blocks(self, plan, blocks, threads, on_block)
    }
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

    #[test]
    fn precisions_go_by_their_manifest_names() {
        for p in [Precision::F32, Precision::F64] {
            assert_eq!(Precision::from_name(p.name()), Some(p));
        }
        assert_eq!(Precision::from_name("float16"), None);
        assert_eq!(Precision::default(), Precision::F32);
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
