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
