//! Why a plugin file was refused: [`PluginLoadError`].

use std::path::PathBuf;

use thiserror::Error;

use super::MAX_ENVS;
use rwg_env::plugin::abi::{status_name, Status};

/// Why a plugin file was refused.
#[derive(Debug, Clone, Error, PartialEq)]
#[error("plugin {}: {kind}", path.display())]
pub struct PluginLoadError {
    /// The library file.
    pub path: PathBuf,
    /// What was wrong.
    pub kind: PluginLoadErrorKind,
}

/// What was wrong with a plugin file.
#[derive(Debug, Clone, Error, PartialEq)]
#[non_exhaustive]
pub enum PluginLoadErrorKind {
    /// The dynamic loader could not open the file.
    #[error("cannot open the library: {0}")]
    Open(String),
    /// The library does not export the entry symbol.
    #[error("not an rwg plugin: it does not export `rwg_plugin_entry_v1`")]
    NoEntrySymbol,
    /// The entry function returned NULL.
    #[error(
        "rwg_plugin_entry_v1 returned NULL: the plugin cannot serve a host of ABI \
         {host_major}.{host_minor} (or failed to initialise)"
    )]
    Declined {
        /// The host's ABI major.
        host_major: u32,
        /// The host's ABI minor.
        host_minor: u32,
    },
    /// The plugin was built for another ABI major.
    #[error(
        "ABI version mismatch: the plugin was built for ABI {plugin_major}.{plugin_minor}, \
         this rwg speaks ABI {host_major}.{host_minor} (majors must match)"
    )]
    AbiMajor {
        /// The plugin's major.
        plugin_major: u32,
        /// The plugin's minor.
        plugin_minor: u32,
        /// The host's major.
        host_major: u32,
        /// The host's minor.
        host_minor: u32,
    },
    /// A growable struct is smaller than ABI 1.0's.
    #[error("{what} is too small: struct_size is {size}, ABI 1.0 needs at least {needed} bytes")]
    StructTooSmall {
        /// The C struct's name.
        what: String,
        /// The `struct_size` found.
        size: u32,
        /// The size needed.
        needed: u32,
    },
    /// `abi_tag` is not `"rwg-env-plugin"`.
    #[error("wrong abi_tag {found:?} (expected \"rwg-env-plugin\")")]
    AbiTag {
        /// What was found (lossy UTF-8; `"NULL"` for a null pointer).
        found: String,
    },
    /// A required pointer is NULL.
    #[error("{0} is NULL")]
    Null(&'static str),
    /// A string is not acceptable.
    #[error("{what}: {reason}")]
    BadString {
        /// Which string.
        what: &'static str,
        /// Why.
        reason: String,
    },
    /// `init` failed.
    #[error("init failed with {} ({status}): {message}", status_name(*status))]
    InitFailed {
        /// The status `init` returned.
        status: Status,
        /// The message it wrote.
        message: String,
    },
    /// `env_count()` is 0 or absurd.
    #[error("env_count() returned {0} (must be 1..={MAX_ENVS})")]
    EnvCount(u32),
    /// An environment's descriptor or table is not acceptable.
    #[error("environment #{index}{}: {reason}", id.as_ref().map(|i| format!(" '{i}'")).unwrap_or_default())]
    Env {
        /// Its index.
        index: u32,
        /// Its id, if it could be read.
        id: Option<String>,
        /// Why.
        reason: String,
    },
    /// Two environments of the plugin have the same id.
    #[error("duplicate environment id '{id}' (environments #{first} and #{second})")]
    DuplicateId {
        /// The id.
        id: String,
        /// The first index.
        first: u32,
        /// The second index.
        second: u32,
    },
    /// An id is already provided by another plugin file (see [`load_plugin_path`](crate::load_plugin_path)).
    #[error("environment id '{id}' is already provided by {}", other.display())]
    IdTaken {
        /// The id.
        id: String,
        /// The file that provides it.
        other: PathBuf,
    },
    /// An id belongs to the host (a built-in environment; see
    /// [`load_plugin_path_reserving`](crate::load_plugin_path_reserving)).
    #[error("environment id '{id}' is built into rwg (plugin ids must differ from built-in ones)")]
    IdReserved {
        /// The id.
        id: String,
    },
}
