//! # rwg-gym: any Gymnasium environment through a crash-isolated bridge
//!
//! An environment id `gymnasium:ID` (or `gymnasium:module:ID`, which imports
//! `module` first) runs in Python worker processes: each hosts [`GROUPS`]
//! groups of [`rwg_core::sampler::LANES`] instances of the env, made with
//! `gym.make`, and resets/steps a group in lockstep, one exchange over its
//! stdin/stdout per batch step (one group in flight while rwg works on the
//! other), in the binary format of `docs/bridge-protocol.md`. Everything
//! else — weights, the network's forward pass, reset seeds, statistics —
//! stays in rwg, so a Gymnasium env gives the numbers a built-in env of the
//! same dynamics gives.
//!
//! The worker program ([`WORKER_PY`]) ships inside rwg and is handed to
//! `python -c` after [`BOOT_PY`]; the user installs only Gymnasium and the env's package. A
//! worker that crashes (a segfault in a C extension), hangs (no answer within
//! the timeout) or raises is reported as an error naming what happened, with
//! the Python traceback; rwg itself keeps running.
//!
//! This is its own crate (not part of the runner's core) because it owns
//! a Python program and what Gymnasium's spaces and errors mean. The worker
//! processes, the protocol and the batched host are `rwg-worker`'s, shared
//! with the isolated plugin workers.

pub use rwg_worker::describe_status;
pub use rwg_worker::protocol;

pub mod kwargs;

use protocol::*;
use rwg_core::batch::{
    run_blocks_batched, BatchEnv, BatchFailure, BatchPool, LaneActions, LaneOp, LaneOutcome,
    SingleLane,
};
use rwg_core::sampler::{BlockResult, CellPlan, SampleError, LANES};
use rwg_env::{ActionDtype, BoxSpace, EnvError, EnvSpec, Space};
use rwg_worker::host::{handshake, Describe, PipeBatch, StartFailure, StartTimeouts};
use rwg_worker::lane_file::LaneFile;
use rwg_worker::{ProcError, Worker};
use serde::Deserialize;
use std::ops::Range;
use std::time::Duration;
use thiserror::Error;

/// The worker program, run by [`BOOT_PY`].
pub const WORKER_PY: &str = include_str!("worker.py");

/// What `python -c` runs, with [`WORKER_PY`] as its argument: a check that
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

/// Default time a batch step may take before the worker counts as hung.
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

/// Groups of [`LANES`] env instances per worker: while the worker steps one
/// group, rwg computes the next actions of the other, so neither waits.
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
    /// How long one batch step may take (and one reset or step of the
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

/// `RWG_PYTHON` if set, else `python3`; an error if it is not UTF-8.
pub fn python_setting() -> Result<String, rwg_env::vars::VarError> {
    Ok(rwg_env::vars::text(PYTHON_VAR)?.unwrap_or_else(|| "python3".into()))
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

/// What can go wrong with a Gymnasium environment.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum GymError {
    /// The interpreter could not be started.
    #[error(
        "cannot run Python '{python}': {source}; install Python 3 with Gymnasium \
             (python3 -m pip install gymnasium), or name the interpreter with `python = \"...\"` \
             in the manifest or the RWG_PYTHON environment variable"
    )]
    NoPython {
        /// The interpreter.
        python: String,
        /// Why it did not start.
        source: std::io::Error,
    },
    /// The worker reported a fatal error (import, registration, make, spaces...).
    #[error("{}", worker_error_text(.python, .error))]
    Worker {
        /// The interpreter.
        python: String,
        /// What it reported.
        error: WorkerError,
    },
    /// The worker process ended.
    #[error("the Python worker {how}{}", tail(.stderr))]
    Died {
        /// How it ended ("was killed by signal 11 (SIGSEGV)").
        how: String,
        /// The end of its stderr.
        stderr: String,
    },
    /// The worker did not answer in time.
    #[error("the Python worker did not answer within {secs} s (the environment hangs in reset or step?) \
             and was killed; set {TIMEOUT_VAR} (seconds) to allow more{}", tail(.stderr))]
    Timeout {
        /// The limit.
        secs: f64,
        /// The end of its stderr (with the traceback of where it hung).
        stderr: String,
    },
    /// The worker did not finish starting in time.
    #[error("the Python worker did not start within {secs} s (importing the env's module and \
             making its instances with gym.make) and was killed; set {START_TIMEOUT_VAR} \
             (seconds) to allow more{}", tail(.stderr))]
    StartTimeout {
        /// The limit.
        secs: f64,
        /// The end of its stderr (with the traceback of where it hung).
        stderr: String,
    },
    /// A reset or step of the checks made when a worker starts did not
    /// return in time.
    #[error("the Python worker did not answer within {secs} s in a reset or step of the checks \
             rwg makes when a worker starts (the environment hangs in reset or step?) and was \
             killed; set {TIMEOUT_VAR} (seconds) to allow more{}", tail(.stderr))]
    CheckTimeout {
        /// The limit.
        secs: f64,
        /// The end of its stderr (with the traceback of where it hung).
        stderr: String,
    },
    /// A worker describes the env otherwise than the first worker did.
    #[error("another worker process of the env (pid {pid}) reports other spaces than the first \
             one did: {}; rwg runs every episode of a cell under one set of spaces, so they must \
             not depend on the process (on environment variables, files or random numbers the \
             env reads when it is made)", .differences.join("; "))]
    OtherSpaces {
        /// The worker's process id.
        pid: u32,
        /// What differs, one entry each: `what: first's, this one's`.
        differences: Vec<String>,
    },
    /// The worker said something unexpected.
    #[error("bridge protocol error: {0}")]
    Protocol(String),
}

use rwg_worker::stderr_tail_text as tail;

impl From<ProcError> for GymError {
    fn from(e: ProcError) -> Self {
        match e {
            ProcError::Spawn { program, source } => GymError::NoPython {
                python: program,
                source,
            },
            ProcError::Died { how, stderr } => GymError::Died { how, stderr },
            ProcError::Timeout { secs, stderr } => GymError::Timeout { secs, stderr },
            ProcError::Protocol(m) => GymError::Protocol(m),
            other => GymError::Protocol(other.to_string()),
        }
    }
}

/// How the bridge's failures read.
const DESCRIBE: Describe = Describe {
    proc: |e| GymError::from(e).into(),
    fatal: |python, error| {
        GymError::Worker {
            python: python.to_string(),
            error,
        }
        .into()
    },
    traceback: "Python traceback",
};

fn worker_error_text(python: &str, e: &WorkerError) -> String {
    let mut s = match e.kind.as_str() {
        "python" => format!(
            "Gymnasium is not installed for {python}: {}; install it with:\n  {python} -m pip install \"gymnasium[box2d,mujoco]\"\n(or name another interpreter with `python = \"...\"` in the manifest or RWG_PYTHON)",
            e.message
        ),
        "not_registered" => format!(
            "Gymnasium has no such environment: {} (for an env of your own package, write \
             gymnasium:your_module:YourEnv-v0 so that rwg imports the module first)",
            e.message
        ),
        _ => e.message.clone(),
    };
    if !e.traceback.trim().is_empty() {
        s.push_str("\nPython traceback:\n");
        s.push_str(e.traceback.trim_end());
    }
    s
}

impl From<GymError> for EnvError {
    fn from(e: GymError) -> Self {
        EnvError::Other(e.to_string())
    }
}

impl From<GymError> for BatchFailure {
    fn from(e: GymError) -> Self {
        BatchFailure {
            lane: None,
            between_calls: false,
            error: e.into(),
        }
    }
}

/// What the worker says about the environment in its ready message.
#[derive(Debug, Clone, Deserialize)]
struct Ready {
    gymnasium: String,
    python: String,
    observation_space: String,
    obs_dim: usize,
    obs_low: Vec<serde_json::Value>,
    obs_high: Vec<serde_json::Value>,
    action_space: String,
    action: serde_json::Value,
    max_episode_steps: Option<u32>,
    /// A number, or "nan"/"inf"/"-inf" as in the bounds.
    reward_threshold: Option<serde_json::Value>,
    fresh_per_episode: bool,
    /// The observation of `reset(seed=CHECK_SEED)`, when asked to check it.
    #[serde(default)]
    check_obs: Option<Vec<serde_json::Value>>,
}

/// The environment as the worker described it.
#[derive(Debug, Clone, PartialEq)]
pub struct GymInfo {
    /// The spec in rwg's terms (id `gymnasium:...`, flattened spaces).
    pub spec: EnvSpec,
    /// Gymnasium's text of the observation space (`Box(-inf, inf, (4,), float32)`).
    pub observation_space: String,
    /// Gymnasium's text of the action space.
    pub action_space: String,
    /// Gymnasium's version.
    pub gymnasium: String,
    /// Python's version.
    pub python: String,
    /// Whether the env's episodes depend on the instance's earlier episodes,
    /// so that every episode runs on a fresh instance.
    pub fresh_per_episode: bool,
    /// The `reward_threshold` of the env's spec as registered, also when it
    /// is not a finite number (then `spec.reward_threshold` is `None`: no
    /// score reaches it meaningfully, so a study needs its own `solved`).
    pub registered_threshold: Option<f64>,
    /// The observation of `reset(seed)` for the seed of the determinism
    /// check, where the worker was asked to make it: the same in every
    /// worker process of an env, else its episodes depend on the process.
    pub check_obs: Option<Vec<f64>>,
}

fn parse_ready(cfg: &GymConfig, r: Ready) -> Result<GymInfo, GymError> {
    let low = floats(&r.obs_low)?;
    let high = floats(&r.obs_high)?;
    if low.len() != r.obs_dim || high.len() != r.obs_dim {
        return Err(GymError::Protocol(
            "observation bounds of the wrong length".into(),
        ));
    }
    let action_space = match r.action["type"].as_str() {
        Some("Discrete") => {
            let n = r.action["n"].as_u64().unwrap_or(0) as usize;
            if n == 0 {
                return Err(GymError::Protocol("Discrete(0) action space".into()));
            }
            Space::Discrete { n }
        }
        Some("Box") => {
            let list = |k: &str| -> Result<Vec<f64>, GymError> {
                Ok(floats(r.action[k].as_array().map_or(&[][..], |v| v))?)
            };
            Space::Box(BoxSpace::new(list("low")?, list("high")?))
        }
        _ => return Err(GymError::Protocol(format!("action {}", r.action))),
    };
    let threshold = match &r.reward_threshold {
        None => None,
        Some(t) => Some(floats(std::slice::from_ref(t))?[0]),
    };
    Ok(GymInfo {
        spec: EnvSpec {
            id: cfg.rwg_id(),
            observation_space: Space::Box(BoxSpace::new(low, high)),
            action_space,
            max_episode_steps: r.max_episode_steps,
            reward_threshold: threshold.filter(|t| t.is_finite()),
        },
        observation_space: r.observation_space,
        action_space: r.action_space,
        gymnasium: r.gymnasium,
        python: r.python,
        fresh_per_episode: r.fresh_per_episode,
        registered_threshold: threshold,
        check_obs: r.check_obs.as_deref().map(floats).transpose()?,
    })
}

/// Sends the hello message and reads the answer (tag, payload): the
/// worker's start-up (imports, gym.make) within `cfg.start_timeout`, each
/// reset or step of its checks (announced by progress messages) within
/// `cfg.timeout`; a timeout names the variable that sets it.
fn start(
    worker: &mut Worker,
    hello: &serde_json::Value,
    cfg: &GymConfig,
) -> Result<(u8, Vec<u8>), GymError> {
    let timeouts = StartTimeouts {
        start: cfg.start_timeout,
        call: cfg.timeout,
    };
    handshake(worker, hello, timeouts).map_err(|f| match f {
        StartFailure {
            error: ProcError::Timeout { secs, stderr },
            in_call: true,
        } => GymError::CheckTimeout { secs, stderr },
        StartFailure {
            error: ProcError::Timeout { secs, stderr },
            in_call: false,
        } => GymError::StartTimeout { secs, stderr },
        StartFailure { error, .. } => error.into(),
    })
}

/// What differs between the env as the first worker described it and as
/// `other` does: `what: first's, other's`, one entry each (empty: the same).
pub fn info_differences(first: &GymInfo, other: &GymInfo) -> Vec<String> {
    let mut out = vec![];
    let mut differ = |what: &str, a: String, b: String| {
        if a != b {
            out.push(format!("{what}: {a} in the first, {b} in this one"));
        }
    };
    differ(
        "observation space",
        first.observation_space.clone(),
        other.observation_space.clone(),
    );
    differ(
        "action space",
        first.action_space.clone(),
        other.action_space.clone(),
    );
    let (a, b) = (&first.spec, &other.spec);
    if first.observation_space == other.observation_space {
        differ(
            "flat observation bounds",
            format!("{:?}", a.observation_space),
            format!("{:?}", b.observation_space),
        );
    }
    if first.action_space == other.action_space {
        differ(
            "action bounds",
            format!("{:?}", a.action_space),
            format!("{:?}", b.action_space),
        );
    }
    let steps = |s: Option<u32>| s.map_or("none".into(), |s| format!("{s} steps"));
    differ(
        "time limit",
        steps(a.max_episode_steps),
        steps(b.max_episode_steps),
    );
    let threshold = |t: Option<f64>| t.map_or("none".into(), |t| t.to_string());
    differ(
        "reward threshold",
        threshold(a.reward_threshold),
        threshold(b.reward_threshold),
    );
    if let (Some(x), Some(y)) = (&first.check_obs, &other.check_obs) {
        let same = x.len() == y.len()
            && x.iter()
                .zip(y)
                .all(|(p, q)| p.to_bits() == q.to_bits() || p.is_nan() && q.is_nan());
        if !same {
            let head = |v: &[f64]| format!("{:?}", &v[..v.len().min(4)]);
            out.push(format!(
                "reset(seed={CHECK_SEED}) observes {} in the first, {} in this one (the env's \
                 reset depends on the process: its id, the time, or Python's hash() of strings \
                 with {HASH_SEED_VAR} set to \"random\"?)",
                head(x),
                head(y)
            ));
        }
    }
    out
}

/// A worker process hosting `lanes` instances of one Gymnasium env.
pub struct GymBatch {
    pipe: PipeBatch,
    info: GymInfo,
}

impl GymBatch {
    /// Starts a worker with `lanes` instances; with `check_reset`, it also
    /// checks that two `reset(seed=s)` give the same observation.
    pub fn spawn(
        cfg: &GymConfig,
        lanes: usize,
        groups: usize,
        check_reset: bool,
    ) -> Result<GymBatch, GymError> {
        let mut command = std::process::Command::new(&cfg.python);
        command.arg("-c").arg(BOOT_PY).arg(WORKER_PY);
        command.env(HASH_SEED_VAR, &cfg.hash_seed);
        #[cfg(unix)]
        let dump = Some(libc::SIGUSR1);
        #[cfg(not(unix))]
        let dump = None;
        let mut worker = Worker::spawn(command, &cfg.python, dump)?;
        let lane_file = LaneFile::create();
        let hello = serde_json::json!({
            "lane_file": lane_file.path(),
            "protocol": PROTOCOL,
            "env": cfg.id,
            "kwargs": cfg.kwargs,
            "lanes": lanes,
            "groups": groups,
            "max_episode_steps": cfg.max_episode_steps,
            "action_dtype": cfg.action_dtype.name(),
            "max_obs": MAX_OBS,
            "check_reset": if check_reset { Some(CHECK_SEED) } else { None },
            "probe_history": cfg.fresh_per_episode.is_none(),
            "fresh_per_episode": cfg.fresh_per_episode.unwrap_or(false),
        });
        let (tag, payload) = start(&mut worker, &hello, cfg)?;
        let ready: Ready = match tag {
            TAG_READY => serde_json::from_slice(&payload)
                .map_err(|e| GymError::Protocol(format!("ready message: {e}")))?,
            TAG_ERROR => {
                let error: WorkerError = serde_json::from_slice(&payload)
                    .map_err(|e| GymError::Protocol(format!("error message: {e}")))?;
                return Err(GymError::Worker {
                    python: worker.program().to_string(),
                    error,
                });
            }
            t => return Err(GymError::Protocol(format!("unexpected tag {t}"))),
        };
        let info = parse_ready(cfg, ready)?;
        let pipe = PipeBatch::new(
            worker,
            lane_file,
            info.spec.clone(),
            lanes,
            groups,
            cfg.timeout,
            DESCRIBE,
        );
        Ok(GymBatch { pipe, info })
    }

    /// The environment as the worker described it.
    pub fn info(&self) -> &GymInfo {
        &self.info
    }

    /// This worker, if it describes the env as `first` does; else an error
    /// naming what differs.
    fn same_as(self, first: &GymInfo) -> Result<GymBatch, GymError> {
        let differences = info_differences(first, &self.info);
        if differences.is_empty() {
            Ok(self)
        } else {
            Err(GymError::OtherSpaces {
                pid: self.pipe.worker().id(),
                differences,
            })
        }
    }
}

impl BatchEnv for GymBatch {
    fn spec(&self) -> &EnvSpec {
        &self.info.spec
    }

    fn lanes(&self) -> usize {
        self.pipe.lanes()
    }

    fn groups(&self) -> usize {
        self.pipe.groups()
    }

    fn send(
        &mut self,
        group: usize,
        ops: &[LaneOp],
        actions: LaneActions<'_>,
    ) -> Result<(), BatchFailure> {
        self.pipe.send(group, ops, actions)
    }

    fn recv(
        &mut self,
        group: usize,
        obs: &mut [f64],
        out: &mut [LaneOutcome],
    ) -> Result<(), BatchFailure> {
        self.pipe.recv(group, obs, out)
    }
}

/// One Gymnasium environment of a study: its config, its description, and
/// the worker processes kept between cells.
pub struct GymSource {
    config: GymConfig,
    info: GymInfo,
    pool: BatchPool<GymBatch>,
}

impl std::fmt::Debug for GymSource {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("GymSource")
            .field("config", &self.config)
            .finish()
    }
}

impl GymSource {
    /// Starts one worker (checking that the env builds, its spaces are
    /// supported and its reset is deterministic) and keeps it for the run.
    pub fn open(mut config: GymConfig) -> Result<GymSource, GymError> {
        let first = GymBatch::spawn(&config, LANES, GROUPS, true)?;
        let info = first.info().clone();
        // The workers started later (and single instances) need not probe again.
        config.fresh_per_episode = Some(info.fresh_per_episode);
        let pool = BatchPool::default();
        pool.put(first);
        Ok(GymSource { config, info, pool })
    }

    /// The config.
    pub fn config(&self) -> &GymConfig {
        &self.config
    }

    /// The environment as Gymnasium describes it.
    pub fn info(&self) -> &GymInfo {
        &self.info
    }

    /// Runs blocks of a cell (see [`run_blocks_batched`]): one worker process
    /// per thread of the current rayon pool, reused across calls. Each
    /// worker started here must describe the env as the first did, its
    /// checked reset included ([`info_differences`]).
    pub fn run_blocks<G, X>(
        &self,
        plan: &CellPlan,
        blocks: &[Range<u64>],
        wave: usize,
        on_block: G,
    ) -> Result<(), X>
    where
        G: FnMut(BlockResult) -> Result<(), X>,
        X: From<SampleError> + Send,
    {
        run_blocks_batched(
            plan,
            blocks,
            wave,
            &self.pool,
            || {
                GymBatch::spawn(&self.config, LANES, GROUPS, true)
                    .and_then(|w| w.same_as(&self.info))
                    .map_err(EnvError::from)
            },
            on_block,
        )
    }

    /// CPU seconds used so far by the idle worker processes (all of them
    /// between runs), where the OS reports it.
    pub fn workers_cpu_seconds(&self) -> Option<f64> {
        self.pool
            .with_idle(|ws| ws.iter().map(|w| w.pipe.worker().cpu_seconds()).sum())
    }

    /// Number of worker processes started and idle.
    pub fn workers(&self) -> usize {
        self.pool.idle()
    }

    /// A single instance behind [`rwg_env::Environment`] (for rollouts,
    /// checks and replays), in a worker of its own.
    pub fn make_single(&self) -> Result<SingleLane<GymBatch>, GymError> {
        // (the config carries the probe's verdict on fresh instances)
        let worker = GymBatch::spawn(&self.config, 1, 1, true)?.same_as(&self.info)?;
        Ok(SingleLane::new(worker))
    }
}

/// A single instance of the env `config` describes, without the checks of
/// [`GymSource::open`].
pub fn make_single(config: &GymConfig) -> Result<SingleLane<GymBatch>, GymError> {
    Ok(SingleLane::new(GymBatch::spawn(config, 1, 1, false)?))
}
