//! A manifest expanded into cells, and what `run` and `merge` share about them.

use crate::env_source::{describe, is_builtin, EnvSource, Found, PluginSource, Plugins};
use crate::error::CellError;
use crate::manifest::{EnvEntry, Manifest, ManifestError};
use crate::rundir::blocks::{finalize_cell, CellTotals, BLOCK_SAMPLES};
use crate::rundir::cell_dir;
use crate::rundir::meta::{CellId, CellMeta, RunMeta, ShardMeta, WeightsMeta, RUN_FORMAT};
use crate::rundir::names::check_distinct;
use crate::stats;
use crate::StudyError;
use rwg_core::policy::{Architecture, PolicyKind};
use rwg_core::sampler::BlockResult;
use rwg_core::sampler::CellPlan;
use rwg_env::{ActionDtype, EnvSpec, Environment, Space};
use rwg_envs::{visit, EnvOptions, EnvVisitor};
use rwg_plugin_host::PluginEnvType;
use std::path::Path;

/// One cell (env × architecture × bias) with everything resolved.
pub struct Cell {
    /// Which cell (env, architecture name and layers, bias, directory).
    pub id: CellId,
    /// What the sampler runs.
    pub plan: CellPlan,
    /// How the env is built.
    pub source: EnvSource,
    /// The env's description (with overrides applied).
    pub spec: EnvSpec,
    /// Solved score and where it came from.
    pub solved: Option<f64>,
    /// `manifest` or `env`.
    pub solved_source: Option<String>,
}

struct SpecOf;

impl EnvVisitor for SpecOf {
    type Output = EnvSpec;
    fn visit<E: Environment + Clone + Send + Sync + 'static>(self, env: E) -> EnvSpec {
        env.spec().clone()
    }
}

/// Finds where env `i` of the manifest comes from and checks that it builds
/// (errors point into the manifest). Returns the source and the spec with
/// the manifest's overrides applied.
fn resolve_env(
    m: &Manifest,
    i: usize,
    plugins: &mut Plugins,
    jax: &mut std::collections::HashMap<usize, rwg_jax::StartingSource>,
) -> Result<(EnvSource, EnvSpec), ManifestError> {
    let e: &EnvEntry = &m.envs[i];
    if crate::jax_source::is_jax(&e.id) {
        let src = crate::jax_source::open_entry(m, i, jax.remove(&i))?;
        let spec = src.info().spec.clone();
        return Ok((EnvSource::Jax(std::sync::Arc::new(src)), spec));
    }
    if crate::gym_source::is_gym(&e.id) {
        let src = crate::gym_source::open_entry(m, i)?;
        let spec = src.info().spec.clone();
        return Ok((EnvSource::Gym(std::sync::Arc::new(src)), spec));
    }
    crate::gym_source::check_not_gym_fields(m, i)?;
    let key = format!("envs[{i}]");
    let ty = match &e.plugin {
        Some(path) => plugin_file_env(m, e, &key, path, plugins)?,
        None => match plugins.find(&e.id) {
            Found::Builtin => return builtin_env(m, e, &key),
            Found::OnPath(ty) => *ty,
            Found::Unknown(msg) => {
                return Err(m.error_at(e.id_span.clone(), format!("envs: {msg}")))
            }
        },
    };
    open_plugin_env(m, e, &key, ty)
}

/// The env type of entry `e` (`key`) in the plugin file `path` it names.
fn plugin_file_env(
    m: &Manifest,
    e: &EnvEntry,
    key: &str,
    path: &Path,
    plugins: &mut Plugins,
) -> Result<PluginEnvType, ManifestError> {
    let at = e.plugin_span.clone().unwrap_or(e.id_span.clone());
    let id_err = |msg: String| m.error_at(e.id_span.clone(), msg);
    if is_builtin(&e.id) {
        return Err(id_err(format!(
            "{key}.id: '{}' is a built-in environment; remove `plugin` to run it \
             (a plugin cannot replace a built-in id)",
            e.id
        )));
    }
    crate::plugin_path::check_file(key, path).map_err(|msg| m.error_at(at.clone(), msg))?;
    let plugin = plugins
        .file(path)
        .map_err(|err| m.error_at(at, format!("{key}.plugin: {err}")))?;
    if let Some(ty) = plugin.env(&e.id) {
        return Ok(ty.clone());
    }
    let ids: Vec<&str> = plugin.envs().iter().map(|t| t.id()).collect();
    let hint = rwg_env::suggest::nearest(&e.id, ids.iter().copied())
        .map(|s| format!(" (did you mean '{s}'?)"))
        .unwrap_or_default();
    Err(id_err(format!(
        "{key}.id: plugin '{}' ({}) has no environment '{}'{hint}; its environments: {}",
        plugin.id(),
        path.display(),
        e.id,
        ids.join(", ")
    )))
}

/// Built-in env `e` (`key`), which takes no `config`.
fn builtin_env(
    m: &Manifest,
    e: &EnvEntry,
    key: &str,
) -> Result<(EnvSource, EnvSpec), ManifestError> {
    if let Some(at) = e.config_span.clone() {
        return Err(m.error_at(
            at,
            format!(
                "{key}.config: '{}' is built in; only plugin environments take a config string",
                e.id
            ),
        ));
    }
    let opts = EnvOptions {
        action_dtype: e.action_dtype.unwrap_or_default(),
        max_episode_steps: e.max_episode_steps,
    };
    let spec = visit(&e.id, &opts, SpecOf).expect("a built-in id");
    Ok((EnvSource::Builtin(opts), spec))
}

/// Plugin env `e` (`key`) of type `ty`, with one instance created (in a
/// worker process if isolated) so that running the cells cannot fail to.
fn open_plugin_env(
    m: &Manifest,
    e: &EnvEntry,
    key: &str,
    ty: PluginEnvType,
) -> Result<(EnvSource, EnvSpec), ManifestError> {
    if e.action_dtype.unwrap_or_default() != ActionDtype::default() {
        return Err(m.error_at(
            e.id_span.clone(),
            format!(
                "{key}.action_dtype: applies to built-in environments only; {} takes its settings \
             through `config`",
                describe(&ty)
            ),
        ));
    }
    let mut source = PluginSource {
        ty,
        config: e.config.clone().unwrap_or_default(),
        max_episode_steps: e.max_episode_steps,
        isolated: None,
    };
    let cannot = |err: rwg_env::EnvError, config: &str| {
        m.error_at(
            e.config_span.clone().unwrap_or(e.id_span.clone()),
            format!(
                "{key}: cannot create '{}' with config {config:?}: {err}",
                e.id
            ),
        )
    };
    if e.isolate {
        // Its instances are created in a first worker process (kept for
        // the run), never in this one.
        let iso = crate::isolate::IsolatedPlugin::open(&source)
            .map_err(|err| cannot(err, &source.config))?;
        let spec = iso.spec().clone();
        source.isolated = Some(std::sync::Arc::new(iso));
        return Ok((EnvSource::Plugin(Box::new(source)), spec));
    }
    // Create one instance now, so that running the cells cannot fail to.
    let env = source.make().map_err(|err| cannot(err, &source.config))?;
    let spec = env.spec().clone();
    Ok((EnvSource::Plugin(Box::new(source)), spec))
}

/// Expands the manifest into cells (env, then architecture, then bias),
/// finding every env (errors point into the manifest).
///
/// An id is built in, or comes from the `plugin =` file given with it, or
/// else from the plugins on `RWG_PLUGIN_PATH`; such an entry gets that
/// file's path written into `m.envs[i].plugin`, so the resolved manifest
/// (`manifest.toml` of a run) names the file that provided the env and a run
/// resumed with another file is a different study. Plugins are loaded (their
/// code runs) and one instance of each plugin env is created.
pub fn plan_cells(m: &mut Manifest) -> Result<Vec<Cell>, StudyError> {
    let mut cells = vec![];
    // (env index, architecture index) of each cell, to name colliding entries
    let mut owners = vec![];
    let mut plugins = Plugins::default();
    // JAX workers import while the other envs are resolved
    let mut jax = crate::jax_source::start_all(m);
    for i in 0..m.envs.len() {
        let (source, spec) = resolve_env(m, i, &mut plugins, &mut jax)?;
        if let EnvSource::Plugin(p) = &source {
            if m.envs[i].plugin.is_none() {
                m.envs[i].plugin = Some(std::path::absolute(p.path()).map_err(StudyError::io(
                    format!("cannot resolve {}", p.path().display()),
                ))?);
            }
        }
        let e = &m.envs[i];
        if spec.max_episode_steps.is_none() {
            return Err(m
                .error_at(
                    e.id_span.clone(),
                    format!(
                        "envs[{i}]: '{}' has no time limit (its max_episode_steps is 0: none), \
                         and rwg run needs one to bound every episode; set max_episode_steps \
                         in this [[envs]] entry",
                        e.id
                    ),
                )
                .into());
        }
        let (solved, solved_source) = match (e.solved, spec.reward_threshold) {
            (Some(s), _) => (Some(s), Some("manifest".to_string())),
            (None, Some(t)) => (Some(t), Some("env".to_string())),
            (None, None) => (None, None),
        };
        let seed_id = seed_id(&e.id).to_string();
        for (j, a) in m.architectures.iter().enumerate() {
            for &bias in a.biases(&m.bias) {
                owners.push((i, j));
                let plan = CellPlan {
                    seed: m.seed,
                    env_id: seed_id.clone(),
                    arch: Architecture {
                        hidden: a.hidden.clone(),
                        bias,
                    },
                    episodes: m.episodes,
                    dist: m.weights,
                    policy: a.policy,
                    non_finite: e.non_finite,
                };
                check_cell(m, i, j, &plan, &spec)?;
                cells.push(Cell {
                    // (Cells whose directories would be one, also on case-insensitive
                    // file systems, are refused below, naming both manifest lines.)
                    id: CellId::new(&e.id, &a.name, &a.hidden, bias),
                    plan,
                    source: source.clone(),
                    spec: spec.clone(),
                    solved,
                    solved_source: solved_source.clone(),
                });
            }
        }
    }
    let names: Vec<&str> = cells.iter().map(|c| c.id.dir.as_str()).collect();
    if let Some((x, y)) = check_distinct(&names) {
        return Err(StudyError::Manifest(collision(
            m, owners[x], owners[y], names[x], names[y],
        )));
    }
    Ok(cells)
}

/// Refuses the cell of `plan` (env `i`, architecture `j`) where it cannot
/// run on `spec`: a network over rwg's weight limit; random actions in a box
/// with a bound that is not finite (nothing is uniform on it).
fn check_cell(
    m: &Manifest,
    i: usize,
    j: usize,
    plan: &CellPlan,
    spec: &EnvSpec,
) -> Result<(), ManifestError> {
    let (e, a) = (&m.envs[i], &m.architectures[j]);
    let n_weights = plan.net_shape(spec).n_weights();
    if n_weights > crate::limits::MAX_WEIGHTS {
        return Err(m.error_at(
            e.id_span.clone(),
            format!(
                "envs[{i}]: architectures[{j}] '{}' on '{}' has {n_weights} weights per \
                 network; at most {} (rwg's limit)",
                a.name,
                e.id,
                crate::limits::MAX_WEIGHTS
            ),
        ));
    }
    if let (PolicyKind::Random, Space::Box(b)) = (plan.policy, &spec.action_space) {
        if !b.low.iter().chain(&b.high).all(|v| v.is_finite()) {
            return Err(m.error_at(
                e.id_span.clone(),
                format!(
                    "envs[{i}]: architectures[{j}] '{}' (policy = \"random\") on '{}': its \
                     action space {} has bounds that are not finite, and no action is \
                     uniformly random on an unbounded box; leave this env out of a manifest \
                     with random actions, or give it finite bounds",
                    a.name,
                    e.id,
                    spec.action_space.describe()
                ),
            ));
        }
    }
    Ok(())
}

/// The error for two cells whose directories would be one on some file
/// system: located at the second entry, naming both.
fn collision(
    m: &Manifest,
    (e1, a1): (usize, usize),
    (e2, a2): (usize, usize),
    n1: &str,
    n2: &str,
) -> ManifestError {
    let line = |span: std::ops::Range<usize>| m.error_at(span, "").line;
    let (what, first, second, span) = if e1 == e2 {
        let (x, y) = (&m.architectures[a1], &m.architectures[a2]);
        (
            format!(
                "architectures[{a1}].name '{}' and architectures[{a2}].name '{}'",
                x.name, y.name
            ),
            line(x.name_span.clone()),
            line(y.name_span.clone()),
            y.name_span.clone(),
        )
    } else {
        let (x, y) = (&m.envs[e1], &m.envs[e2]);
        (
            format!("envs[{e1}].id '{}' and envs[{e2}].id '{}'", x.id, y.id),
            line(x.id_span.clone()),
            line(y.id_span.clone()),
            y.id_span.clone(),
        )
    };
    m.error_at(
        span,
        format!(
            "{what} (lines {first} and {second}) give cell directories {n1} and {n2}, which are \
             one directory on case-insensitive file systems (macOS, Windows); rename one"
        ),
    )
}

/// The id that enters the seeds: a Gymnasium or JAX env's id without its
/// prefix (`gymnasium:`, `gymnax:`, `brax:`, `jax:`), so that it meets what
/// the built-in env of that id meets (network n has the same weights).
pub fn seed_id(id: &str) -> &str {
    rwg_gym::gym_id(id)
        .or(rwg_jax::jax_id(id).map(|(_, rest)| rest))
        .unwrap_or(id)
}

impl Cell {
    /// The dtype the env's continuous actions are computed in: the manifest's
    /// for a built-in env; float64 for a plugin env (actions cross the ABI as
    /// doubles; what the plugin does with them is up to it and its config);
    /// a JAX env's precision.
    pub fn action_dtype(&self) -> ActionDtype {
        match &self.source {
            EnvSource::Builtin(opts) => opts.action_dtype,
            EnvSource::Plugin(_) => ActionDtype::F64,
            EnvSource::Gym(g) => g.config().action_dtype,
            EnvSource::Jax(j) => match j.config().precision {
                rwg_jax::Precision::F32 => ActionDtype::F32,
                rwg_jax::Precision::F64 => ActionDtype::F64,
            },
        }
    }

    /// A new instance of the cell's env behind a trait object (for code
    /// outside the sampler's hot loop).
    pub fn make_env(&self) -> Result<Box<dyn Environment + Send>, StudyError> {
        Ok(match &self.source {
            EnvSource::Builtin(opts) => rwg_envs::make(&self.plan.env_id, opts)?,
            EnvSource::Plugin(p) => Box::new(p.make()?),
            EnvSource::Gym(g) => Box::new(g.make_single().map_err(rwg_env::EnvError::from)?),
            EnvSource::Jax(_) => {
                return Err(StudyError::Refused(format!(
                    "{}: a JAX env runs whole episodes in compiled calls, not step by step \
                     through rwg; its episodes are replayed through a JAX worker",
                    self.spec.id
                )))
            }
        })
    }

    /// The env as this cell runs it, for the cell's `env.json`
    /// ([`crate::rundir::env_record`]).
    pub fn env_record(&self) -> crate::rundir::env_record::EnvRecord {
        use crate::rundir::env_record::{EnvRecord, GymRecord, JaxRecord};
        let gymnasium = match &self.source {
            EnvSource::Gym(g) => Some(GymRecord {
                observation_space: g.info().observation_space.clone(),
                action_space: g.info().action_space.clone(),
                python_hash_seed: g.config().hash_seed.clone(),
                gymnasium_version: g.info().gymnasium.clone(),
                python_version: g.info().python.clone(),
            }),
            _ => None,
        };
        let record = EnvRecord::new(&self.spec, gymnasium);
        match &self.source {
            EnvSource::Jax(j) => record.with_jax(JaxRecord {
                observation_space: j.info().observation_space.clone(),
                action_space: j.info().action_space.clone(),
                versions: j.info().versions.clone(),
                device_kind: j.info().device_kind.clone(),
                platform: j.info().platform.clone(),
                precision: j.info().precision.name().to_string(),
                matmul_precision: j.config().matmul_precision.name().to_string(),
                lanes: j.lanes(),
                refill: (j.lanes() / 8).max(1),
                episode_loop: Some(j.info().episode_loop.clone()),
                source: j.info().source.clone(),
                observation_leaves: j.info().observation_leaves.clone(),
                action_mask: Some(j.info().action_mask.clone()),
                settings: j.info().settings.clone(),
            }),
            _ => record,
        }
    }

    /// The rows of the cell's score files: `m`'s episodes per network, and
    /// the `non_finite` flag when its env has `non_finite = "end"`.
    pub fn rows(&self, m: &Manifest) -> crate::rundir::rows::CellRows {
        crate::rundir::rows::CellRows {
            episodes: m.episodes,
            flagged: self.plan.non_finite == rwg_core::sampler::NonFinite::End,
        }
    }

    /// The cell's metadata for `run.json` / `cell.json` (its
    /// `non_finite_episodes` left for the finalisation to count).
    pub fn meta(&self, m: &Manifest, env_steps: u64, wall_s: f64) -> CellMeta {
        CellMeta {
            id: self.id.clone(),
            n_weights: self.plan.net_shape(&self.spec).n_weights(),
            obs_dim: self.spec.obs_dim(),
            max_episode_steps: self.spec.max_episode_steps.unwrap_or(0),
            solved: self.solved,
            solved_source: self.solved_source.clone(),
            samples: m.samples,
            episodes: m.episodes,
            wall_s,
            env_steps,
            steps_per_s: if wall_s > 0.0 {
                env_steps as f64 / wall_s
            } else {
                0.0
            },
            non_finite_episodes: None,
        }
    }

    /// Finalises the cell in `out` (all blocks present) and returns its
    /// metadata and totals (with every episode's score and length if `keep`);
    /// `pending`: its blocks not committed to files ([`finalize_cell`]).
    pub fn finalize(
        &self,
        m: &Manifest,
        out: &Path,
        wall_s: f64,
        keep: bool,
        pending: &[BlockResult],
    ) -> Result<(CellMeta, CellTotals), StudyError> {
        let dir = cell_dir(out, &self.id.dir);
        let mut meta = None;
        // (Cells without a time limit are refused when planned.)
        let limit = self.spec.max_episode_steps.unwrap_or(u32::MAX);
        let totals = finalize_cell(&dir, m.samples, self.rows(m), limit, keep, pending, |t| {
            let mut cm = self.meta(m, t.env_steps, wall_s);
            cm.non_finite_episodes = t.non_finite;
            let json = serde_json::to_string_pretty(&cm).expect("serialisable");
            meta = Some(cm);
            Some(json)
        })
        .map_err(|source| StudyError::RunDir {
            context: format!("cannot finalise cell {}", self.id.dir),
            source,
        })?;
        Ok((meta.expect("set by finalize_cell"), totals))
    }

    /// The run's error for a failure of this cell (naming the cell, its
    /// plugin or Gymnasium env, and the run directory).
    pub fn failure(&self, out: &Path, e: CellError) -> StudyError {
        match e {
            CellError::Interrupted => StudyError::Interrupted,
            source => StudyError::Cell {
                cell: self.id.dir.clone(),
                plugin: match &self.source {
                    EnvSource::Plugin(p) => Some(p.path().to_path_buf()),
                    EnvSource::Builtin(_) | EnvSource::Gym(_) | EnvSource::Jax(_) => None,
                },
                gym: match &self.source {
                    EnvSource::Gym(g) => {
                        Some(format!("{}, Python {}", self.spec.id, g.config().python))
                    }
                    EnvSource::Jax(j) => {
                        Some(format!("{}, Python {}", self.spec.id, j.config().python))
                    }
                    _ => None,
                },
                out: out.to_path_buf(),
                source: Box::new(source),
            },
        }
    }

    /// One line of the end-of-run summary, computed by the statistics code
    /// that writes `stats.csv` (the same median, best mean and solved count).
    pub fn summary_line(&self, means: &[f64], steps_per_s: Option<f64>) -> SummaryLine {
        SummaryLine {
            dir: self.id.dir.clone(),
            best_mean: stats::max(means),
            median_mean: stats::percentile(means, 50.0),
            solved_percent: self.solved.map(|s| {
                let prop = stats::solved_fraction(means, s);
                100.0 * prop.successes as f64 / prop.trials as f64
            }),
            steps_per_s,
        }
    }
}

/// A finished cell's line in the end-of-run summary of `rwg run` / `rwg merge`.
#[derive(Debug, Clone, PartialEq)]
pub struct SummaryLine {
    /// The cell's directory name.
    pub dir: String,
    /// Highest sample mean.
    pub best_mean: f64,
    /// Median of the sample means (as in `stats.csv`).
    pub median_mean: f64,
    /// Percentage of samples whose mean reaches the solved score (`None`
    /// without a solved score).
    pub solved_percent: Option<f64>,
    /// Env steps per second of the cell (`None` when unknown, as after a merge).
    pub steps_per_s: Option<f64>,
}

/// Fresh run metadata for manifest `m`.
pub fn new_meta(
    m: &Manifest,
    threads: usize,
    start_time: String,
    shard: Option<ShardMeta>,
) -> RunMeta {
    RunMeta {
        format: RUN_FORMAT,
        rwg_version: env!("CARGO_PKG_VERSION").into(),
        seed: m.seed,
        samples: m.samples,
        episodes: m.episodes,
        weights: WeightsMeta {
            distribution: m.weights.name().into(),
            scale: m.weights.scale(),
        },
        threads,
        start_time,
        end_time: None,
        wall_s: 0.0,
        env_steps: 0,
        steps_per_s: 0.0,
        cells: vec![],
        block_samples: BLOCK_SAMPLES,
        shard,
        study: Some(m.to_toml()),
    }
}
