//! The exchange format (docs/bridge-protocol.md): length-prefixed messages,
//! JSON for the handshake, fixed binary layouts for every exchange.

use crate::ProcError;
use rwg_core::remote::{LaneActions, LaneOp};
use serde::{Deserialize, Serialize};

/// Version of the protocol; the worker refuses another.
pub const PROTOCOL: u32 = 1;

/// Host -> worker: hello (JSON).
pub const TAG_HELLO: u8 = b'H';
/// Worker -> host: ready (JSON: spaces, spec).
pub const TAG_READY: u8 = b'R';
/// Worker -> host, while starting (before its ready message): what comes
/// next, one byte: `c` a call into the env (a reset or step of the checks a
/// worker makes when it starts), within the step timeout; `m` making
/// instances, within the start-up timeout. A worker need not send any.
pub const TAG_PROGRESS: u8 = b'P';
/// Worker -> host: a fatal error (JSON: kind, message, traceback); the worker exits.
pub const TAG_ERROR: u8 = b'E';
/// Host -> worker: one exchange.
pub const TAG_STEP: u8 = b'S';
/// Worker -> host: the outcome of an exchange.
pub const TAG_OUTCOME: u8 = b'O';
/// Host -> worker: quit.
pub const TAG_QUIT: u8 = b'Q';

/// Lane op codes in a step message.
pub const OP_IDLE: u8 = 0;
/// Reset with the lane's seed word.
pub const OP_RESET: u8 = 1;
/// Step with the lane's action words.
pub const OP_STEP: u8 = 2;

/// Outcome flag bits.
pub const F_OK: u8 = 1;
/// `terminated`.
pub const F_TERMINATED: u8 = 2;
/// `truncated`.
pub const F_TRUNCATED: u8 = 4;
/// The lane failed (its error is in the trailing JSON).
pub const F_ERROR: u8 = 8;

/// `n` rounded up to a multiple of 8.
pub fn pad8(n: usize) -> usize {
    n.div_ceil(8) * 8
}

/// Starts a message in `buf`: the length (filled by [`finish`]) and tag.
pub fn begin(buf: &mut Vec<u8>, tag: u8) {
    buf.clear();
    buf.extend_from_slice(&[0, 0, 0, 0, tag]);
}

/// Writes the message length into the first four bytes.
pub fn finish(buf: &mut [u8]) {
    let n = (buf.len() - 4) as u32;
    buf[..4].copy_from_slice(&n.to_le_bytes());
}

/// Encodes a step message for group `group`: the group (a byte padded to
/// 8), `lanes` op bytes (padded to 8), then per lane
/// `words` 8-byte little-endian words: the reset seed (u64), the discrete
/// action (i64) or the continuous action (`words` f64).
pub fn encode_step(
    buf: &mut Vec<u8>,
    group: usize,
    ops: &[LaneOp],
    actions: LaneActions<'_>,
    action_dim: usize,
) {
    let n = ops.len();
    let words = action_dim.max(1);
    begin(buf, TAG_STEP);
    buf.extend_from_slice(&[group as u8, 0, 0, 0, 0, 0, 0, 0]);
    for op in ops {
        buf.push(match op {
            LaneOp::Idle => OP_IDLE,
            LaneOp::Reset(_) => OP_RESET,
            LaneOp::Step => OP_STEP,
        });
    }
    buf.resize(13 + pad8(n), 0);
    for (i, op) in ops.iter().enumerate() {
        match op {
            LaneOp::Reset(seed) => {
                buf.extend_from_slice(&seed.to_le_bytes());
                buf.resize(buf.len() + 8 * (words - 1), 0);
            }
            LaneOp::Step if action_dim == 0 => {
                buf.extend_from_slice(&actions.discrete[i].to_le_bytes())
            }
            LaneOp::Step => {
                for a in &actions.continuous[i * action_dim..(i + 1) * action_dim] {
                    buf.extend_from_slice(&a.to_le_bytes());
                }
            }
            LaneOp::Idle => buf.resize(buf.len() + 8 * words, 0),
        }
    }
    finish(buf);
}

/// Size of an outcome payload without its error trailer: the group (a byte
/// padded to 8), flags, rewards, observations.
pub fn outcome_len(lanes: usize, obs_dim: usize) -> usize {
    8 + pad8(lanes) + 8 * lanes + 8 * lanes * obs_dim
}

/// A fatal error the worker reports before exiting.
#[derive(Debug, Deserialize, Serialize)]
pub struct WorkerError {
    /// `python`, `import`, `not_registered`, `make`, `space`, `reset`,
    /// `nondeterministic` or `protocol`.
    pub kind: String,
    /// What happened.
    pub message: String,
    /// The Python traceback, if any.
    #[serde(default)]
    pub traceback: String,
}

/// One lane's error in an outcome's trailer.
#[derive(Debug, Deserialize, Serialize)]
pub struct LaneError {
    /// The lane.
    pub lane: usize,
    /// What the env raised.
    pub message: String,
    /// The Python traceback.
    #[serde(default)]
    pub traceback: String,
    /// `non_finite` when the lane's env returned a value that is not
    /// finite ([`rwg_env::EnvError::NonFinite`]: rwg's own plugin workers;
    /// a NaN or infinite value a Python worker sends is judged by the host).
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub kind: String,
}

/// [`LaneError::kind`] of a value that is not finite.
pub const LANE_NON_FINITE: &str = "non_finite";

/// A step message as the worker reads it (see [`encode_step`]).
#[derive(Debug, Clone, PartialEq)]
pub struct StepRequest {
    /// The group.
    pub group: usize,
    /// One op per lane.
    pub ops: Vec<LaneOp>,
    /// Per lane `max(1, action_dim)` words: the reset seed, the discrete
    /// action or the continuous action (as raw little-endian words).
    pub words: Vec<[u8; 8]>,
}

/// Decodes a step message's payload (after the tag) for `lanes` lanes with
/// `action_dim` (0: discrete) action values each.
pub fn decode_step(
    payload: &[u8],
    lanes: usize,
    action_dim: usize,
) -> Result<StepRequest, ProcError> {
    let w = action_dim.max(1);
    let want = 8 + pad8(lanes) + 8 * lanes * w;
    if payload.len() != want {
        return Err(ProcError::Protocol(format!(
            "a step message of {} bytes, expected {want}",
            payload.len()
        )));
    }
    let ops = payload[8..8 + lanes]
        .iter()
        .enumerate()
        .map(|(i, op)| {
            let at = 8 + pad8(lanes) + 8 * i * w;
            match *op {
                OP_IDLE => Ok(LaneOp::Idle),
                OP_RESET => Ok(LaneOp::Reset(u64::from_le_bytes(
                    payload[at..at + 8].try_into().expect("8 bytes"),
                ))),
                OP_STEP => Ok(LaneOp::Step),
                other => Err(ProcError::Protocol(format!("lane op {other}"))),
            }
        })
        .collect::<Result<Vec<_>, _>>()?;
    let words = payload[8 + pad8(lanes)..]
        .chunks_exact(8)
        .map(|c| c.try_into().expect("8 bytes"))
        .collect();
    Ok(StepRequest {
        group: payload[0] as usize,
        ops,
        words,
    })
}

/// Reads one whole message from `r`: `Ok(None)` at end of file before it
/// starts, else (tag, payload).
pub fn read_message(r: &mut impl std::io::Read) -> std::io::Result<Option<(u8, Vec<u8>)>> {
    let mut head = [0u8; 5];
    let mut got = 0;
    while got < 5 {
        match r.read(&mut head[got..])? {
            0 if got == 0 => return Ok(None),
            0 => return Err(std::io::ErrorKind::UnexpectedEof.into()),
            n => got += n,
        }
    }
    let len = u32::from_le_bytes(head[..4].try_into().expect("4 bytes")) as usize;
    if len == 0 {
        return Err(std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            "a message without a tag",
        ));
    }
    let mut payload = vec![0u8; len - 1];
    r.read_exact(&mut payload)?;
    Ok(Some((head[4], payload)))
}

/// A whole message of `tag` with `payload`.
pub fn message(tag: u8, payload: &[u8]) -> Vec<u8> {
    let mut buf = Vec::with_capacity(5 + payload.len());
    begin(&mut buf, tag);
    buf.extend_from_slice(payload);
    finish(&mut buf);
    buf
}

/// A JSON float list where infinities are the strings "inf"/"-inf".
pub fn floats(v: &[serde_json::Value]) -> Result<Vec<f64>, ProcError> {
    v.iter()
        .map(|x| match x {
            serde_json::Value::Number(n) => n
                .as_f64()
                .ok_or_else(|| ProcError::Protocol(format!("bad number {n}"))),
            serde_json::Value::String(s) if s == "inf" => Ok(f64::INFINITY),
            serde_json::Value::String(s) if s == "-inf" => Ok(f64::NEG_INFINITY),
            serde_json::Value::String(s) if s == "nan" => Ok(f64::NAN),
            other => Err(ProcError::Protocol(format!("bad bound {other}"))),
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn step_message_layout() {
        let mut buf = vec![];
        let ops = [LaneOp::Reset(7), LaneOp::Step, LaneOp::Idle];
        let acts = LaneActions {
            discrete: &[0, -2, 0],
            continuous: &[],
        };
        encode_step(&mut buf, 1, &ops, acts, 0);
        assert_eq!(buf.len(), 4 + 1 + 8 + 8 + 3 * 8);
        assert_eq!(u32::from_le_bytes(buf[..4].try_into().unwrap()), 41);
        assert_eq!(buf[4], TAG_STEP);
        assert_eq!(&buf[5..13], &[1, 0, 0, 0, 0, 0, 0, 0]);
        assert_eq!(&buf[13..16], &[OP_RESET, OP_STEP, OP_IDLE]);
        assert_eq!(&buf[21..29], &7u64.to_le_bytes());
        assert_eq!(&buf[29..37], &(-2i64).to_le_bytes());
        let acts = LaneActions {
            discrete: &[],
            continuous: &[0.0, 0.0, 1.5, -0.5, 0.0, 0.0],
        };
        encode_step(&mut buf, 0, &ops, acts, 2);
        assert_eq!(buf.len(), 4 + 1 + 8 + 8 + 3 * 16);
        assert_eq!(&buf[21..29], &7u64.to_le_bytes());
        assert_eq!(&buf[29..37], &[0; 8]);
        assert_eq!(&buf[37..45], &1.5f64.to_le_bytes());
        assert_eq!(&buf[45..53], &(-0.5f64).to_le_bytes());
    }

    #[test]
    fn a_step_message_decodes_to_what_was_encoded() {
        let mut buf = vec![];
        let ops = [LaneOp::Reset(7), LaneOp::Step, LaneOp::Idle];
        let acts = LaneActions {
            discrete: &[],
            continuous: &[0.0, 0.0, 1.5, -0.5, 0.0, 0.0],
        };
        encode_step(&mut buf, 1, &ops, acts, 2);
        let (tag, payload) = read_message(&mut &buf[..]).unwrap().unwrap();
        assert_eq!(tag, TAG_STEP);
        let req = decode_step(&payload, 3, 2).unwrap();
        assert_eq!(req.group, 1);
        assert_eq!(req.ops, ops);
        assert_eq!(req.words.len(), 6);
        assert_eq!(f64::from_le_bytes(req.words[2]), 1.5);
        assert_eq!(f64::from_le_bytes(req.words[3]), -0.5);
        assert!(decode_step(&payload, 4, 2).is_err(), "wrong lane count");
        assert!(read_message(&mut &buf[..3]).is_err(), "truncated");
        assert!(
            read_message(&mut &b""[..]).unwrap().is_none(),
            "end of file"
        );
    }

    #[test]
    fn float_lists_with_infinities() {
        let v: Vec<serde_json::Value> = serde_json::from_str(r#"[1.5, "inf", "-inf"]"#).unwrap();
        assert_eq!(floats(&v).unwrap(), [1.5, f64::INFINITY, f64::NEG_INFINITY]);
    }
}
