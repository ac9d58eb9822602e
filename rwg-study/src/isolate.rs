//! Isolated plugin environments (`isolate = true` in an `[[envs]]` entry,
//! `rwg run --isolate`): the env's instances run in worker processes — the
//! program running the study started again as `PROGRAM __plugin-worker`
//! ([`IsolateSettings`]) — stepped in exchanges over the protocol of
//! `docs/bridge-protocol.md` (`rwg-worker`, shared with the Gymnasium
//! bridge). A plugin that crashes, aborts, calls `exit()` or hangs ends its
//! worker, not the run: the cell fails with an error naming the plugin,
//! env, network, episode and step, and every committed block is kept.
//!
//! The results are those of the in-process env: the host computes the same
//! weights, reset seeds and actions (`rwg_core::remote`), and the worker
//! makes each instance exactly as the runner does (`PluginEnvType::make`,
//! with the manifest's config and time limit).
//!
//! [`IsolatedPlugin`] is the host's side, [`worker_main`] the worker's.

use crate::env_source::PluginSource;
use rwg_core::remote::{
    run_blocks_remote, LaneActions, LaneOp, LaneOutcome, RemoteEnv, RemoteFailure, RemotePool,
};
use rwg_core::sampler::{BlockResult, CellPlan, SampleError, LANES};
use rwg_env::{EnvError, EnvSpec, Space};
use rwg_worker::host::{handshake, Describe, PipeLanes, StartFailure, StartTimeouts};
use rwg_worker::lane_file::{LaneFile, LaneMark};
use rwg_worker::protocol::{
    message, read_message, WorkerError, PROTOCOL, TAG_ERROR, TAG_HELLO, TAG_PROGRESS, TAG_READY,
};
use rwg_worker::{ProcError, Worker};
use serde::{Deserialize, Serialize};
use std::io::{Read, Write};
use std::ops::Range;
use std::path::PathBuf;
use std::sync::Mutex;
use std::time::Duration;

/// The hidden subcommand of `rwg` that runs a plugin worker.
pub const WORKER_SUBCOMMAND: &str = "__plugin-worker";

/// Groups of [`LANES`] instances per worker (one in flight while the host
/// computes the other's actions).
pub const GROUPS: usize = 2;

/// How isolated plugin workers are started and how long a step may take.
#[derive(Debug, Clone, PartialEq)]
pub struct IsolateSettings {
    /// The worker program (`rwg` itself by default).
    pub program: PathBuf,
    /// Its arguments (by default [`WORKER_SUBCOMMAND`]).
    pub args: Vec<String>,
    /// How long one exchange (a reset or step of each lane of a group)
    /// may take before the worker counts as hung and is killed; `None`: no
    /// limit.
    pub timeout: Option<Duration>,
}

impl Default for IsolateSettings {
    /// The running program as `PROGRAM __plugin-worker`, 60 s per exchange.
    fn default() -> Self {
        IsolateSettings {
            program: std::env::current_exe().unwrap_or_else(|_| PathBuf::from("rwg")),
            args: vec![WORKER_SUBCOMMAND.to_string()],
            timeout: Some(Duration::from_secs(60)),
        }
    }
}

static SETTINGS: Mutex<Option<IsolateSettings>> = Mutex::new(None);

/// Sets how the isolated plugin envs planned from now on start their
/// workers (a program other than `rwg` that runs studies must make its own
/// binary answer [`WORKER_SUBCOMMAND`] with [`worker_main`], or name one
/// that does).
pub fn set_settings(s: IsolateSettings) {
    *SETTINGS.lock().unwrap_or_else(|p| p.into_inner()) = Some(s);
}

/// The settings set with [`set_settings`], else the defaults.
pub fn settings() -> IsolateSettings {
    SETTINGS
        .lock()
        .unwrap_or_else(|p| p.into_inner())
        .clone()
        .unwrap_or_default()
}

/// What the host asks a plugin worker to host (the `H` message's JSON).
#[derive(Debug, Serialize, Deserialize)]
struct Hello {
    protocol: u32,
    plugin: PathBuf,
    env: String,
    config: String,
    max_episode_steps: Option<u32>,
    lanes: usize,
    groups: usize,
    lane_file: Option<String>,
}

/// What a plugin worker answers (the `R` message's JSON): enough for the
/// host to check that the worker hosts the env it planned with.
#[derive(Debug, Serialize, Deserialize, PartialEq)]
struct Ready {
    protocol: u32,
    obs_dim: usize,
    action_dim: usize,
    max_episode_steps: Option<u32>,
}

fn action_dim(spec: &EnvSpec) -> usize {
    match &spec.action_space {
        Space::Discrete { .. } => 0,
        Space::Box(b) => b.dim(),
    }
}

/// How an isolated plugin's failures read.
const DESCRIBE: Describe = Describe {
    proc: |e| EnvError::Other(proc_text(e)),
    fatal: |_, e| EnvError::Other(e.message),
    traceback: "traceback",
};

/// A worker that did not start in time: in a create call it announced
/// (`in_call`: the step timeout applied), or loading the plugin.
fn start_timeout_text(secs: f64, in_call: bool, stderr: &str) -> String {
    let tail = rwg_worker::stderr_tail_text(stderr);
    if in_call {
        format!(
            "creating an instance (the plugin's create) did not return within {secs} s in its \
             isolated worker process, which was killed; raise --step-timeout if the env is just \
             slow{tail}"
        )
    } else {
        format!(
            "its isolated worker process did not start within {secs} s (loading the plugin \
             library) and was killed; --step-timeout above {secs} allows more{tail}"
        )
    }
}

fn proc_text(e: ProcError) -> String {
    match e {
        ProcError::Died { how, stderr } => format!(
            "its isolated worker process {how}{}",
            rwg_worker::stderr_tail_text(&stderr)
        ),
        ProcError::Timeout { secs, stderr } => format!(
            "its isolated worker process did not answer within {secs} s (a reset or step \
             hangs?) and was killed; raise --step-timeout if the env is just slow{}",
            rwg_worker::stderr_tail_text(&stderr)
        ),
        ProcError::Spawn { program, source } => {
            format!("cannot start the isolated plugin worker {program}: {source}")
        }
        ProcError::Protocol(m) => format!("isolated plugin worker: protocol error: {m}"),
        other => format!("isolated plugin worker: {other}"),
    }
}

/// A plugin env run in worker processes, shared by its cells: what the
/// workers host, and the idle workers kept between blocks and cells.
pub struct IsolatedPlugin {
    hello: Hello,
    prefix: String,
    spec: EnvSpec,
    settings: IsolateSettings,
    pool: RemotePool<Named>,
}

impl std::fmt::Debug for IsolatedPlugin {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("IsolatedPlugin")
            .field("plugin", &self.hello.plugin)
            .field("env", &self.hello.env)
            .field("settings", &self.settings)
            .finish()
    }
}

impl IsolatedPlugin {
    /// Starts one worker for `src` with the current [`settings`] (it loads
    /// the plugin and creates its instances, so a config the plugin refuses
    /// fails here) and keeps it for the run.
    pub fn open(src: &PluginSource) -> Result<IsolatedPlugin, EnvError> {
        let ty = &src.ty;
        let mut spec = ty.spec().clone();
        if src.max_episode_steps.is_some() {
            spec.max_episode_steps = src.max_episode_steps;
        }
        let iso = IsolatedPlugin {
            hello: Hello {
                protocol: PROTOCOL,
                plugin: ty.plugin().path.clone(),
                env: ty.id().to_string(),
                config: src.config.clone(),
                max_episode_steps: src.max_episode_steps,
                lanes: LANES,
                groups: GROUPS,
                lane_file: None,
            },
            prefix: format!("plugin '{}' env '{}'", ty.plugin().id, ty.id()),
            spec,
            settings: settings(),
            pool: RemotePool::default(),
        };
        let first = iso.spawn()?;
        iso.pool.put(first);
        Ok(iso)
    }

    /// The env's spec (with the manifest's time limit).
    pub fn spec(&self) -> &EnvSpec {
        &self.spec
    }

    /// The settings its workers were started with.
    pub fn settings(&self) -> &IsolateSettings {
        &self.settings
    }

    /// Starts a worker and checks what it hosts.
    fn spawn(&self) -> Result<Named, EnvError> {
        let fail = |e: ProcError| EnvError::Other(format!("{}: {}", self.prefix, proc_text(e)));
        let mut cmd = std::process::Command::new(&self.settings.program);
        cmd.args(&self.settings.args);
        let program = self.settings.program.display().to_string();
        let mut worker = Worker::spawn(cmd, &program, None).map_err(fail)?;
        let lane_file = LaneFile::create();
        let mut hello = serde_json::to_value(&self.hello).expect("serialisable");
        hello["lane_file"] = lane_file.path().into();
        let timeout = self.timeout();
        // Loading the plugin may take a while; each create call is a call
        // into the env like a reset or step.
        let timeouts = StartTimeouts {
            start: timeout.max(Duration::from_secs(60)),
            call: timeout,
        };
        let (tag, payload) = handshake(&mut worker, &hello, timeouts).map_err(|f| match f {
            StartFailure {
                error: ProcError::Timeout { secs, stderr },
                in_call,
            } => EnvError::Other(format!(
                "{}: {}",
                self.prefix,
                start_timeout_text(secs, in_call, &stderr)
            )),
            StartFailure { error, .. } => fail(error),
        })?;
        let protocol = |m: String| fail(ProcError::Protocol(m));
        match tag {
            TAG_READY => {
                let ready: Ready = serde_json::from_slice(&payload)
                    .map_err(|e| protocol(format!("ready message: {e}")))?;
                let want = Ready {
                    protocol: PROTOCOL,
                    obs_dim: self.spec.obs_dim(),
                    action_dim: action_dim(&self.spec),
                    max_episode_steps: self.spec.max_episode_steps,
                };
                if ready != want {
                    return Err(protocol(format!(
                        "the worker hosts {ready:?}, the host planned {want:?}"
                    )));
                }
            }
            TAG_ERROR => {
                let e: WorkerError = serde_json::from_slice(&payload)
                    .map_err(|e| protocol(format!("error message: {e}")))?;
                return Err(EnvError::Other(e.message));
            }
            t => return Err(protocol(format!("unexpected tag {t}"))),
        }
        Ok(Named {
            pipe: PipeLanes::new(
                worker,
                lane_file,
                self.spec.clone(),
                LANES,
                GROUPS,
                timeout,
                DESCRIBE,
            ),
            prefix: self.prefix.as_str().into(),
        })
    }

    /// The per-step timeout as a duration (a decade for none).
    fn timeout(&self) -> Duration {
        self.settings
            .timeout
            .unwrap_or(Duration::from_secs(10 * 365 * 24 * 3600))
    }

    /// Runs blocks of a cell (see [`run_blocks_remote`]): one worker
    /// process per thread of the current rayon pool, reused across calls.
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
        run_blocks_remote(plan, blocks, wave, &self.pool, || self.spawn(), on_block)
    }

    /// Number of worker processes started and idle.
    pub fn workers(&self) -> usize {
        self.pool.idle()
    }
}

/// A worker's lanes, whose whole-env failures (the process died or hung)
/// name the plugin and env (lane failures carry the plugin's own message,
/// which does).
pub struct Named {
    pipe: PipeLanes,
    prefix: std::sync::Arc<str>,
}

impl Named {
    fn named(&self, mut f: RemoteFailure) -> RemoteFailure {
        if let EnvError::Other(m) = &f.error {
            f.error = EnvError::Other(format!("{}: {m}", self.prefix));
        }
        f
    }
}

impl RemoteEnv for Named {
    fn spec(&self) -> &EnvSpec {
        self.pipe.spec()
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
    ) -> Result<(), RemoteFailure> {
        self.pipe
            .send(group, ops, actions)
            .map_err(|f| self.named(f))
    }

    fn recv(
        &mut self,
        group: usize,
        obs: &mut [f64],
        out: &mut [LaneOutcome],
    ) -> Result<(), RemoteFailure> {
        self.pipe.recv(group, obs, out).map_err(|f| self.named(f))
    }
}

/// The worker's side (`rwg __plugin-worker`): reads the hello message on
/// `input`, loads the plugin, creates `lanes × groups` instances of the env
/// as the runner would (`PluginEnvType::make`), answers ready on `output`
/// and serves step messages until quit or end of file. Whatever stops it
/// from hosting the env is reported to the host as an `E` message too.
///
/// The caller must make sure the plugin cannot write into `output` (the
/// `rwg` binary passes a private duplicate of its stdout and points fd 1 at
/// stderr, and fd 0 at `/dev/null`, before calling this).
pub fn worker_main(input: &mut impl Read, output: &mut impl Write) -> Result<(), ProcError> {
    let Some((tag, payload)) =
        read_message(input).map_err(|e| ProcError::Protocol(format!("reading hello: {e}")))?
    else {
        return Ok(());
    };
    let fatal = |output: &mut dyn Write, kind: &str, text: String| -> ProcError {
        let e = WorkerError {
            kind: kind.into(),
            message: text.clone(),
            traceback: String::new(),
        };
        let json = serde_json::to_vec(&e).expect("serialisable");
        let _ = output
            .write_all(&message(TAG_ERROR, &json))
            .and_then(|()| output.flush());
        ProcError::Protocol(text)
    };
    if tag != TAG_HELLO {
        return Err(fatal(
            output,
            "protocol",
            format!("expected hello, got tag {tag}"),
        ));
    }
    let hello: Hello = match serde_json::from_slice(&payload) {
        Ok(h) => h,
        Err(e) => return Err(fatal(output, "protocol", format!("hello message: {e}"))),
    };
    if hello.protocol != PROTOCOL {
        return Err(fatal(
            output,
            "protocol",
            format!(
                "protocol {} asked, this worker speaks {PROTOCOL}",
                hello.protocol
            ),
        ));
    }
    if hello.lanes == 0 || hello.groups == 0 || hello.lanes * hello.groups > 255 {
        return Err(fatal(
            output,
            "protocol",
            format!("{} groups of {} lanes", hello.groups, hello.lanes),
        ));
    }
    let plugin = match rwg_plugin_host::load_plugin(&hello.plugin) {
        Ok(p) => p,
        Err(e) => return Err(fatal(output, "load", e.to_string())),
    };
    let Some(ty) = plugin.env(&hello.env) else {
        return Err(fatal(
            output,
            "not_registered",
            format!(
                "plugin {} has no env '{}'",
                hello.plugin.display(),
                hello.env
            ),
        ));
    };
    let mut envs = Vec::with_capacity(hello.lanes * hello.groups);
    for _ in 0..hello.lanes * hello.groups {
        // the host gives each create call the step timeout
        output
            .write_all(&message(TAG_PROGRESS, b"c"))
            .and_then(|()| output.flush())
            .map_err(|e| ProcError::Protocol(format!("cannot answer the host: {e}")))?;
        match ty.make(&hello.config, hello.max_episode_steps) {
            Ok(e) => envs.push(e),
            Err(e) => return Err(fatal(output, "make", e.to_string())),
        }
    }
    let spec = rwg_env::Environment::spec(&envs[0]).clone();
    let ready = Ready {
        protocol: PROTOCOL,
        obs_dim: spec.obs_dim(),
        action_dim: action_dim(&spec),
        max_episode_steps: spec.max_episode_steps,
    };
    // mapped before the ready: the host then removes the file's name
    let mark = hello.lane_file.as_deref().and_then(LaneMark::open);
    let json = serde_json::to_vec(&ready).expect("serialisable");
    output
        .write_all(&message(TAG_READY, &json))
        .and_then(|()| output.flush())
        .map_err(|e| ProcError::Protocol(format!("cannot answer the host: {e}")))?;
    rwg_worker::serve::serve(input, output, &mut envs, hello.lanes, mark)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A message: (tag, payload).
    type Msg = (u8, Vec<u8>);

    /// Runs the worker on `input`; returns its result and its messages.
    fn worker(input: &[u8]) -> (Result<(), ProcError>, Vec<Msg>) {
        let mut out = vec![];
        let r = worker_main(&mut &input[..], &mut out);
        let mut msgs = vec![];
        let mut rd = &out[..];
        while let Some(m) = read_message(&mut rd).unwrap() {
            msgs.push(m);
        }
        (r, msgs)
    }

    fn hello(h: &Hello) -> Vec<u8> {
        message(TAG_HELLO, &serde_json::to_vec(h).unwrap())
    }

    fn sample_hello() -> Hello {
        Hello {
            protocol: PROTOCOL,
            plugin: "/nonexistent/librwg_nothing.so".into(),
            env: "x/Y-v0".into(),
            config: String::new(),
            max_episode_steps: None,
            lanes: LANES,
            groups: GROUPS,
            lane_file: None,
        }
    }

    fn error_of(msgs: &[Msg]) -> WorkerError {
        assert_eq!(msgs.len(), 1, "{msgs:?}");
        assert_eq!(msgs[0].0, TAG_ERROR);
        serde_json::from_slice(&msgs[0].1).unwrap()
    }

    #[test]
    fn a_worker_whose_host_is_gone_exits_quietly() {
        let (r, msgs) = worker(b"");
        assert!(r.is_ok());
        assert!(msgs.is_empty());
    }

    #[test]
    fn what_stops_a_worker_is_reported_to_the_host() {
        let (r, msgs) = worker(&hello(&sample_hello()));
        assert!(r.is_err());
        let e = error_of(&msgs);
        assert_eq!(e.kind, "load");
        assert!(
            e.message.contains("/nonexistent/librwg_nothing.so"),
            "{}",
            e.message
        );

        let (r, msgs) = worker(&hello(&Hello {
            protocol: PROTOCOL + 1,
            ..sample_hello()
        }));
        assert!(r.is_err());
        assert_eq!(error_of(&msgs).kind, "protocol");

        let (_, msgs) = worker(&hello(&Hello {
            lanes: 200,
            ..sample_hello()
        }));
        assert!(error_of(&msgs).message.contains("2 groups of 200 lanes"));

        let (_, msgs) = worker(&message(TAG_READY, b"{}"));
        assert!(error_of(&msgs).message.contains("expected hello"));
    }

    #[test]
    fn workers_are_this_program_by_default() {
        let s = IsolateSettings::default();
        assert_eq!(s.program, std::env::current_exe().unwrap());
        assert_eq!(s.args, [WORKER_SUBCOMMAND]);
        assert_eq!(s.timeout, Some(Duration::from_secs(60)));
    }
}
