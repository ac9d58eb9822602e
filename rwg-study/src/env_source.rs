//! Where environments come from: built in (`rwg-envs`, statically
//! dispatched) or a plugin library (an explicit file, or the
//! `RWG_PLUGIN_PATH` scan, which never shadows a built-in id), or a Gymnasium
//! env (`gymnasium:ID`, run by `rwg-gym`'s Python workers), or a JAX env
//! (`gymnax:ID`, `brax:NAME`, `jax:module:callable`, run by `rwg-jax`'s
//! Python workers, one compiled call per chunk of networks). A new kind of
//! environment source is a new [`EnvSource`] variant here.

use rwg_env::{EnvError, TimeLimit};
use rwg_envs::EnvOptions;
use rwg_plugin_host::{
    load_plugin, load_plugin_path_from_env_reserving, Plugin, PluginEnv, PluginEnvType,
    PluginLoadError, PluginScan, PLUGIN_PATH_VAR,
};
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// Where a cell's environment comes from.
#[derive(Debug, Clone)]
pub enum EnvSource {
    /// Built in: statically dispatched through [`rwg_envs::visit`].
    Builtin(EnvOptions),
    /// From a plugin library (given with `plugin =` or found on `RWG_PLUGIN_PATH`).
    Plugin(Box<PluginSource>),
    /// A Gymnasium env run by Python worker processes (`gymnasium:ID`); its
    /// workers are shared by the env's cells.
    Gym(std::sync::Arc<rwg_gym::GymSource>),
    /// A JAX env run by Python worker processes (`gymnax:`, `brax:`,
    /// `jax:`); its workers are shared by the env's cells.
    Jax(std::sync::Arc<rwg_jax::JaxSource>),
}

/// A plugin environment as a cell builds it.
#[derive(Debug, Clone)]
pub struct PluginSource {
    /// The environment type (its plugin, spec and constructor).
    pub ty: PluginEnvType,
    /// The manifest's `config` (`""` if not given).
    pub config: String,
    /// The manifest's time limit override.
    pub max_episode_steps: Option<u32>,
    /// Set when the env runs isolated (`isolate`): its worker processes,
    /// which `rwg run` steps instead of in-process instances.
    pub isolated: Option<std::sync::Arc<crate::isolate::IsolatedPlugin>>,
}

impl PluginSource {
    /// A new instance with the cell's config and time limit.
    pub fn make(&self) -> Result<TimeLimit<PluginEnv>, EnvError> {
        self.ty.make(&self.config, self.max_episode_steps)
    }

    /// The plugin library file.
    pub fn path(&self) -> &Path {
        &self.ty.plugin().path
    }
}

/// Whether `id` is a built-in environment.
pub fn is_builtin(id: &str) -> bool {
    rwg_envs::registry::registration(id).is_some()
}

/// Loads every plugin on `RWG_PLUGIN_PATH`. Files that fail to load, repeat
/// an id of an earlier file, or export a built-in id are rejected with the
/// reason. Runs the plugins' code in this process.
pub fn scan_plugin_path() -> PluginScan {
    load_plugin_path_from_env_reserving(&is_builtin)
}

/// Plugins loaded so far by one command: explicit files (each loaded once)
/// and, when first needed, the `RWG_PLUGIN_PATH` scan.
#[derive(Default)]
pub struct Plugins {
    files: HashMap<PathBuf, Result<Plugin, PluginLoadError>>,
    scan: Option<PluginScan>,
}

/// Where an env id was found.
pub enum Found {
    /// A built-in environment.
    Builtin,
    /// An environment of a plugin on `RWG_PLUGIN_PATH`.
    OnPath(Box<PluginEnvType>),
    /// Nowhere: the message says what was searched.
    Unknown(String),
}

impl Plugins {
    /// The plugin in file `path`, loaded on first use.
    pub fn file(&mut self, path: &Path) -> Result<&Plugin, &PluginLoadError> {
        self.files
            .entry(path.to_path_buf())
            .or_insert_with(|| load_plugin(path))
            .as_ref()
    }

    /// The `RWG_PLUGIN_PATH` scan, done on first use.
    pub fn scan(&mut self) -> &PluginScan {
        self.scan.get_or_insert_with(scan_plugin_path)
    }

    /// Finds an env id given without a plugin file: built in, else on
    /// `RWG_PLUGIN_PATH` (scanned only then).
    pub fn find(&mut self, id: &str) -> Found {
        if is_builtin(id) {
            return Found::Builtin;
        }
        let scan = self.scan();
        if let Some(ty) = scan.plugins.iter().find_map(|p| p.env(id)) {
            return Found::OnPath(Box::new(ty.clone()));
        }
        let builtin: Vec<&str> = rwg_envs::registry::known_ids().collect();
        let on_path: Vec<&str> = scan
            .plugins
            .iter()
            .flat_map(|p| p.envs().iter().map(|e| e.id()))
            .collect();
        let suggestion = rwg_env::suggest::nearest(id, builtin.iter().chain(&on_path).copied())
            .map(|s| format!(" (did you mean '{s}'?)"))
            .unwrap_or_default();
        let mut msg = format!(
            "unknown environment '{id}'{suggestion}; known environments: {}",
            builtin.join(", ")
        );
        match std::env::var_os(PLUGIN_PATH_VAR) {
            None => msg.push_str(&format!(
                "; for a plugin environment, give its library with `plugin = \"path\"` \
                 or list its folder in {PLUGIN_PATH_VAR}"
            )),
            Some(_) if on_path.is_empty() => {
                msg.push_str(&format!("; no plugin environments on {PLUGIN_PATH_VAR}"))
            }
            Some(_) => msg.push_str(&format!("; on {PLUGIN_PATH_VAR}: {}", on_path.join(", "))),
        }
        if !scan.rejected.is_empty() {
            let why: Vec<String> = scan.rejected.iter().map(|r| r.to_string()).collect();
            msg.push_str(&format!(
                "; rejected on {PLUGIN_PATH_VAR}: {}",
                why.join("; ")
            ));
        }
        Found::Unknown(msg)
    }
}

/// "plugin 'id' (file)": how messages name a plugin.
pub fn describe(ty: &PluginEnvType) -> String {
    format!(
        "plugin '{}' ({})",
        ty.plugin().id,
        ty.plugin().path.display()
    )
}
