//! Loading plugins: handshake, validation, and [`PluginEnv`], the host-side
//! [`Environment`] over a plugin's C function table.
//!
//! **Loading a plugin runs its code in this process** (the library's
//! initialisers, its entry function, `init`, and later every env call). A
//! plugin that breaks the ABI contract can crash the process or worse; only
//! load plugins you trust, and use `rwg check` (which runs a plugin in a child
//! process) on new ones. Libraries are never unloaded: unloading a Rust cdylib
//! runs thread-local destructors after `dlclose` and crashes, so every loaded
//! `Library` is leaked for the life of the process.

use std::ffi::{c_char, CStr, CString, OsStr};
use std::path::{Path, PathBuf};
use std::sync::Arc;

use thiserror::Error;

use rwg_env::env::{Action, EnvError, EnvSpec, Environment, Step};
use rwg_env::plugin::abi::*;
use rwg_env::space::{BoxSpace, Space};
use rwg_env::time_limit::TimeLimit;

/// The environment variable listing plugin directories (`:`-separated on
/// Unix, `;` on Windows, like `PATH`).
pub const PLUGIN_PATH_VAR: &str = "RWG_PLUGIN_PATH";

/// The largest Box dimension the host accepts from a descriptor.
pub const MAX_BOX_DIM: u64 = 1 << 20;
/// The largest number of environments one plugin may export.
pub const MAX_ENVS: u32 = 1 << 16;

const ERR_BUF_LEN: usize = 1024;

/// Why a plugin file was refused.
#[derive(Debug, Clone, Error, PartialEq)]
#[error("plugin {}: {kind}", path.display())]
pub struct LoadError {
    /// The library file.
    pub path: PathBuf,
    /// What was wrong.
    pub kind: LoadErrorKind,
}

/// What was wrong with a plugin file.
#[derive(Debug, Clone, Error, PartialEq)]
pub enum LoadErrorKind {
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
    /// An id is already provided by another plugin file (see [`load_plugin_path`]).
    #[error("environment id '{id}' is already provided by {}", other.display())]
    IdTaken {
        /// The id.
        id: String,
        /// The file that provides it.
        other: PathBuf,
    },
    /// An id belongs to the host (a built-in environment; see
    /// [`load_plugin_path_reserving`]).
    #[error("environment id '{id}' is built into rwg (plugin ids must differ from built-in ones)")]
    IdReserved {
        /// The id.
        id: String,
    },
}

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
struct VTable {
    create: CreateFn,
    destroy: DestroyFn,
    reset: ResetFn,
    step: StepFn,
    last_error: LastErrorFn,
}

/// One environment a plugin exports: its spec and how to create instances.
/// Cheap to clone, `Send + Sync`; creating instances is thread-safe.
#[derive(Debug, Clone)]
pub struct PluginEnvType {
    info: Arc<PluginInfo>,
    index: u32,
    spec: EnvSpec,
    summary: String,
    vt: VTable,
}

/// A loaded plugin: its facts and its environments.
#[derive(Debug, Clone)]
pub struct Plugin {
    info: Arc<PluginInfo>,
    envs: Vec<PluginEnvType>,
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

struct HostTable(RwgHost);
// SAFETY: the pointers are to static, immutable strings.
unsafe impl Sync for HostTable {}

static HOST: HostTable = HostTable(RwgHost {
    struct_size: HOST_SIZE_V1_0,
    abi_major: ABI_MAJOR,
    abi_minor: ABI_MINOR,
    reserved: 0,
    name: c"rwg".as_ptr(),
    version: concat!(env!("CARGO_PKG_VERSION"), "\0").as_ptr() as *const c_char,
});

/// Loads the plugin library at `path`, validates its handshake and
/// descriptors, and returns its environments. The library is never unloaded.
///
/// This runs the plugin's code in this process: see the module docs.
pub fn load_plugin(path: impl AsRef<Path>) -> Result<Plugin, LoadError> {
    let path = path.as_ref();
    let err = |kind| LoadError {
        path: path.to_path_buf(),
        kind,
    };
    // SAFETY: loading a library runs its initialisers; trusting the file is
    // the caller's decision (documented above).
    let lib = unsafe { libloading::Library::new(path) }
        .map_err(|e| err(LoadErrorKind::Open(e.to_string())))?;
    // SAFETY: the symbol is declared with the header's signature.
    let entry = unsafe { lib.get::<EntryFn>(ENTRY_SYMBOL) }.map(|s| *s);
    // Never unload (see the module docs), not even a library we refuse.
    std::mem::forget(lib);
    let entry = entry.map_err(|_| err(LoadErrorKind::NoEntrySymbol))?;
    // SAFETY: `entry` is the plugin's exported entry function.
    unsafe { load_from_entry(path, entry) }
}

/// Runs the handshake with an entry function already in this process and
/// validates what it returns. `origin` names the plugin in errors.
/// [`load_plugin`] uses it after `dlopen`; tests use it on in-process plugins.
///
/// # Safety
/// `entry` must be an `rwg_plugin_entry_v1` function that keeps the header's
/// contract (the host cannot check pointers for validity).
pub unsafe fn load_from_entry(origin: &Path, entry: EntryFn) -> Result<Plugin, LoadError> {
    let err = |kind| LoadError {
        path: origin.to_path_buf(),
        kind,
    };
    let p = entry(ABI_MAJOR, ABI_MINOR);
    if p.is_null() {
        return Err(err(LoadErrorKind::Declined {
            host_major: ABI_MAJOR,
            host_minor: ABI_MINOR,
        }));
    }
    // struct_size, abi_major and abi_minor lead the entry struct of every
    // ABI version; read them before trusting the rest of the layout.
    let head = p.cast::<[u32; 3]>().read();
    let [size, major, minor] = head;
    if major != ABI_MAJOR {
        return Err(err(LoadErrorKind::AbiMajor {
            plugin_major: major,
            plugin_minor: minor,
            host_major: ABI_MAJOR,
            host_minor: ABI_MINOR,
        }));
    }
    if size < ENTRY_SIZE_V1_0 {
        return Err(err(LoadErrorKind::StructTooSmall {
            what: "rwg_plugin_entry_t".into(),
            size,
            needed: ENTRY_SIZE_V1_0,
        }));
    }
    let e = p.read();
    let tag = if e.abi_tag.is_null() {
        "NULL".to_string()
    } else {
        CStr::from_ptr(e.abi_tag).to_string_lossy().into_owned()
    };
    if tag.as_bytes() != ABI_TAG.to_bytes() {
        return Err(err(LoadErrorKind::AbiTag { found: tag }));
    }
    let plugin_id = read_str(e.plugin_id, "plugin_id", false).map_err(err)?;
    if plugin_id.is_empty() {
        return Err(err(LoadErrorKind::BadString {
            what: "plugin_id",
            reason: "empty".into(),
        }));
    }
    let version = read_str(e.plugin_version, "plugin_version", true).map_err(err)?;
    let env_count = e
        .env_count
        .ok_or_else(|| err(LoadErrorKind::Null("env_count")))?;
    let env_desc = e
        .env_desc
        .ok_or_else(|| err(LoadErrorKind::Null("env_desc")))?;
    let env_vtable = e
        .env_vtable
        .ok_or_else(|| err(LoadErrorKind::Null("env_vtable")))?;

    if let Some(init) = e.init {
        let mut buf = [0 as c_char; ERR_BUF_LEN];
        let status = init(&HOST.0, buf.as_mut_ptr(), buf.len());
        if status != RWG_OK {
            return Err(err(LoadErrorKind::InitFailed {
                status,
                message: buf_message(&buf),
            }));
        }
    }

    let info = Arc::new(PluginInfo {
        path: origin.to_path_buf(),
        id: plugin_id,
        version,
        abi: (major, minor),
    });
    let n = env_count();
    if n == 0 || n > MAX_ENVS {
        return Err(err(LoadErrorKind::EnvCount(n)));
    }
    let mut envs: Vec<PluginEnvType> = Vec::with_capacity(n as usize);
    for index in 0..n {
        let env_err = |id: Option<&str>, reason: String| {
            err(LoadErrorKind::Env {
                index,
                id: id.map(str::to_string),
                reason,
            })
        };
        let d = env_desc(index);
        if d.is_null() {
            return Err(env_err(None, "env_desc returned NULL".into()));
        }
        let dsize = d.cast::<u32>().read();
        if dsize < ENV_DESC_SIZE_V1_0 {
            return Err(env_err(
                None,
                format!(
                    "rwg_env_desc_t is too small: struct_size is {dsize}, ABI 1.0 needs at least {ENV_DESC_SIZE_V1_0} bytes"
                ),
            ));
        }
        let d = d.read();
        let id = read_str(d.id, "id", false).map_err(|k| env_err(None, k.to_string()))?;
        check_env_id(&id).map_err(|r| env_err((!id.is_empty()).then_some(id.as_str()), r))?;
        if let Some(first) = envs.iter().find(|t| t.spec.id == id) {
            return Err(err(LoadErrorKind::DuplicateId {
                id,
                first: first.index,
                second: index,
            }));
        }
        let summary =
            read_str(d.summary, "summary", true).map_err(|k| env_err(Some(&id), k.to_string()))?;
        let observation_space = read_space(&d.observation_space)
            .map_err(|r| env_err(Some(&id), format!("observation space: {r}")))?;
        if !matches!(observation_space, Space::Box(_)) {
            return Err(env_err(
                Some(&id),
                "observation space: must be a Box".into(),
            ));
        }
        let action_space = read_space(&d.action_space)
            .map_err(|r| env_err(Some(&id), format!("action space: {r}")))?;
        let reward_threshold = if d.reward_threshold.is_nan() {
            None
        } else if d.reward_threshold.is_infinite() {
            return Err(env_err(
                Some(&id),
                format!(
                    "reward_threshold is {} (use NaN for none)",
                    d.reward_threshold
                ),
            ));
        } else {
            Some(d.reward_threshold)
        };
        let spec = EnvSpec {
            id: id.clone(),
            observation_space,
            action_space,
            max_episode_steps: (d.max_episode_steps != 0).then_some(d.max_episode_steps),
            reward_threshold,
        };
        let vt = env_vtable(index);
        if vt.is_null() {
            return Err(env_err(Some(&id), "env_vtable returned NULL".into()));
        }
        let vsize = vt.cast::<u32>().read();
        if vsize < ENV_VTABLE_SIZE_V1_0 {
            return Err(env_err(
                Some(&id),
                format!(
                    "rwg_env_vtable_t is too small: struct_size is {vsize}, ABI 1.0 needs at least {ENV_VTABLE_SIZE_V1_0} bytes"
                ),
            ));
        }
        let v = vt.read();
        let null = |f: &str| env_err(Some(&id), format!("env_vtable: {f} is NULL"));
        let vt = VTable {
            create: v.create.ok_or_else(|| null("create"))?,
            destroy: v.destroy.ok_or_else(|| null("destroy"))?,
            reset: v.reset.ok_or_else(|| null("reset"))?,
            step: v.step.ok_or_else(|| null("step"))?,
            last_error: v.last_error.ok_or_else(|| null("last_error"))?,
        };
        envs.push(PluginEnvType {
            info: info.clone(),
            index,
            spec,
            summary,
            vt,
        });
    }
    Ok(Plugin { info, envs })
}

/// Reads a plugin string. `nullable`: NULL reads as "".
unsafe fn read_str(
    p: *const c_char,
    what: &'static str,
    nullable: bool,
) -> Result<String, LoadErrorKind> {
    if p.is_null() {
        return if nullable {
            Ok(String::new())
        } else {
            Err(LoadErrorKind::Null(what))
        };
    }
    CStr::from_ptr(p)
        .to_str()
        .map(str::to_string)
        .map_err(|e| LoadErrorKind::BadString {
            what,
            reason: format!("not valid UTF-8 ({e})"),
        })
}

fn buf_message(buf: &[c_char]) -> String {
    let bytes: Vec<u8> = buf
        .iter()
        .take_while(|&&c| c != 0)
        .map(|&c| c as u8)
        .collect();
    String::from_utf8_lossy(&bytes).into_owned()
}

/// Checks a Gymnasium-style id `[namespace/]Name-vN`: non-empty, at most 256
/// bytes, no whitespace or control characters, at most one `/` with text on
/// both sides. (The `-vN` suffix is recommended, not required.)
pub fn check_env_id(id: &str) -> Result<(), String> {
    if id.is_empty() {
        return Err("the id is empty".into());
    }
    if id.len() > 256 {
        return Err(format!("the id is {} bytes long (at most 256)", id.len()));
    }
    if let Some(c) = id.chars().find(|c| c.is_whitespace() || c.is_control()) {
        return Err(format!("the id {id:?} contains the character {c:?}"));
    }
    let parts: Vec<&str> = id.split('/').collect();
    if parts.len() > 2 || parts.iter().any(|p| p.is_empty()) {
        return Err(format!(
            "the id {id:?} is not of the form [namespace/]Name-vN"
        ));
    }
    Ok(())
}

/// Validates and copies a space from a descriptor.
unsafe fn read_space(s: &RwgSpace) -> Result<Space, String> {
    match s.kind {
        RWG_SPACE_DISCRETE => {
            if s.n == 0 || s.n > MAX_DISCRETE_N {
                return Err(format!("Discrete n is {} (must be 1..=2^53)", s.n));
            }
            Ok(Space::Discrete { n: s.n as usize })
        }
        RWG_SPACE_BOX => {
            if s.n == 0 || s.n > MAX_BOX_DIM {
                return Err(format!("Box length is {} (must be 1..={MAX_BOX_DIM})", s.n));
            }
            if s.low.is_null() || s.high.is_null() {
                return Err("Box low or high is NULL".into());
            }
            let n = s.n as usize;
            let low = std::slice::from_raw_parts(s.low, n).to_vec();
            let high = std::slice::from_raw_parts(s.high, n).to_vec();
            for i in 0..n {
                let (lo, hi) = (low[i], high[i]);
                if lo.is_nan() || hi.is_nan() {
                    return Err(format!("Box bound {i} is NaN (low {lo}, high {hi})"));
                }
                if lo > hi {
                    return Err(format!("Box low[{i}] = {lo} > high[{i}] = {hi}"));
                }
            }
            Ok(Space::Box(BoxSpace::new(low, high)))
        }
        k => Err(format!("unknown space kind {k}")),
    }
}

impl PluginEnvType {
    /// The spec from the descriptor (with the plugin's time limit, which
    /// [`PluginEnvType::make`] applies).
    pub fn spec(&self) -> &EnvSpec {
        &self.spec
    }

    /// The environment id.
    pub fn id(&self) -> &str {
        &self.spec.id
    }

    /// The one-line summary.
    pub fn summary(&self) -> &str {
        &self.summary
    }

    /// Facts about the plugin that exports it.
    pub fn plugin(&self) -> &PluginInfo {
        &self.info
    }

    fn prefix(&self) -> String {
        format!("plugin '{}' env '{}'", self.info.id, self.spec.id)
    }

    /// Creates a raw instance (no time limit, and reset-before-step left to
    /// the plugin). `config` is passed to the plugin verbatim.
    pub fn create(&self, config: &str) -> Result<PluginEnv, EnvError> {
        let c = CString::new(config).map_err(|_| {
            EnvError::Other(format!("{}: the config contains a NUL byte", self.prefix()))
        })?;
        let mut buf = [0 as c_char; ERR_BUF_LEN];
        let mut out: *mut RwgEnv = std::ptr::null_mut();
        // SAFETY: the arguments follow the header's contract for create.
        let status = unsafe {
            (self.vt.create)(
                self.index,
                c.as_ptr(),
                &mut out,
                buf.as_mut_ptr(),
                buf.len(),
            )
        };
        if status != RWG_OK {
            return Err(EnvError::Other(format!(
                "{}: create failed with {} ({status}): {}",
                self.prefix(),
                status_name(status),
                buf_message(&buf)
            )));
        }
        if out.is_null() {
            return Err(EnvError::Other(format!(
                "{}: create returned RWG_OK but no instance",
                self.prefix()
            )));
        }
        let discrete = matches!(self.spec.action_space, Space::Discrete { .. });
        Ok(PluginEnv {
            prefix: self.prefix(),
            ty: self.clone(),
            config: config.to_string(),
            handle: out,
            poisoned: false,
            discrete,
            obs_dim: self.spec.obs_dim(),
            step_fn: self.vt.step,
        })
    }

    /// Creates an instance wrapped in [`TimeLimit`] with the descriptor's
    /// `max_episode_steps` (or `max_episode_steps` if given): what rwg runs.
    pub fn make(
        &self,
        config: &str,
        max_episode_steps: Option<u32>,
    ) -> Result<TimeLimit<PluginEnv>, EnvError> {
        Ok(TimeLimit::new(self.create(config)?, max_episode_steps))
    }
}

/// A plugin environment instance, implementing [`Environment`] over the
/// plugin's function table.
///
/// It checks what the plugin returns: a non-`RWG_OK` status becomes an
/// [`EnvError`] carrying the plugin's `last_error` message; non-finite
/// observations or rewards and flags other than 0/1 are errors naming the
/// plugin, the env and the value. After `RWG_ERR_PANIC` the instance is
/// poisoned and no longer called. `PluginEnv` has no time limit: use
/// [`PluginEnvType::make`] for the [`TimeLimit`]-wrapped env.
pub struct PluginEnv {
    ty: PluginEnvType,
    prefix: String,
    config: String,
    handle: *mut RwgEnv,
    poisoned: bool,
    discrete: bool,
    /// `spec.obs_dim()` and the table's `step`, kept at hand for the step loop.
    obs_dim: usize,
    step_fn: StepFn,
}

// SAFETY: the ABI allows an instance to move between threads between calls;
// every call goes through `&mut self`, so one thread at a time uses it.
unsafe impl Send for PluginEnv {}
// SAFETY: `&PluginEnv` gives access to nothing that calls the plugin.
unsafe impl Sync for PluginEnv {}

impl std::fmt::Debug for PluginEnv {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("PluginEnv")
            .field("plugin", &self.ty.info.id)
            .field("env", &self.ty.spec.id)
            .field("config", &self.config)
            .field("poisoned", &self.poisoned)
            .finish()
    }
}

impl Drop for PluginEnv {
    fn drop(&mut self) {
        // SAFETY: the handle came from this table's create and is destroyed once.
        unsafe { (self.ty.vt.destroy)(self.handle) }
    }
}

impl PluginEnv {
    /// The environment type this instance belongs to.
    pub fn env_type(&self) -> &PluginEnvType {
        &self.ty
    }

    /// The config string it was created with.
    pub fn config(&self) -> &str {
        &self.config
    }

    /// Whether the plugin reported a panic on this instance.
    pub fn is_poisoned(&self) -> bool {
        self.poisoned
    }

    /// A new instance of the same type and config (not a copy of the state).
    pub fn try_clone(&self) -> Result<PluginEnv, EnvError> {
        self.ty.create(&self.config)
    }

    fn fail(&mut self, what: &str, status: Status) -> EnvError {
        // SAFETY: valid handle; the string is read before any other call.
        let msg = unsafe {
            let p = (self.ty.vt.last_error)(self.handle);
            if p.is_null() {
                String::new()
            } else {
                CStr::from_ptr(p).to_string_lossy().into_owned()
            }
        };
        let text = format!(
            "{}: {what} failed with {} ({status}){}{msg}",
            self.prefix,
            status_name(status),
            if msg.is_empty() { "" } else { ": " }
        );
        match status {
            RWG_ERR_PANIC => {
                self.poisoned = true;
                EnvError::Other(text)
            }
            RWG_ERR_INVALID_ARGUMENT if what == "step" => EnvError::InvalidAction(text),
            RWG_ERR_RESET_NEEDED => EnvError::ResetNeeded,
            RWG_ERR_UNSUPPORTED => EnvError::Unsupported(text),
            _ => EnvError::Other(text),
        }
    }

    fn check_usable(&self, obs: &[f64]) -> Result<(), EnvError> {
        if self.poisoned {
            return Err(EnvError::Other(format!(
                "{}: the instance is poisoned by an earlier panic in the plugin",
                self.prefix
            )));
        }
        let dim = self.obs_dim;
        if obs.len() != dim {
            return Err(EnvError::Other(format!(
                "{}: obs buffer has length {}, the observation space has {dim}",
                self.prefix,
                obs.len()
            )));
        }
        Ok(())
    }

    fn check_obs(&self, what: &str, obs: &[f64]) -> Result<(), EnvError> {
        match obs.iter().position(|x| !x.is_finite()) {
            None => Ok(()),
            Some(i) => Err(EnvError::Other(format!(
                "{}: {what} returned a non-finite observation: obs[{i}] = {}",
                self.prefix, obs[i]
            ))),
        }
    }

    /// `reset` with the raw `has_seed` flag (rwg's own reset always passes 1).
    pub fn reset_raw(&mut self, has_seed: u8, seed: u64, obs: &mut [f64]) -> Result<(), EnvError> {
        self.check_usable(obs)?;
        obs.fill(f64::NAN);
        // SAFETY: valid handle; obs is a live buffer of obs.len() doubles.
        let status =
            unsafe { (self.ty.vt.reset)(self.handle, has_seed, seed, obs.as_mut_ptr(), obs.len()) };
        if status != RWG_OK {
            return Err(self.fail("reset", status));
        }
        self.check_obs("reset", obs)
    }

    /// `step` with the action as the raw double array that crosses the ABI
    /// (a discrete action is one integral double). Nothing is checked before
    /// the call: `rwg check` uses this to probe the plugin's own checks.
    pub fn step_raw(&mut self, action: &[f64], obs: &mut [f64]) -> Result<Step, EnvError> {
        if self.poisoned || obs.len() != self.obs_dim {
            return Err(self.unusable(obs));
        }
        obs.fill(f64::NAN);
        // Values a plugin cannot leave there by accident unnoticed.
        let mut out = RwgStepOut {
            reward: f64::NAN,
            terminated: 0xff,
            truncated: 0xff,
            reserved: [0; 6],
        };
        // SAFETY: valid handle; the buffers are live for the call.
        let status = unsafe {
            (self.step_fn)(
                self.handle,
                if action.is_empty() {
                    std::ptr::null()
                } else {
                    action.as_ptr()
                },
                action.len(),
                obs.as_mut_ptr(),
                obs.len(),
                &mut out,
            )
        };
        // One test for everything that can be wrong; the message is built
        // out of line, so the step loop stays small.
        if status != RWG_OK
            || (out.terminated | out.truncated) > 1
            || !out.reward.is_finite()
            || !obs.iter().all(|x| x.is_finite())
        {
            return Err(self.step_failure(status, &out, obs));
        }
        Ok(Step {
            reward: out.reward,
            terminated: out.terminated == 1,
            truncated: out.truncated == 1,
        })
    }

    /// The error of a step whose status, flags, reward or observation is bad,
    /// checked in that order.
    #[cold]
    #[inline(never)]
    fn step_failure(&mut self, status: Status, out: &RwgStepOut, obs: &[f64]) -> EnvError {
        if status != RWG_OK {
            return self.fail("step", status);
        }
        for (name, v) in [("terminated", out.terminated), ("truncated", out.truncated)] {
            if v > 1 {
                return EnvError::Other(format!(
                    "{}: step returned {name} = {v} (must be 0 or 1)",
                    self.prefix
                ));
            }
        }
        if !out.reward.is_finite() {
            return EnvError::Other(format!(
                "{}: step returned a non-finite reward: {}",
                self.prefix, out.reward
            ));
        }
        match self.check_obs("step", obs) {
            Err(e) => e,
            Ok(()) => EnvError::Other(format!("{}: step failed", self.prefix)),
        }
    }

    /// The error of [`PluginEnv::check_usable`], out of line.
    #[cold]
    #[inline(never)]
    fn unusable(&self, obs: &[f64]) -> EnvError {
        match self.check_usable(obs) {
            Err(e) => e,
            Ok(()) => EnvError::Other(format!("{}: unusable instance", self.prefix)),
        }
    }
}

impl Environment for PluginEnv {
    fn spec(&self) -> &EnvSpec {
        &self.ty.spec
    }

    fn reset(&mut self, seed: u64, obs: &mut [f64]) -> Result<(), EnvError> {
        self.reset_raw(1, seed, obs)
    }

    fn step(&mut self, action: Action<'_>, obs: &mut [f64]) -> Result<Step, EnvError> {
        match (action, self.discrete) {
            (Action::Discrete(a), true) => {
                // Exactly representable: checked so the plugin sees the same integer.
                if a.unsigned_abs() > MAX_DISCRETE_N {
                    return Err(EnvError::InvalidAction(format!(
                        "{}: discrete action {a} is out of range",
                        self.prefix
                    )));
                }
                self.step_raw(&[a as f64], obs)
            }
            (Action::Continuous(a), false) => self.step_raw(a, obs),
            (Action::Discrete(a), false) => Err(EnvError::InvalidAction(format!(
                "{}: discrete action {a} given to a continuous action space",
                self.prefix
            ))),
            (Action::Continuous(_), true) => Err(EnvError::InvalidAction(format!(
                "{}: a continuous action was given to a discrete action space",
                self.prefix
            ))),
        }
    }
}

/// The platform's file name for a shared library named `name`:
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
                        reason: LoadErrorKind::IdReserved {
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
                        reason: LoadErrorKind::IdTaken { id, other }.to_string(),
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
