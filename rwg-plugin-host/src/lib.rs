//! # rwg-plugin-host
//!
//! The host side of rwg's environment plugins (the stable C ABI v1 of
//! `rwg-env/include/rwg_plugin.h`; its types and the export macro are in
//! `rwg_env::plugin`).
//!
//! - [`loader`]: the host side: [`load_plugin`], validation, [`PluginEnv`],
//!   and the `RWG_PLUGIN_PATH` search ([`load_plugin_path`]).
//! - [`check`]: the `rwg check` conformance checks as a library.
//!
//! Loading a plugin runs its code in this process; libraries are never
//! unloaded. See the header for the full contract.
//!
//! # Example
//!
//! [`load_plugin`] opens a plugin library (`dlopen`) and runs the
//! handshake; [`loader::load_from_entry`] runs it on an entry function already in
//! this process, as here, with a plugin exported by `rwg_env`:
//!
//! ```
//! use rwg_env::plugin::export::{entry_v1, ExportedPlugin, PluginStatic};
//! use rwg_env::plugin::{abi::RwgPluginEntry, PluginBuilder};
//! use rwg_env::{Action, BoxSpace, EnvError, EnvSpec, Environment, Space, Step};
//! use rwg_plugin_host::loader::load_from_entry;
//! use std::sync::OnceLock;
//!
//! /// An env that stays where it is and pays 1 per step.
//! struct Still(EnvSpec);
//! impl Environment for Still {
//!     fn spec(&self) -> &EnvSpec {
//!         &self.0
//!     }
//!     fn reset(&mut self, _seed: u64, obs: &mut [f64]) -> Result<(), EnvError> {
//!         obs[0] = 0.0;
//!         Ok(())
//!     }
//!     fn step(&mut self, _action: Action<'_>, obs: &mut [f64]) -> Result<Step, EnvError> {
//!         obs[0] = 0.0;
//!         Ok(Step { reward: 1.0, terminated: false, truncated: false })
//!     }
//! }
//! fn spec() -> EnvSpec {
//!     EnvSpec {
//!         id: "doc/Still-v0".into(),
//!         observation_space: Space::Box(BoxSpace::symmetric(&[1.0])),
//!         action_space: Space::Discrete { n: 2 },
//!         max_episode_steps: Some(10),
//!         reward_threshold: None,
//!     }
//! }
//!
//! /// What `export_plugin!` generates in a plugin's `cdylib`.
//! struct Doc;
//! impl PluginStatic for Doc {
//!     fn cell() -> &'static OnceLock<ExportedPlugin> {
//!         static CELL: OnceLock<ExportedPlugin> = OnceLock::new();
//!         &CELL
//!     }
//!     fn build() -> PluginBuilder {
//!         PluginBuilder::new("doc", "0.1.0").env(spec(), "stands still", |_config: &str| {
//!             Ok::<_, String>(Still(spec()))
//!         })
//!     }
//! }
//! unsafe extern "C" fn entry(major: u32, minor: u32) -> *const RwgPluginEntry {
//!     entry_v1::<Doc>(major, minor)
//! }
//!
//! // SAFETY: `entry` is an `rwg_plugin_entry_v1` that keeps the header's
//! // contract (rwg_env's export side).
//! let plugin = unsafe { load_from_entry(std::path::Path::new("<doc>"), entry) }?;
//! assert_eq!(plugin.id(), "doc");
//! let env_type = plugin.env("doc/Still-v0").expect("the plugin's env");
//! let mut env = env_type.create("")?;
//! let mut obs = [9.0];
//! env.reset(0, &mut obs)?;
//! let step = env.step(Action::Discrete(1), &mut obs)?;
//! assert_eq!((obs[0], step.reward), (0.0, 1.0));
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! # Modules
//!
//! - [`loader`]: `search.rs` (`RWG_PLUGIN_PATH`), `handshake.rs` (load and
//!   validate), `instance.rs` ([`PluginEnv`]), `batch.rs` (`PluginBatch`: many
//!   instances through the batched calls; the plugin's results checked over
//!   whole buffers, `batch_scan.rs`, with a lane-by-lane pass only when that
//!   finds something), `vec_env.rs` (`PluginVecEnv`: a plugin's vector env, its
//!   errors naming the lane), `lanes.rs` (either one behind one type),
//!   `clock.rs` (the host's time limit over lanes), `error.rs`.
//! - [`check`]: one function per conformance check (`env_checks.rs`,
//!   `plugin_checks.rs`), `batch_checks.rs` (batched calls and vector env equal
//!   the single calls bit for bit), results in `report.rs`.

pub mod check;
pub mod loader;

pub use check::{
    check_env, check_env_observed, check_plugin, check_plugin_env, check_plugin_env_observed,
    CheckEvent, CheckResult, CheckStatus,
};
pub use loader::{
    find_plugin_files, library_file_name, load_plugin, load_plugin_path, load_plugin_path_from_env,
    load_plugin_path_from_env_reserving, load_plugin_path_reserving, LaneCalls, LaneFailure,
    Plugin, PluginBatch, PluginEnv, PluginEnvType, PluginFiles, PluginInfo, PluginLanes,
    PluginLoadError, PluginLoadErrorKind, PluginScan, PluginVecEnv, Rejected, PLUGIN_PATH_VAR,
};

#[cfg(test)]
mod tests;
