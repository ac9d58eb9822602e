//! The plugin side of the stable C ABI v1 (`include/rwg_plugin.h`).
//!
//! - [`abi`]: `#[repr(C)]` mirrors of the header's structs and constants.
//! - [`export`]: exporting Rust [`Environment`](crate::Environment)s as a
//!   plugin ([`export_plugin!`](crate::export_plugin), [`PluginBuilder`]).
//!
//! The host side (loading, validating and checking plugins) is the
//! `rwg-plugin-host` crate.

pub mod abi;
pub mod export;

pub use export::{DynEnv, PluginBuilder};
