//! The command-line options of `gymnasium:` envs (`--kwargs`, `--python`),
//! shared by `rwg envs`, `rollout` and `check`.

use rwg_gym::GymConfig;

/// Whether `id` names a Gymnasium env (`gymnasium:...`).
pub fn is_gym(id: &str) -> bool {
    rwg_gym::gym_id(id).is_some()
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
            serde_json::Value::Object(m) => cfg.kwargs = m,
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
