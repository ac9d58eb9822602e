//! The checks only the raw ABI can express: id style, malformed discrete
//! actions, reset without a seed. One function per check.

use super::env_checks::Outcome;
use super::report::CheckStatus::{Failed, Passed, Warned};
use crate::loader::{check_env_id, PluginEnvType};
use rwg_env::env::{EnvError, Environment};

/// The 'id' check: a valid id, namespaced and versioned.
pub(super) fn id(id: &str) -> Outcome {
    if let Err(e) = check_env_id(id) {
        return (Failed, e);
    }
    let name = id.rsplit('/').next().unwrap_or(id);
    let versioned = name.rsplit_once("-v").is_some_and(|(n, v)| {
        !n.is_empty() && !v.is_empty() && v.bytes().all(|b| b.is_ascii_digit())
    });
    match (id.contains('/'), versioned) {
        (true, true) => (Passed, "namespaced and versioned".into()),
        (false, _) => (
            Warned,
            "not namespaced: plugin ids should look like namespace/Name-v0".into(),
        ),
        (_, false) => (Warned, "no version suffix: ids should end in -vN".into()),
    }
}

/// The 'raw discrete actions' check: non-integral, NaN and wrongly sized
/// discrete actions are refused.
pub(super) fn raw_discrete_actions(ty: &PluginEnvType, config: &str) -> Outcome {
    let dim = ty.spec().obs_dim();
    let mut env = match ty.create(config) {
        Ok(e) => e,
        Err(e) => return (Failed, e.to_string()),
    };
    let mut obs = vec![0.0; dim];
    let mut accepted = Vec::new();
    for (what, a) in [
        ("0.5", &[0.5][..]),
        ("NaN", &[f64::NAN][..]),
        ("two values", &[0.0, 0.0][..]),
        ("no value", &[][..]),
    ] {
        if let Err(e) = env.reset(5, &mut obs) {
            return (Failed, format!("reset failed: {e}"));
        }
        if env.step_raw(a, &mut obs).is_ok() {
            accepted.push(what);
        }
    }
    if accepted.is_empty() {
        (Passed, "malformed discrete actions refused".into())
    } else {
        (
            Failed,
            format!(
                "malformed discrete actions accepted: {}",
                accepted.join(", ")
            ),
        )
    }
}

/// The 'unseeded reset' check: reset without a seed works or is refused as
/// unsupported.
pub(super) fn unseeded_reset(ty: &PluginEnvType, config: &str) -> Outcome {
    let dim = ty.spec().obs_dim();
    let mut env = match ty.create(config) {
        Ok(e) => e,
        Err(e) => return (Failed, e.to_string()),
    };
    let mut obs = vec![0.0; dim];
    match env.reset_raw(0, 0, &mut obs) {
        Ok(()) => (Passed, "reset without a seed works".into()),
        Err(EnvError::Unsupported(_)) => (
            Passed,
            "reset without a seed is refused as unsupported (allowed)".into(),
        ),
        Err(e) => (Warned, format!("reset without a seed: {e}")),
    }
}
