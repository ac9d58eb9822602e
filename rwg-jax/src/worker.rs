//! One JAX worker process: started with `python -c` through
//! [`rwg_worker::Worker`] (process group, death signal, stderr tail,
//! deadlines), past its handshake; compiles cells and runs chunks, several
//! in flight.

use crate::protocol::*;
use crate::{JaxConfig, JaxError, JaxInfo, MAX_OBS, MODULES, WORKER_PY};
use rwg_worker::python::{loader_args, LOAD_PY};
use rwg_worker::{ProcError, Worker};
use std::time::Duration;

/// A worker process started and sent its hello, not yet ready: its
/// imports run while rwg does other things ([`Starting::ready`] waits).
pub struct Starting {
    worker: Worker,
    python: String,
    timeout: Duration,
}

impl Starting {
    /// Waits for the worker's ready message (its progress messages in
    /// between), within the config's timeout.
    pub fn ready(mut self, cfg: &JaxConfig) -> Result<(JaxWorker, JaxInfo), JaxError> {
        let mut buf = Vec::new();
        let tag = loop {
            match self.worker.recv_message(&mut buf, self.timeout) {
                Ok(TAG_PROGRESS) => {}
                Ok(tag) => break tag,
                Err(e) => return Err(JaxError::from_proc(e, "starting")),
            }
        };
        let w = JaxWorker {
            worker: self.worker,
            python: self.python,
            timeout: self.timeout,
            cell: None,
            buf: Vec::new(),
            in_flight: 0,
        };
        let payload = buf.split_off(5);
        let ready: Ready = w.expect(tag, &payload, TAG_READY)?;
        let info = parse_ready(cfg, ready)?;
        Ok((w, info))
    }
}

/// A started JAX worker.
pub struct JaxWorker {
    worker: Worker,
    python: String,
    timeout: Duration,
    /// The cell last compiled (what a chunk runs).
    cell: Option<CellShape>,
    buf: Vec<u8>,
    /// Chunks sent whose outcomes are not read yet.
    in_flight: usize,
}

impl JaxWorker {
    /// Starts a worker for `cfg` and sends its hello; [`Starting::ready`]
    /// waits for it.
    pub fn start(cfg: &JaxConfig) -> Result<Starting, JaxError> {
        let mut command = std::process::Command::new(&cfg.python);
        command.arg("-c").arg(LOAD_PY);
        loader_args(&mut command, WORKER_PY, &MODULES);
        #[cfg(unix)]
        let dump = Some(libc::SIGUSR1);
        #[cfg(not(unix))]
        let dump = None;
        let mut worker = Worker::spawn(command, &cfg.python, dump)
            .map_err(|e| JaxError::from_proc(e, "starting"))?;
        worker
            .send(&message(
                TAG_HELLO,
                hello(cfg, MAX_OBS).to_string().as_bytes(),
            ))
            .map_err(|e| JaxError::from_proc(e, "starting"))?;
        Ok(Starting {
            worker,
            python: cfg.python.clone(),
            timeout: cfg.timeout,
        })
    }

    /// Starts a worker for `cfg` and reads its ready message.
    pub fn spawn(cfg: &JaxConfig) -> Result<(JaxWorker, JaxInfo), JaxError> {
        Self::start(cfg)?.ready(cfg)
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
    /// the first time it is named); the seconds the compile took. No chunk
    /// may be in flight.
    pub fn set_cell(&mut self, cell: &CellShape) -> Result<Option<f64>, JaxError> {
        debug_assert_eq!(self.in_flight, 0);
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

    /// Chunks sent whose outcomes were not read.
    pub fn in_flight(&self) -> usize {
        self.in_flight
    }

    /// Sends a chunk of `n` networks (`weights`, network-major) with the
    /// reset seeds `seeds` (`n * episodes`) to run on the current cell,
    /// telling the worker to answer the `answers` oldest chunks in flight
    /// after starting it: read them with [`JaxWorker::recv_outcome`].
    pub fn send_chunk(
        &mut self,
        answers: usize,
        n: usize,
        weights: &[f64],
        seeds: &[u64],
    ) -> Result<(), JaxError> {
        let episodes = self.cell.as_ref().expect("a cell is set").episodes;
        let answers = answers.min(self.in_flight + 1);
        encode_chunk(&mut self.buf, answers as u32, n, episodes, weights, seeds);
        self.in_flight += 1;
        self.worker
            .send(&self.buf)
            .map_err(|e| JaxError::from_proc(e, "running a chunk"))
    }

    /// Asks the worker to answer every chunk in flight.
    pub fn flush(&mut self) -> Result<(), JaxError> {
        self.worker
            .send(&message(TAG_FLUSH, &[]))
            .map_err(|e| JaxError::from_proc(e, "running a chunk"))
    }

    /// The outcome of the oldest chunk in flight, of `m` episodes.
    pub fn recv_outcome(&mut self, m: usize) -> Result<Outcome, JaxError> {
        let tag = self
            .worker
            .recv_message(&mut self.buf, self.timeout)
            .map_err(|e| JaxError::from_proc(e, "running a chunk"))?;
        if tag != TAG_OUTCOME {
            let payload = self.buf.split_off(5);
            return Err(self.unexpected(tag, &payload));
        }
        self.in_flight -= 1;
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
