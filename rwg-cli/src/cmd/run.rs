//! `rwg run`: the RWG study described by a manifest.

use anyhow::{bail, Context, Result};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use rwg_core::export::{
    rfc3339, write_atomic, write_sample_rows, write_score_rows, AtomicFile, SCORES_HEADER,
};
use rwg_core::manifest::Manifest;
use rwg_core::policy::{Architecture, NetShape};
use rwg_core::run_meta::{cell_dir_name, CellMeta, RunMeta, WeightsMeta, RUN_FORMAT};
use rwg_core::sampler::{run_cell, BlockResult, CellPlan, SampleError};
use rwg_core::summary::{ranks_by_mean, SampleSummary};
use rwg_core::Environment;
use rwg_envs::{visit, EnvOptions, EnvVisitor};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::{Instant, SystemTime};

/// Samples per block: the unit of parallel work.
const BLOCK: u64 = 32;

/// Arguments of `rwg run`.
#[derive(clap::Args)]
#[command(after_help = "\
Writes a run directory:
  manifest.toml               the resolved manifest (overrides applied, defaults written out)
  run.json                    run metadata: version, times, threads, env steps, steps/s, per cell
  cells/<env>__<arch>__<bias|nobias>/scores.csv   sample,episode,score,steps (one row per episode)
  cells/<env>__<arch>__<bias|nobias>/samples.csv  sample,mean,variance,std,min,max,rank

Example:
  rwg run examples/quick.toml
  rwg run examples/paper.toml --samples 1000 --out runs/paper-1k")]
pub struct Args {
    /// The study's TOML manifest.
    manifest: PathBuf,
    /// Run directory (default: the manifest's `out`, else runs/<manifest name>).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Networks per cell (overrides the manifest).
    #[arg(long)]
    samples: Option<u64>,
    /// Episodes per network (overrides the manifest).
    #[arg(long)]
    episodes: Option<u32>,
    /// Master seed (overrides the manifest).
    #[arg(long)]
    seed: Option<u64>,
    /// Worker threads (overrides the manifest; default: all cores).
    #[arg(long)]
    threads: Option<usize>,
}

/// One cell to run, with everything resolved.
struct Cell {
    plan: CellPlan,
    arch_name: String,
    opts: EnvOptions,
    solved: Option<f64>,
    solved_source: Option<String>,
    dir: String,
}

/// Runs `rwg run`.
pub fn run(args: Args) -> Result<()> {
    let mut m = Manifest::load(&args.manifest)?;
    if let Some(s) = args.samples {
        if s == 0 {
            bail!("--samples must be at least 1");
        }
        m.samples = s;
    }
    if let Some(e) = args.episodes {
        if e == 0 {
            bail!("--episodes must be at least 1");
        }
        m.episodes = e;
    }
    if let Some(s) = args.seed {
        m.seed = s;
    }
    if let Some(t) = args.threads {
        if t == 0 {
            bail!("--threads must be at least 1");
        }
        m.threads = Some(t);
    }
    let out = match (&args.out, &m.out) {
        (Some(o), _) => o.clone(),
        (None, Some(o)) => o.clone(),
        (None, None) => {
            let stem = args
                .manifest
                .file_stem()
                .map_or("run".into(), |s| s.to_string_lossy().into_owned());
            PathBuf::from("runs").join(stem)
        }
    };
    m.out = Some(out.clone());
    let cells = plan_cells(&m)?;
    let threads = m
        .threads
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));

    prepare_dir(&out)?;
    write_atomic(&out.join("manifest.toml"), m.to_toml().as_bytes())?;

    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()?;
    let total = cells.len() as u64 * m.samples;
    let bar = progress_bar(total);
    let start_time = SystemTime::now();
    let t0 = Instant::now();
    let mut meta = RunMeta {
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
        start_time: rfc3339(start_time),
        end_time: None,
        wall_s: 0.0,
        env_steps: 0,
        steps_per_s: 0.0,
        cells: vec![],
    };
    let mut summary_lines = vec![];
    for (i, cell) in cells.iter().enumerate() {
        bar.set_message(format!("cell {}/{}: {}", i + 1, cells.len(), cell.dir));
        let result = pool.install(|| run_one_cell(&m, cell, &out, &bar, meta.env_steps, t0));
        match result {
            Ok(c) => {
                meta.env_steps += c.meta.env_steps;
                summary_lines.push(c.line);
                meta.cells.push(c.meta);
            }
            Err(e) => {
                bar.abandon();
                meta.wall_s = t0.elapsed().as_secs_f64();
                write_atomic(
                    &out.join("run.json"),
                    serde_json::to_string_pretty(&meta)?.as_bytes(),
                )?;
                return Err(e.context(format!(
                    "cell {} failed; the {} cells before it are complete in {}",
                    cell.dir,
                    meta.cells.len(),
                    out.display()
                )));
            }
        }
        meta.wall_s = t0.elapsed().as_secs_f64();
        write_atomic(
            &out.join("run.json"),
            serde_json::to_string_pretty(&meta)?.as_bytes(),
        )?;
    }
    bar.finish_and_clear();
    meta.wall_s = t0.elapsed().as_secs_f64();
    meta.steps_per_s = meta.env_steps as f64 / meta.wall_s;
    meta.end_time = Some(rfc3339(SystemTime::now()));
    write_atomic(
        &out.join("run.json"),
        serde_json::to_string_pretty(&meta)?.as_bytes(),
    )?;

    println!(
        "{:<40} {:>12} {:>12} {:>9} {:>12}",
        "cell", "best mean", "median mean", "solved", "steps/s"
    );
    for l in summary_lines {
        println!("{l}");
    }
    println!(
        "\n{} cells, {} networks x {} episodes, {} env steps in {:.2} s ({:.3e} steps/s, {} threads)",
        cells.len(),
        m.samples,
        m.episodes,
        meta.env_steps,
        meta.wall_s,
        meta.steps_per_s,
        threads
    );
    println!(
        "Results: {}  (run.json, cells/*/scores.csv, cells/*/samples.csv)",
        out.display()
    );
    Ok(())
}

/// Expands the manifest into cells (env × architecture × bias), checking env ids.
fn plan_cells(m: &Manifest) -> Result<Vec<Cell>> {
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
                    solved,
                    solved_source: solved_source.clone(),
                    dir: cell_dir_name(&e.id, &a.name, bias),
                });
            }
        }
    }
    Ok(cells)
}

struct SpecOf;

impl EnvVisitor for SpecOf {
    type Output = rwg_core::EnvSpec;
    fn visit<E: Environment + Clone + Send + Sync + 'static>(self, env: E) -> Self::Output {
        env.spec().clone()
    }
}

/// Creates the run directory; refuses one that already holds a run.
fn prepare_dir(out: &Path) -> Result<()> {
    if out.join("run.json").exists() {
        bail!(
            "{} already holds a run (run.json); choose another directory with --out, or delete it",
            out.display()
        );
    }
    std::fs::create_dir_all(out.join("cells"))
        .with_context(|| format!("cannot create {}", out.display()))
}

fn progress_bar(total: u64) -> ProgressBar {
    let bar = ProgressBar::with_draw_target(Some(total), ProgressDrawTarget::stderr());
    bar.set_style(
        ProgressStyle::with_template(
            "{msg}\n[{elapsed_precise}] {wide_bar} {pos}/{len} networks ({per_sec}, ETA {eta})",
        )
        .expect("valid template"),
    );
    bar
}

struct CellDone {
    meta: CellMeta,
    line: String,
}

/// Runs one cell through the statically dispatched sampler and writes its files.
fn run_one_cell(
    m: &Manifest,
    cell: &Cell,
    out: &Path,
    bar: &ProgressBar,
    steps_before: u64,
    t_run: Instant,
) -> Result<CellDone> {
    struct Runner<'a> {
        m: &'a Manifest,
        cell: &'a Cell,
        dir: PathBuf,
        bar: &'a ProgressBar,
        steps_before: u64,
        t_run: Instant,
    }
    impl EnvVisitor for Runner<'_> {
        type Output = Result<CellDone>;
        fn visit<E: Environment + Clone + Send + Sync + 'static>(self, env: E) -> Result<CellDone> {
            let Runner {
                m,
                cell,
                dir,
                bar,
                steps_before,
                t_run,
            } = self;
            std::fs::create_dir_all(&dir)
                .with_context(|| format!("cannot create {}", dir.display()))?;
            let spec = env.spec().clone();
            let t0 = Instant::now();
            let e = m.episodes as usize;
            let mut scores = AtomicFile::create(&dir.join("scores.csv"))?;
            writeln!(scores, "{SCORES_HEADER}")?;
            let mut summaries: Vec<SampleSummary> = Vec::with_capacity(m.samples as usize);
            let mut steps = 0u64;
            let mut buf = Vec::with_capacity(e);
            let mut scratch = Vec::with_capacity(e);
            run_cell(
                &cell.plan,
                0..m.samples,
                BLOCK,
                rayon::current_num_threads() * 4,
                || env.clone(),
                |b: BlockResult| -> Result<(), RunError> {
                    write_score_rows(&mut scores, &b, m.episodes).map_err(RunError::Io)?;
                    for chunk in b.episodes.chunks_exact(e) {
                        buf.clear();
                        buf.extend(chunk.iter().map(|r| r.score));
                        steps += chunk.iter().map(|r| r.steps as u64).sum::<u64>();
                        summaries.push(SampleSummary::of(&buf, &mut scratch));
                    }
                    bar.inc(b.samples.end - b.samples.start);
                    let all = steps_before + steps;
                    bar.set_message(format!(
                        "{}  {:.3e} env steps/s",
                        bar.message().split("  ").next().unwrap_or(""),
                        all as f64 / t_run.elapsed().as_secs_f64()
                    ));
                    Ok(())
                },
            )?;
            scores.commit()?;
            let means: Vec<f64> = summaries.iter().map(|s| s.mean).collect();
            let ranks = ranks_by_mean(&means);
            let mut samples = AtomicFile::create(&dir.join("samples.csv"))?;
            write_sample_rows(&mut samples, &summaries, &ranks)?;
            samples.commit()?;
            let wall_s = t0.elapsed().as_secs_f64();

            let shape = NetShape::new(
                spec.obs_dim(),
                &cell.plan.arch,
                NetShape::outputs_for(&spec.action_space),
            );
            let best = means.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            let mut sorted = means.clone();
            sorted.sort_by(f64::total_cmp);
            let median = sorted[sorted.len() / 2];
            let solved_txt = match cell.solved {
                Some(s) => {
                    let k = means.iter().filter(|&&x| x >= s).count();
                    format!("{:.2}%", 100.0 * k as f64 / means.len() as f64)
                }
                None => "-".into(),
            };
            let steps_per_s = steps as f64 / wall_s;
            let line = format!(
                "{:<40} {:>12.2} {:>12.2} {:>9} {:>12.3e}",
                cell.dir, best, median, solved_txt, steps_per_s
            );
            let meta = CellMeta {
                dir: cell.dir.clone(),
                env: spec.id.clone(),
                arch: cell.arch_name.clone(),
                hidden: cell.plan.arch.hidden.clone(),
                bias: cell.plan.arch.bias,
                n_weights: shape.n_weights(),
                obs_dim: spec.obs_dim(),
                max_episode_steps: spec.max_episode_steps.unwrap_or(0),
                solved: cell.solved,
                solved_source: cell.solved_source.clone(),
                samples: m.samples,
                episodes: m.episodes,
                wall_s,
                env_steps: steps,
                steps_per_s,
            };
            Ok(CellDone { meta, line })
        }
    }
    let runner = Runner {
        m,
        cell,
        dir: out.join("cells").join(&cell.dir),
        bar,
        steps_before,
        t_run,
    };
    visit(&cell.plan.env_id, &cell.opts, runner)?
}

/// What can stop a cell.
#[derive(Debug, thiserror::Error)]
enum RunError {
    #[error(transparent)]
    Sample(#[from] SampleError),
    #[error("cannot write results: {0}")]
    Io(std::io::Error),
}
