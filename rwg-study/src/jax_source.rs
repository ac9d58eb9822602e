//! JAX environments (`gymnax:ID`, `brax:NAME`, `playground:NAME`, ...,
//! `jax:module:callable`: [`rwg_jax::FAMILIES`]) in a manifest: an
//! `[[envs]]` entry turned into a [`JaxConfig`] (its `kwargs`, `python`,
//! time limit, `precision`, `device`, `networks_per_call`, `action_mask`), and
//! the workers' start-up errors located at the manifest line that explains
//! them. The keys themselves are checked where the manifest is parsed.

use crate::manifest::{EnvEntry, Manifest, ManifestError};
use rwg_jax::{JaxConfig, JaxError, JaxKind, JaxSource};

/// Whether `id` names a JAX env (of one of [`rwg_jax::FAMILIES`]).
pub fn is_jax(id: &str) -> bool {
    rwg_jax::jax_id(id).is_some()
}

/// The config of manifest entry `e` (a JAX env's).
pub fn config_of(e: &EnvEntry) -> JaxConfig {
    let (kind, id) = rwg_jax::jax_id(&e.id).expect("a JAX id");
    let mut cfg = JaxConfig::new(kind, id);
    if let Some(p) = &e.python {
        cfg.python = p.clone();
    }
    if let Some(k) = &e.kwargs {
        cfg.kwargs = crate::manifest::kwargs::to_json(k);
    }
    cfg.max_episode_steps = e.max_episode_steps;
    cfg.precision = e.precision.unwrap_or_default();
    cfg.device = e.device.clone();
    cfg.networks_per_call = e.networks_per_call;
    cfg.action_mask = e.action_mask.unwrap_or(true);
    cfg
}

/// Opens env `i` of the manifest (one worker: the env made, its spaces and
/// the device checked), or an error pointing at the manifest line that
/// explains it.
pub fn open_entry(m: &Manifest, i: usize) -> Result<JaxSource, ManifestError> {
    let e = &m.envs[i];
    let cfg = config_of(e);
    JaxSource::open(cfg).map_err(|err| {
        let at = match &err {
            JaxError::NoPython { .. } => e.python_span.clone(),
            JaxError::Worker { error, .. } => match error.kind.as_str() {
                "python" => e.python_span.clone(),
                // jax or the family's library missing: the interpreter's fault;
                // a module of the user's: the id names it
                "import" if !matches!(rwg_jax::jax_id(&e.id), Some((JaxKind::Custom, _))) => {
                    e.python_span.clone()
                }
                "make" => e.kwargs_span.clone(),
                // an env whose files are missing (the message says which)
                "assets" => None,
                "device" => e.device_span.clone(),
                _ => None,
            },
            _ => None,
        }
        .unwrap_or(e.id_span.clone());
        m.error_at(at, format!("envs[{i}]: {}: {err}", e.id))
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use rwg_jax::Precision;
    use std::path::Path;

    #[test]
    fn an_entry_becomes_the_config_of_its_env() {
        let text = "samples = 1\nepisodes = 1\n[[architectures]]\nname = \"0HL\"\nhidden = []\n\
                    [[envs]]\nid = \"jax:my_pkg.envs:make_env\"\npython = \"/usr/bin/python3\"\n\
                    kwargs = { size = 3 }\nmax_episode_steps = 70\nprecision = \"float64\"\n\
                    device = \"gpu:1\"\nnetworks_per_call = 64\naction_mask = false\n";
        let m = Manifest::parse(text, "m.toml", Path::new("/base")).unwrap();
        let cfg = config_of(&m.envs[0]);
        assert_eq!(cfg.kind, JaxKind::Custom);
        assert_eq!(cfg.id, "my_pkg.envs:make_env");
        assert_eq!(cfg.python, "/usr/bin/python3");
        assert_eq!(cfg.kwargs.get("size"), Some(&serde_json::json!(3)));
        assert_eq!(cfg.max_episode_steps, Some(70));
        assert_eq!(cfg.precision, Precision::F64);
        assert_eq!(cfg.device.as_deref(), Some("gpu:1"));
        assert_eq!(cfg.networks_per_call, Some(64));
        assert!(!cfg.action_mask);
        assert!(
            m.to_toml().contains("action_mask = false"),
            "{}",
            m.to_toml()
        );
        let dflt = Manifest::parse(
            &text.replace("action_mask = false\n", ""),
            "m.toml",
            Path::new("/b"),
        )
        .unwrap();
        assert!(config_of(&dflt.envs[0]).action_mask);
        assert!(
            !dflt.to_toml().contains("action_mask"),
            "{}",
            dflt.to_toml()
        );
        assert!(is_jax("gymnax:CartPole-v1") && is_jax("brax:ant"));
        assert!(!is_jax("gymnasium:CartPole-v1") && !is_jax("CartPole-v1"));
    }
}
