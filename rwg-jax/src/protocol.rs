//! The JAX worker's messages (framing as `docs/bridge-protocol.md`): the
//! hello, cell, chunk and flush messages rwg sends, the ready, compiled and
//! outcome messages the worker answers. Tags shared with the Gymnasium
//! bridge come from [`rwg_worker::protocol`].
//!
//! Chunks are pipelined: the worker starts a chunk on a device as soon as
//! it reads it and writes outcomes in the order the chunks came, only when
//! asked: a chunk message says how many of the oldest chunks in flight to
//! answer after it, a flush answers them all. Both sides alternate one
//! chunk sent, its answers read, so neither waits on a full pipe.

use crate::{JaxConfig, JaxError, JaxInfo, MatmulPrecision, Precision};
use rwg_env::{BoxSpace, EnvSpec, Space};
use serde::Deserialize;
use std::collections::BTreeMap;

pub use rwg_worker::protocol::{
    begin, finish, message, pad8, WorkerError, PROTOCOL, TAG_ERROR, TAG_HELLO, TAG_OUTCOME,
    TAG_PROGRESS, TAG_QUIT, TAG_READY,
};

/// Host -> worker: a cell to compile (JSON).
pub const TAG_CELL: u8 = b'C';
/// Worker -> host: the cell is compiled (JSON: `compile_s`).
pub const TAG_COMPILED: u8 = b'K';
/// Host -> worker: a chunk of networks (binary).
pub const TAG_CHUNK: u8 = b'B';
/// Host -> worker: answer every chunk in flight (no payload).
pub const TAG_FLUSH: u8 = b'F';

/// Fault bit: a non-finite observation was seen while the episode ran.
pub const FAULT_OBS: u8 = 1;
/// Fault bit: a non-finite reward.
pub const FAULT_REWARD: u8 = 2;
/// Fault bit (with `non_finite = "end"` only): finite rewards took the
/// return beyond ±1e100 (or, in float32, to infinity).
pub const FAULT_RETURN: u8 = 4;

/// The hello message's JSON for `cfg`.
pub fn hello(cfg: &JaxConfig, max_obs: usize) -> serde_json::Value {
    serde_json::json!({
        "protocol": PROTOCOL,
        "source": cfg.kind.source(),
        "package": cfg.kind.family().package,
        "action_mask": cfg.action_mask,
        "env": cfg.id,
        "kwargs": cfg.kwargs,
        "max_episode_steps": cfg.max_episode_steps,
        "precision": cfg.precision.name(),
        "device": cfg.device,
        "max_obs": max_obs,
        "compile_cache": cfg.compile_cache,
    })
}

/// What a cell message names: the compiled call's shape.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CellShape {
    /// Hidden layer sizes.
    pub hidden: Vec<usize>,
    /// Whether the layers have a bias input.
    pub bias: bool,
    /// Networks per call.
    pub networks: u32,
    /// Episodes per network.
    pub episodes: u32,
    /// Weights per network (0 for random actions).
    pub n_weights: usize,
    /// Episodes run at once (the program's lanes).
    pub lanes: u32,
    /// Ended lanes that wait before they take new episodes together.
    pub refill: u32,
    /// The precision of matrix products.
    pub matmul_precision: MatmulPrecision,
    /// Uniformly random actions instead of networks (the random baseline).
    pub random: bool,
    /// The manifest's `non_finite = "end"`: an episode ends at its first
    /// value that is not finite (observation, reward, or a return beyond
    /// ±1e100), its return that of the steps before, its fault bits set.
    pub non_finite_ends: bool,
}

impl CellShape {
    /// The cell message's JSON (`"non_finite": "end"` only with
    /// [`CellShape::non_finite_ends`]).
    pub fn json(&self) -> serde_json::Value {
        let mut j = serde_json::json!({
            "hidden": self.hidden,
            "bias": self.bias,
            "networks": self.networks,
            "episodes": self.episodes,
            "n_weights": self.n_weights,
            "lanes": self.lanes,
            "refill": self.refill,
            "matmul_precision": self.matmul_precision.name(),
            "policy": if self.random { "random" } else { "network" },
        });
        if self.non_finite_ends {
            j["non_finite"] = "end".into();
        }
        j
    }
}

/// Encodes a chunk message into `buf`: how many of the oldest chunks in
/// flight the worker answers after starting this one (`answers`, padded to
/// 8 bytes), then `n` networks' weights (`weights`, network-major, `n *
/// n_weights` values) and `n * episodes` reset seeds.
pub fn encode_chunk(
    buf: &mut Vec<u8>,
    answers: u32,
    n: usize,
    episodes: u32,
    weights: &[f64],
    seeds: &[u64],
) {
    debug_assert_eq!(seeds.len(), n * episodes as usize);
    begin(buf, TAG_CHUNK);
    buf.reserve(16 + 8 * (weights.len() + seeds.len()));
    buf.extend_from_slice(&answers.to_le_bytes());
    buf.extend_from_slice(&[0; 4]);
    buf.extend_from_slice(&(n as u32).to_le_bytes());
    buf.extend_from_slice(&episodes.to_le_bytes());
    for w in weights {
        buf.extend_from_slice(&w.to_le_bytes());
    }
    for s in seeds {
        buf.extend_from_slice(&s.to_le_bytes());
    }
    finish(buf);
}

/// A chunk's outcome: per episode (network-major) its return, length and
/// fault bits.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Outcome {
    /// Returns.
    pub returns: Vec<f64>,
    /// Lengths.
    pub lengths: Vec<u32>,
    /// Fault bits ([`FAULT_OBS`], [`FAULT_REWARD`]).
    pub faults: Vec<u8>,
}

/// Length of the outcome payload of `m` episodes.
pub fn outcome_len(m: usize) -> usize {
    8 * m + 4 * m + pad8(m)
}

/// Decodes an outcome payload of `m` episodes.
pub fn decode_outcome(payload: &[u8], m: usize) -> Result<Outcome, JaxError> {
    if payload.len() != outcome_len(m) {
        return Err(JaxError::Protocol(format!(
            "an outcome of {} bytes for {m} episodes ({} expected)",
            payload.len(),
            outcome_len(m)
        )));
    }
    let (r, rest) = payload.split_at(8 * m);
    let (l, f) = rest.split_at(4 * m);
    Ok(Outcome {
        returns: r
            .chunks_exact(8)
            .map(|b| f64::from_le_bytes(b.try_into().expect("8 bytes")))
            .collect(),
        lengths: l
            .chunks_exact(4)
            .map(|b| u32::from_le_bytes(b.try_into().expect("4 bytes")))
            .collect(),
        faults: f[..m].to_vec(),
    })
}

/// One leaf of a structured observation: its name (its path in the
/// pytree), shape and dtype.
#[derive(Debug, Clone, PartialEq, Eq, Deserialize, serde::Serialize)]
pub struct Leaf {
    /// `grid`, `agent.position`, `['state']`; `obs` for a bare array.
    pub name: String,
    /// Its shape (`[]` for a scalar).
    pub shape: Vec<u64>,
    /// Its dtype as JAX names it (`float32`, `uint8`, `bool`).
    pub dtype: String,
}

/// What the worker says in its ready message.
#[derive(Debug, Clone, Deserialize)]
pub struct Ready {
    observation_leaves: Vec<Leaf>,
    action_mask: String,
    settings: BTreeMap<String, String>,
    obs_dim: usize,
    obs_low: Vec<serde_json::Value>,
    obs_high: Vec<serde_json::Value>,
    action: serde_json::Value,
    max_episode_steps: u32,
    observation_space: String,
    action_space: String,
    versions: BTreeMap<String, String>,
    device: String,
    devices: usize,
    device_kind: String,
    platform: String,
    precision: String,
    memory: Option<u64>,
    item_bytes: u64,
    #[serde(default)]
    source: Option<ModuleSource>,
    episode_loop: EpisodeLoop,
}

/// Which of the two programs runs a cell's episodes, and why: `lanes`
/// (an ended lane takes the next episode) or `plain` (the lanes take their
/// episodes together and step until all have ended, for an env whose
/// episodes all end at the same step whatever the actions). The same bits
/// either way: a speed choice, made by the worker from the env's traced
/// step.
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize, Deserialize)]
pub struct EpisodeLoop {
    /// `lanes` or `plain`.
    #[serde(rename = "loop")]
    pub kind: String,
    /// Why, in words.
    pub why: String,
}

/// What the code of a `jax:module:callable` env is: a digest of its
/// package's source files (a resume under other code is refused), and the
/// `PYTHONPATH` it was imported through (what a printed command needs).
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize, Deserialize)]
pub struct ModuleSource {
    /// The top module (`my_pkg` of `jax:my_pkg.envs:make`).
    pub module: String,
    /// SHA-256 of its `.py` files (relative path and bytes, in path order).
    pub sha256: String,
    /// How many files.
    pub files: u64,
    /// The `PYTHONPATH` (absolute folders) it was imported through, if it
    /// was found through `PYTHONPATH` or the current directory (not an
    /// installed package): what a command that starts the env again needs.
    #[serde(default)]
    pub pythonpath: Option<String>,
}

fn floats(v: &[serde_json::Value]) -> Result<Vec<f64>, JaxError> {
    rwg_worker::protocol::floats(v).map_err(|e| JaxError::Protocol(e.to_string()))
}

/// The env as the ready message `r` describes it, for `cfg`.
pub fn parse_ready(cfg: &JaxConfig, r: Ready) -> Result<JaxInfo, JaxError> {
    let low = floats(&r.obs_low)?;
    let high = floats(&r.obs_high)?;
    if low.len() != r.obs_dim || high.len() != r.obs_dim || r.obs_dim == 0 {
        return Err(JaxError::Protocol(
            "observation bounds of the wrong length".into(),
        ));
    }
    let action_space = if let Some(n) = r.action.get("discrete") {
        match n.as_u64() {
            Some(n) if n > 0 => Space::Discrete { n: n as usize },
            _ => return Err(JaxError::Protocol(format!("action {}", r.action))),
        }
    } else if let Some(b) = r.action.get("box") {
        let list = |k: &str| floats(b[k].as_array().map_or(&[][..], |v| v));
        let (lo, hi) = (list("low")?, list("high")?);
        if lo.is_empty() || lo.len() != hi.len() {
            return Err(JaxError::Protocol(format!("action {}", r.action)));
        }
        Space::Box(BoxSpace::new(lo, hi))
    } else {
        return Err(JaxError::Protocol(format!("action {}", r.action)));
    };
    let precision = Precision::from_name(&r.precision)
        .ok_or_else(|| JaxError::Protocol(format!("precision {:?}", r.precision)))?;
    Ok(JaxInfo {
        spec: EnvSpec {
            id: cfg.rwg_id(),
            observation_space: Space::Box(BoxSpace::new(low, high)),
            action_space,
            max_episode_steps: Some(r.max_episode_steps),
            reward_threshold: None,
        },
        observation_space: r.observation_space,
        action_space: r.action_space,
        versions: r.versions,
        observation_leaves: r.observation_leaves,
        action_mask: r.action_mask,
        settings: r.settings,
        device: r.device,
        devices: r.devices.max(1),
        device_kind: r.device_kind,
        platform: r.platform,
        precision,
        memory: r.memory,
        item_bytes: r.item_bytes,
        source: r.source,
        episode_loop: r.episode_loop,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::JaxKind;

    #[test]
    fn a_chunk_is_counts_weights_then_seeds() {
        let mut buf = vec![];
        encode_chunk(&mut buf, 1, 2, 1, &[1.5, -2.0], &[7, u64::MAX]);
        assert_eq!(
            u32::from_le_bytes(buf[..4].try_into().unwrap()) as usize,
            buf.len() - 4
        );
        assert_eq!(buf[4], TAG_CHUNK);
        let p = &buf[5..];
        assert_eq!(&p[..8], &[1, 0, 0, 0, 0, 0, 0, 0]);
        let p = &p[8..];
        assert_eq!(&p[..8], &[2, 0, 0, 0, 1, 0, 0, 0]);
        assert_eq!(&p[8..16], &1.5f64.to_le_bytes());
        assert_eq!(&p[16..24], &(-2.0f64).to_le_bytes());
        assert_eq!(&p[24..32], &7u64.to_le_bytes());
        assert_eq!(&p[32..40], &u64::MAX.to_le_bytes());
        assert_eq!(p.len(), 40);
    }

    #[test]
    fn an_outcome_is_returns_lengths_then_padded_faults() {
        let mut p = vec![];
        for r in [1.0f64, 2.5, -3.0] {
            p.extend_from_slice(&r.to_le_bytes());
        }
        for l in [4u32, 5, 6] {
            p.extend_from_slice(&l.to_le_bytes());
        }
        p.extend_from_slice(&[0, FAULT_OBS, FAULT_REWARD, 0, 0, 0, 0, 0]);
        let o = decode_outcome(&p, 3).unwrap();
        assert_eq!(o.returns, [1.0, 2.5, -3.0]);
        assert_eq!(o.lengths, [4, 5, 6]);
        assert_eq!(o.faults, [0, 1, 2]);
        assert!(decode_outcome(&p[..p.len() - 1], 3).is_err());
    }

    #[test]
    fn ready_becomes_the_spec() {
        let cfg = JaxConfig::new(JaxKind::Brax, "inverted_pendulum");
        let r: Ready = serde_json::from_value(serde_json::json!({
            "observation_leaves": [{"name": "obs", "shape": [4], "dtype": "float32"}],
            "action_mask": "none", "settings": {},
            "obs_shape": [4], "obs_dim": 4, "obs_low": ["-inf", "-inf", "-inf", "-inf"],
            "obs_high": ["inf", "inf", "inf", "inf"],
            "action": {"box": {"low": [-1.0], "high": [1.0], "shape": [1]}},
            "max_episode_steps": 1000, "observation_space": "Box", "action_space": "Box",
            "versions": {"jax": "0.10.2"}, "device": "cpu:0", "devices": 1,
            "device_kind": "cpu", "platform": "cpu", "precision": "float64", "memory": null,
            "item_bytes": 40,
            "episode_loop": {"loop": "lanes", "why": "its episodes end on what the actions do"}
        }))
        .unwrap();
        let info = parse_ready(&cfg, r).unwrap();
        assert_eq!(info.spec.id, "brax:inverted_pendulum");
        assert_eq!(info.spec.obs_dim(), 4);
        assert_eq!(info.spec.max_episode_steps, Some(1000));
        assert_eq!(info.precision, Precision::F64);
        assert!(matches!(info.spec.action_space, Space::Box(ref b) if b.dim() == 1));
    }
}
