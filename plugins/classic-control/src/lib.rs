//! The reference plugin: every environment in [`rwg_envs::REGISTRY`],
//! exported through the C ABI v1 with no environment code of its own.
//!
//! Ids are namespaced, `classic_control/<built-in id>` (e.g.
//! `classic_control/CartPole-v0`), so the plugin never collides with the
//! built-ins. Instances are the built-in envs without their time limit: the
//! host applies `max_episode_steps` from the descriptor, so a plugin episode
//! reproduces the built-in one bit for bit.
//!
//! Config string: `""` (defaults) or `action_dtype=float32` /
//! `action_dtype=float64`, the dtype of the continuous action array (see
//! [`rwg_env::ActionDtype`]; it matters for Pendulum-v1 and
//! MountainCarContinuous-v0 only).

use rwg_env::plugin::{DynEnv, PluginBuilder};
use rwg_env::ActionDtype;
use rwg_envs::{make, EnvOptions, REGISTRY};

/// The namespace of this plugin's ids.
pub const NAMESPACE: &str = "classic_control";

/// Parses the config string into build options (with no time limit).
fn options(config: &str) -> Result<EnvOptions, String> {
    let mut opts = EnvOptions {
        // The host applies the time limit; u32::MAX means none.
        max_episode_steps: Some(u32::MAX),
        ..EnvOptions::default()
    };
    for item in config.split([',', ' ']).filter(|s| !s.is_empty()) {
        match item.split_once('=') {
            Some(("action_dtype", v)) => opts.action_dtype = v.parse::<ActionDtype>()?,
            _ => {
                return Err(format!(
                    "unknown config item '{item}' (expected action_dtype=float64 or action_dtype=float32)"
                ))
            }
        }
    }
    Ok(opts)
}

/// Describes the plugin: one export per registered built-in environment.
pub fn plugin() -> PluginBuilder {
    let mut b = PluginBuilder::new(NAMESPACE, env!("CARGO_PKG_VERSION"));
    for r in REGISTRY {
        let id = r.id;
        let mut spec = make(id, &EnvOptions::default())
            .unwrap_or_else(|e| panic!("registered env {id} does not build: {e}"))
            .spec()
            .clone();
        spec.id = format!("{NAMESPACE}/{id}");
        b = b.env_boxed(
            spec,
            r.summary,
            move |config: &str| -> Result<DynEnv, String> {
                let opts = options(config)?;
                make(id, &opts).map_err(|e| e.to_string())
            },
        );
    }
    b
}

rwg_env::export_plugin!(plugin());
