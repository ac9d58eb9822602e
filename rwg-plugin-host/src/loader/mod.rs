//! Loading plugins: the search of `RWG_PLUGIN_PATH` (`search`), the
//! handshake and validation of a library (`handshake`), [`PluginEnv`], the
//! host-side `Environment` over a plugin's C function table (`instance`),
//! [`PluginBatch`], many instances reset and stepped by ABI 1.1's batched
//! calls (`batch`), and why a file is refused (`error`).
//!
//! **Loading a plugin runs its code in this process** (the library's
//! initialisers, its entry function, `init`, and later every env call). A
//! plugin that breaks the ABI contract can crash the process or worse; only
//! load plugins you trust, and use `rwg check` (which runs a plugin in a child
//! process) on new ones. Libraries are never unloaded: unloading a Rust cdylib
//! runs thread-local destructors after `dlclose` and crashes, so every loaded
//! `Library` is leaked for the life of the process.

mod batch;
mod batch_scan;
mod clock;
mod error;
mod handshake;
mod instance;
mod lanes;
mod search;
mod std_fds;
mod vec_env;

pub use std_fds::refill as refill_std_fds;

use std::path::{Path, PathBuf};
use std::sync::Arc;

use rwg_env::env::EnvSpec;
use rwg_env::plugin::abi::*;

pub use batch::{LaneFailure, PluginBatch};
pub use error::{PluginLoadError, PluginLoadErrorKind};
pub use handshake::{check_env_id, load_from_entry, load_plugin};
pub use instance::PluginEnv;
pub use lanes::{LaneCalls, PluginLanes};
pub use search::{
    find_plugin_files, library_file_name, load_plugin_path, load_plugin_path_from_env,
    load_plugin_path_from_env_reserving, load_plugin_path_reserving, PluginFiles, PluginScan,
    Rejected,
};
pub use vec_env::PluginVecEnv;

/// The environment variable listing plugin directories (`:`-separated on
/// Unix, `;` on Windows, like `PATH`).
pub const PLUGIN_PATH_VAR: &str = "RWG_PLUGIN_PATH";

/// The largest Box dimension the host accepts from a descriptor.
pub const MAX_BOX_DIM: u64 = 1 << 20;
/// The largest number of environments one plugin may export.
pub const MAX_ENVS: u32 = 1 << 16;

pub(crate) const ERR_BUF_LEN: usize = 1024;

/// Facts about a loaded plugin file.
#[derive(Debug, Clone, PartialEq)]
pub struct PluginInfo {
    /// The library file it was loaded from.
    pub path: PathBuf,
    /// The plugin's id (`plugin_id`).
    pub id: String,
    /// The plugin's version text.
    pub version: String,
    /// The ABI version the plugin was built with.
    pub abi: (u32, u32),
}

#[derive(Debug, Clone, Copy)]
pub(crate) struct VTable {
    pub(crate) create: CreateFn,
    pub(crate) destroy: DestroyFn,
    pub(crate) reset: ResetFn,
    pub(crate) step: StepFn,
    pub(crate) last_error: LastErrorFn,
    /// ABI 1.1's batched calls (both or neither).
    pub(crate) reset_many: Option<ResetManyFn>,
    pub(crate) step_many: Option<StepManyFn>,
    /// ABI 1.2's vector env (all five functions or none).
    pub(crate) vec: Option<VecVTable>,
}

/// ABI 1.2's vector-env functions of an environment.
#[derive(Debug, Clone, Copy)]
pub(crate) struct VecVTable {
    pub(crate) create: VecCreateFn,
    pub(crate) destroy: VecDestroyFn,
    pub(crate) reset: VecResetFn,
    pub(crate) step: VecStepFn,
    pub(crate) last_error: VecLastErrorFn,
}

/// One environment a plugin exports: its spec and how to create instances.
/// Cheap to clone, `Send + Sync`; creating instances is thread-safe.
#[derive(Debug, Clone)]
pub struct PluginEnvType {
    pub(crate) info: Arc<PluginInfo>,
    pub(crate) index: u32,
    pub(crate) spec: EnvSpec,
    pub(crate) summary: String,
    pub(crate) vt: VTable,
}

/// A loaded plugin: its facts and its environments.
#[derive(Debug, Clone)]
pub struct Plugin {
    pub(crate) info: Arc<PluginInfo>,
    pub(crate) envs: Vec<PluginEnvType>,
}

impl Plugin {
    /// Facts about the plugin file.
    pub fn info(&self) -> &PluginInfo {
        &self.info
    }

    /// The library file.
    pub fn path(&self) -> &Path {
        &self.info.path
    }

    /// The plugin's id.
    pub fn id(&self) -> &str {
        &self.info.id
    }

    /// The environments, in the plugin's order.
    pub fn envs(&self) -> &[PluginEnvType] {
        &self.envs
    }

    /// The environment with this id.
    pub fn env(&self, id: &str) -> Option<&PluginEnvType> {
        self.envs.iter().find(|e| e.spec.id == id)
    }
}
