//! `rwg run`: the RWG study described by a manifest, resumable and shardable.

use crate::study::{new_meta, plan_cells, read_meta, summary_header, write_meta, Cell, EnvSource};
use anyhow::{bail, Context, Result};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use rwg_core::export::{rfc3339, write_atomic};
use rwg_core::manifest::Manifest;
use rwg_core::run_meta::{CellMeta, ShardMeta};
use rwg_core::rundir::{
    block_done, block_samples, cell_complete, n_blocks, tidy_complete_cell, write_block,
};
use rwg_core::sampler::{run_blocks, BlockResult, SampleError};
use rwg_env::Environment;
use rwg_envs::{visit, EnvVisitor};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Instant, SystemTime};

/// Arguments of `rwg run`.
#[derive(clap::Args)]
#[command(after_help = "\
Writes a run directory:
  manifest.toml   the study (resolved manifest: overrides applied, defaults written out)
  run.json        run metadata: version, times, threads, env steps, steps/s, per cell
  cells/<env>__<arch>__<bias|nobias>/scores.csv   sample,episode,score,steps (one row per episode)
  cells/<env>__<arch>__<bias|nobias>/samples.csv  sample,mean,variance,std,min,max,rank
  cells/<env>__<arch>__<bias|nobias>/cell.json    the cell's metadata

Work is committed in blocks of 32 networks. Running the same manifest on a
directory that holds an unfinished run resumes it; the result is byte-identical to
an uninterrupted run. Ctrl-C stops after the blocks in flight.

Examples:
  rwg run examples/quick.toml
  rwg run examples/paper.toml --samples 1000 --out runs/paper-1k
  rwg run examples/paper.toml --shard 0/3 --out runs/paper-s0   # then rwg merge")]
pub struct Args {
    /// The study's TOML manifest.
    manifest: PathBuf,
    /// Run directory (default: the manifest's `out`, else runs/NAME for a manifest NAME.toml).
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
    /// Compute only shard K of N (0 <= K < N): every N-th block of networks,
    /// across all cells, into its own directory; combine shards with `rwg merge`.
    #[arg(long, value_name = "K/N")]
    shard: Option<ShardMeta>,
    /// Delete what the run directory holds and start over (needed when it holds
    /// a different study).
    #[arg(long)]
    force_new: bool,
    /// Skip the analysis at the end (stats.json, stats.csv, figures/, report.html;
    /// `rwg report` writes them later). The analysis holds the run's scores in
    /// memory, 12 bytes per episode.
    #[arg(long)]
    no_report: bool,
}

/// Writes stats, figures and report.html into a finished run directory.
fn write_report(out: &Path) -> Result<()> {
    let written = rwg_analysis::write_analysis(out, false)
        .with_context(|| format!("cannot analyse {}", out.display()))?;
    let figures = written
        .iter()
        .filter(|p| p.extension().is_some_and(|e| e == "svg"))
        .count();
    println!(
        "Report: {}  (stats.json, stats.csv, {figures} figures in figures/)",
        out.join("report.html").display()
    );
    Ok(())
}

/// Set by Ctrl-C; checked after every wave of blocks.
static INTERRUPTED: AtomicBool = AtomicBool::new(false);

/// Why a cell stopped.
#[derive(Debug, thiserror::Error)]
enum StopError {
    #[error(transparent)]
    Sample(#[from] SampleError),
    #[error(transparent)]
    Store(#[from] rwg_core::rundir::RunDirError),
    #[error("interrupted")]
    Interrupted,
}

/// Applies the command-line overrides to the manifest.
fn apply_overrides(m: &mut Manifest, args: &Args) -> Result<()> {
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
    Ok(())
}

/// Runs `rwg run`.
pub fn run(args: Args) -> Result<()> {
    let mut m = Manifest::load(&args.manifest)?;
    apply_overrides(&mut m, &args)?;
    let out = match (&args.out, &m.out) {
        (Some(o), _) | (None, Some(o)) => o.clone(),
        (None, None) => {
            let stem = args
                .manifest
                .file_stem()
                .map_or("run".into(), |s| s.to_string_lossy().into_owned());
            PathBuf::from("runs").join(stem)
        }
    };
    let cells = plan_cells(&mut m)?;
    let threads = m
        .threads
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
    let previous = prepare_dir(&out, &m, args.shard, args.force_new)?;
    if previous.as_ref().is_some_and(|p| p.end_time.is_some()) {
        println!(
            "{} already holds this study, complete; nothing to do.",
            out.display()
        );
        if args.shard.is_none() && !args.no_report && !out.join("report.html").exists() {
            write_report(&out)?;
        }
        return Ok(());
    }
    write_atomic(&out.join("manifest.toml"), m.to_toml().as_bytes())?;

    let _ = ctrlc::set_handler(|| {
        if INTERRUPTED.swap(true, Ordering::SeqCst) {
            std::process::exit(130);
        }
        eprintln!("\ninterrupted: finishing the blocks in flight (Ctrl-C again to quit at once)");
    });

    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()?;
    let nb = n_blocks(m.samples);
    let owned = |ci: usize, b: u64| args.shard.is_none_or(|s| s.owns(ci, nb, b));
    let todo: u64 = cells
        .iter()
        .enumerate()
        .map(|(ci, c)| {
            let dir = out.join("cells").join(&c.dir);
            if args.shard.is_none() && cell_complete(&dir) {
                return 0;
            }
            (0..nb)
                .filter(|&b| owned(ci, b) && !block_done(&dir, b))
                .map(|b| block_samples(b, m.samples).count() as u64)
                .sum()
        })
        .sum();
    let bar = progress_bar(todo);
    let t0 = Instant::now();
    let mut meta = new_meta(&m, threads, rfc3339(SystemTime::now()), args.shard);
    if let Some(p) = &previous {
        meta.start_time = p.start_time.clone();
    }
    let mut lines = vec![];
    let mut steps_now = 0u64;

    for (ci, cell) in cells.iter().enumerate() {
        let dir = out.join("cells").join(&cell.dir);
        if args.shard.is_none() && cell_complete(&dir) {
            tidy_complete_cell(&dir)?;
            let cm = read_cell_meta(&dir)?;
            meta.env_steps += cm.env_steps;
            meta.cells.push(cm);
            continue;
        }
        let label = format!(
            "cell {}/{} ({} done): {}",
            ci + 1,
            cells.len(),
            ci,
            cell.dir
        );
        bar.set_message(label.clone());
        let blocks: Vec<_> = (0..nb)
            .filter(|&b| owned(ci, b) && !block_done(&dir, b))
            .map(|b| block_samples(b, m.samples))
            .collect();
        let t_cell = Instant::now();
        let mut cell_steps = 0u64;
        let result = pool.install(|| {
            run_cell_blocks(cell, &blocks, &dir, m.episodes, |b: &BlockResult| {
                let s: u64 = b.episodes.iter().map(|r| r.steps as u64).sum();
                cell_steps += s;
                steps_now += s;
                bar.inc(b.samples.end - b.samples.start);
                let secs = t0.elapsed().as_secs_f64();
                let nets = bar.position() as f64 / secs;
                let rate = steps_now as f64 / secs;
                bar.set_message(format!(
                    "{label}  {nets:.0} networks/s, {rate:.3e} env steps/s"
                ));
            })
        });
        if let Err(e) = result {
            bar.abandon();
            meta.wall_s = t0.elapsed().as_secs_f64();
            write_meta(&out, &meta)?;
            let resume = format!(
                "rwg run {} --out {}{}",
                args.manifest.display(),
                out.display(),
                shard_flag(args.shard)
            );
            return match e {
                StopError::Interrupted => {
                    eprintln!(
                        "stopped; every finished block is saved in {}. Resume with:\n  {resume}",
                        out.display()
                    );
                    std::process::exit(130)
                }
                e => Err(anyhow::Error::new(e).context(format!(
                    "cell {}{} failed; the blocks and cells finished before are saved in {}",
                    cell.dir,
                    match &cell.source {
                        EnvSource::Plugin(p) => format!(" (plugin {})", p.path().display()),
                        EnvSource::Builtin(_) => String::new(),
                    },
                    out.display()
                ))),
            };
        }
        let wall = t_cell.elapsed().as_secs_f64();
        if args.shard.is_none() {
            let (cm, totals) = cell.finalize(&m, &out, wall)?;
            lines.push(cell.summary_line(&totals.means, cm.steps_per_s));
            meta.env_steps += cm.env_steps;
            meta.cells.push(cm);
        } else {
            meta.env_steps += cell_steps;
        }
        meta.wall_s = t0.elapsed().as_secs_f64();
        write_meta(&out, &meta)?;
    }
    bar.finish_and_clear();
    meta.wall_s = t0.elapsed().as_secs_f64();
    meta.steps_per_s = steps_now as f64 / meta.wall_s;
    meta.end_time = Some(rfc3339(SystemTime::now()));
    write_meta(&out, &meta)?;

    if args.shard.is_none() {
        println!("{}", summary_header());
        for l in &lines {
            println!("{l}");
        }
        if lines.len() < cells.len() {
            println!(
                "({} cells were already complete)",
                cells.len() - lines.len()
            );
        }
    }
    println!(
        "\n{} cells, {} networks x {} episodes; this session: {} env steps in {:.2} s ({:.3e} steps/s, {} threads)",
        cells.len(),
        m.samples,
        m.episodes,
        steps_now,
        meta.wall_s,
        meta.steps_per_s,
        threads
    );
    match args.shard {
        None => {
            println!(
                "Results: {}  (run.json, cells/*/scores.csv, cells/*/samples.csv)",
                out.display()
            );
            if !args.no_report {
                write_report(&out)?;
            }
        }
        Some(s) => println!(
            "Shard {}/{} done: {}. Combine all shards with: rwg merge DIR... --out DIR",
            s.index,
            s.count,
            out.display()
        ),
    }
    Ok(())
}

fn shard_flag(s: Option<ShardMeta>) -> String {
    s.map_or(String::new(), |s| {
        format!(" --shard {}/{}", s.index, s.count)
    })
}

/// Runs the given blocks of a cell, committing each. Built-in envs are
/// statically dispatched (the sampler is monomorphised for each); plugin envs
/// run through the same generic sampler with `TimeLimit<PluginEnv>`.
fn run_cell_blocks(
    cell: &Cell,
    blocks: &[std::ops::Range<u64>],
    dir: &Path,
    episodes: u32,
    on_done: impl FnMut(&BlockResult),
) -> Result<(), StopError> {
    struct Runner<'a, F> {
        cell: &'a Cell,
        blocks: &'a [std::ops::Range<u64>],
        dir: &'a Path,
        episodes: u32,
        on_done: F,
    }
    impl<F: FnMut(&BlockResult)> Runner<'_, F> {
        fn run<E: Environment + Send>(
            self,
            make_env: impl Fn() -> E + Sync,
        ) -> Result<(), StopError> {
            let Runner {
                cell,
                blocks,
                dir,
                episodes,
                mut on_done,
            } = self;
            let wave = rayon::current_num_threads() * 2;
            run_blocks(
                &cell.plan,
                blocks,
                wave,
                make_env,
                |b: BlockResult| -> Result<(), StopError> {
                    write_block(dir, &b, episodes)?;
                    on_done(&b);
                    if INTERRUPTED.load(Ordering::SeqCst) {
                        return Err(StopError::Interrupted);
                    }
                    Ok(())
                },
            )
        }
    }
    impl<F: FnMut(&BlockResult)> EnvVisitor for Runner<'_, F> {
        type Output = Result<(), StopError>;
        fn visit<E: Environment + Clone + Send + Sync + 'static>(self, env: E) -> Self::Output {
            self.run(|| env.clone())
        }
    }
    let runner = Runner {
        cell,
        blocks,
        dir,
        episodes,
        on_done,
    };
    match &cell.source {
        EnvSource::Builtin(opts) => visit(&cell.plan.env_id, opts, runner)
            .expect("env ids are checked when cells are planned"),
        EnvSource::Plugin(p) => runner.run(|| {
            p.make()
                .expect("an instance was created when the cells were planned")
        }),
    }
}

fn read_cell_meta(dir: &Path) -> Result<CellMeta> {
    let p = dir.join("cell.json");
    let text =
        std::fs::read_to_string(&p).with_context(|| format!("cannot read {}", p.display()))?;
    serde_json::from_str(&text).with_context(|| format!("{} is not an rwg cell.json", p.display()))
}

/// Creates the run directory, or checks that the one there holds the same
/// study (to resume it). Returns the previous run's metadata, if any.
fn prepare_dir(
    out: &Path,
    m: &Manifest,
    shard: Option<ShardMeta>,
    force_new: bool,
) -> Result<Option<rwg_core::run_meta::RunMeta>> {
    let manifest_path = out.join("manifest.toml");
    if force_new {
        for p in ["cells", "run.json", "manifest.toml"] {
            let p = out.join(p);
            if p.is_dir() {
                std::fs::remove_dir_all(&p)
                    .with_context(|| format!("cannot remove {}", p.display()))?;
            } else if p.exists() {
                std::fs::remove_file(&p)
                    .with_context(|| format!("cannot remove {}", p.display()))?;
            }
        }
    }
    let mut previous = None;
    if manifest_path.exists() {
        let old = Manifest::load(&manifest_path)?;
        let diffs = old.study_differences(m);
        if !diffs.is_empty() {
            bail!(
                "{} holds a different study ({}); use another --out, or --force-new to delete it and start over",
                out.display(),
                diffs.join("; ")
            );
        }
        if out.join("run.json").exists() {
            let meta = read_meta(out)?;
            if meta.shard != shard {
                let show = |s: Option<ShardMeta>| {
                    s.map_or("the whole study".into(), |s| {
                        format!("shard {}/{}", s.index, s.count)
                    })
                };
                bail!(
                    "{} holds {}, not {}; use another --out",
                    out.display(),
                    show(meta.shard),
                    show(shard)
                );
            }
            previous = Some(meta);
        }
    } else if out.join("run.json").exists() {
        bail!(
            "{} holds a run.json but no manifest.toml; use another --out, or --force-new",
            out.display()
        );
    }
    std::fs::create_dir_all(out.join("cells"))
        .with_context(|| format!("cannot create {}", out.display()))?;
    Ok(previous)
}

fn progress_bar(total: u64) -> ProgressBar {
    let bar = ProgressBar::with_draw_target(Some(total), ProgressDrawTarget::stderr());
    bar.set_style(
        ProgressStyle::with_template(
            "{msg}\n[{elapsed_precise}] {wide_bar} {pos}/{len} networks (ETA {eta})",
        )
        .expect("valid template"),
    );
    bar
}
