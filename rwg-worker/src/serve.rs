//! The worker's side of the protocol for instances of any
//! [`Environment`]: [`serve`] answers step messages until `Q` or end of
//! file. The handshake (what to host, the `R` answer) is the caller's: it
//! depends on what the worker hosts (`rwg_study::isolate` for plugins).

use crate::lane_file::LaneMark;
use crate::protocol::*;
use crate::ProcError;
use rwg_core::remote::LaneOp;
use rwg_env::{Action, EnvError, Environment, Space};
use std::io::{Read, Write};

/// Answers the host's step messages on `input` with outcome messages on
/// `output`, for `envs`: `envs.len() / lanes` groups of `lanes` instances
/// (instance `g × lanes + i` is lane `i` of group `g`), until a quit
/// message or the end of `input`. The ops of a message are applied in lane
/// order, each instance's number written to `mark` (if any) while it runs.
/// A lane whose env fails reports the error's text; the others go on.
pub fn serve<E: Environment>(
    input: &mut impl Read,
    output: &mut impl Write,
    envs: &mut [E],
    lanes: usize,
    mut mark: Option<LaneMark>,
) -> Result<(), ProcError> {
    let Some(first) = envs.first() else {
        return Err(ProcError::Protocol("no instances to serve".into()));
    };
    let spec = first.spec().clone();
    let d = spec.obs_dim();
    let action_dim = match &spec.action_space {
        Space::Discrete { .. } => 0,
        Space::Box(b) => b.dim(),
    };
    let groups = envs.len() / lanes;
    let mut obs = vec![0.0; d];
    let mut action = vec![0.0; action_dim];
    let mut buf = Vec::new();
    let io = |e: std::io::Error| ProcError::Protocol(format!("cannot talk to the host: {e}"));
    loop {
        let Some((tag, payload)) = read_message(input).map_err(io)? else {
            return Ok(());
        };
        match tag {
            TAG_QUIT => return Ok(()),
            TAG_STEP => {}
            other => return Err(refuse_tag(output, other)),
        }
        let req = decode_step(&payload, lanes, action_dim)?;
        if req.group >= groups {
            return Err(ProcError::Protocol(format!("no group {}", req.group)));
        }
        let w = action_dim.max(1);
        begin(&mut buf, TAG_OUTCOME);
        buf.extend_from_slice(&[req.group as u8, 0, 0, 0, 0, 0, 0, 0]);
        let flags_at = buf.len();
        buf.resize(flags_at + pad8(lanes) + 8 * lanes + 8 * lanes * d, 0);
        let rew_at = flags_at + pad8(lanes);
        let obs_at = rew_at + 8 * lanes;
        let mut errors: Vec<LaneError> = vec![];
        for (i, op) in req.ops.iter().enumerate() {
            let k = req.group * lanes + i;
            let env = &mut envs[k];
            if *op == LaneOp::Idle {
                continue;
            }
            if let Some(m) = &mut mark {
                m.set(Some(k));
            }
            let words = &req.words[i * w..(i + 1) * w];
            match run_lane(env, *op, words, &mut action, &mut obs) {
                Ok((reward, flags)) => {
                    buf[flags_at + i] = F_OK | flags;
                    buf[rew_at + 8 * i..rew_at + 8 * i + 8].copy_from_slice(&reward.to_le_bytes());
                    for (j, v) in obs.iter().enumerate() {
                        let at = obs_at + 8 * (i * d + j);
                        buf[at..at + 8].copy_from_slice(&v.to_le_bytes());
                    }
                }
                Err(e) => {
                    buf[flags_at + i] = F_ERROR;
                    let kind = match e {
                        EnvError::NonFinite(_) => LANE_NON_FINITE.to_string(),
                        _ => String::new(),
                    };
                    errors.push(LaneError {
                        lane: i,
                        message: e.to_string(),
                        traceback: String::new(),
                        kind,
                    });
                }
            }
        }
        if let Some(m) = &mut mark {
            m.set(None);
        }
        if !errors.is_empty() {
            buf.extend_from_slice(&serde_json::to_vec(&errors).expect("serialisable"));
        }
        finish(&mut buf);
        output
            .write_all(&buf)
            .and_then(|()| output.flush())
            .map_err(io)?;
    }
}

/// Answers a message of an unexpected `tag` with an error message (if
/// `output` still takes it); the error to end the loop with.
fn refuse_tag(output: &mut impl Write, tag: u8) -> ProcError {
    let why = format!("unexpected message tag {tag}");
    let e = WorkerError {
        kind: "protocol".into(),
        message: why.clone(),
        traceback: String::new(),
    };
    let json = serde_json::to_vec(&e).expect("serialisable");
    let _ = output.write_all(&message(TAG_ERROR, &json));
    ProcError::Protocol(why)
}

/// Runs one lane's `op` (a reset, or a step with the action in `words`:
/// a discrete action when `action` is empty, else `action.len()` values,
/// decoded into `action`) on `env`, observing into `obs`: the reward and
/// the terminated/truncated flags (0 and none for a reset).
fn run_lane<E: Environment>(
    env: &mut E,
    op: LaneOp,
    words: &[[u8; 8]],
    action: &mut [f64],
    obs: &mut [f64],
) -> Result<(f64, u8), EnvError> {
    if let LaneOp::Reset(seed) = op {
        return env.reset(seed, obs).map(|()| (0.0, 0));
    }
    let a = if action.is_empty() {
        Action::Discrete(i64::from_le_bytes(words[0]))
    } else {
        for (x, b) in action.iter_mut().zip(words) {
            *x = f64::from_le_bytes(*b);
        }
        Action::Continuous(action)
    };
    env.step(a, obs).map(|s| {
        let mut flags = 0;
        if s.terminated {
            flags |= F_TERMINATED;
        }
        if s.truncated {
            flags |= F_TRUNCATED;
        }
        (s.reward, flags)
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use rwg_core::remote::LaneActions;
    use rwg_envs::EnvOptions;

    /// Two groups of 3 CartPoles served from a script of messages give the
    /// bits of the same calls made directly.
    #[test]
    fn served_instances_answer_as_direct_calls() {
        let opts = EnvOptions::default();
        let make = || rwg_envs::make("CartPole-v1", &opts).unwrap();
        let mut envs: Vec<_> = (0..6).map(|_| make()).collect();
        let mut script = vec![];
        let mut buf = vec![];
        let no = LaneActions {
            discrete: &[0, 0, 0],
            continuous: &[],
        };
        let resets = [LaneOp::Reset(1), LaneOp::Reset(2), LaneOp::Idle];
        encode_step(&mut buf, 1, &resets, no, 0);
        script.extend_from_slice(&buf);
        let acts = LaneActions {
            discrete: &[1, 0, 5],
            continuous: &[],
        };
        let steps = [LaneOp::Step, LaneOp::Step, LaneOp::Step];
        encode_step(&mut buf, 1, &steps, acts, 0);
        script.extend_from_slice(&buf);
        script.extend_from_slice(&message(TAG_QUIT, &[]));
        let mut out = vec![];
        serve(&mut &script[..], &mut out, &mut envs, 3, None).unwrap();

        let mut r = &out[..];
        let (tag, o1) = read_message(&mut r).unwrap().unwrap();
        assert_eq!(tag, TAG_OUTCOME);
        let (_, o2) = read_message(&mut r).unwrap().unwrap();
        assert!(read_message(&mut r).unwrap().is_none());
        assert_eq!(o1.len(), outcome_len(3, 4));
        assert_eq!(o1[0], 1);
        assert_eq!(&o1[8..11], &[F_OK, F_OK, 0]);
        // lane 2 was never reset: its step fails, the others go on
        assert_eq!(o2[8 + 2], F_ERROR);
        let errors: Vec<LaneError> = serde_json::from_slice(&o2[outcome_len(3, 4)..]).unwrap();
        assert_eq!(errors.len(), 1);
        assert_eq!(errors[0].lane, 2);

        let mut direct = make();
        let mut obs = [0.0; 4];
        direct.reset(2, &mut obs).unwrap();
        let word = |b: &[u8], i: usize| f64::from_le_bytes(b[i..i + 8].try_into().unwrap());
        let obs_at = 8 + 8 + 8 * 3;
        for (j, v) in obs.iter().enumerate() {
            assert_eq!(word(&o1, obs_at + 8 * (4 + j)).to_bits(), v.to_bits());
        }
        let s = direct.step(Action::Discrete(0), &mut obs).unwrap();
        assert_eq!(word(&o2, 16 + 8).to_bits(), s.reward.to_bits());
        for (j, v) in obs.iter().enumerate() {
            assert_eq!(word(&o2, obs_at + 8 * (4 + j)).to_bits(), v.to_bits());
        }
    }
}
