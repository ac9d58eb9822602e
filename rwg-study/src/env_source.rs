//! Where environments come from: built in (`rwg-envs`, statically
//! dispatched) or a plugin library (an explicit file, or the
//! `RWG_PLUGIN_PATH` scan, which never shadows a built-in id), or a Gymnasium
//! env (`gymnasium:ID`, run by `rwg-gym`'s Python workers), or a JAX env
//! (`gymnax:ID`, `brax:NAME`, `jax:module:callable`, run by `rwg-jax`'s
//! Python workers, one compiled call per chunk of networks). A new kind of
//! environment source is a new [`EnvSource`] variant here, with its arm in
//! [`EnvSource::run_blocks`] (how a cell's blocks are sampled) and
//! [`EnvSource::fault_label`].

use crate::cells::Cell;
use crate::error::CellError;
use crate::fault_context::Watched;
use rwg_core::many::run_blocks_many;
use rwg_core::sampler::{run_blocks, BlockResult, CellPlan, LANES};
use rwg_env::{EnvError, Environment, TimeLimit};
use rwg_envs::{visit, visit_lockstep, EnvOptions, EnvVisitor, LockstepEnv, LockstepVisitor};
use rwg_plugin_host::{
    load_plugin, load_plugin_path_from_env_reserving, Plugin, PluginEnv, PluginEnvType,
    PluginLoadError, PluginScan, PLUGIN_PATH_VAR,
};
use std::collections::HashMap;
use std::ops::Range;
use std::path::{Path, PathBuf};

/// Where a cell's environment comes from.
#[derive(Debug, Clone)]
pub enum EnvSource {
    /// Built in: statically dispatched through [`rwg_envs::visit`].
    Builtin(EnvOptions),
    /// From a plugin library (given with `plugin =` or found on `RWG_PLUGIN_PATH`).
    Plugin(Box<PluginSource>),
    /// A Gymnasium env run by Python worker processes (`gymnasium:ID`); its
    /// workers are shared by the env's cells.
    Gym(std::sync::Arc<rwg_gym::GymSource>),
    /// A JAX env run by Python worker processes (`gymnax:`, `brax:`,
    /// `jax:`); its workers are shared by the env's cells.
    Jax(std::sync::Arc<rwg_jax::JaxSource>),
}

impl EnvSource {
    /// Runs the given blocks of a cell (`plan`), each finished block to
    /// `on_block`, in block order; the cell stops at `on_block`'s first
    /// error. Built-in envs are statically dispatched (the sampler is
    /// monomorphised for each), through their lockstep version (all lanes in
    /// one `step_many`) where they have one and
    /// [`use_lockstep`](crate::runner::use_lockstep) says so; plugin envs
    /// see [`PluginSource::run_blocks`]; Gymnasium envs run through the
    /// remote sampler (`rwg_core::remote`); JAX envs through their workers'
    /// compiled calls (`rwg_jax`). Called inside the run's worker pool.
    pub fn run_blocks(
        &self,
        plan: &CellPlan,
        blocks: &[Range<u64>],
        on_block: impl FnMut(BlockResult) -> Result<(), CellError>,
    ) -> Result<(), CellError> {
        match self {
            EnvSource::Builtin(opts) => run_builtin(opts, plan, blocks, on_block),
            EnvSource::Plugin(p) => p.run_blocks(plan, blocks, on_block),
            // Remote: one Python worker per thread steps its 16 lanes together.
            EnvSource::Gym(g) => g.run_blocks(plan, blocks, wave(), on_block),
            // Compiled calls of many networks: one worker process per thread on
            // a CPU device, one on a GPU or TPU (rwg_jax::JaxSource::workers_for).
            EnvSource::Jax(j) => j.run_blocks(plan, blocks, rayon::current_num_threads(), on_block),
        }
    }

    /// Whether `self` and `other` are one JAX env's source (its workers).
    fn same_jax(&self, other: &EnvSource) -> bool {
        matches!((self, other), (EnvSource::Jax(a), EnvSource::Jax(b)) if std::sync::Arc::ptr_eq(a, b))
    }

    /// Ends a JAX env's idle worker processes, and the memory their
    /// imports and compiled programs hold, unless a cell of `keep` runs
    /// on the same env (a later cell of it starts new ones). Other envs
    /// keep no process between cells.
    pub fn release_unless_used<'a>(&self, mut keep: impl Iterator<Item = &'a EnvSource>) {
        if let EnvSource::Jax(j) = self {
            if !keep.any(|o| self.same_jax(o)) {
                j.release_workers();
            }
        }
    }

    /// For a JAX env, the wall time its cells' warm-ups (workers starting,
    /// compiling) took so far, added up (`rwg_jax::JaxSource::warm_up_time`);
    /// `None` for the envs that compile nothing.
    pub fn warm_up_time(&self) -> Option<std::time::Duration> {
        match self {
            EnvSource::Jax(j) => Some(j.warm_up_time()),
            _ => None,
        }
    }

    /// How a fault report names `cell` (whose source this is) and its env
    /// (see [`fault_context`](crate::fault_context)).
    pub fn fault_label(&self, cell: &Cell) -> String {
        match self {
            EnvSource::Plugin(p) => format!(
                "plugin '{}' ({}), env '{}', cell {}",
                p.ty.plugin().id,
                p.path().display(),
                cell.plan.env_id,
                cell.id.dir
            ),
            EnvSource::Builtin(_) => {
                format!("env '{}', cell {}", cell.plan.env_id, cell.id.dir)
            }
            EnvSource::Gym(_) => format!("env '{}', cell {}", cell.spec.id, cell.id.dir),
            EnvSource::Jax(j) => format!(
                "JAX env '{}' ({} on {}), cell {}",
                cell.spec.id,
                j.info().precision.name(),
                j.info().device,
                cell.id.dir
            ),
        }
    }
}

/// Blocks in flight at once: two per worker thread of the pool running them.
fn wave() -> usize {
    rayon::current_num_threads() * 2
}

/// A built-in env's blocks: through its lockstep version when it has one
/// and [`use_lockstep`](crate::runner::use_lockstep) says so, else one
/// scalar env per lane.
fn run_builtin(
    opts: &EnvOptions,
    plan: &CellPlan,
    blocks: &[Range<u64>],
    on_block: impl FnMut(BlockResult) -> Result<(), CellError>,
) -> Result<(), CellError> {
    let mut runner = BuiltinRunner {
        plan,
        blocks,
        on_block,
    };
    let id = &plan.env_id;
    if crate::runner::use_lockstep() {
        match visit_lockstep::<LANES, _>(id, opts, runner) {
            Ok(done) => return done,
            Err(back) => runner = back,
        }
    }
    visit(id, opts, runner).expect("env ids are checked when cells are planned")
}

/// A built-in env's blocks, handed the env by [`visit`] or [`visit_lockstep`].
struct BuiltinRunner<'a, G> {
    plan: &'a CellPlan,
    blocks: &'a [Range<u64>],
    on_block: G,
}

impl<G: FnMut(BlockResult) -> Result<(), CellError>> EnvVisitor for BuiltinRunner<'_, G> {
    type Output = Result<(), CellError>;
    fn visit<E: Environment + Clone + Send + Sync + 'static>(self, env: E) -> Self::Output {
        run_blocks(
            self.plan,
            self.blocks,
            wave(),
            || env.clone(),
            self.on_block,
        )
    }
}

impl<G: FnMut(BlockResult) -> Result<(), CellError>> LockstepVisitor for BuiltinRunner<'_, G> {
    type Output = Result<(), CellError>;
    fn visit<M: LockstepEnv + Clone + Send + Sync + 'static>(self, env: M) -> Self::Output {
        let make = || Ok(env.clone());
        run_blocks_many(self.plan, self.blocks, wave(), make, self.on_block)
    }
}

/// A plugin environment as a cell builds it.
#[derive(Debug, Clone)]
pub struct PluginSource {
    /// The environment type (its plugin, spec and constructor).
    pub ty: PluginEnvType,
    /// The manifest's `config` (`""` if not given).
    pub config: String,
    /// The manifest's time limit override.
    pub max_episode_steps: Option<u32>,
    /// Set when the env runs isolated (`isolate`): its worker processes,
    /// which `rwg run` steps instead of in-process instances.
    pub isolated: Option<std::sync::Arc<crate::isolate::IsolatedPlugin>>,
}

impl PluginSource {
    /// A new instance with the cell's config and time limit.
    pub fn make(&self) -> Result<TimeLimit<PluginEnv>, EnvError> {
        self.ty.make(&self.config, self.max_episode_steps)
    }

    /// The plugin library file.
    pub fn path(&self) -> &Path {
        &self.ty.plugin().path
    }

    /// Runs the given blocks of a cell of this plugin env (see
    /// [`EnvSource::run_blocks`]): isolated, stepped by exchanges with one worker
    /// process per thread ([`isolate`](crate::isolate)); with ABI 1.2's
    /// vector env or 1.1's batched calls, one call stepping a worker's lanes
    /// ([`plugin_batch`](crate::plugin_batch)); else through the generic
    /// sampler as `Watched<TimeLimit<PluginEnv>>`, its calls recorded for
    /// fault reports ([`fault_context`](crate::fault_context)).
    pub fn run_blocks(
        &self,
        plan: &CellPlan,
        blocks: &[Range<u64>],
        on_block: impl FnMut(BlockResult) -> Result<(), CellError>,
    ) -> Result<(), CellError> {
        if let Some(iso) = &self.isolated {
            return iso.run_blocks(plan, blocks, wave(), on_block);
        }
        if let Some(calls) = crate::plugin_batch::calls_for(self) {
            return crate::plugin_batch::run_blocks(self, calls, plan, blocks, wave(), on_block);
        }
        let make_env = || {
            Watched::create(|| {
                self.make()
                    .expect("an instance was created when the cells were planned")
            })
        };
        run_blocks(plan, blocks, wave(), make_env, on_block)
    }
}

/// Whether `id` is a built-in environment.
pub fn is_builtin(id: &str) -> bool {
    rwg_envs::registry::registration(id).is_some()
}

/// Loads every plugin on `RWG_PLUGIN_PATH`. Files that fail to load, repeat
/// an id of an earlier file, or export a built-in id are rejected with the
/// reason. Runs the plugins' code in this process.
pub fn scan_plugin_path() -> PluginScan {
    load_plugin_path_from_env_reserving(&is_builtin)
}

/// Plugins loaded so far by one command: explicit files (each loaded once)
/// and, when first needed, the `RWG_PLUGIN_PATH` scan.
#[derive(Default)]
pub struct Plugins {
    files: HashMap<PathBuf, Result<Plugin, PluginLoadError>>,
    scan: Option<PluginScan>,
}

/// Where an env id was found.
pub enum Found {
    /// A built-in environment.
    Builtin,
    /// An environment of a plugin on `RWG_PLUGIN_PATH`.
    OnPath(Box<PluginEnvType>),
    /// Nowhere: the message says what was searched.
    Unknown(String),
}

impl Plugins {
    /// The plugin in file `path`, loaded on first use.
    pub fn file(&mut self, path: &Path) -> Result<&Plugin, &PluginLoadError> {
        self.files
            .entry(path.to_path_buf())
            .or_insert_with(|| load_plugin(path))
            .as_ref()
    }

    /// The `RWG_PLUGIN_PATH` scan, done on first use.
    pub fn scan(&mut self) -> &PluginScan {
        self.scan.get_or_insert_with(scan_plugin_path)
    }

    /// Finds an env id given without a plugin file: built in, else on
    /// `RWG_PLUGIN_PATH` (scanned only then).
    pub fn find(&mut self, id: &str) -> Found {
        if is_builtin(id) {
            return Found::Builtin;
        }
        let scan = self.scan();
        if let Some(ty) = scan.plugins.iter().find_map(|p| p.env(id)) {
            return Found::OnPath(Box::new(ty.clone()));
        }
        let builtin: Vec<&str> = rwg_envs::registry::known_ids().collect();
        let on_path: Vec<&str> = scan
            .plugins
            .iter()
            .flat_map(|p| p.envs().iter().map(|e| e.id()))
            .collect();
        let suggestion = rwg_env::suggest::nearest(id, builtin.iter().chain(&on_path).copied())
            .map(|s| format!(" (did you mean '{s}'?)"))
            .unwrap_or_default();
        let mut msg = format!(
            "unknown environment '{id}'{suggestion}; known environments: {}",
            builtin.join(", ")
        );
        match std::env::var_os(PLUGIN_PATH_VAR) {
            None => msg.push_str(&format!(
                "; for a plugin environment, give its library with `plugin = \"path\"` \
                 or list its folder in {PLUGIN_PATH_VAR}"
            )),
            Some(_) if on_path.is_empty() => {
                msg.push_str(&format!("; no plugin environments on {PLUGIN_PATH_VAR}"))
            }
            Some(_) => msg.push_str(&format!("; on {PLUGIN_PATH_VAR}: {}", on_path.join(", "))),
        }
        if !scan.rejected.is_empty() {
            let why: Vec<String> = scan.rejected.iter().map(|r| r.to_string()).collect();
            msg.push_str(&format!(
                "; rejected on {PLUGIN_PATH_VAR}: {}",
                why.join("; ")
            ));
        }
        Found::Unknown(msg)
    }
}

/// "plugin 'id' (file)": how messages name a plugin.
pub fn describe(ty: &PluginEnvType) -> String {
    format!(
        "plugin '{}' ({})",
        ty.plugin().id,
        ty.plugin().path.display()
    )
}
