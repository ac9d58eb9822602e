//! [`PluginBuilder`]: a plugin's id, version and environments, and the C
//! tables ([`ExportedPlugin`]) it is turned into on the first entry call.

use std::collections::HashSet;
use std::ffi::CString;
use std::fmt::Display;
use std::sync::OnceLock;

use super::batched::{reset_many, step_many};
use super::step::step;
use super::trampolines::{
    create, deinit, destroy, env_count, env_desc, env_vtable, get_extension, init, instantiate,
    last_error, reset,
};
use super::vec_env::{
    instantiate_vec, vec_create, vec_destroy, vec_last_error, vec_reset, vec_step,
};
use crate::env::{EnvSpec, Environment};
use crate::many::ManyEnv;
use crate::plugin::abi::*;
use crate::space::Space;

/// An exported environment instance behind a trait object.
pub type DynEnv = Box<dyn Environment + Send>;

/// Builds an instance (`Box<Instance<E>>` as `rwg_env_t *`) from the
/// user's config, given the descriptor's observation dimension and action
/// shape; the error is the status and message `create` returns.
pub(super) type Constructor =
    Box<dyn Fn(&str, usize, ActionKind) -> Result<*mut RwgEnv, (Status, String)> + Send + Sync>;

/// Builds a vector env (`Box<VecInstance<M>>` as `rwg_vec_env_t *`) of
/// the given lanes from the user's config, given the descriptor's
/// observation dimension and action shape.
pub(super) type VecConstructor = Box<
    dyn Fn(&str, usize, usize, ActionKind) -> Result<*mut RwgVecEnv, (Status, String)>
        + Send
        + Sync,
>;

/// The vector env's functions that depend on its concrete `ManyEnv` type.
#[derive(Clone, Copy)]
struct VecFns {
    destroy: VecDestroyFn,
    reset: VecResetFn,
    step: VecStepFn,
    last_error: VecLastErrorFn,
}

/// The functions of an environment's table that depend on its concrete
/// type: instantiated per environment type, so the env's `step` is a
/// direct (inlinable) call in the single and batched step loops.
#[derive(Clone, Copy)]
struct TypedFns {
    destroy: DestroyFn,
    reset: ResetFn,
    step: StepFn,
    last_error: LastErrorFn,
    reset_many: ResetManyFn,
    step_many: StepManyFn,
}

impl TypedFns {
    fn of<E: Environment + Send + 'static>() -> TypedFns {
        TypedFns {
            destroy: destroy::<E>,
            reset: reset::<E>,
            step: step::<E>,
            last_error: last_error::<E>,
            reset_many: reset_many::<E>,
            step_many: step_many::<E>,
        }
    }
}

struct EnvExport {
    spec: EnvSpec,
    summary: String,
    make: Constructor,
    fns: TypedFns,
    vec: Option<(VecConstructor, VecFns)>,
}

/// Describes a plugin: its id, version and environments.
///
/// Each environment is given by the [`EnvSpec`] published in its descriptor
/// (id, spaces, `max_episode_steps`, `reward_threshold`) and a constructor
/// that builds an instance from the user's config string (`""` = defaults).
/// The constructor must return an env *without* a time limit: the host
/// applies `spec.max_episode_steps` itself. Constructors are called from any
/// thread, concurrently.
pub struct PluginBuilder {
    id: String,
    version: String,
    envs: Vec<EnvExport>,
}

impl PluginBuilder {
    /// A plugin named `id` (e.g. `"classic_control"`) at `version`.
    pub fn new(id: impl Into<String>, version: impl Into<String>) -> Self {
        PluginBuilder {
            id: id.into(),
            version: version.into(),
            envs: Vec::new(),
        }
    }

    /// Adds an environment built by `make(config)`.
    ///
    /// The exported functions are instantiated for `E`, so `E`'s `step` is
    /// called directly (and can be inlined into the batched call's lane
    /// loop): give the concrete type, not a `Box<dyn Environment>`, where
    /// speed matters.
    pub fn env<E, Er, F>(mut self, spec: EnvSpec, summary: impl Into<String>, make: F) -> Self
    where
        E: Environment + Send + 'static,
        Er: Display,
        F: Fn(&str) -> Result<E, Er> + Send + Sync + 'static,
    {
        self.envs.push(EnvExport {
            spec,
            summary: summary.into(),
            make: Box::new(move |config: &str, obs_dim, action| {
                let env = make(config).map_err(|e| (RWG_ERR_INVALID_ARGUMENT, e.to_string()))?;
                instantiate(env, obs_dim, action)
            }),
            fns: TypedFns::of::<E>(),
            vec: None,
        });
        self
    }

    /// Gives the environment added last ABI 1.2's vector env: `make(config)`
    /// builds a [`ManyEnv`] of some number of lanes (its width, e.g.
    /// `rwg-envs`' lockstep envs over 16 lanes), and a vector env of `n`
    /// lanes is `ceil(n / width)` of them. Its lanes must give the single
    /// instances' results bit for bit (`rwg check` tests it) and check
    /// actions as the single step does (a lane with an invalid action fails
    /// through `on_fail`); like the single env, it has no time limit.
    ///
    /// # Panics
    /// If no environment was added yet.
    pub fn vec_env<M, Er, F>(mut self, make: F) -> Self
    where
        M: ManyEnv + Send + 'static,
        Er: Display,
        F: Fn(&str) -> Result<M, Er> + Send + Sync + 'static,
    {
        let e = self
            .envs
            .last_mut()
            .expect("PluginBuilder::vec_env: add the environment (env) first");
        let make = move |config: &str| make(config).map_err(|e| e.to_string());
        let construct: VecConstructor = Box::new(move |config, lanes, obs_dim, action| {
            instantiate_vec::<M>(&make, config, lanes, obs_dim, action)
        });
        let fns = VecFns {
            destroy: vec_destroy::<M>,
            reset: vec_reset::<M>,
            step: vec_step::<M>,
            last_error: vec_last_error::<M>,
        };
        e.vec = Some((construct, fns));
        self
    }

    /// Adds an environment whose constructor returns a boxed env (every call
    /// of its `step` goes through the trait object).
    pub fn env_boxed<Er, F>(self, spec: EnvSpec, summary: impl Into<String>, make: F) -> Self
    where
        Er: Display,
        F: Fn(&str) -> Result<DynEnv, Er> + Send + Sync + 'static,
    {
        self.env::<DynEnv, Er, F>(spec, summary, make)
    }

    /// Number of environments added so far.
    pub fn len(&self) -> usize {
        self.envs.len()
    }

    /// Whether no environment was added.
    pub fn is_empty(&self) -> bool {
        self.envs.is_empty()
    }
}

/// Where an exported plugin's tables live; implemented by
/// [`export_plugin!`](crate::export_plugin) for a type private to the plugin
/// crate. The generic `extern "C"` shims are instantiated per implementor, so
/// one process (e.g. a test binary) can hold several exported plugins.
pub trait PluginStatic: 'static {
    /// The once-built tables.
    fn cell() -> &'static OnceLock<ExportedPlugin>;
    /// Describes the plugin; called once, on the first entry call.
    fn build() -> PluginBuilder;
}

/// The shape of an environment's actions, as the trampolines check them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum ActionKind {
    /// `Discrete(n)`.
    Discrete(u64),
    /// A box of this many dimensions.
    Box(usize),
}

pub(super) struct ExportedEnv {
    pub(super) desc: RwgEnvDesc,
    pub(super) vtable: RwgEnvVtable,
    pub(super) make: Constructor,
    pub(super) make_vec: Option<VecConstructor>,
    pub(super) obs_dim: usize,
    pub(super) action: ActionKind,
    // Storage the descriptor points into (heap buffers do not move).
    _id: CString,
    _summary: CString,
    _bounds: Vec<Vec<f64>>,
}

/// The C tables of an exported plugin. Built once by [`entry_v1`](super::entry_v1) and kept in
/// a `static` for the life of the library.
pub struct ExportedPlugin {
    pub(super) entry: RwgPluginEntry,
    pub(super) envs: Vec<ExportedEnv>,
    _id: CString,
    _version: CString,
}

// SAFETY: the raw pointers point into heap storage owned by the same value,
// which is never mutated after construction.
unsafe impl Send for ExportedPlugin {}
// SAFETY: as above; all access is read-only.
unsafe impl Sync for ExportedPlugin {}

fn c_string(what: &str, s: &str) -> Result<CString, String> {
    CString::new(s).map_err(|_| format!("{what} '{s}' contains a NUL byte"))
}

fn c_space(space: &Space, bounds: &mut Vec<Vec<f64>>) -> RwgSpace {
    match space {
        Space::Discrete { n } => RwgSpace {
            kind: RWG_SPACE_DISCRETE,
            reserved: 0,
            n: *n as u64,
            low: std::ptr::null(),
            high: std::ptr::null(),
        },
        Space::Box(b) => {
            let low = b.low.clone();
            let high = b.high.clone();
            let s = RwgSpace {
                kind: RWG_SPACE_BOX,
                reserved: 0,
                n: b.dim() as u64,
                low: low.as_ptr(),
                high: high.as_ptr(),
            };
            bounds.push(low);
            bounds.push(high);
            s
        }
    }
}

impl ExportedPlugin {
    /// Builds the tables, checking what the host would refuse anyway (so the
    /// plugin author sees the reason): ids non-empty, unique and NUL-free,
    /// observation spaces boxes, spaces non-empty.
    pub fn new<P: PluginStatic>(b: PluginBuilder) -> Result<ExportedPlugin, String> {
        if b.id.is_empty() {
            return Err("the plugin id is empty".into());
        }
        if b.envs.is_empty() {
            return Err(format!("plugin '{}' exports no environments", b.id));
        }
        let id = c_string("plugin id", &b.id)?;
        let version = c_string("plugin version", &b.version)?;
        let mut seen = HashSet::new();
        let mut envs = Vec::with_capacity(b.envs.len());
        for e in b.envs {
            envs.push(export_env::<P>(&b.id, e, &mut seen)?);
        }
        let entry = RwgPluginEntry {
            struct_size: ENTRY_SIZE_V1_0,
            abi_major: ABI_MAJOR,
            abi_minor: ABI_MINOR,
            reserved: 0,
            abi_tag: ABI_TAG.as_ptr(),
            plugin_id: id.as_ptr(),
            plugin_version: version.as_ptr(),
            init: Some(init::<P>),
            deinit: Some(deinit),
            env_count: Some(env_count::<P>),
            env_desc: Some(env_desc::<P>),
            env_vtable: Some(env_vtable::<P>),
            get_extension: Some(get_extension),
        };
        Ok(ExportedPlugin {
            entry,
            envs,
            _id: id,
            _version: version,
        })
    }

    /// The entry table.
    pub fn entry(&self) -> &RwgPluginEntry {
        &self.entry
    }
}

/// One environment's descriptor and function table, checked as
/// [`ExportedPlugin::new`] says; `seen` holds the ids exported before it.
fn export_env<P: PluginStatic>(
    plugin_id: &str,
    e: EnvExport,
    seen: &mut HashSet<String>,
) -> Result<ExportedEnv, String> {
    let spec = &e.spec;
    if spec.id.is_empty() {
        return Err(format!(
            "plugin '{}': an environment id is empty",
            plugin_id
        ));
    }
    if !seen.insert(spec.id.clone()) {
        return Err(format!(
            "plugin '{}': duplicate id '{}'",
            plugin_id, spec.id
        ));
    }
    let obs_dim = match &spec.observation_space {
        Space::Box(bx) if bx.dim() > 0 => bx.dim(),
        s => {
            return Err(format!(
                "env '{}': the observation space must be a non-empty Box, not {}",
                spec.id,
                s.describe()
            ))
        }
    };
    let action = match &spec.action_space {
        Space::Discrete { n } if *n > 0 && (*n as u64) <= MAX_DISCRETE_N => {
            ActionKind::Discrete(*n as u64)
        }
        Space::Box(bx) if bx.dim() > 0 => ActionKind::Box(bx.dim()),
        s => {
            return Err(format!(
                "env '{}': invalid action space {}",
                spec.id,
                s.describe()
            ))
        }
    };
    let env_id = c_string("environment id", &spec.id)?;
    let summary = c_string("summary", &e.summary)?;
    let mut bounds = Vec::new();
    let desc = RwgEnvDesc {
        struct_size: ENV_DESC_SIZE_V1_0,
        flags: 0,
        id: env_id.as_ptr(),
        summary: summary.as_ptr(),
        observation_space: c_space(&spec.observation_space, &mut bounds),
        action_space: c_space(&spec.action_space, &mut bounds),
        max_episode_steps: spec.max_episode_steps.unwrap_or(0),
        reserved: 0,
        reward_threshold: spec.reward_threshold.unwrap_or(f64::NAN),
    };
    let (make_vec, vec_fns) = match e.vec {
        Some((make, fns)) => (Some(make), Some(fns)),
        None => (None, None),
    };
    let vtable = RwgEnvVtable {
        struct_size: ENV_VTABLE_SIZE_V1_2,
        reserved: 0,
        create: Some(create::<P>),
        destroy: Some(e.fns.destroy),
        reset: Some(e.fns.reset),
        step: Some(e.fns.step),
        last_error: Some(e.fns.last_error),
        reset_many: Some(e.fns.reset_many),
        step_many: Some(e.fns.step_many),
        vec_create: vec_fns.map(|_| vec_create::<P> as VecCreateFn),
        vec_destroy: vec_fns.map(|f| f.destroy),
        vec_reset: vec_fns.map(|f| f.reset),
        vec_step: vec_fns.map(|f| f.step),
        vec_last_error: vec_fns.map(|f| f.last_error),
    };
    Ok(ExportedEnv {
        desc,
        vtable,
        make: e.make,
        make_vec,
        obs_dim,
        action,
        _id: env_id,
        _summary: summary,
        _bounds: bounds,
    })
}
