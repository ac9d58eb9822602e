//! [`PipeLanes`]: the host's side of a started worker, a
//! [`RemoteEnv`] whose exchanges are the protocol's step and outcome messages.

use crate::lane_file::LaneFile;
use crate::process::Worker;
use crate::protocol::*;
use crate::ProcError;
use rwg_core::remote::{LaneActions, LaneOp, LaneOutcome, RemoteEnv, RemoteFailure};
use rwg_env::{EnvError, EnvSpec, Space, Step};
use std::time::Duration;

/// How a kind of worker words its failures.
#[derive(Debug, Clone, Copy)]
pub struct Describe {
    /// A failure of the process (died, hung, protocol) as the error reported.
    pub proc: fn(ProcError) -> EnvError,
    /// A fatal `E` message of the worker running `program`.
    pub fatal: fn(program: &str, WorkerError) -> EnvError,
    /// What introduces a lane error's traceback ("Python traceback").
    pub traceback: &'static str,
}

/// How long a worker's start-up may take.
#[derive(Debug, Clone, Copy)]
pub struct StartTimeouts {
    /// Until the worker's answer, or its next progress message, while it
    /// is not in a call into the env (loading, making instances).
    pub start: Duration,
    /// From the worker's announcement of a call into the env (a progress
    /// message `c`: a create, reset or step) until its next message.
    pub call: Duration,
}

/// A start-up that failed: the error, and whether it came while the worker
/// was in a call into the env it had announced (so the call timeout applied).
#[derive(Debug)]
pub struct StartFailure {
    /// What happened.
    pub error: ProcError,
    /// Whether the worker was in an announced call.
    pub in_call: bool,
}

/// Sends the hello message (`hello`, JSON) and reads the answer (tag,
/// payload), passing over the worker's progress messages
/// ([`TAG_PROGRESS`]): each `c` gives the next message `timeouts.call`,
/// anything else `timeouts.start`.
pub fn handshake(
    worker: &mut Worker,
    hello: &serde_json::Value,
    timeouts: StartTimeouts,
) -> Result<(u8, Vec<u8>), StartFailure> {
    let mut in_call = false;
    let fail = |error, in_call| StartFailure { error, in_call };
    worker
        .send(&message(TAG_HELLO, hello.to_string().as_bytes()))
        .map_err(|e| fail(e, false))?;
    let mut buf = Vec::new();
    loop {
        let timeout = if in_call {
            timeouts.call
        } else {
            timeouts.start
        };
        match worker.recv_message(&mut buf, timeout) {
            Ok(TAG_PROGRESS) => in_call = buf.get(5) == Some(&b'c'),
            Ok(tag) => return Ok((tag, buf.split_off(5))),
            Err(e) => return Err(fail(e, in_call)),
        }
    }
}

/// A started worker hosting `groups × lanes` instances of one environment,
/// past its handshake.
pub struct PipeLanes {
    worker: Worker,
    groups: usize,
    /// The ops last sent to each group (to read its answer).
    sent: Vec<Vec<LaneOp>>,
    /// The file holding the lane being stepped.
    lane_file: LaneFile,
    spec: EnvSpec,
    lanes: usize,
    obs_dim: usize,
    action_dim: usize,
    timeout: Duration,
    describe: Describe,
    send: Vec<u8>,
    recv: Vec<u8>,
}

impl PipeLanes {
    /// The lanes of `worker`, which answered the hello (given `lane_file`)
    /// for `spec` with `lanes` lanes in each of `groups` groups; each step
    /// may take `timeout`.
    pub fn new(
        worker: Worker,
        mut lane_file: LaneFile,
        spec: EnvSpec,
        lanes: usize,
        groups: usize,
        timeout: Duration,
        describe: Describe,
    ) -> PipeLanes {
        lane_file.mapped();
        let obs_dim = spec.obs_dim();
        let action_dim = match &spec.action_space {
            Space::Discrete { .. } => 0,
            Space::Box(b) => b.dim(),
        };
        PipeLanes {
            worker,
            groups,
            sent: vec![vec![LaneOp::Idle; lanes]; groups],
            lane_file,
            spec,
            lanes,
            obs_dim,
            action_dim,
            timeout,
            describe,
            send: Vec::new(),
            recv: Vec::new(),
        }
    }

    /// The worker process.
    pub fn worker(&self) -> &Worker {
        &self.worker
    }

    /// A whole-env failure, naming the lane the worker was on (if any).
    fn failure(&self, e: ProcError) -> RemoteFailure {
        let mark = self.lane_file.mark();
        RemoteFailure {
            lane: mark
                .map(usize::from)
                .filter(|&l| l < self.lanes * self.groups),
            between_calls: mark == Some(crate::lane_file::NO_LANE),
            error: (self.describe.proc)(e),
        }
    }

    /// Decodes group `group`'s outcome message (payload) into its lanes' outcomes.
    fn decode(
        &self,
        tag: u8,
        group: usize,
        payload: &[u8],
        obs: &mut [f64],
        out: &mut [LaneOutcome],
    ) -> Result<(), RemoteFailure> {
        let protocol =
            |m: String| RemoteFailure::from((self.describe.proc)(ProcError::Protocol(m)));
        let n = self.lanes;
        let ops = &self.sent[group];
        if tag == TAG_ERROR {
            let error: WorkerError = serde_json::from_slice(payload)
                .map_err(|e| protocol(format!("error message: {e}")))?;
            return Err((self.describe.fatal)(self.worker.program(), error).into());
        }
        let d = self.obs_dim;
        let base = outcome_len(n, d);
        if tag != TAG_OUTCOME || payload.len() < base || payload[0] as usize != group {
            return Err(protocol(format!(
                "expected group {group}'s outcome of {base} bytes, got tag {} with {} bytes",
                tag,
                payload.len()
            )));
        }
        let mut lane_errors: Vec<LaneError> = vec![];
        if payload.len() > base {
            lane_errors = serde_json::from_slice(&payload[base..])
                .map_err(|e| protocol(format!("lane errors: {e}")))?;
        }
        let word = |b: &[u8], i: usize| f64::from_le_bytes(b[i..i + 8].try_into().expect("8"));
        let rew_at = 8 + pad8(n);
        let obs_at = rew_at + 8 * n;
        for i in 0..n {
            let flags = payload[8 + i];
            out[i] = if flags & F_ERROR != 0 {
                let e = lane_errors.iter().find(|e| e.lane == i);
                let text = match e {
                    Some(e) if !e.traceback.trim().is_empty() => format!(
                        "{}\n{}:\n{}",
                        e.message,
                        self.describe.traceback,
                        e.traceback.trim_end()
                    ),
                    Some(e) => e.message.clone(),
                    None => "failed (no message)".into(),
                };
                if text.starts_with("step raised ResetNeeded") {
                    // Gymnasium's OrderEnforcing: a step before reset
                    LaneOutcome::Failed(EnvError::ResetNeeded)
                } else if e.is_some_and(|e| e.kind == LANE_NON_FINITE) {
                    LaneOutcome::Failed(EnvError::NonFinite(text))
                } else {
                    LaneOutcome::Failed(EnvError::Other(text))
                }
            } else if flags & F_OK == 0 {
                LaneOutcome::Idle
            } else {
                let o = &mut obs[i * d..(i + 1) * d];
                for (j, v) in o.iter_mut().enumerate() {
                    *v = word(payload, obs_at + 8 * (i * d + j));
                }
                let what = if matches!(ops[i], LaneOp::Reset(_)) {
                    "reset"
                } else {
                    "step"
                };
                let reward = word(payload, rew_at + 8 * i);
                if let Some(j) = o.iter().position(|v| !v.is_finite()) {
                    LaneOutcome::Failed(EnvError::NonFinite(format!(
                        "{what} returned a non-finite observation: value {j} of {d} is {}",
                        o[j]
                    )))
                } else if !reward.is_finite() {
                    LaneOutcome::Failed(EnvError::NonFinite(format!(
                        "step returned a non-finite reward ({reward})"
                    )))
                } else if let LaneOp::Reset(_) = ops[i] {
                    LaneOutcome::Reset
                } else {
                    LaneOutcome::Step(Step {
                        reward,
                        terminated: flags & F_TERMINATED != 0,
                        truncated: flags & F_TRUNCATED != 0,
                    })
                }
            };
        }
        Ok(())
    }
}

impl RemoteEnv for PipeLanes {
    fn spec(&self) -> &EnvSpec {
        &self.spec
    }

    fn lanes(&self) -> usize {
        self.lanes
    }

    fn groups(&self) -> usize {
        self.groups
    }

    fn send(
        &mut self,
        group: usize,
        ops: &[LaneOp],
        actions: LaneActions<'_>,
    ) -> Result<(), RemoteFailure> {
        encode_step(&mut self.send, group, ops, actions, self.action_dim);
        self.sent[group].copy_from_slice(ops);
        self.worker.send(&self.send).map_err(|e| self.failure(e))
    }

    fn recv(
        &mut self,
        group: usize,
        obs: &mut [f64],
        out: &mut [LaneOutcome],
    ) -> Result<(), RemoteFailure> {
        let base = outcome_len(self.lanes, self.obs_dim);
        // Room for the usual answer, so that one read takes it.
        if self.recv.len() < 5 + base {
            self.recv.resize(5 + base, 0);
        }
        let tag = match self.worker.recv_message(&mut self.recv, self.timeout) {
            Ok(tag) => tag,
            Err(e) => return Err(self.failure(e)),
        };
        let msg = std::mem::take(&mut self.recv);
        let result = self.decode(tag, group, &msg[5..], obs, out);
        self.recv = msg;
        result
    }
}

impl Drop for PipeLanes {
    fn drop(&mut self) {
        let _ = self.worker.send(&message(TAG_QUIT, &[]));
    }
}
