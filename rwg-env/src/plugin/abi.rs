//! `#[repr(C)]` mirrors of `rwg-env/include/rwg_plugin.h`, ABI v1.2.
//!
//! The header is normative: read it for the ownership, lifetime and threading
//! contract of every field and function. The const assertions at the end of
//! this file check that these structs have the header's sizes and offsets
//! (the header asserts the same numbers with `_Static_assert`).
//!
//! Function pointers are `Option<unsafe extern "C" fn ...>` so that a NULL
//! from a plugin is a representable value the loader can reject, never
//! undefined behaviour.

use std::ffi::c_char;
use std::marker::{PhantomData, PhantomPinned};
use std::mem::{offset_of, size_of};

/// `RWG_PLUGIN_ABI_MAJOR`: hosts and plugins work together when majors match.
pub const ABI_MAJOR: u32 = 1;
/// `RWG_PLUGIN_ABI_MINOR`: additions within the major.
pub const ABI_MINOR: u32 = 2;
/// `RWG_PLUGIN_ABI_TAG`, NUL-terminated.
pub const ABI_TAG: &std::ffi::CStr = c"rwg-env-plugin";
/// `RWG_PLUGIN_ENTRY_SYMBOL`, NUL-terminated, as `libloading` wants it.
pub const ENTRY_SYMBOL: &[u8] = b"rwg_plugin_entry_v1\0";

/// `rwg_status_t`.
pub type Status = i32;
/// `RWG_OK`.
pub const RWG_OK: Status = 0;
/// `RWG_ERR_INVALID_ARGUMENT`: bad action, config, index or pointer.
pub const RWG_ERR_INVALID_ARGUMENT: Status = 1;
/// `RWG_ERR_RESET_NEEDED`: step before the first reset.
pub const RWG_ERR_RESET_NEEDED: Status = 2;
/// `RWG_ERR_BUFFER_SIZE`: `obs_len` is not the observation length.
pub const RWG_ERR_BUFFER_SIZE: Status = 3;
/// `RWG_ERR_UNSUPPORTED`: e.g. reset without a seed.
pub const RWG_ERR_UNSUPPORTED: Status = 4;
/// `RWG_ERR_PANIC`: a panic was caught; the instance is poisoned.
pub const RWG_ERR_PANIC: Status = 5;
/// `RWG_ERR_INTERNAL`: any other failure.
pub const RWG_ERR_INTERNAL: Status = 6;

/// The header's name of a status code (`"RWG_ERR_PANIC"`, ...), or
/// `"unknown status"` for a code ABI v1.0 does not define.
pub fn status_name(status: Status) -> &'static str {
    match status {
        RWG_OK => "RWG_OK",
        RWG_ERR_INVALID_ARGUMENT => "RWG_ERR_INVALID_ARGUMENT",
        RWG_ERR_RESET_NEEDED => "RWG_ERR_RESET_NEEDED",
        RWG_ERR_BUFFER_SIZE => "RWG_ERR_BUFFER_SIZE",
        RWG_ERR_UNSUPPORTED => "RWG_ERR_UNSUPPORTED",
        RWG_ERR_PANIC => "RWG_ERR_PANIC",
        RWG_ERR_INTERNAL => "RWG_ERR_INTERNAL",
        _ => "unknown status",
    }
}

/// `RWG_SPACE_DISCRETE`.
pub const RWG_SPACE_DISCRETE: u32 = 1;
/// `RWG_SPACE_BOX`.
pub const RWG_SPACE_BOX: u32 = 2;

/// The largest Discrete `n`: actions cross as doubles, exact up to 2^53.
pub const MAX_DISCRETE_N: u64 = 1 << 53;

/// `rwg_space_t`: an observation or action space. Frozen for ABI v1.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct RwgSpace {
    /// `RWG_SPACE_DISCRETE` or `RWG_SPACE_BOX`.
    pub kind: u32,
    /// 0.
    pub reserved: u32,
    /// Discrete: number of values; Box: number of dimensions.
    pub n: u64,
    /// Box: `n` lower bounds; Discrete: NULL.
    pub low: *const f64,
    /// Box: `n` upper bounds; Discrete: NULL.
    pub high: *const f64,
}

/// `rwg_env_desc_t`: what an environment is. Growable.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct RwgEnvDesc {
    /// `sizeof(rwg_env_desc_t)` of the plugin's header.
    pub struct_size: u32,
    /// No flags in 1.0.
    pub flags: u32,
    /// Gymnasium-style id, NUL-terminated UTF-8.
    pub id: *const c_char,
    /// One-line description, may be NULL.
    pub summary: *const c_char,
    /// Must be a Box.
    pub observation_space: RwgSpace,
    /// Box or Discrete.
    pub action_space: RwgSpace,
    /// 0 = no limit; applied by the host.
    pub max_episode_steps: u32,
    /// 0.
    pub reserved: u32,
    /// NaN = none.
    pub reward_threshold: f64,
}

/// `rwg_env_t`: an opaque environment instance.
#[repr(C)]
pub struct RwgEnv {
    _data: [u8; 0],
    _marker: PhantomData<(*mut u8, PhantomPinned)>,
}

/// `rwg_vec_env_t` (ABI 1.2): many lanes of an environment in one object;
/// opaque.
#[repr(C)]
pub struct RwgVecEnv {
    _data: [u8; 0],
    _marker: PhantomData<(*mut u8, PhantomPinned)>,
}

/// `rwg_step_out_t`: reward and flags of a step. Frozen for ABI v1.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RwgStepOut {
    /// Reward of the transition.
    pub reward: f64,
    /// 0 or 1.
    pub terminated: u8,
    /// 0 or 1.
    pub truncated: u8,
    /// Ignored.
    pub reserved: [u8; 6],
}

/// `create`.
pub type CreateFn = unsafe extern "C" fn(
    env_index: u32,
    config: *const c_char,
    out_env: *mut *mut RwgEnv,
    err_buf: *mut c_char,
    err_len: usize,
) -> Status;
/// `destroy`.
pub type DestroyFn = unsafe extern "C" fn(env: *mut RwgEnv);
/// `reset`.
pub type ResetFn = unsafe extern "C" fn(
    env: *mut RwgEnv,
    has_seed: u8,
    seed: u64,
    obs: *mut f64,
    obs_len: usize,
) -> Status;
/// `step`.
pub type StepFn = unsafe extern "C" fn(
    env: *mut RwgEnv,
    action: *const f64,
    action_len: usize,
    obs: *mut f64,
    obs_len: usize,
    out: *mut RwgStepOut,
) -> Status;
/// `last_error`.
pub type LastErrorFn = unsafe extern "C" fn(env: *const RwgEnv) -> *const c_char;
/// `reset_many` (ABI 1.1): seeded resets of many instances.
pub type ResetManyFn = unsafe extern "C" fn(
    envs: *const *mut RwgEnv,
    n: usize,
    mask: *const u8,
    seeds: *const u64,
    obs: *mut f64,
    obs_len: usize,
    failed: *mut usize,
) -> Status;
/// `step_many` (ABI 1.1): steps of many instances over structure-of-arrays buffers.
pub type StepManyFn = unsafe extern "C" fn(
    envs: *const *mut RwgEnv,
    n: usize,
    mask: *const u8,
    actions: *const f64,
    action_len: usize,
    obs: *mut f64,
    obs_len: usize,
    rewards: *mut f64,
    terminated: *mut u8,
    truncated: *mut u8,
    failed: *mut usize,
) -> Status;

/// `vec_create` (ABI 1.2): a vector env of `lanes` lanes.
pub type VecCreateFn = unsafe extern "C" fn(
    env_index: u32,
    config: *const c_char,
    lanes: usize,
    out_vec: *mut *mut RwgVecEnv,
    err_buf: *mut c_char,
    err_len: usize,
) -> Status;
/// `vec_destroy` (ABI 1.2).
pub type VecDestroyFn = unsafe extern "C" fn(vec: *mut RwgVecEnv);
/// `vec_reset` (ABI 1.2): seeded resets of the masked lanes.
pub type VecResetFn = unsafe extern "C" fn(
    vec: *mut RwgVecEnv,
    mask: *const u8,
    seeds: *const u64,
    obs: *mut f64,
    obs_len: usize,
    status: *mut Status,
) -> Status;
/// `vec_step` (ABI 1.2): a step of the masked lanes.
pub type VecStepFn = unsafe extern "C" fn(
    vec: *mut RwgVecEnv,
    mask: *const u8,
    actions: *const f64,
    action_len: usize,
    obs: *mut f64,
    obs_len: usize,
    rewards: *mut f64,
    terminated: *mut u8,
    truncated: *mut u8,
    status: *mut Status,
) -> Status;
/// `vec_last_error` (ABI 1.2): lane `lane`'s message (`lane >= n`: the call's).
pub type VecLastErrorFn = unsafe extern "C" fn(vec: *const RwgVecEnv, lane: usize) -> *const c_char;

/// `rwg_env_vtable_t`: the functions of one environment. Growable.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct RwgEnvVtable {
    /// `sizeof(rwg_env_vtable_t)` of the plugin's header.
    pub struct_size: u32,
    /// 0.
    pub reserved: u32,
    /// Creates an instance (thread-safe).
    pub create: Option<CreateFn>,
    /// Frees an instance (NULL-safe).
    pub destroy: Option<DestroyFn>,
    /// Starts an episode.
    pub reset: Option<ResetFn>,
    /// Applies an action.
    pub step: Option<StepFn>,
    /// Message of the last failed call on the instance.
    pub last_error: Option<LastErrorFn>,
    /// ABI 1.1, optional: resets many instances (read only when
    /// `struct_size` covers it).
    pub reset_many: Option<ResetManyFn>,
    /// ABI 1.1, optional: steps many instances (read only when
    /// `struct_size` covers it).
    pub step_many: Option<StepManyFn>,
    /// ABI 1.2, optional (all five vector-env functions or none): creates a
    /// vector env (read only when `struct_size` covers it).
    pub vec_create: Option<VecCreateFn>,
    /// ABI 1.2: frees a vector env.
    pub vec_destroy: Option<VecDestroyFn>,
    /// ABI 1.2: resets lanes of a vector env.
    pub vec_reset: Option<VecResetFn>,
    /// ABI 1.2: steps lanes of a vector env.
    pub vec_step: Option<VecStepFn>,
    /// ABI 1.2: a lane's message after a failed vector call.
    pub vec_last_error: Option<VecLastErrorFn>,
}

/// `rwg_host_t`: what the host tells the plugin in `init`. Growable.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct RwgHost {
    /// `sizeof(rwg_host_t)` of the host's header.
    pub struct_size: u32,
    /// The host's ABI major.
    pub abi_major: u32,
    /// The host's ABI minor.
    pub abi_minor: u32,
    /// 0.
    pub reserved: u32,
    /// `"rwg"`.
    pub name: *const c_char,
    /// The host's version.
    pub version: *const c_char,
}

/// `init`.
pub type InitFn =
    unsafe extern "C" fn(host: *const RwgHost, err_buf: *mut c_char, err_len: usize) -> Status;
/// `deinit`.
pub type DeinitFn = unsafe extern "C" fn();
/// `env_count`.
pub type EnvCountFn = unsafe extern "C" fn() -> u32;
/// `env_desc`.
pub type EnvDescFn = unsafe extern "C" fn(index: u32) -> *const RwgEnvDesc;
/// `env_vtable`.
pub type EnvVtableFn = unsafe extern "C" fn(index: u32) -> *const RwgEnvVtable;
/// `get_extension`.
pub type GetExtensionFn = unsafe extern "C" fn(extension_id: *const c_char) -> *const ();

/// `rwg_plugin_entry_t`: the plugin's table. Growable.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct RwgPluginEntry {
    /// `sizeof(rwg_plugin_entry_t)` of the plugin's header.
    pub struct_size: u32,
    /// The plugin's ABI major.
    pub abi_major: u32,
    /// The plugin's ABI minor.
    pub abi_minor: u32,
    /// 0.
    pub reserved: u32,
    /// [`ABI_TAG`].
    pub abi_tag: *const c_char,
    /// The plugin's name.
    pub plugin_id: *const c_char,
    /// The plugin's version.
    pub plugin_version: *const c_char,
    /// Optional initialisation.
    pub init: Option<InitFn>,
    /// Optional de-initialisation (rwg never calls it).
    pub deinit: Option<DeinitFn>,
    /// Number of environments.
    pub env_count: Option<EnvCountFn>,
    /// Descriptor of environment i.
    pub env_desc: Option<EnvDescFn>,
    /// Function table of environment i.
    pub env_vtable: Option<EnvVtableFn>,
    /// Optional extensions.
    pub get_extension: Option<GetExtensionFn>,
}

/// The signature of `rwg_plugin_entry_v1`.
pub type EntryFn =
    unsafe extern "C" fn(host_abi_major: u32, host_abi_minor: u32) -> *const RwgPluginEntry;

// Layout checks: the same numbers as the header's _Static_asserts.
const P: usize = size_of::<*const u8>();
const S: usize = size_of::<RwgSpace>();
const _: () = {
    assert!(size_of::<CreateFn>() == P);
    assert!(size_of::<Option<CreateFn>>() == P);
    assert!(size_of::<f64>() == 8);

    assert!(offset_of!(RwgSpace, n) == 8);
    assert!(offset_of!(RwgSpace, low) == 16);
    assert!(offset_of!(RwgSpace, high) == 16 + P);
    assert!(S == 16 + 2 * P);

    assert!(offset_of!(RwgEnvDesc, flags) == 4);
    assert!(offset_of!(RwgEnvDesc, id) == 8);
    assert!(offset_of!(RwgEnvDesc, summary) == 8 + P);
    assert!(offset_of!(RwgEnvDesc, observation_space) == 8 + 2 * P);
    assert!(offset_of!(RwgEnvDesc, action_space) == 8 + 2 * P + S);
    assert!(offset_of!(RwgEnvDesc, max_episode_steps) == 8 + 2 * P + 2 * S);
    assert!(offset_of!(RwgEnvDesc, reward_threshold) == 16 + 2 * P + 2 * S);
    assert!(size_of::<RwgEnvDesc>() == 24 + 2 * P + 2 * S);

    assert!(offset_of!(RwgStepOut, terminated) == 8);
    assert!(offset_of!(RwgStepOut, truncated) == 9);
    assert!(size_of::<RwgStepOut>() == 16);

    assert!(offset_of!(RwgEnvVtable, create) == 8);
    assert!(offset_of!(RwgEnvVtable, last_error) == 8 + 4 * P);
    assert!(offset_of!(RwgEnvVtable, reset_many) == 8 + 5 * P);
    assert!(offset_of!(RwgEnvVtable, step_many) == 8 + 6 * P);
    assert!(offset_of!(RwgEnvVtable, vec_create) == 8 + 7 * P);
    assert!(offset_of!(RwgEnvVtable, vec_last_error) == 8 + 11 * P);
    assert!(size_of::<RwgEnvVtable>() == 8 + 12 * P);

    assert!(offset_of!(RwgHost, name) == 16);
    assert!(size_of::<RwgHost>() == 16 + 2 * P);

    assert!(offset_of!(RwgPluginEntry, abi_tag) == 16);
    assert!(offset_of!(RwgPluginEntry, init) == 16 + 3 * P);
    assert!(offset_of!(RwgPluginEntry, env_count) == 16 + 5 * P);
    assert!(offset_of!(RwgPluginEntry, get_extension) == 16 + 8 * P);
    assert!(size_of::<RwgPluginEntry>() == 16 + 9 * P);
};

/// `sizeof(rwg_plugin_entry_t)` in ABI 1.0, as `struct_size` carries it.
pub const ENTRY_SIZE_V1_0: u32 = size_of::<RwgPluginEntry>() as u32;
/// `sizeof(rwg_env_desc_t)` in ABI 1.0.
pub const ENV_DESC_SIZE_V1_0: u32 = size_of::<RwgEnvDesc>() as u32;
/// `sizeof(rwg_env_vtable_t)` in ABI 1.0 (up to `last_error`).
pub const ENV_VTABLE_SIZE_V1_0: u32 = offset_of!(RwgEnvVtable, reset_many) as u32;
/// `sizeof(rwg_env_vtable_t)` in ABI 1.1 (with the batched calls).
pub const ENV_VTABLE_SIZE_V1_1: u32 = offset_of!(RwgEnvVtable, vec_create) as u32;
/// `sizeof(rwg_env_vtable_t)` at ABI 1.2 (the vector env's five functions).
pub const ENV_VTABLE_SIZE_V1_2: u32 = size_of::<RwgEnvVtable>() as u32;
/// `sizeof(rwg_host_t)` in ABI 1.0.
pub const HOST_SIZE_V1_0: u32 = size_of::<RwgHost>() as u32;

/// Writes `msg` into a C error buffer of `len` bytes as NUL-terminated text,
/// truncated to fit on a UTF-8 character boundary. Does nothing if the buffer
/// is NULL or empty.
///
/// # Safety
/// `buf` is NULL or valid for writes of `len` bytes.
pub unsafe fn write_c_message(buf: *mut c_char, len: usize, msg: &str) {
    if buf.is_null() || len == 0 {
        return;
    }
    let mut n = msg.len().min(len - 1);
    while !msg.is_char_boundary(n) {
        n -= 1;
    }
    // SAFETY: `n < len` bytes into a buffer valid for `len` (the caller's
    // promise), from `msg`, which cannot overlap it (it is borrowed).
    unsafe { std::ptr::copy_nonoverlapping(msg.as_ptr(), buf.cast::<u8>(), n) };
    // SAFETY: `n < len`: within the buffer.
    unsafe { *buf.add(n) = 0 };
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_on_64_bit_match_the_header_comments() {
        if P == 8 {
            assert_eq!(size_of::<RwgSpace>(), 32);
            assert_eq!(size_of::<RwgEnvDesc>(), 104);
            assert_eq!(ENV_VTABLE_SIZE_V1_0, 48);
            assert_eq!(ENV_VTABLE_SIZE_V1_1, 64);
            assert_eq!(size_of::<RwgEnvVtable>(), 104);
            assert_eq!(size_of::<RwgPluginEntry>(), 88);
            assert_eq!(size_of::<RwgHost>(), 32);
        }
    }

    #[test]
    fn c_message_truncates_on_char_boundary() {
        let mut buf = [0x55 as c_char; 6];
        unsafe { write_c_message(buf.as_mut_ptr(), buf.len(), "abcdé-long") };
        let s = unsafe { std::ffi::CStr::from_ptr(buf.as_ptr()) };
        assert_eq!(s.to_str().unwrap(), "abcd");
        let mut one = [0x55 as c_char; 1];
        unsafe { write_c_message(one.as_mut_ptr(), 1, "x") };
        assert_eq!(one[0], 0);
        unsafe { write_c_message(std::ptr::null_mut(), 10, "x") };
    }

    #[test]
    fn status_names() {
        assert_eq!(status_name(RWG_ERR_PANIC), "RWG_ERR_PANIC");
        assert_eq!(status_name(42), "unknown status");
    }
}
