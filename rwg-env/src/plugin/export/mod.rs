//! Exporting Rust [`Environment`](crate::Environment)s as a plugin through the C ABI.
//!
//! A plugin crate (`crate-type = ["cdylib"]`, built with `panic = "unwind"`)
//! describes its environments with a [`PluginBuilder`] and hands the builder
//! to [`export_plugin!`](crate::export_plugin), which defines the exported
//! `rwg_plugin_entry_v1`:
//!
//! ```ignore
//! rwg_env::export_plugin!(
//!     rwg_env::plugin::PluginBuilder::new("example", env!("CARGO_PKG_VERSION"))
//!         .env(PointMass::spec(), "move a point mass to a target", |config: &str| {
//!             PointMass::from_config(config)
//!         })
//! );
//! ```
//!
//! Every exported function catches panics (`catch_unwind`): a panic becomes
//! `RWG_ERR_PANIC` with the panic message in `last_error`, and poisons the
//! instance, so a buggy environment never aborts the host. Actions are checked
//! against the action space before the environment sees them (a discrete
//! action must be an integral double in `0..n`, a continuous one finite and of
//! the right length).
//!
//! The files: `builder` ([`PluginBuilder`] and the C tables it becomes),
//! `trampolines` (the `extern "C"` functions the host calls, which check
//! their arguments, catch panics and forward to the Rust environments),
//! `step` (the step trampoline: a fast path for well-formed calls on healthy
//! instances, a checked path that reports any other call), `batched` (ABI 1.1's `reset_many` / `step_many`, every exported env has
//! them: a loop over the single calls' trampolines) and `vec_env` (ABI 1.2's
//! vector env over a [`ManyEnv`](crate::many::ManyEnv), for envs given one
//! with [`PluginBuilder::vec_env`]).

mod batched;
mod builder;
mod step;
mod trampolines;
mod vec_env;

pub use builder::{DynEnv, ExportedPlugin, PluginBuilder, PluginStatic};
pub use trampolines::{entry_v1, status_of};

/// Defines `rwg_plugin_entry_v1`, exporting the plugin described by a
/// [`PluginBuilder`] expression (evaluated once, on the first entry call).
///
/// Use it once, at the top level of a `cdylib` crate built with
/// `panic = "unwind"` (the default; the macro refuses `panic = "abort"`,
/// where a panic could not be caught).
#[macro_export]
macro_rules! export_plugin {
    ($builder:expr $(,)?) => {
        #[cfg(panic = "abort")]
        compile_error!("rwg plugins must be built with panic = \"unwind\" so panics can be caught");

        const _: () = {
            struct RwgExportedPlugin;
            static RWG_EXPORTED_PLUGIN: ::std::sync::OnceLock<
                $crate::plugin::export::ExportedPlugin,
            > = ::std::sync::OnceLock::new();
            impl $crate::plugin::export::PluginStatic for RwgExportedPlugin {
                fn cell() -> &'static ::std::sync::OnceLock<$crate::plugin::export::ExportedPlugin>
                {
                    &RWG_EXPORTED_PLUGIN
                }
                fn build() -> $crate::plugin::export::PluginBuilder {
                    $builder
                }
            }

            /// The rwg plugin entry point (ABI v1).
            #[no_mangle]
            pub extern "C" fn rwg_plugin_entry_v1(
                host_abi_major: u32,
                host_abi_minor: u32,
            ) -> *const $crate::plugin::abi::RwgPluginEntry {
                $crate::plugin::export::entry_v1::<RwgExportedPlugin>(
                    host_abi_major,
                    host_abi_minor,
                )
            }
        };
    };
}
