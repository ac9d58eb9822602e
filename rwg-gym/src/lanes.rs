//! One worker process hosting lanes of a Gymnasium env ([`GymLanes`]):
//! starting it, its handshake, and the host side of the exchanges over it.

use crate::error::DESCRIBE;
use crate::info::{info_differences, parse_ready, GymInfo, Ready};
use crate::protocol::{WorkerError, PROTOCOL, TAG_ERROR, TAG_READY};
use crate::{GymConfig, GymError, BOOT_PY, CHECK_SEED, HASH_SEED_VAR, MAX_OBS, MODULES, WORKER_PY};
use rwg_core::remote::{LaneActions, LaneOp, LaneOutcome, RemoteEnv, RemoteFailure};
use rwg_env::EnvSpec;
use rwg_worker::host::{handshake, PipeLanes, StartFailure, StartTimeouts};
use rwg_worker::lane_file::LaneFile;
use rwg_worker::python::{loader_args, LOAD_PY};
use rwg_worker::{ProcError, Worker};

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

/// A worker process hosting `lanes` instances of one Gymnasium env.
pub struct GymLanes {
    pub(crate) pipe: PipeLanes,
    info: GymInfo,
}

impl GymLanes {
    /// Starts a worker with `lanes` instances; with `check_reset`, it also
    /// checks that two `reset(seed=s)` give the same observation.
    pub fn spawn(
        cfg: &GymConfig,
        lanes: usize,
        groups: usize,
        check_reset: bool,
    ) -> Result<GymLanes, GymError> {
        let mut command = std::process::Command::new(&cfg.python);
        command.arg("-c").arg(BOOT_PY).arg(LOAD_PY);
        loader_args(&mut command, WORKER_PY, &MODULES);
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
            "non_finite_ends": cfg.non_finite_ends,
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
        let pipe = PipeLanes::new(
            worker,
            lane_file,
            info.spec.clone(),
            lanes,
            groups,
            cfg.timeout,
            DESCRIBE,
        );
        Ok(GymLanes { pipe, info })
    }

    /// The environment as the worker described it.
    pub fn info(&self) -> &GymInfo {
        &self.info
    }

    /// This worker, if it describes the env as `first` does; else an error
    /// naming what differs.
    pub(crate) fn same_as(self, first: &GymInfo) -> Result<GymLanes, GymError> {
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

impl RemoteEnv for GymLanes {
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
    ) -> Result<(), RemoteFailure> {
        self.pipe.send(group, ops, actions)
    }

    fn recv(
        &mut self,
        group: usize,
        obs: &mut [f64],
        out: &mut [LaneOutcome],
    ) -> Result<(), RemoteFailure> {
        self.pipe.recv(group, obs, out)
    }
}
