//! The `extern "C"` side of an exported plugin: the entry function's body
//! and the functions of the plugin and environment tables. Every one checks
//! its arguments, catches panics (a panic poisons the instance and becomes
//! `RWG_ERR_PANIC`) and reports errors through `last_error`.

use std::any::Any;
use std::ffi::{c_char, CStr};
use std::panic::{catch_unwind, AssertUnwindSafe};

use super::builder::{ActionKind, ExportedEnv, ExportedPlugin, PluginStatic};
use crate::env::{Action, EnvError, EnvSpec, Environment, Step};
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
    env: E,
    obs_dim: usize,
    action: ActionKind,
    /// A Discrete space's `n` as a double (exact: `n` is at most 2^53).
    action_n: f64,
    /// The [`FastKey`] of a step call the fast path takes on this instance
    /// (its shapes), or [`FastKey::NONE`] while it is poisoned or holds a
    /// failed call's message (the checked path then runs and clears it):
    /// one comparison for the instance's state and both lengths.
    fast: FastKey,
    /// The message of the panic that poisoned the instance.
    poisoned: Option<String>,
    /// `last_error`'s text, always NUL-terminated ("" when the last call succeeded).
    error: Vec<u8>,
}

impl<E> Instance<E> {
    fn set_error(&mut self, msg: &str) {
        self.error.clear();
        self.error
            .extend(msg.bytes().map(|b| if b == 0 { b' ' } else { b }));
        self.error.push(0);
        self.fast = FastKey::NONE;
    }

    /// Clears `last_error` (after a successful call that followed a failed one).
    fn clear_error(&mut self) {
        self.error.clear();
        self.error.push(0);
        if self.poisoned.is_none() {
            self.fast = FastKey::of_instance(self.obs_dim, self.action);
        }
    }

    /// Poisons the instance after a panic with message `msg`.
    fn poison(&mut self, msg: String) {
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
        EnvError::Other(_) => RWG_ERR_INTERNAL,
    }
}

/// Runs `f` on the instance behind `env`, catching panics and recording errors.
///
/// # Safety
/// `env` is NULL or an instance of `E` (made by this table's `create`), not
/// in use elsewhere during the call.
unsafe fn with_instance<E>(
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
unsafe fn obs_slice<'a>(
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

fn env_err(e: EnvError) -> (Status, String) {
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

/// Converts the C action to an [`Action`], checking it against the space.
fn action_of(a: &[f64], kind: ActionKind) -> Result<Action<'_>, String> {
    match kind {
        ActionKind::Discrete(n) => {
            if a.len() != 1 {
                return Err(format!(
                    "a discrete action has length 1, got action_len {}",
                    a.len()
                ));
            }
            let v = a[0];
            // The common case first, without `fract` (a libm call on
            // baseline x86-64): in range (false for NaN) and integral.
            if v >= 0.0 && v < n as f64 {
                let i = v as u64;
                if i as f64 == v {
                    return Ok(Action::Discrete(i as i64));
                }
            }
            if !v.is_finite() || v.fract() != 0.0 {
                return Err(format!("discrete action {v:?} is not an integer"));
            }
            if v < 0.0 || v >= n as f64 {
                return Err(format!(
                    "{v} is outside the action space Discrete({n}) (valid: 0..={})",
                    n - 1
                ));
            }
            Ok(Action::Discrete(v as i64))
        }
        ActionKind::Box(dim) => {
            if a.len() != dim {
                return Err(format!(
                    "action has {} values, the action space has {dim}",
                    a.len()
                ));
            }
            if let Some(i) = a.iter().position(|x| !x.is_finite()) {
                return Err(format!("action[{i}] is {:?}, not a finite number", a[i]));
            }
            Ok(Action::Continuous(a))
        }
    }
}

pub(super) unsafe extern "C" fn step<E: Environment>(
    env: *mut RwgEnv,
    action: *const f64,
    action_len: usize,
    obs: *mut f64,
    obs_len: usize,
    out: *mut RwgStepOut,
) -> Status {
    // SAFETY: `step_inline`'s contract is `step`'s (the ABI's).
    unsafe { step_inline::<E>(env, action, action_len, obs, obs_len, out) }
}

/// The body of [`step`].
///
/// # Safety
/// The ABI's contract for `step`: `env` is NULL or an instance of `E` made
/// by this table, `action` NULL or valid for `action_len` reads, `obs` NULL
/// or valid for `obs_len` writes, `out` NULL or writable.
#[inline(always)]
pub(super) unsafe fn step_inline<E: Environment>(
    env: *mut RwgEnv,
    action: *const f64,
    action_len: usize,
    obs: *mut f64,
    obs_len: usize,
    out: *mut RwgStepOut,
) -> Status {
    if !out.is_null() && !obs.is_null() && !action.is_null() {
        let keys = call_keys(obs_len, action_len);
        // SAFETY: the contract above, the three pointers checked non-NULL.
        match unsafe { step_fast::<E>(env, keys, action, action_len, obs, obs_len) } {
            Ok(s) => {
                // SAFETY: `out` is non-NULL, so writable.
                unsafe {
                    *out = RwgStepOut {
                        reward: s.reward,
                        terminated: u8::from(s.terminated),
                        truncated: u8::from(s.truncated),
                        reserved: [0; 6],
                    }
                };
                return RWG_OK;
            }
            Err(Some(status)) => return status,
            Err(None) => {}
        }
    }
    // SAFETY: `step_checked`'s contract is this function's.
    unsafe { step_checked::<E>(env, action, action_len, obs, obs_len, out) }
}

/// What the fast path of a step compares an instance with: the call's
/// observation and action lengths and the kind of action, packed into one
/// word (an instance that is not healthy has [`FastKey::NONE`], which no
/// call has).
#[derive(Clone, Copy, PartialEq, Eq)]
pub(super) struct FastKey(u64);

impl FastKey {
    /// The key of no call.
    const NONE: FastKey = FastKey(u64::MAX);

    /// The key of a call with these lengths on a discrete (`discrete`) or
    /// continuous action space; `NONE` for lengths no instance has.
    #[inline(always)]
    pub(super) fn of_call(obs_len: usize, action_len: usize, discrete: bool) -> FastKey {
        if obs_len > u32::MAX as usize || action_len > (u32::MAX >> 1) as usize {
            return FastKey::NONE;
        }
        FastKey(((obs_len as u64) << 32) | ((action_len as u64) << 1) | u64::from(discrete))
    }

    /// The key of a well-formed step call on a healthy instance with these
    /// spaces (its dimensions are at most 2^20, so it is never `NONE`).
    fn of_instance(obs_dim: usize, action: ActionKind) -> FastKey {
        match action {
            ActionKind::Discrete(_) => FastKey::of_call(obs_dim, 1, true),
            ActionKind::Box(d) => FastKey::of_call(obs_dim, d, false),
        }
    }
}

/// The keys of a step call with these lengths on a discrete and on a
/// continuous action space.
#[inline(always)]
pub(super) fn call_keys(obs_len: usize, action_len: usize) -> (FastKey, FastKey) {
    (
        FastKey::of_call(obs_len, action_len, true),
        FastKey::of_call(obs_len, action_len, false),
    )
}

/// The fast path of a step, shared by `step` and `step_many`'s lane loop:
/// a well-formed call (`action` and `obs` non-NULL, the caller checked; its
/// [`call_keys`] in `keys`) on a healthy instance steps the env. `Err(None)`
/// if the call is unusual in any way: nothing has been done to the env
/// then, and the caller goes to [`step_checked`], which finds and reports
/// the problem, so the two paths behave the same. `Err(Some(status))` if the
/// env failed or panicked (recorded in the instance, as `step_checked`
/// records it).
///
/// # Safety
/// `step_inline`'s contract, with `action` and `obs` not NULL.
#[inline(always)]
pub(super) unsafe fn step_fast<E: Environment>(
    env: *mut RwgEnv,
    keys: (FastKey, FastKey),
    action: *const f64,
    action_len: usize,
    obs: *mut f64,
    obs_len: usize,
) -> Result<Step, Option<Status>> {
    // SAFETY: `env` is NULL or an instance of `E` (the contract).
    let Some(inst) = (unsafe { env.cast::<Instance<E>>().as_mut() }) else {
        return Err(None);
    };
    // SAFETY: `action` is valid for `action_len` reads (the contract).
    let Some(a) = (unsafe { action_fast(inst, keys, action, action_len) }) else {
        return Err(None);
    };
    // SAFETY: `obs` is valid for `obs_len` writes (the contract).
    let o = unsafe { std::slice::from_raw_parts_mut(obs, obs_len) };
    let env = &mut inst.env;
    match catch_unwind(AssertUnwindSafe(|| env.step(a, o))) {
        Ok(Ok(s)) => Ok(s),
        Ok(Err(e)) => Err(Some(step_error(inst, e))),
        Err(p) => Err(Some(step_panic(inst, p))),
    }
}

/// The action of a fast-path call on `inst` if the instance is healthy,
/// the lengths are its own (one comparison of [`FastKey`]s) and the action
/// is valid; `None` otherwise (no message).
///
/// # Safety
/// `action` is valid for `len` reads.
#[inline(always)]
unsafe fn action_fast<'a, E>(
    inst: &Instance<E>,
    (discrete, continuous): (FastKey, FastKey),
    action: *const f64,
    len: usize,
) -> Option<Action<'a>> {
    if inst.fast == discrete {
        // SAFETY: the key says `len` is 1: one read (the contract).
        let v = unsafe { *action };
        // 0 <= v < n (false for NaN; n is at most 2^53, exact) and
        // integral: exactly the valid actions, in two comparisons and one
        // round trip through i64 (in range, so the unchecked conversion is
        // exact truncation). -0.0 is action 0, as in `action_of`.
        if v >= 0.0 && v < inst.action_n {
            // SAFETY: 0 <= v < 2^53: finite and within i64.
            let i = unsafe { v.to_int_unchecked::<i64>() };
            if i as f64 == v {
                return Some(Action::Discrete(i));
            }
        }
        None
    } else if inst.fast == continuous {
        // SAFETY: `action` is valid for `len` reads (the contract).
        let a = unsafe { std::slice::from_raw_parts(action, len) };
        a.iter()
            .all(|x| x.is_finite())
            .then_some(Action::Continuous(a))
    } else {
        None
    }
}

#[cold]
#[inline(never)]
fn step_error<E>(inst: &mut Instance<E>, e: EnvError) -> Status {
    let (status, msg) = env_err(e);
    inst.set_error(&msg);
    status
}

#[cold]
#[inline(never)]
fn step_panic<E>(inst: &mut Instance<E>, p: Box<dyn std::any::Any + Send>) -> Status {
    inst.poison(panic_message(&*p));
    RWG_ERR_PANIC
}

/// `step` with every argument checked and every problem reported.
///
/// # Safety
/// `step_inline`'s contract.
#[cold]
#[inline(never)]
unsafe fn step_checked<E: Environment>(
    env: *mut RwgEnv,
    action: *const f64,
    action_len: usize,
    obs: *mut f64,
    obs_len: usize,
    out: *mut RwgStepOut,
) -> Status {
    let call = |e: &mut E, obs_dim: usize, kind: ActionKind| {
        let invalid = |m: String| (RWG_ERR_INVALID_ARGUMENT, m);
        if out.is_null() {
            return Err(invalid("step: out is NULL".into()));
        }
        let a: &[f64] = if action_len == 0 {
            &[]
        } else if action.is_null() {
            return Err(invalid("step: action is NULL".into()));
        } else {
            // SAFETY: non-NULL: valid for `action_len` reads (the contract).
            unsafe { std::slice::from_raw_parts(action, action_len) }
        };
        let a = action_of(a, kind).map_err(invalid)?;
        // SAFETY: `obs` is NULL or valid for `obs_len` writes (the contract).
        let obs = unsafe { obs_slice(obs, obs_len, obs_dim) }?;
        let s = e.step(a, obs).map_err(env_err)?;
        // SAFETY: `out` was checked non-NULL: writable (the contract).
        unsafe {
            *out = RwgStepOut {
                reward: s.reward,
                terminated: u8::from(s.terminated),
                truncated: u8::from(s.truncated),
                reserved: [0; 6],
            }
        };
        Ok(())
    };
    // SAFETY: the contract (`env` NULL or an instance of `E`).
    unsafe { with_instance(env, call) }
}

pub(super) unsafe extern "C" fn last_error<E>(env: *const RwgEnv) -> *const c_char {
    // SAFETY: `env` is NULL or an instance of `E` (the ABI's contract).
    match unsafe { env.cast::<Instance<E>>().as_ref() } {
        Some(inst) => inst.error.as_ptr().cast(),
        None => c"last_error: env is NULL".as_ptr(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn discrete_actions_must_be_integral_and_in_range() {
        let k = ActionKind::Discrete(3);
        assert_eq!(action_of(&[2.0], k), Ok(Action::Discrete(2)));
        for bad in [[3.0], [-1.0], [0.5], [f64::NAN], [f64::INFINITY]] {
            assert!(action_of(&bad, k).is_err(), "{bad:?}");
        }
        assert!(action_of(&[0.0, 1.0], k).is_err());
        assert!(action_of(&[], k).is_err());
        assert_eq!(action_of(&[-0.0], k), Ok(Action::Discrete(0)));
        assert!(action_of(&[1e300], k).unwrap_err().contains("outside"));
        assert!(action_of(&[1.5], k).unwrap_err().contains("not an integer"));
    }

    #[test]
    fn continuous_actions_must_be_finite_and_sized() {
        let k = ActionKind::Box(2);
        assert!(action_of(&[5.0, -7.0], k).is_ok());
        assert!(action_of(&[0.0, f64::NAN], k)
            .unwrap_err()
            .contains("action[1]"));
        assert!(action_of(&[0.0], k).is_err());
    }
}
