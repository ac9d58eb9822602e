//! Finding plugins: the `RWG_PLUGIN_PATH` search and loading everything on
//! it, with every refused file and its reason.

use std::ffi::OsStr;
use std::path::PathBuf;

use super::error::PluginLoadErrorKind;
use super::handshake::load_plugin;
use super::{Plugin, PLUGIN_PATH_VAR};

/// `lib{name}.so` on Linux, `lib{name}.dylib` on macOS, `{name}.dll` on
/// Windows. A cdylib crate `my-plugin` builds `library_file_name("my_plugin")`.
pub fn library_file_name(name: &str) -> String {
    format!(
        "{}{name}{}",
        std::env::consts::DLL_PREFIX,
        std::env::consts::DLL_SUFFIX
    )
}

/// A file or directory that [`find_plugin_files`] or [`load_plugin_path`]
/// refused, with the reason.
#[derive(Debug, Clone, PartialEq)]
pub struct Rejected {
    /// The file or directory.
    pub path: PathBuf,
    /// Why it was refused.
    pub reason: String,
}

impl std::fmt::Display for Rejected {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}: {}", self.path.display(), self.reason)
    }
}

/// The plugin files found on a search path.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PluginFiles {
    /// Candidate libraries (files with the platform's shared-library
    /// extension, `.so` / `.dylib` / `.dll`), in path order, then by name.
    pub files: Vec<PathBuf>,
    /// Directories that could not be read.
    pub rejected: Vec<Rejected>,
}

/// Lists the candidate plugin files in the directories of `search_path`
/// (`RWG_PLUGIN_PATH` syntax: separated like `PATH`; empty entries skipped).
/// Does not load anything. A file reached twice (through two directories or a
/// symlink) is listed once.
pub fn find_plugin_files(search_path: &OsStr) -> PluginFiles {
    let mut out = PluginFiles::default();
    let mut seen = std::collections::HashSet::new();
    for dir in std::env::split_paths(search_path) {
        if dir.as_os_str().is_empty() {
            continue;
        }
        let entries = match std::fs::read_dir(&dir) {
            Ok(e) => e,
            Err(e) => {
                out.rejected.push(Rejected {
                    path: dir,
                    reason: format!("cannot read the plugin directory: {e}"),
                });
                continue;
            }
        };
        let mut files: Vec<PathBuf> = entries
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| {
                p.extension() == Some(OsStr::new(std::env::consts::DLL_EXTENSION)) && p.is_file()
            })
            .collect();
        files.sort();
        for f in files {
            let key = std::fs::canonicalize(&f).unwrap_or_else(|_| f.clone());
            if seen.insert(key) {
                out.files.push(f);
            }
        }
    }
    out
}

/// What [`load_plugin_path`] found.
#[derive(Debug, Clone, Default)]
pub struct PluginScan {
    /// The plugins that loaded and validated.
    pub plugins: Vec<Plugin>,
    /// Every file or directory refused, with its reason.
    pub rejected: Vec<Rejected>,
}

/// Loads every candidate plugin on `search_path` (see [`find_plugin_files`]).
/// A file that fails to load, or that exports an env id an earlier file
/// already provides, is rejected as a whole, with its reason; nothing is
/// silently skipped. Loading runs the plugins' code (see the module docs).
pub fn load_plugin_path(search_path: &OsStr) -> PluginScan {
    load_plugin_path_reserving(search_path, &|_| false)
}

/// [`load_plugin_path`], also rejecting every file that exports an id for
/// which `reserved` is true (the host's built-in environments: a plugin on
/// the search path never shadows them).
pub fn load_plugin_path_reserving(
    search_path: &OsStr,
    reserved: &dyn Fn(&str) -> bool,
) -> PluginScan {
    let found = find_plugin_files(search_path);
    let mut scan = PluginScan {
        plugins: Vec::new(),
        rejected: found.rejected,
    };
    for path in found.files {
        match load_plugin(&path) {
            Ok(p) => {
                if let Some(e) = p.envs.iter().find(|e| reserved(e.id())) {
                    scan.rejected.push(Rejected {
                        reason: PluginLoadErrorKind::IdReserved {
                            id: e.id().to_string(),
                        }
                        .to_string(),
                        path,
                    });
                    continue;
                }
                let taken = p.envs.iter().find_map(|e| {
                    scan.plugins
                        .iter()
                        .find(|q| q.env(e.id()).is_some())
                        .map(|q| (e.id().to_string(), q.path().to_path_buf()))
                });
                match taken {
                    Some((id, other)) => scan.rejected.push(Rejected {
                        reason: PluginLoadErrorKind::IdTaken { id, other }.to_string(),
                        path,
                    }),
                    None => scan.plugins.push(p),
                }
            }
            Err(e) => scan.rejected.push(Rejected {
                path,
                reason: e.kind.to_string(),
            }),
        }
    }
    scan
}

/// [`load_plugin_path`] on the `RWG_PLUGIN_PATH` environment variable (an
/// empty scan if it is unset).
pub fn load_plugin_path_from_env() -> PluginScan {
    load_plugin_path_from_env_reserving(&|_| false)
}

/// [`load_plugin_path_reserving`] on the `RWG_PLUGIN_PATH` environment
/// variable (an empty scan if it is unset).
pub fn load_plugin_path_from_env_reserving(reserved: &dyn Fn(&str) -> bool) -> PluginScan {
    match std::env::var_os(PLUGIN_PATH_VAR) {
        Some(p) => load_plugin_path_reserving(&p, reserved),
        None => PluginScan::default(),
    }
}
