//! The `extern "C"` side of an exported plugin: the entry function's body,
//! the functions of the plugin table, and those of the environment table
//! but `step` (in `step`): an instance's creation, reset, `last_error` and
//! destruction. Every one checks its arguments, catches panics (a panic
//! poisons the instance and becomes `RWG_ERR_PANIC`) and reports errors
//! through `last_error`.

use std::any::Any;
use std::ffi::{c_char, CStr};
use std::panic::{catch_unwind, AssertUnwindSafe};

use super::builder::{ActionKind, ExportedEnv, ExportedPlugin, PluginStatic};
use super::step::FastKey;
use crate::env::{EnvError, EnvSpec, Environment};
use crate::plugin::abi::*;
use crate::space::Space;

/// The body of `rwg_plugin_entry_v1` for the plugin `P`: builds the tables on
/// the first call and returns them; NULL if the host's major differs or
/// building failed (the reason is printed to stderr by the panic hook).
pub fn entry_v1<P: PluginStatic>(
    host_abi_major: u32,
    _host_abi_minor: u32,
) -> *const RwgPluginEntry {
    if host_abi_major != ABI_MAJOR {
        return std::ptr::null();
    }
    let built = catch_unwind(|| {
        P::cell().get_or_init(|| {
            ExportedPlugin::new::<P>(P::build())
                .unwrap_or_else(|e| panic!("rwg plugin cannot be exported: {e}"))
        }) as *const ExportedPlugin
    });
    match built {
        // SAFETY: the pointer comes from a live &'static reference.
        Ok(p) => unsafe { &(*p).entry },
        Err(_) => std::ptr::null(),
    }
}

pub(super) fn panic_message(payload: &(dyn Any + Send)) -> String {
    if let Some(s) = payload.downcast_ref::<&str>() {
        (*s).to_string()
    } else if let Some(s) = payload.downcast_ref::<String>() {
        s.clone()
    } else {
        "panic with a non-string payload".to_string()
    }
}

pub(super) fn plugin<P: PluginStatic>() -> Option<&'static ExportedPlugin> {
    P::cell().get()
}

pub(super) unsafe extern "C" fn init<P: PluginStatic>(
    host: *const RwgHost,
    err_buf: *mut c_char,
    err_len: usize,
) -> Status {
    let fail = |msg: &str| {
        // SAFETY: `err_buf` is NULL or valid for `err_len` bytes (the ABI).
        unsafe { write_c_message(err_buf, err_len, msg) };
        RWG_ERR_INVALID_ARGUMENT
    };
    if host.is_null() {
        return fail("init: host is NULL");
    }
    // SAFETY: a non-NULL `host` points to a host table (the ABI), of at
    // least the 1.0 size it starts with.
    let host = unsafe { &*host };
    if host.struct_size < HOST_SIZE_V1_0 || host.abi_major != ABI_MAJOR {
        return fail("init: incompatible host table");
    }
    if plugin::<P>().is_none() {
        // SAFETY: as in `fail`.
        unsafe { write_c_message(err_buf, err_len, "init: the entry function failed") };
        return RWG_ERR_INTERNAL;
    }
    RWG_OK
}

pub(super) unsafe extern "C" fn deinit() {}

pub(super) unsafe extern "C" fn env_count<P: PluginStatic>() -> u32 {
    plugin::<P>().map_or(0, |p| p.envs.len() as u32)
}

pub(super) unsafe extern "C" fn env_desc<P: PluginStatic>(index: u32) -> *const RwgEnvDesc {
    plugin::<P>()
        .and_then(|p| p.envs.get(index as usize))
        .map_or(std::ptr::null(), |e| &e.desc)
}

pub(super) unsafe extern "C" fn env_vtable<P: PluginStatic>(index: u32) -> *const RwgEnvVtable {
    plugin::<P>()
        .and_then(|p| p.envs.get(index as usize))
        .map_or(std::ptr::null(), |e| &e.vtable)
}

pub(super) unsafe extern "C" fn get_extension(_id: *const c_char) -> *const () {
    std::ptr::null()
}

/// An instance as the C side sees it (`rwg_env_t *`), of the environment
/// type `E` its table's functions are instantiated for.
pub(super) struct Instance<E> {
    pub(super) env: E,
    pub(super) obs_dim: usize,
    pub(super) action: ActionKind,
    /// A Discrete space's `n` as a double (exact: `n` is at most 2^53).
    pub(super) action_n: f64,
    /// The [`FastKey`] of a step call the fast path takes on this instance
    /// (its shapes), or [`FastKey::NONE`] while it is poisoned or holds a
    /// failed call's message (the checked path then runs and clears it):
    /// one comparison for the instance's state and both lengths.
    pub(super) fast: FastKey,
    /// The message of the panic that poisoned the instance.
    pub(super) poisoned: Option<String>,
    /// `last_error`'s text, always NUL-terminated ("" when the last call succeeded).
    pub(super) error: Vec<u8>,
}

impl<E> Instance<E> {
    /// Records a failed call's message as `last_error` (NULs become
    /// spaces) and sends the next step down the checked path.
    pub(super) fn set_error(&mut self, msg: &str) {
        self.error.clear();
        self.error
            .extend(msg.bytes().map(|b| if b == 0 { b' ' } else { b }));
        self.error.push(0);
        self.fast = FastKey::NONE;
    }

    /// Clears `last_error` (after a successful call that followed a failed one).
    pub(super) fn clear_error(&mut self) {
        self.error.clear();
        self.error.push(0);
        if self.poisoned.is_none() {
            self.fast = FastKey::of_instance(self.obs_dim, self.action);
        }
    }

    /// Poisons the instance after a panic with message `msg`.
    pub(super) fn poison(&mut self, msg: String) {
        self.set_error(&format!("panic: {msg}"));
        self.poisoned = Some(msg);
    }
}

pub(super) fn same_shape(spec: &EnvSpec, obs_dim: usize, action: ActionKind) -> bool {
    let obs_ok = matches!(&spec.observation_space, Space::Box(b) if b.dim() == obs_dim);
    let act_ok = match (&spec.action_space, action) {
        (Space::Discrete { n }, ActionKind::Discrete(m)) => *n as u64 == m,
        (Space::Box(b), ActionKind::Box(d)) => b.dim() == d,
        _ => false,
    };
    obs_ok && act_ok
}

/// Boxes `env` as the instance `create` hands out, after checking that its
/// spaces are those of the descriptor.
pub(super) fn instantiate<E: Environment>(
    env: E,
    obs_dim: usize,
    action: ActionKind,
) -> Result<*mut RwgEnv, (Status, String)> {
    let spec = env.spec();
    if !same_shape(spec, obs_dim, action) {
        return Err((
            RWG_ERR_INTERNAL,
            format!(
                "create: the constructor built an env with spaces {} / {}, \
                 but the descriptor says Box({}) / {}",
                spec.observation_space.describe(),
                spec.action_space.describe(),
                obs_dim,
                match action {
                    ActionKind::Discrete(n) => format!("Discrete({n})"),
                    ActionKind::Box(d) => format!("Box({d})"),
                }
            ),
        ));
    }
    let action_n = match action {
        ActionKind::Discrete(n) => n as f64,
        ActionKind::Box(_) => 0.0,
    };
    let inst = Box::new(Instance {
        env,
        obs_dim,
        action,
        action_n,
        fast: FastKey::of_instance(obs_dim, action),
        poisoned: None,
        error: vec![0],
    });
    Ok(Box::into_raw(inst).cast::<RwgEnv>())
}

pub(super) unsafe extern "C" fn create<P: PluginStatic>(
    env_index: u32,
    config: *const c_char,
    out_env: *mut *mut RwgEnv,
    err_buf: *mut c_char,
    err_len: usize,
) -> Status {
    // SAFETY: `creation`'s contract is `create`'s (the ABI's).
    unsafe {
        creation::<P, RwgEnv>(
            "create",
            env_index,
            config,
            out_env,
            err_buf,
            err_len,
            |e, c| (e.make)(c, e.obs_dim, e.action),
        )
    }
}

/// The body of `create` and `vec_create` (`what`): the arguments checked,
/// `make` called with the environment's export and the config, panics
/// caught, the object handed out through `out` or the failure's message
/// written to `err_buf`.
///
/// # Safety
/// `config` is NULL or a NUL-terminated string, `out` NULL or writable,
/// `err_buf` NULL or valid for `err_len` bytes.
pub(super) unsafe fn creation<P: PluginStatic, T>(
    what: &str,
    env_index: u32,
    config: *const c_char,
    out: *mut *mut T,
    err_buf: *mut c_char,
    err_len: usize,
    make: impl FnOnce(&ExportedEnv, &str) -> Result<*mut T, (Status, String)>,
) -> Status {
    let result = catch_unwind(AssertUnwindSafe(|| -> Result<*mut T, (Status, String)> {
        let invalid = |m: String| (RWG_ERR_INVALID_ARGUMENT, m);
        if out.is_null() {
            return Err(invalid(format!("{what}: the out pointer is NULL")));
        }
        let Some(e) = plugin::<P>().and_then(|p| p.envs.get(env_index as usize)) else {
            return Err(invalid(format!(
                "{what}: no environment with index {env_index}"
            )));
        };
        let config = if config.is_null() {
            ""
        } else {
            // SAFETY: a non-NULL `config` is NUL-terminated (the contract).
            unsafe { CStr::from_ptr(config) }
                .to_str()
                .map_err(|_| invalid(format!("{what}: config is not UTF-8")))?
        };
        make(e, config)
    }));
    let (status, msg) = match result {
        Ok(Ok(ptr)) => {
            // SAFETY: `out` was checked non-NULL above: writable (the contract).
            unsafe { *out = ptr };
            return RWG_OK;
        }
        Ok(Err(e)) => e,
        Err(p) => (
            RWG_ERR_PANIC,
            format!("{what} panicked: {}", panic_message(&*p)),
        ),
    };
    // SAFETY: `err_buf` is NULL or valid for `err_len` bytes (the contract).
    unsafe { write_c_message(err_buf, err_len, &msg) };
    status
}

pub(super) unsafe extern "C" fn destroy<E>(env: *mut RwgEnv) {
    if env.is_null() {
        return;
    }
    // SAFETY: a non-NULL `env` is an instance of `E` this table's `create`
    // made with `Box::into_raw`, destroyed once (the ABI).
    let inst = unsafe { Box::from_raw(env.cast::<Instance<E>>()) };
    // A panicking Drop must not unwind into C; whatever it left is leaked.
    let _ = catch_unwind(AssertUnwindSafe(move || drop(inst)));
}

/// The status an [`EnvError`] crosses the boundary as.
pub fn status_of(e: &EnvError) -> Status {
    match e {
        EnvError::InvalidAction(_) | EnvError::StateLength { .. } => RWG_ERR_INVALID_ARGUMENT,
        EnvError::ResetNeeded => RWG_ERR_RESET_NEEDED,
        EnvError::Unsupported(_) => RWG_ERR_UNSUPPORTED,
        EnvError::Other(_) | EnvError::NonFinite(_) => RWG_ERR_INTERNAL,
    }
}

/// Runs `f` on the instance behind `env`, catching panics and recording errors.
///
/// # Safety
/// `env` is NULL or an instance of `E` (made by this table's `create`), not
/// in use elsewhere during the call.
pub(super) unsafe fn with_instance<E>(
    env: *mut RwgEnv,
    f: impl FnOnce(&mut E, usize, ActionKind) -> Result<(), (Status, String)>,
) -> Status {
    // SAFETY: the contract above.
    let Some(inst) = (unsafe { env.cast::<Instance<E>>().as_mut() }) else {
        return RWG_ERR_INVALID_ARGUMENT;
    };
    if let Some(p) = &inst.poisoned {
        let msg = format!("the instance is poisoned by an earlier panic: {p}");
        inst.set_error(&msg);
        return RWG_ERR_PANIC;
    }
    let (obs_dim, action) = (inst.obs_dim, inst.action);
    let env = &mut inst.env;
    match catch_unwind(AssertUnwindSafe(|| f(env, obs_dim, action))) {
        Ok(Ok(())) => {
            if inst.error.len() != 1 {
                // The last call failed: its message is no longer current.
                inst.clear_error();
            }
            RWG_OK
        }
        Ok(Err((status, msg))) => {
            inst.set_error(&msg);
            status
        }
        Err(p) => {
            inst.poison(panic_message(&*p));
            RWG_ERR_PANIC
        }
    }
}

/// The observation buffer as a slice, if it is not NULL and has the
/// space's length.
///
/// # Safety
/// `obs` is NULL or valid for `obs_len` writes, not aliased during `'a`.
pub(super) unsafe fn obs_slice<'a>(
    obs: *mut f64,
    obs_len: usize,
    obs_dim: usize,
) -> Result<&'a mut [f64], (Status, String)> {
    if obs.is_null() || obs_len != obs_dim {
        return Err((
            RWG_ERR_BUFFER_SIZE,
            format!("obs buffer has length {obs_len}, the observation space has {obs_dim}"),
        ));
    }
    // SAFETY: non-NULL, so valid for `obs_len` writes (the contract).
    Ok(unsafe { std::slice::from_raw_parts_mut(obs, obs_len) })
}

/// An environment's error as the status and message the C side gets.
pub(super) fn env_err(e: EnvError) -> (Status, String) {
    (status_of(&e), e.to_string())
}

#[inline]
pub(super) unsafe extern "C" fn reset<E: Environment>(
    env: *mut RwgEnv,
    has_seed: u8,
    seed: u64,
    obs: *mut f64,
    obs_len: usize,
) -> Status {
    let call = |e: &mut E, obs_dim: usize, _: ActionKind| {
        match has_seed {
            1 => {}
            0 => {
                return Err((
                    RWG_ERR_UNSUPPORTED,
                    "reset without a seed is not supported: pass has_seed = 1".into(),
                ))
            }
            x => {
                return Err((
                    RWG_ERR_INVALID_ARGUMENT,
                    format!("has_seed is {x}, not 0 or 1"),
                ))
            }
        }
        // SAFETY: `obs` is NULL or valid for `obs_len` writes (the ABI).
        let obs = unsafe { obs_slice(obs, obs_len, obs_dim) }?;
        e.reset(seed, obs).map_err(env_err)
    };
    // SAFETY: the ABI's contract for `reset`: `env` is NULL or an instance of
    // this table's, `obs` NULL or valid for `obs_len` writes.
    unsafe { with_instance(env, call) }
}

pub(super) unsafe extern "C" fn last_error<E>(env: *const RwgEnv) -> *const c_char {
    // SAFETY: `env` is NULL or an instance of `E` (the ABI's contract).
    match unsafe { env.cast::<Instance<E>>().as_ref() } {
        Some(inst) => inst.error.as_ptr().cast(),
        None => c"last_error: env is NULL".as_ptr(),
    }
}
