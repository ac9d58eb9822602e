//! The manifest's `[[envs]]` entries: each key checked where it stands, in
//! groups (lengths, the id, episode keys, paths, kwargs, the JAX keys of
//! [`super::jax_keys`]), and relative paths resolved against the manifest's
//! folder.

use super::checker::Checker;
use super::raw::RawEnv;
use super::{jax_keys, EnvEntry, ManifestError};
use crate::limits;
use rwg_core::sampler::NonFinite;
use rwg_env::env::ActionDtype;
use std::path::{Path, PathBuf};
use toml::Spanned;

/// The envs: at least one, at most rwg's limit, ids unique; relative paths
/// resolved against `base`.
pub(super) fn envs(
    at: &Checker,
    raw: &Spanned<Vec<RawEnv>>,
    base: &Path,
) -> Result<Vec<EnvEntry>, ManifestError> {
    at.entry_count(raw, "envs", "one environment", limits::MAX_ENVS, |e| {
        e.id.span()
    })?;
    let mut envs: Vec<EnvEntry> = Vec::new();
    for (i, e) in raw.get_ref().iter().enumerate() {
        let entry = env(at, &format!("envs[{i}]"), e, &envs, base)?;
        envs.push(entry);
    }
    Ok(envs)
}

/// Entry `key` (`envs[i]`), whose id none of `earlier` has.
fn env(
    at: &Checker,
    key: &str,
    e: &RawEnv,
    earlier: &[EnvEntry],
    base: &Path,
) -> Result<EnvEntry, ManifestError> {
    check_lengths(at, key, e)?;
    check_id_unique(at, key, e, earlier)?;
    let solved = solved(at, key, e)?;
    let max_episode_steps = max_episode_steps(at, key, e)?;
    let action_dtype = action_dtype(at, key, e)?;
    let non_finite = non_finite(at, key, e)?;
    let id = e.id.get_ref();
    let jax = jax_keys::check(key, id, e).map_err(|l| at.located(l))?;
    // (a JAX env refuses the key: jax_keys::check)
    let action_dtype = jax.precision.is_none().then_some(action_dtype);
    let plugin = plugin_path(e, base);
    let kwargs = kwargs(at, key, e)?;
    Ok(EnvEntry {
        id: id.clone(),
        solved,
        max_episode_steps,
        action_dtype,
        plugin,
        config: e.config.as_ref().map(|c| c.get_ref().clone()),
        kwargs,
        python: python(e, base),
        isolate: e.isolate.as_ref().is_some_and(|i| *i.get_ref()),
        precision: jax.precision,
        matmul_precision: jax.matmul_precision,
        device: jax.device,
        networks_per_call: jax.networks_per_call,
        action_mask: jax.action_mask,
        non_finite,
        device_span: e.device.as_ref().map(|d| d.span()),
        kwargs_span: e.kwargs.as_ref().map(|k| k.span()),
        python_span: e.python.as_ref().map(|p| p.span()),
        id_span: e.id.span(),
        plugin_span: e.plugin.as_ref().map(|p| p.span()),
        config_span: e.config.as_ref().map(|c| c.span()),
    })
}

/// `id`, `config` and `plugin` within rwg's limits; `plugin` a path rwg
/// can load from.
fn check_lengths(at: &Checker, key: &str, e: &RawEnv) -> Result<(), ManifestError> {
    at.short(&e.id, &format!("{key}.id"), limits::MAX_ENV_ID_BYTES)?;
    if let Some(c) = &e.config {
        at.short(c, &format!("{key}.config"), limits::MAX_CONFIG_BYTES)?;
    }
    if let Some(p) = &e.plugin {
        at.short(p, &format!("{key}.plugin"), limits::MAX_PATH_BYTES)?;
        crate::plugin_path::check_value(key, p.get_ref()).map_err(|m| at.err(p.span(), m))?;
    }
    Ok(())
}

/// The id is on no earlier entry (it enters the seeds and the cell names).
fn check_id_unique(
    at: &Checker,
    key: &str,
    e: &RawEnv,
    earlier: &[EnvEntry],
) -> Result<(), ManifestError> {
    let id = e.id.get_ref();
    if !earlier.iter().any(|x| x.id == *id) {
        return Ok(());
    }
    let hint = if rwg_gym::gym_id(id).is_some() {
        " (one entry per id, as the id enters the seeds and the cell names: for \
         another configuration of the env use a registered id of its own, e.g. \
         gymnasium:LunarLanderContinuous-v3 beside gymnasium:LunarLander-v3, or a \
         second manifest)"
    } else {
        ""
    };
    Err(at.err(
        e.id.span(),
        format!("{key}.id: '{id}' is listed twice{hint}"),
    ))
}

/// `solved`: a finite number, if given.
fn solved(at: &Checker, key: &str, e: &RawEnv) -> Result<Option<f64>, ManifestError> {
    match &e.solved {
        None => Ok(None),
        Some(s) if s.get_ref().get().is_finite() => Ok(Some(s.get_ref().get())),
        Some(s) => Err(at.err(s.span(), format!("{key}.solved: must be a finite number"))),
    }
}

/// `max_episode_steps`: 1 to rwg's limit, if given.
fn max_episode_steps(at: &Checker, key: &str, e: &RawEnv) -> Result<Option<u32>, ManifestError> {
    e.max_episode_steps
        .as_ref()
        .map(|m| {
            let max = limits::MAX_EPISODE_STEPS.into();
            let steps = at.count(m, &format!("{key}.max_episode_steps"), 1, max)?;
            Ok(steps as u32)
        })
        .transpose()
}

/// `action_dtype`: float64 (the default) or float32.
fn action_dtype(at: &Checker, key: &str, e: &RawEnv) -> Result<ActionDtype, ManifestError> {
    match &e.action_dtype {
        None => Ok(ActionDtype::F64),
        Some(d) => d
            .get_ref()
            .parse()
            .map_err(|m: String| at.err(d.span(), format!("{key}.action_dtype: {m}"))),
    }
}

/// `non_finite`: stop (the default) or end.
fn non_finite(at: &Checker, key: &str, e: &RawEnv) -> Result<NonFinite, ManifestError> {
    match &e.non_finite {
        None => Ok(NonFinite::Stop),
        Some(d) => d
            .get_ref()
            .parse()
            .map_err(|m: String| at.err(d.span(), format!("{key}.non_finite: {m}"))),
    }
}

/// `kwargs`: a table `gym.make` can receive, if given.
fn kwargs(at: &Checker, key: &str, e: &RawEnv) -> Result<Option<toml::Table>, ManifestError> {
    e.kwargs
        .as_ref()
        .map(|k| {
            k.get_ref()
                .to_table(&format!("{key}.kwargs"))
                .map_err(|l| at.located(l))
        })
        .transpose()
}

/// `plugin`, resolved against `base` if relative.
fn plugin_path(e: &RawEnv, base: &Path) -> Option<PathBuf> {
    e.plugin.as_ref().map(|p| {
        let p = Path::new(p.get_ref());
        if p.is_absolute() {
            p.to_path_buf()
        } else {
            base.join(p)
        }
    })
}

/// `python`: a relative path with a `/` resolved against `base`; a bare
/// name (looked up on PATH) or an absolute path as written.
fn python(e: &RawEnv, base: &Path) -> Option<String> {
    e.python.as_ref().map(|p| {
        let v = p.get_ref();
        if v.contains('/') && !Path::new(v).is_absolute() {
            base.join(v).to_string_lossy().into_owned()
        } else {
            v.clone()
        }
    })
}
