//! The command-line options of `gymnasium:` envs (`--kwargs`, `--python`),
//! shared by `rwg envs`, `rollout` and `check`; `rwg envs` gives them to
//! JAX envs (`gymnax:`, `brax:`, `playground:`, ..., `jax:`) too.

use rwg_gym::GymConfig;

/// Whether `id` names a Gymnasium env (`gymnasium:...`).
pub fn is_gym(id: &str) -> bool {
    rwg_gym::gym_id(id).is_some()
}

/// An error for `command` (which steps an env a call at a time) given a
/// JAX env id, saying what works for one instead.
pub fn refuse_jax(id: &str, command: &str) -> anyhow::Result<()> {
    if rwg_jax::jax_id(id).is_some() {
        anyhow::bail!(
            "'{id}' is a JAX env, which runs whole episodes in compiled calls: {command} \
             steps an env one call at a time and cannot run it; describe it with \
             `rwg envs {id}`, run it in a study (`rwg run`), and replay a network's episodes \
             with `rwg replay`"
        );
    }
    Ok(())
}

/// The command-line options of a `gymnasium:` env.
#[derive(clap::Args, Debug, Clone, Default)]
pub struct GymArgs {
    /// gym.make keyword arguments of a gymnasium: env, as a JSON object
    /// (e.g. '{"continuous": true}').
    #[arg(long, value_name = "JSON")]
    pub kwargs: Option<String>,
    /// Python interpreter for gymnasium: envs (default: RWG_PYTHON, then python3).
    #[arg(long, value_name = "PATH")]
    pub python: Option<String>,
}

impl GymArgs {
    /// The config of `id` (a `gymnasium:` id) with these options.
    pub fn config(&self, id: &str) -> anyhow::Result<GymConfig> {
        config_from_args(id, self.kwargs.as_deref(), self.python.as_deref())
    }

    /// The config of `id` (a JAX id: `gymnax:`, `playground:`, ...) with these
    /// options (the kwargs are the env's: see the manifest's `kwargs`).
    pub fn jax_config(&self, id: &str) -> anyhow::Result<rwg_jax::JaxConfig> {
        let (kind, rest) =
            rwg_jax::jax_id(id).ok_or_else(|| anyhow::anyhow!("{id} is not a JAX env id"))?;
        let mut cfg = rwg_jax::JaxConfig::new(kind, rest);
        if let Some(k) = &self.kwargs {
            cfg.kwargs = kwargs_json(k)?;
        }
        if let Some(p) = &self.python {
            cfg.python = p.clone();
        }
        Ok(cfg)
    }

    /// An error if options were given for an env that is not a Gymnasium one.
    pub fn refuse_for(&self, id: &str) -> anyhow::Result<()> {
        if self.kwargs.is_some() || self.python.is_some() {
            anyhow::bail!(
                "--kwargs and --python apply to Gymnasium environments only (write gymnasium:{id})"
            );
        }
        Ok(())
    }
}

/// The config of a command-line id (`gymnasium:...`) with `--kwargs` JSON and
/// an optional interpreter.
pub fn config_from_args(
    id: &str,
    kwargs: Option<&str>,
    python: Option<&str>,
) -> anyhow::Result<GymConfig> {
    let gid = rwg_gym::gym_id(id).ok_or_else(|| anyhow::anyhow!("{id} is not a gymnasium: id"))?;
    let mut cfg = GymConfig::new(gid);
    if let Some(k) = kwargs {
        cfg.kwargs = kwargs_json(k)?;
    }
    if let Some(p) = python {
        cfg.python = p.to_string();
    }
    Ok(cfg)
}

/// `--kwargs` JSON as the workers read it (nan/inf escaped).
fn kwargs_json(k: &str) -> anyhow::Result<serde_json::Map<String, serde_json::Value>> {
    let v: serde_json::Value = serde_json::from_str(k)
        .map_err(|e| anyhow::anyhow!("--kwargs: not a JSON object ({e}): {k}"))?;
    match v {
        serde_json::Value::Object(m) => Ok(m
            .into_iter()
            .map(|(k, v)| (k, rwg_gym::kwargs::escape(v)))
            .collect()),
        _ => anyhow::bail!("--kwargs: expected a JSON object such as '{{\"continuous\": true}}'"),
    }
}
