//! Gymnasium environments (`gymnasium:ID`, `gymnasium:module:ID`) in a
//! manifest: an `[[envs]]` entry turned into a [`GymConfig`] (its `kwargs`,
//! `python`, time limit and action dtype), and the bridge's start-up errors
//! located at the manifest line that explains them.

use crate::manifest::{EnvEntry, Manifest, ManifestError};
use rwg_gym::{GymConfig, GymError, GymSource};
use std::io::Write;

/// Whether `id` names a Gymnasium env (`gymnasium:...`).
pub fn is_gym(id: &str) -> bool {
    rwg_gym::gym_id(id).is_some()
}

/// The config of manifest entry `e`.
pub fn config_of(e: &EnvEntry) -> GymConfig {
    let mut cfg = GymConfig::new(rwg_gym::gym_id(&e.id).expect("a gymnasium: id"));
    if let Some(p) = &e.python {
        cfg.python = p.clone();
    }
    if let Some(k) = &e.kwargs {
        cfg.kwargs = crate::manifest::kwargs::to_json(k);
    }
    cfg.max_episode_steps = e.max_episode_steps;
    cfg.action_dtype = e.action_dtype.unwrap_or_default();
    cfg.non_finite_ends = e.non_finite == rwg_core::sampler::NonFinite::End;
    cfg
}

/// Opens env `i` of the manifest (one worker, checked), or an error pointing
/// at the manifest line that explains it.
pub fn open_entry(m: &Manifest, i: usize) -> Result<GymSource, ManifestError> {
    let e = &m.envs[i];
    let key = format!("envs[{i}]");
    if let Some(at) = e.plugin_span.clone().or(e.config_span.clone()) {
        return Err(m.error_at(
            at,
            format!(
                "{key}: '{}' is a Gymnasium environment; `plugin` and `config` apply to plugin \
                 environments only (give gym.make's arguments with `kwargs = {{ ... }}`)",
                e.id
            ),
        ));
    }
    let cfg = config_of(e);
    let src = GymSource::open(cfg).map_err(|err| {
        let at = match &err {
            GymError::NoPython { .. } => e.python_span.clone(),
            GymError::Worker { error, .. } if error.kind == "python" => e.python_span.clone(),
            GymError::Worker { error, .. } if error.kind == "make" => e.kwargs_span.clone(),
            _ => None,
        }
        .unwrap_or(e.id_span.clone());
        m.error_at(at, format!("{key}: {}: {err}", e.id))
    })?;
    match src.info().registered_threshold {
        Some(t) if !t.is_finite() && e.solved.is_none() => {
            return Err(m.error_at(
                e.id_span.clone(),
                format!(
                    "{key}: {} registers reward_threshold = {}, not a score a network can be \
                     said to reach; set `solved = ...` in this [[envs]] entry (the mean score \
                     that counts as solved)",
                    e.id,
                    if t.is_nan() {
                        "nan".into()
                    } else {
                        t.to_string()
                    }
                ),
            ))
        }
        _ => {}
    }
    if src.info().fresh_per_episode {
        // a closed stderr is no reason to fail (eprintln! would panic)
        let _ = writeln!(
            std::io::stderr(),
            "note: {}: an episode depends on the episodes an instance ran before, so every \
             episode runs on a fresh gym.make instance (slower, but the results do not depend \
             on scheduling)",
            e.id
        );
    }
    Ok(src)
}

/// The error for `kwargs`/`python` given to an env that is neither a
/// Gymnasium nor a JAX one.
pub fn check_not_gym_fields(m: &Manifest, i: usize) -> Result<(), ManifestError> {
    let e = &m.envs[i];
    match e.kwargs_span.clone().or(e.python_span.clone()) {
        Some(at) => Err(m.error_at(
            at,
            format!(
                "envs[{i}]: `kwargs` and `python` apply to Gymnasium and JAX environments \
                 only (write the id as gymnasium:{}, or as a JAX id: {})",
                e.id,
                rwg_jax::id_forms()
            ),
        )),
        None => Ok(()),
    }
}
