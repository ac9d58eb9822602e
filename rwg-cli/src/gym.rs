//! The command-line options of `gymnasium:` envs (`--kwargs`, `--python`),
//! shared by `rwg envs`, `rollout` and `check`.

use rwg_gym::GymConfig;

/// Whether `id` names a Gymnasium env (`gymnasium:...`).
pub fn is_gym(id: &str) -> bool {
    rwg_gym::gym_id(id).is_some()
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
        let v: serde_json::Value = serde_json::from_str(k)
            .map_err(|e| anyhow::anyhow!("--kwargs: not a JSON object ({e}): {k}"))?;
        match v {
            serde_json::Value::Object(m) => {
                cfg.kwargs = m
                    .into_iter()
                    .map(|(k, v)| (k, rwg_gym::kwargs::escape(v)))
                    .collect()
            }
            _ => {
                anyhow::bail!("--kwargs: expected a JSON object such as '{{\"continuous\": true}}'")
            }
        }
    }
    if let Some(p) = python {
        cfg.python = p.to_string();
    }
    Ok(cfg)
}
