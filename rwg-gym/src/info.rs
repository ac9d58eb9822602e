//! The environment as a worker describes it ([`GymInfo`]): its ready
//! message read into rwg's terms, and what differs between two workers.

use crate::protocol::floats;
use crate::{GymConfig, GymError, CHECK_SEED, HASH_SEED_VAR};
use rwg_env::{BoxSpace, EnvSpec, Space};
use serde::Deserialize;

/// What the worker says about the environment in its ready message.
#[derive(Debug, Clone, Deserialize)]
pub(crate) struct Ready {
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

pub(crate) fn parse_ready(cfg: &GymConfig, r: Ready) -> Result<GymInfo, GymError> {
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
