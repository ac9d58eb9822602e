//! The handshake with a plugin library: open it, call its entry function,
//! and validate everything it returns (ABI version, struct sizes, strings,
//! descriptors, spaces) before any of it is used.

use std::ffi::{c_char, CStr};
use std::path::Path;
use std::sync::Arc;

use super::error::{PluginLoadError, PluginLoadErrorKind};
use super::{
    Plugin, PluginEnvType, PluginInfo, VTable, VecVTable, ERR_BUF_LEN, MAX_BOX_DIM, MAX_ENVS,
};
use rwg_env::env::EnvSpec;
use rwg_env::plugin::abi::*;
use rwg_env::space::{BoxSpace, Space};

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
pub fn load_plugin(path: impl AsRef<Path>) -> Result<Plugin, PluginLoadError> {
    let path = path.as_ref();
    let err = |kind| PluginLoadError {
        path: path.to_path_buf(),
        kind,
    };
    // A bare file name ("libfoo.so") means the file in the current
    // directory, as everywhere else a path is accepted; dlopen would search
    // the system's library path for it instead.
    let open_path = if path.parent() == Some(Path::new("")) {
        Path::new(".").join(path)
    } else {
        path.to_path_buf()
    };
    // SAFETY: loading a library runs its initialisers; trusting the file is
    // the caller's decision (documented above).
    let lib = unsafe { libloading::Library::new(&open_path) }
        .map_err(|e| err(PluginLoadErrorKind::Open(e.to_string())))?;
    // SAFETY: the symbol is declared with the header's signature.
    let entry = unsafe { lib.get::<EntryFn>(ENTRY_SYMBOL) }.map(|s| *s);
    // Never unload (see the module docs), not even a library we refuse.
    std::mem::forget(lib);
    let entry = entry.map_err(|_| err(PluginLoadErrorKind::NoEntrySymbol))?;
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
pub unsafe fn load_from_entry(origin: &Path, entry: EntryFn) -> Result<Plugin, PluginLoadError> {
    let err = |kind| PluginLoadError {
        path: origin.to_path_buf(),
        kind,
    };
    // SAFETY (of every call below): the plugin keeps the header's contract
    // (this function's precondition): the pointers it returns are NULL or
    // point to what the header says, its functions are callable as declared,
    // and every struct is at least as large as its `struct_size` says.
    let (e, abi) = unsafe { read_entry(entry) }.map_err(err)?;
    // SAFETY: see above.
    let fns = unsafe { read_identity(&e) }.map_err(err)?;
    // SAFETY: see above.
    let init = unsafe { run_init(e.init) };
    super::std_fds::refill();
    init.map_err(err)?;
    let info = Arc::new(PluginInfo {
        path: origin.to_path_buf(),
        id: fns.plugin_id.clone(),
        version: fns.version.clone(),
        abi,
    });
    // SAFETY: see above.
    let n = unsafe { (fns.env_count)() };
    if n == 0 || n > MAX_ENVS {
        return Err(err(PluginLoadErrorKind::EnvCount(n)));
    }
    let mut envs: Vec<PluginEnvType> = Vec::with_capacity(n as usize);
    for index in 0..n {
        // SAFETY: see above (`index < n`).
        let env = unsafe { read_env(&fns, index, &envs, &info) }.map_err(err)?;
        envs.push(env);
    }
    Ok(Plugin { info, envs })
}

/// The plugin's identity and the functions that list its environments.
struct Identity {
    plugin_id: String,
    version: String,
    env_count: EnvCountFn,
    env_desc: EnvDescFn,
    env_vtable: EnvVtableFn,
}

/// Calls `entry` and checks the entry struct's head (ABI major, size, tag)
/// before trusting the rest of it; the struct and the plugin's ABI version.
///
/// # Safety
/// As [`load_from_entry`].
unsafe fn read_entry(entry: EntryFn) -> Result<(RwgPluginEntry, (u32, u32)), PluginLoadErrorKind> {
    // SAFETY: the contract.
    let p = unsafe { entry(ABI_MAJOR, ABI_MINOR) };
    if p.is_null() {
        return Err(PluginLoadErrorKind::Declined {
            host_major: ABI_MAJOR,
            host_minor: ABI_MINOR,
        });
    }
    // struct_size, abi_major and abi_minor lead the entry struct of every
    // ABI version; read them before trusting the rest of the layout.
    // SAFETY: the contract (non-NULL: an entry struct).
    let head = unsafe { p.cast::<[u32; 3]>().read() };
    let [size, major, minor] = head;
    if major != ABI_MAJOR {
        return Err(PluginLoadErrorKind::AbiMajor {
            plugin_major: major,
            plugin_minor: minor,
            host_major: ABI_MAJOR,
            host_minor: ABI_MINOR,
        });
    }
    if size < ENTRY_SIZE_V1_0 {
        return Err(PluginLoadErrorKind::StructTooSmall {
            what: "rwg_plugin_entry_t".into(),
            size,
            needed: ENTRY_SIZE_V1_0,
        });
    }
    // SAFETY: the contract (`size` is at least the 1.0 entry's, all it has).
    let e = unsafe { p.read() };
    let tag = if e.abi_tag.is_null() {
        "NULL".to_string()
    } else {
        // SAFETY: the contract (a NUL-terminated string).
        unsafe { CStr::from_ptr(e.abi_tag) }
            .to_string_lossy()
            .into_owned()
    };
    if tag.as_bytes() != ABI_TAG.to_bytes() {
        return Err(PluginLoadErrorKind::AbiTag { found: tag });
    }
    Ok((e, (major, minor)))
}

/// The plugin's id and version, and its functions that must not be NULL.
///
/// # Safety
/// `e` keeps the header's contract (its strings NULL or NUL-terminated).
unsafe fn read_identity(e: &RwgPluginEntry) -> Result<Identity, PluginLoadErrorKind> {
    // SAFETY: the contract (NULL or a NUL-terminated string).
    let plugin_id = unsafe { read_str(e.plugin_id, "plugin_id", false) }?;
    if plugin_id.is_empty() {
        return Err(PluginLoadErrorKind::BadString {
            what: "plugin_id",
            reason: "empty".into(),
        });
    }
    // SAFETY: as above.
    let version = unsafe { read_str(e.plugin_version, "plugin_version", true) }?;
    Ok(Identity {
        plugin_id,
        version,
        env_count: e.env_count.ok_or(PluginLoadErrorKind::Null("env_count"))?,
        env_desc: e.env_desc.ok_or(PluginLoadErrorKind::Null("env_desc"))?,
        env_vtable: e
            .env_vtable
            .ok_or(PluginLoadErrorKind::Null("env_vtable"))?,
    })
}

/// Calls the plugin's `init`, if it has one, with the host table.
///
/// # Safety
/// `init` keeps the header's contract.
unsafe fn run_init(init: Option<InitFn>) -> Result<(), PluginLoadErrorKind> {
    let Some(init) = init else { return Ok(()) };
    let mut buf = [0 as c_char; ERR_BUF_LEN];
    // SAFETY: the contract; `buf` is writable for its length.
    let status = unsafe { init(&HOST.0, buf.as_mut_ptr(), buf.len()) };
    if status != RWG_OK {
        return Err(PluginLoadErrorKind::InitFailed {
            status,
            message: buf_message(&buf),
        });
    }
    Ok(())
}

/// The environment at `index`: its descriptor and its function table,
/// validated; `envs` are those read before it (ids must not repeat).
///
/// # Safety
/// `fns` keep the header's contract and `index` is below the env count.
unsafe fn read_env(
    fns: &Identity,
    index: u32,
    envs: &[PluginEnvType],
    info: &Arc<PluginInfo>,
) -> Result<PluginEnvType, PluginLoadErrorKind> {
    // SAFETY: the contract (`index` below the count).
    let (spec, summary) = unsafe { read_desc((fns.env_desc)(index), index, envs) }?;
    // SAFETY: as above.
    let vt = unsafe { read_vtable((fns.env_vtable)(index)) }.map_err(|reason| {
        PluginLoadErrorKind::Env {
            index,
            id: Some(spec.id.clone()),
            reason,
        }
    })?;
    Ok(PluginEnvType {
        info: info.clone(),
        index,
        spec,
        summary,
        vt,
    })
}

/// The spec and summary of the descriptor of env `index`, validated; its id
/// must not be one of `envs`'.
///
/// # Safety
/// `d` is NULL or a descriptor keeping the header's contract.
unsafe fn read_desc(
    d: *const RwgEnvDesc,
    index: u32,
    envs: &[PluginEnvType],
) -> Result<(EnvSpec, String), PluginLoadErrorKind> {
    let env_err = |id: Option<&str>, reason: String| PluginLoadErrorKind::Env {
        index,
        id: id.map(str::to_string),
        reason,
    };
    if d.is_null() {
        return Err(env_err(None, "env_desc returned NULL".into()));
    }
    // SAFETY: the contract (non-NULL: a descriptor, `struct_size` first).
    let dsize = unsafe { d.cast::<u32>().read() };
    if dsize < ENV_DESC_SIZE_V1_0 {
        return Err(env_err(
            None,
            format!(
                "rwg_env_desc_t is too small: struct_size is {dsize}, ABI 1.0 needs at least {ENV_DESC_SIZE_V1_0} bytes"
            ),
        ));
    }
    // SAFETY: the contract (at least the 1.0 size, all it has).
    let d = unsafe { d.read() };
    // SAFETY: the contract (NULL or a NUL-terminated string).
    let id = unsafe { read_str(d.id, "id", false) }.map_err(|k| env_err(None, k.to_string()))?;
    check_env_id(&id).map_err(|r| env_err((!id.is_empty()).then_some(id.as_str()), r))?;
    if let Some(first) = envs.iter().find(|t| t.spec.id == id) {
        return Err(PluginLoadErrorKind::DuplicateId {
            id,
            first: first.index,
            second: index,
        });
    }
    let fail = |r: String| env_err(Some(&id), r);
    // SAFETY: as above.
    let summary =
        unsafe { read_str(d.summary, "summary", true) }.map_err(|k| fail(k.to_string()))?;
    // SAFETY: the contract (a Box's bounds hold `n` values).
    let observation_space = unsafe { read_space(&d.observation_space) }
        .map_err(|r| fail(format!("observation space: {r}")))?;
    if !matches!(observation_space, Space::Box(_)) {
        return Err(fail("observation space: must be a Box".into()));
    }
    // SAFETY: as above.
    let action_space =
        unsafe { read_space(&d.action_space) }.map_err(|r| fail(format!("action space: {r}")))?;
    let reward_threshold = if d.reward_threshold.is_nan() {
        None
    } else if d.reward_threshold.is_infinite() {
        return Err(fail(format!(
            "reward_threshold is {} (use NaN for none)",
            d.reward_threshold
        )));
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
    Ok((spec, summary))
}

/// A function table, validated: the five single-env functions set, the
/// batched pair both or neither, the vector-env five all or none.
///
/// # Safety
/// `vt` is NULL or a table keeping the header's contract.
unsafe fn read_vtable(vt: *const RwgEnvVtable) -> Result<VTable, String> {
    if vt.is_null() {
        return Err("env_vtable returned NULL".into());
    }
    // SAFETY: the contract (non-NULL: a table, `struct_size` first).
    let vsize = unsafe { vt.cast::<u32>().read() };
    if vsize < ENV_VTABLE_SIZE_V1_0 {
        return Err(format!(
            "rwg_env_vtable_t is too small: struct_size is {vsize}, ABI 1.0 needs at least {ENV_VTABLE_SIZE_V1_0} bytes"
        ));
    }
    // Read no further than the plugin's struct_size: a 1.0 table ends at
    // last_error. Fields it does not have stay zero (None).
    // SAFETY: all zeros is a valid table (every function `None`).
    let mut v: RwgEnvVtable = unsafe { std::mem::zeroed() };
    // SAFETY: the plugin's table has `vsize` bytes, `v` at least the copied
    // count, and they cannot overlap (`v` is local).
    unsafe {
        std::ptr::copy_nonoverlapping(
            vt.cast::<u8>(),
            (&mut v as *mut RwgEnvVtable).cast::<u8>(),
            (vsize as usize).min(std::mem::size_of::<RwgEnvVtable>()),
        )
    };
    if v.reset_many.is_some() != v.step_many.is_some() {
        let (set, unset) = if v.reset_many.is_some() {
            ("reset_many", "step_many")
        } else {
            ("step_many", "reset_many")
        };
        return Err(format!(
            "env_vtable: {set} is set but {unset} is NULL (ABI 1.1 needs both or neither)"
        ));
    }
    let vec = vec_vtable(&v)?;
    let null = |f: &str| format!("env_vtable: {f} is NULL");
    Ok(VTable {
        create: v.create.ok_or_else(|| null("create"))?,
        destroy: v.destroy.ok_or_else(|| null("destroy"))?,
        reset: v.reset.ok_or_else(|| null("reset"))?,
        step: v.step.ok_or_else(|| null("step"))?,
        last_error: v.last_error.ok_or_else(|| null("last_error"))?,
        reset_many: v.reset_many,
        step_many: v.step_many,
        vec,
    })
}

/// The table's vector-env functions: all five, none, or an error naming
/// those set and those NULL.
fn vec_vtable(v: &RwgEnvVtable) -> Result<Option<VecVTable>, String> {
    match (
        v.vec_create,
        v.vec_destroy,
        v.vec_reset,
        v.vec_step,
        v.vec_last_error,
    ) {
        (Some(create), Some(destroy), Some(reset), Some(step), Some(last_error)) => {
            Ok(Some(VecVTable {
                create,
                destroy,
                reset,
                step,
                last_error,
            }))
        }
        (None, None, None, None, None) => Ok(None),
        _ => {
            let vec_fns = [
                ("vec_create", v.vec_create.is_some()),
                ("vec_destroy", v.vec_destroy.is_some()),
                ("vec_reset", v.vec_reset.is_some()),
                ("vec_step", v.vec_step.is_some()),
                ("vec_last_error", v.vec_last_error.is_some()),
            ];
            let names = |set: bool| {
                vec_fns
                    .iter()
                    .filter(|f| f.1 == set)
                    .map(|f| f.0)
                    .collect::<Vec<_>>()
                    .join(", ")
            };
            Err(format!(
                "env_vtable: {} set but {} NULL (ABI 1.2 needs all five vector-env functions or none)",
                names(true),
                names(false)
            ))
        }
    }
}

/// Reads a plugin string. `nullable`: NULL reads as "".
///
/// # Safety
/// `p` is NULL or a NUL-terminated string.
unsafe fn read_str(
    p: *const c_char,
    what: &'static str,
    nullable: bool,
) -> Result<String, PluginLoadErrorKind> {
    if p.is_null() {
        return if nullable {
            Ok(String::new())
        } else {
            Err(PluginLoadErrorKind::Null(what))
        };
    }
    // SAFETY: non-NULL: NUL-terminated (the contract).
    unsafe { CStr::from_ptr(p) }
        .to_str()
        .map(str::to_string)
        .map_err(|e| PluginLoadErrorKind::BadString {
            what,
            reason: format!("not valid UTF-8 ({e})"),
        })
}

pub(super) fn buf_message(buf: &[c_char]) -> String {
    let bytes: Vec<u8> = buf
        .iter()
        .take_while(|&&c| c != 0)
        .map(|&c| c as u8)
        .collect();
    rwg_env::text::escape_controls(&String::from_utf8_lossy(&bytes)).into_owned()
}

/// A message a plugin wrote (its `last_error`, an error buffer), as text
/// safe to print: invalid UTF-8 replaced, control characters escaped.
pub(super) fn plugin_text(s: &CStr) -> String {
    rwg_env::text::escape_controls(&s.to_string_lossy()).into_owned()
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
///
/// # Safety
/// A Box's `low` and `high` are NULL or hold `n` values each.
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
            // SAFETY: non-NULL: `n` values each (the contract).
            let low = unsafe { std::slice::from_raw_parts(s.low, n) }.to_vec();
            // SAFETY: as above.
            let high = unsafe { std::slice::from_raw_parts(s.high, n) }.to_vec();
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
