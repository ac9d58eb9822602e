//! What determines a JAX env source: its config (the manifest's keys, the
//! Python, the timeout, the compilation cache) and the settings read from
//! the environment.

use crate::{JaxKind, CACHE_VAR, DEFAULT_TIMEOUT_S, MAX_TIMEOUT_S, PYTHON_VAR, TIMEOUT_VAR};
use std::time::Duration;

/// The float type the policy and the env compute in.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum Precision {
    /// `float32` (JAX's default).
    #[default]
    F32,
    /// `float64` (`jax_enable_x64`).
    F64,
}

impl Precision {
    /// The manifest's names, in variant order.
    pub const NAMES: [&'static str; 2] = ["float32", "float64"];

    /// `float32` or `float64`.
    pub fn name(self) -> &'static str {
        Self::NAMES[self as usize]
    }

    /// The precision named `name` ([`Precision::NAMES`]).
    pub fn from_name(name: &str) -> Option<Precision> {
        match name {
            "float32" => Some(Precision::F32),
            "float64" => Some(Precision::F64),
            _ => None,
        }
    }
}

/// The precision of the matrix products in a cell's program (the policy's
/// layers and any product the env computes): JAX's
/// `default_matmul_precision`. On a CPU every choice computes float32
/// products in float32; on a GPU `default` may use TF32 (or bfloat16 passes)
/// and so depend on the GPU.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum MatmulPrecision {
    /// `default`: the backend's fastest (TF32 on recent NVIDIA GPUs).
    Default,
    /// `high`: three bfloat16 passes (or TF32) on GPUs and TPUs.
    High,
    /// `highest`: full float32 (or float64) products everywhere.
    #[default]
    Highest,
}

impl MatmulPrecision {
    /// The manifest's names, in variant order (JAX's too).
    pub const NAMES: [&'static str; 3] = ["default", "high", "highest"];

    /// `highest`, `high` or `default`.
    pub fn name(self) -> &'static str {
        Self::NAMES[self as usize]
    }

    /// The precision named `name` ([`MatmulPrecision::NAMES`]).
    pub fn from_name(name: &str) -> Option<MatmulPrecision> {
        match name {
            "default" => Some(MatmulPrecision::Default),
            "high" => Some(MatmulPrecision::High),
            "highest" => Some(MatmulPrecision::Highest),
            _ => None,
        }
    }
}

/// Everything that determines a JAX environment source.
#[derive(Debug, Clone, PartialEq)]
pub struct JaxConfig {
    /// Which library.
    pub kind: JaxKind,
    /// The id after the prefix (`CartPole-v1`, `my_pkg.envs:make_env`).
    pub id: String,
    /// The Python interpreter.
    pub python: String,
    /// Keyword arguments (gymnax: env params fields; brax:
    /// `get_environment` kwargs; jax: the callable's), encoded as
    /// `rwg_gym::kwargs` does (nan/inf as `{"$rwg": "nan"}`).
    pub kwargs: serde_json::Map<String, serde_json::Value>,
    /// The manifest's time limit override.
    pub max_episode_steps: Option<u32>,
    /// The precision.
    pub precision: Precision,
    /// The precision of matrix products.
    pub matmul_precision: MatmulPrecision,
    /// The JAX devices: `gpu:1` that one, `gpu` (or `None`: JAX's default
    /// kind) every local device of that kind.
    pub device: Option<String>,
    /// Networks per compiled call; `None`: [`JaxSource::networks_per_call`](crate::JaxSource::networks_per_call)'s
    /// default, from the lanes and the device's memory.
    pub networks_per_call: Option<u32>,
    /// Whether a discrete action is the argmax over the legal actions where
    /// the family gives them (`true`), or over all actions.
    pub action_mask: bool,
    /// How long a start, a compile or a call may take.
    pub timeout: Duration,
    /// The folder of JAX's persistent compilation cache (`None`: none).
    pub compile_cache: Option<std::path::PathBuf>,
}

impl JaxConfig {
    /// A config for `id` (without the prefix) of `kind` with defaults: the
    /// Python from [`default_python`], no kwargs, the env's own time limit,
    /// float32, the highest matmul precision, the default devices and call
    /// size, [`default_timeout`], the cache of [`cache_setting`].
    pub fn new(kind: JaxKind, id: &str) -> Self {
        JaxConfig {
            kind,
            id: id.to_string(),
            python: default_python(),
            kwargs: Default::default(),
            max_episode_steps: None,
            precision: Precision::F32,
            matmul_precision: MatmulPrecision::Highest,
            device: None,
            networks_per_call: None,
            action_mask: true,
            timeout: default_timeout(),
            compile_cache: cache_setting().ok().flatten(),
        }
    }

    /// The full rwg id (`gymnax:CartPole-v1`).
    pub fn rwg_id(&self) -> String {
        format!("{}{}", self.kind.prefix(), self.id)
    }
}

/// `RWG_PYTHON` if set, else `python3` (as for `gymnasium:` envs).
pub fn default_python() -> String {
    rwg_env::vars::text(PYTHON_VAR, "a Python interpreter")
        .ok()
        .flatten()
        .unwrap_or_else(|| "python3".into())
}

/// [`TIMEOUT_VAR`] (seconds from 0.001 to [`MAX_TIMEOUT_S`]) if set, else
/// [`DEFAULT_TIMEOUT_S`]; an error naming the variable for any other value.
pub fn timeout_setting() -> Result<Duration, rwg_env::vars::VarError> {
    rwg_env::vars::seconds(
        TIMEOUT_VAR,
        0.001,
        MAX_TIMEOUT_S,
        Duration::from_secs_f64(DEFAULT_TIMEOUT_S),
        "how long a JAX worker may take to start, to compile a cell or to run one call",
    )
}

/// The folder of JAX's persistent compilation cache: [`CACHE_VAR`] if set
/// (`off`: no cache), else `$XDG_CACHE_HOME/rwg/jax`, else
/// `$HOME/.cache/rwg/jax` (`None` without either); an error naming the
/// variable for a relative path.
pub fn cache_setting() -> Result<Option<std::path::PathBuf>, rwg_env::vars::VarError> {
    use std::path::PathBuf;
    if let Some(v) = rwg_env::vars::text(
        CACHE_VAR,
        "an absolute folder for JAX's compiled programs, or off",
    )? {
        if v == "off" {
            return Ok(None);
        }
        let p = PathBuf::from(&v);
        if !p.is_absolute() {
            return Err(rwg_env::vars::VarError {
                var: CACHE_VAR,
                value: v,
                expected: "an absolute folder for JAX's compiled programs, or off".into(),
            });
        }
        return Ok(Some(p));
    }
    let home = |var: &str| {
        std::env::var_os(var)
            .filter(|v| !v.is_empty())
            .map(PathBuf::from)
    };
    Ok(home("XDG_CACHE_HOME")
        .or_else(|| home("HOME").map(|h| h.join(".cache")))
        .map(|c| c.join("rwg").join("jax")))
}

/// [`timeout_setting`], or [`DEFAULT_TIMEOUT_S`] if that is an error (the
/// `rwg` binary checks the variable before it runs a command).
pub fn default_timeout() -> Duration {
    timeout_setting().unwrap_or(Duration::from_secs_f64(DEFAULT_TIMEOUT_S))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn precisions_go_by_their_manifest_names() {
        for p in [Precision::F32, Precision::F64] {
            assert_eq!(Precision::from_name(p.name()), Some(p));
        }
        assert_eq!(Precision::from_name("float16"), None);
        assert_eq!(Precision::default(), Precision::F32);
        for p in [
            MatmulPrecision::Default,
            MatmulPrecision::High,
            MatmulPrecision::Highest,
        ] {
            assert_eq!(MatmulPrecision::from_name(p.name()), Some(p));
        }
        assert_eq!(MatmulPrecision::from_name("tf32"), None);
        assert_eq!(MatmulPrecision::default(), MatmulPrecision::Highest);
    }
}
