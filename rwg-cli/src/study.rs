//! A manifest expanded into cells, and what `run` and `merge` share about them.

use anyhow::{Context, Result};
use rwg_core::manifest::Manifest;
use rwg_core::policy::{Architecture, NetShape};
use rwg_core::run_meta::{cell_dir_name, CellMeta, RunMeta, ShardMeta, WeightsMeta, RUN_FORMAT};
use rwg_core::rundir::{finalize_cell, CellTotals, BLOCK_SAMPLES};
use rwg_core::sampler::CellPlan;
use rwg_core::{EnvSpec, Environment};
use rwg_envs::{visit, EnvOptions, EnvVisitor};
use std::path::Path;

/// One cell (env × architecture × bias) with everything resolved.
pub struct Cell {
    /// What the sampler runs.
    pub plan: CellPlan,
    /// Architecture name from the manifest.
    pub arch_name: String,
    /// How the env is built.
    pub opts: EnvOptions,
    /// The env's description (with overrides applied).
    pub spec: EnvSpec,
    /// Solved score and where it came from.
    pub solved: Option<f64>,
    /// `manifest` or `env`.
    pub solved_source: Option<String>,
    /// Directory name under `cells/`.
    pub dir: String,
}

struct SpecOf;

impl EnvVisitor for SpecOf {
    type Output = EnvSpec;
    fn visit<E: Environment + Clone + Send + Sync + 'static>(self, env: E) -> EnvSpec {
        env.spec().clone()
    }
}

/// Expands the manifest into cells (env, then architecture, then bias),
/// checking env ids (errors point into the manifest).
pub fn plan_cells(m: &Manifest) -> Result<Vec<Cell>> {
    let mut cells = vec![];
    for e in &m.envs {
        if e.plugin.is_some() {
            return Err(m
                .error_at(
                    e.id_span.clone(),
                    format!(
                        "env '{}': plugin environments are not supported by this build",
                        e.id
                    ),
                )
                .into());
        }
        let opts = EnvOptions {
            action_dtype: e.action_dtype,
            max_episode_steps: e.max_episode_steps,
        };
        let spec = visit(&e.id, &opts, SpecOf)
            .map_err(|err| m.error_at(e.id_span.clone(), format!("envs: {err}")))?;
        let (solved, solved_source) = match (e.solved, spec.reward_threshold) {
            (Some(s), _) => (Some(s), Some("manifest".to_string())),
            (None, Some(t)) => (Some(t), Some("env".to_string())),
            (None, None) => (None, None),
        };
        for a in &m.architectures {
            for &bias in &m.bias {
                cells.push(Cell {
                    plan: CellPlan {
                        seed: m.seed,
                        env_id: e.id.clone(),
                        arch: Architecture {
                            hidden: a.hidden.clone(),
                            bias,
                        },
                        episodes: m.episodes,
                        dist: m.weights,
                    },
                    arch_name: a.name.clone(),
                    opts,
                    spec: spec.clone(),
                    solved,
                    solved_source: solved_source.clone(),
                    dir: cell_dir_name(&e.id, &a.name, bias),
                });
            }
        }
    }
    Ok(cells)
}

impl Cell {
    /// The cell's metadata for `run.json` / `cell.json`.
    pub fn meta(&self, m: &Manifest, env_steps: u64, wall_s: f64) -> CellMeta {
        let shape = NetShape::new(
            self.spec.obs_dim(),
            &self.plan.arch,
            NetShape::outputs_for(&self.spec.action_space),
        );
        CellMeta {
            dir: self.dir.clone(),
            env: self.spec.id.clone(),
            arch: self.arch_name.clone(),
            hidden: self.plan.arch.hidden.clone(),
            bias: self.plan.arch.bias,
            n_weights: shape.n_weights(),
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
        }
    }

    /// Finalises the cell in `out` (all blocks present) and returns its metadata.
    pub fn finalize(
        &self,
        m: &Manifest,
        out: &Path,
        wall_s: f64,
    ) -> Result<(CellMeta, CellTotals)> {
        let dir = out.join("cells").join(&self.dir);
        let mut meta = None;
        let totals = finalize_cell(&dir, m.samples, m.episodes, |t| {
            let cm = self.meta(m, t.env_steps, wall_s);
            let json = serde_json::to_string_pretty(&cm).expect("serialisable");
            meta = Some(cm);
            Some(json)
        })
        .with_context(|| format!("cannot finalise cell {}", self.dir))?;
        Ok((meta.expect("set by finalize_cell"), totals))
    }

    /// One line of the end-of-run summary.
    pub fn summary_line(&self, means: &[f64], steps_per_s: f64) -> String {
        let best = means.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let mut sorted = means.to_vec();
        sorted.sort_by(f64::total_cmp);
        let median = sorted.get(sorted.len() / 2).copied().unwrap_or(f64::NAN);
        let solved = match self.solved {
            Some(s) => format!(
                "{:.2}%",
                100.0 * means.iter().filter(|&&x| x >= s).count() as f64 / means.len() as f64
            ),
            None => "-".into(),
        };
        format!(
            "{:<44} {:>11.2} {:>12.2} {:>8} {:>11.3e}",
            self.dir, best, median, solved, steps_per_s
        )
    }
}

/// Header of the summary lines.
pub fn summary_header() -> String {
    format!(
        "{:<44} {:>11} {:>12} {:>8} {:>11}",
        "cell", "best mean", "median mean", "solved", "steps/s"
    )
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
    }
}

/// Writes `run.json` atomically.
pub fn write_meta(out: &Path, meta: &RunMeta) -> Result<()> {
    let p = out.join("run.json");
    rwg_core::export::write_atomic(&p, serde_json::to_string_pretty(meta)?.as_bytes())
        .with_context(|| format!("cannot write {}", p.display()))
}

/// Reads `run.json`.
pub fn read_meta(dir: &Path) -> Result<RunMeta> {
    let p = dir.join("run.json");
    let text =
        std::fs::read_to_string(&p).with_context(|| format!("cannot read {}", p.display()))?;
    serde_json::from_str(&text).with_context(|| format!("{} is not an rwg run.json", p.display()))
}
