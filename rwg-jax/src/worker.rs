//! One JAX worker process: started with `python -c` through
//! [`rwg_worker::Worker`] (process group, death signal, stderr tail,
//! deadlines), past its handshake; compiles cells and runs chunks.

use crate::protocol::*;
use crate::{JaxConfig, JaxError, JaxInfo, MAX_OBS, MODULES, WORKER_PY};
use rwg_worker::host::{handshake, StartFailure, StartTimeouts};
use rwg_worker::python::{loader_args, LOAD_PY};
use rwg_worker::{ProcError, Worker};
use std::time::Duration;

/// A started JAX worker.
pub struct JaxWorker {
    worker: Worker,
    python: String,
    timeout: Duration,
    /// The cell last compiled (what a chunk runs).
    cell: Option<CellShape>,
    buf: Vec<u8>,
}

impl JaxWorker {
    /// Starts a worker for `cfg` and reads its ready message.
    pub fn spawn(cfg: &JaxConfig) -> Result<(JaxWorker, JaxInfo), JaxError> {
        let mut command = std::process::Command::new(&cfg.python);
        command.arg("-c").arg(LOAD_PY);
        loader_args(&mut command, WORKER_PY, &MODULES);
        #[cfg(unix)]
        let dump = Some(libc::SIGUSR1);
        #[cfg(not(unix))]
        let dump = None;
        let mut worker = Worker::spawn(command, &cfg.python, dump)
            .map_err(|e| JaxError::from_proc(e, "starting"))?;
        let timeouts = StartTimeouts {
            start: cfg.timeout,
            call: cfg.timeout,
        };
        let (tag, payload) = handshake(&mut worker, &hello(cfg, MAX_OBS), timeouts)
            .map_err(|StartFailure { error, .. }| JaxError::from_proc(error, "starting"))?;
        let w = JaxWorker {
            worker,
            python: cfg.python.clone(),
            timeout: cfg.timeout,
            cell: None,
            buf: Vec::new(),
        };
        let ready: Ready = w.expect(tag, &payload, TAG_READY)?;
        let info = parse_ready(cfg, ready)?;
        Ok((w, info))
    }

    /// The JSON of a message with tag `want`, or the worker's error.
    fn expect<T: serde::de::DeserializeOwned>(
        &self,
        tag: u8,
        payload: &[u8],
        want: u8,
    ) -> Result<T, JaxError> {
        if tag == want {
            serde_json::from_slice(payload)
                .map_err(|e| JaxError::Protocol(format!("message '{}': {e}", char::from(want))))
        } else {
            Err(self.unexpected(tag, payload))
        }
    }

    /// The error for a message other than the one expected: the worker's
    /// `E`, or a protocol error.
    fn unexpected(&self, tag: u8, payload: &[u8]) -> JaxError {
        if tag == TAG_ERROR {
            match serde_json::from_slice::<WorkerError>(payload) {
                Ok(error) => JaxError::Worker {
                    python: self.python.clone(),
                    error,
                },
                Err(e) => JaxError::Protocol(format!("error message: {e}")),
            }
        } else {
            JaxError::Protocol(format!("unexpected message '{}'", char::from(tag)))
        }
    }

    /// Sends `msg` and reads the answer (tag, payload in `self.buf[5..]`);
    /// `doing` names the wait in a timeout.
    fn exchange(&mut self, msg: &[u8], doing: &'static str) -> Result<u8, JaxError> {
        self.worker
            .send(msg)
            .map_err(|e| JaxError::from_proc(e, doing))?;
        self.worker
            .recv_message(&mut self.buf, self.timeout)
            .map_err(|e| JaxError::from_proc(e, doing))
    }

    /// Makes `cell` the cell the next chunks run (compiled in this worker
    /// the first time it is named); the seconds the compile took.
    pub fn set_cell(&mut self, cell: &CellShape) -> Result<Option<f64>, JaxError> {
        if self.cell.as_ref() == Some(cell) {
            return Ok(None);
        }
        self.cell = None;
        let msg = message(TAG_CELL, cell.json().to_string().as_bytes());
        let tag = self.exchange(&msg, "compiling")?;
        let payload = self.buf.split_off(5);
        let k: serde_json::Value = self.expect(tag, &payload, TAG_COMPILED)?;
        self.cell = Some(cell.clone());
        Ok(k["compile_s"].as_f64())
    }

    /// Sends a chunk of `n` networks (`weights`, network-major) with the
    /// reset seeds `seeds` (`n * episodes`) to run on the current cell; its
    /// outcome is [`JaxWorker::recv_outcome`]'s.
    pub fn send_chunk(&mut self, n: usize, weights: &[f64], seeds: &[u64]) -> Result<(), JaxError> {
        let episodes = self.cell.as_ref().expect("a cell is set").episodes;
        encode_chunk(&mut self.buf, n, episodes, weights, seeds);
        self.worker
            .send(&self.buf)
            .map_err(|e| JaxError::from_proc(e, "running a chunk"))
    }

    /// The outcome of the chunk sent last, of `m` episodes.
    pub fn recv_outcome(&mut self, m: usize) -> Result<Outcome, JaxError> {
        let tag = self
            .worker
            .recv_message(&mut self.buf, self.timeout)
            .map_err(|e| JaxError::from_proc(e, "running a chunk"))?;
        if tag != TAG_OUTCOME {
            let payload = self.buf.split_off(5);
            return Err(self.unexpected(tag, &payload));
        }
        decode_outcome(&self.buf[5..], m)
    }

    /// CPU seconds the process used so far (Linux).
    pub fn cpu_seconds(&self) -> Option<f64> {
        self.worker.cpu_seconds()
    }
}

impl JaxError {
    /// The error of a failed process while `doing` something.
    pub(crate) fn from_proc(e: ProcError, doing: &'static str) -> JaxError {
        match e {
            ProcError::Spawn { program, source } => JaxError::NoPython {
                python: program,
                reason: source,
            },
            ProcError::Died { how, stderr } => JaxError::Died { how, doing, stderr },
            ProcError::Timeout { secs, stderr } => JaxError::Timeout {
                secs,
                doing,
                stderr,
            },
            ProcError::Protocol(m) => JaxError::Protocol(m),
            other => JaxError::Protocol(other.to_string()),
        }
    }
}
