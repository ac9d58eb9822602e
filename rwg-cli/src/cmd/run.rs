//! `rwg run`: the RWG study described by a manifest, resumable and shardable.
//! The study itself is `rwg_study::runner`; this is its arguments and output.

use crate::fault_guard;
use crate::progress::{Bar, Compiling, Lines, Silent};
use anyhow::{Context, Result};
use rwg_jax::warm_up::WarmUpObserver;
use rwg_study::cells::Cell;
use rwg_study::env_source::EnvSource;
use rwg_study::manifest::Manifest;
use rwg_study::rundir::data::KeptEpisodes;
use rwg_study::rundir::meta::ShardMeta;
use rwg_study::rundir::outputs::{Output, OutputKind};
use rwg_study::rundir::REPORT_HTML;
use rwg_study::runner::{run_study, Progress, RunOptions, RunOutcome, RunReport};
use rwg_study::shell::sh_path;
use rwg_study::StudyError;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// Arguments of `rwg run`.
#[derive(clap::Args)]
#[command(
    allow_negative_numbers = true,
    after_help = "\
Writes a run directory:
  manifest.toml   the study (resolved manifest: overrides applied, defaults written out)
  run.json        run metadata: version, times, threads, env steps, steps/s, per cell
  cells/<env>__<arch>__<bias|nobias>/scores.csv   sample,episode,score,steps (one row per episode)
  cells/<env>__<arch>__<bias|nobias>/samples.csv  sample,mean,variance,std,min,max,rank
  cells/<env>__<arch>__<bias|nobias>/cell.json    the cell's metadata

Work is committed in blocks of 32 networks, at most 2 s after they are
computed (RWG_COMMIT_LINGER=SECONDS changes that; a cell computed within
that time writes its results directly, without block files).
Running the same manifest on a
directory that holds an unfinished run resumes it; the result is byte-identical to
an uninterrupted run. Ctrl-C stops after the blocks in flight.

Plugin envs run in rwg's process by default (fastest; a plugin that crashes
kills rwg, though every committed block is kept and a rerun resumes). With
--isolate (or `isolate = true` in an [[envs]] entry) they run in worker
processes: a crash or hang is reported by rwg and the results are the same.

JAX envs (gymnax:ID, brax:NAME, playground:NAME, jumanji:ID, craftax:NAME,
navix:ID, xminigrid:ID, pgx:ID, jax:module:callable) run in Python worker
processes, the episodes of networks_per_call networks in one compiled call:
--threads workers on the CPU (one XLA thread each), one worker running every
GPU or TPU. The results are the same for any --threads, networks_per_call,
number of devices, shards or resume.

Examples:
  rwg run examples/quick.toml
  rwg run examples/paper.toml --samples 1000 --out runs/paper-1k
  rwg run examples/paper.toml --shard 0/3 --out runs/paper-s0   # then rwg merge"
)]
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
    /// Worker threads (overrides the manifest; default: all cores). A JAX
    /// env (gymnax:, playground:, ...) on the CPU runs this many worker processes,
    /// each XLA on one thread; on a GPU or TPU one worker, whatever this says.
    #[arg(long)]
    threads: Option<usize>,
    /// Compute only shard K of N (0 <= K < N): every N-th block of networks,
    /// across all cells, into its own directory; combine shards with `rwg merge`.
    #[arg(long, value_name = "K/N")]
    shard: Option<ShardMeta>,
    /// Delete the run the directory holds and start over (needed when it holds
    /// a different study): every file the old run wrote, its statistics,
    /// figures and report too; nothing rwg did not write.
    #[arg(long)]
    force_new: bool,
    /// Seconds one call into a plugin env (create, reset or step) may take
    /// before rwg reports it as hung and exits (0: no limit). In-process, a
    /// stuck call cannot be stopped, so rwg exits; with isolation it is one
    /// exchange of a worker (a reset or step of each of 16 instances),
    /// and the worker is killed.
    #[arg(long, value_name = "SECONDS", default_value_t = fault_guard::DEFAULT_STEP_TIMEOUT_S)]
    step_timeout: u64,
    /// Run every plugin env isolated, as `isolate = true` in its `[[envs]]`
    /// entry does: in worker processes (rwg itself), stepped in exchanges.
    /// A plugin that crashes, aborts, exits or hangs then ends its worker,
    /// not rwg: the run stops with an error naming the env, network,
    /// episode and step, every committed block kept, and a rerun resumes.
    /// Results are bit-identical to in-process (the default: faster, but
    /// a crash there kills rwg). No effect on built-in and gymnasium: envs.
    #[arg(long)]
    isolate: bool,
    /// Skip the analysis at the end (stats.json, stats.csv, figures/, report.html;
    /// `rwg report` writes them later). The analysis holds the run's scores in
    /// memory, 12 bytes per episode.
    #[arg(long)]
    no_report: bool,
    /// No progress on stderr. Otherwise a progress bar on a terminal, and
    /// without one (a pipe, a batch job's log) a plain line every 5 s: cells,
    /// networks done of total, networks/s, ETA (`RWG_PROGRESS_INTERVAL=SECONDS`
    /// changes the interval). While a JAX cell's workers compile, both say
    /// "compiling" and for how long; rates and ETA count the time outside
    /// compiles.
    #[arg(long, short)]
    quiet: bool,
    /// Print where the wall time went to stderr at the end: set-up, per cell
    /// sampling (parallel; a JAX cell's split into its workers starting and
    /// compiling, and running) and serial time with its share, the cell's last
    /// block commits, finalising and run.json (overlapped with the next
    /// cell), the wait for the last cells, and the report.
    #[arg(long)]
    timing: bool,
}

/// Writes stats, figures and report.html into a finished run directory,
/// reading and drawing the cells on the current rayon pool.
pub(crate) fn write_report(out: &Path, kept: KeptEpisodes) -> Result<()> {
    let written = rwg_analysis::write_analysis(out, false, kept)
        .with_context(|| format!("cannot analyse {}", out.display()))?;
    let figures = written
        .iter()
        .filter(|p| p.extension().is_some_and(|e| e == "svg"))
        .count();
    crate::outln!(
        "Report: {}  (stats.json, stats.csv, {figures} figures in figures/)",
        out.join(REPORT_HTML).display()
    );
    Ok(())
}

/// Applies the command-line overrides to the manifest, within rwg's limits
/// (`rwg_study::limits`).
fn apply_overrides(m: &mut Manifest, args: &Args) -> Result<()> {
    use rwg_study::limits::{in_range, MAX_EPISODES, MAX_SAMPLES, MAX_SEED, MAX_THREADS};
    let flag = |m: String| anyhow::anyhow!("--{m}");
    if let Some(s) = args.samples {
        m.samples = in_range("samples", s, 1, MAX_SAMPLES).map_err(flag)?;
    }
    if let Some(e) = args.episodes {
        m.episodes = in_range("episodes", e, 1, MAX_EPISODES).map_err(flag)?;
    }
    if let Some(s) = args.seed {
        m.seed = in_range("seed", s, 0, MAX_SEED).map_err(flag)?;
    }
    if let Some(t) = args.threads {
        m.threads = Some(in_range("threads", t, 1, MAX_THREADS).map_err(flag)?);
    }
    in_range(
        "step-timeout",
        args.step_timeout,
        0,
        rwg_study::limits::MAX_STEP_TIMEOUT_S,
    )
    .map_err(flag)?;
    if args.isolate {
        m.isolate_all();
    }
    Ok(())
}

/// Runs `rwg run`; the exit status: 0, or 130 after an interrupt and 1
/// after a failed cell, each already reported with how to resume.
pub fn run(args: Args) -> Result<i32> {
    let mut m = Manifest::load(&args.manifest)?;
    apply_overrides(&mut m, &args)?;
    let out = run_dir(&args, &m)?;
    let manifest = crate::cmd::absolute(&args.manifest)?;
    let pp = python_path(&m);
    let pp = pp.as_deref();
    // Until the run directory holds the study, the command as given
    // resumes it; from then on, the directory's own manifest.
    let (resume, resume_stopped) = guard_texts(&out, &resume_command(&args, &out, false, pp));
    let _armed = fault_guard::arm(resume, resume_stopped, args.step_timeout);
    rwg_study::isolate::set_settings(rwg_study::isolate::IsolateSettings {
        timeout: (args.step_timeout > 0).then(|| std::time::Duration::from_secs(args.step_timeout)),
        ..Default::default()
    });
    let opts = RunOptions {
        out: out.clone(),
        manifest_file: Some(&manifest),
        shard: args.shard,
        force_new: args.force_new,
        stop: fault_guard::interrupt_flag(),
        keep_episodes: args.shard.is_none() && !args.no_report,
        commit_linger: crate::env_vars::commit_linger()?,
    };
    let outcome = run_with_progress(&mut m, &opts, &args, &out, pp);
    // What a crash while rwg exits (a plugin's exit handler) leaves.
    let complete = format!(
        "The run in {} is complete: every file was written and indexed before (`rwg verify {}` \
         checks them).",
        out.display(),
        sh_path(&out)
    );
    let mut report = match finished(outcome, &args, &out, pp)? {
        Finished::Report(report) => report,
        Finished::AlreadyComplete => {
            fault_guard::finished(complete);
            return Ok(0);
        }
        Finished::Stopped(status) => {
            fault_guard::finished(fault_guard::resume_stopped_text());
            return Ok(status);
        }
    };
    print_summary(&report, &m, &args);
    let report_time = finish_output(&mut report, &args, &out)?;
    if args.timing {
        crate::stdio::write_err(&crate::timing_table::timing_table(
            &report.timing,
            report_time,
        ));
    }
    fault_guard::finished(complete);
    Ok(0)
}

/// A study's directory: `out` (given on the command line), else the
/// manifest's `out`, else `runs/STEM` for a manifest file `STEM.toml`.
pub(crate) fn default_out(out: Option<&PathBuf>, m: &Manifest, manifest: &Path) -> PathBuf {
    match (out, &m.out) {
        (Some(o), _) | (None, Some(o)) => o.clone(),
        (None, None) => {
            let stem = manifest
                .file_stem()
                .map_or("run".into(), |s| s.to_string_lossy().into_owned());
            PathBuf::from("runs").join(stem)
        }
    }
}

/// The run directory ([`default_out`]), made absolute (before any plugin
/// code runs: a plugin may change the working directory); refused if it
/// exists and is not a directory, or lies in another run's own files.
fn run_dir(args: &Args, m: &Manifest) -> Result<PathBuf> {
    let out = default_out(args.out.as_ref(), m, &args.manifest);
    if out.exists() && !out.is_dir() {
        anyhow::bail!(
            "{}: exists and is not a directory; the run directory (--out, or `out` in the \
             manifest) must be a directory or not exist yet",
            out.display()
        );
    }
    crate::cmd::claim_output(Output::new(&out, OutputKind::RunDir), "")?;
    crate::cmd::absolute(&out)
}

/// Runs the study with the progress display `args` choose, then prints the
/// warnings of the plugin checks (only after a run that succeeded).
fn run_with_progress(
    m: &mut Manifest,
    opts: &RunOptions<'_>,
    args: &Args,
    out: &Path,
    pp: Option<&str>,
) -> Result<RunOutcome, StudyError> {
    // told by the JAX envs' sources when their workers compile
    let compiling = Arc::new(Compiling::default());
    let (mut bar, mut lines, mut silent) = (
        Bar::new(Arc::clone(&compiling)),
        Lines::new(Arc::clone(&compiling)),
        Silent,
    );
    let display: &mut dyn Progress = if args.quiet {
        &mut silent
    } else if crate::stdio::stderr_is_terminal() {
        &mut bar
    } else {
        &mut lines
    };
    let mut progress = WithChecks {
        display,
        compiling,
        checks: vec![],
        started: Some(guard_texts(out, &resume_command(args, out, true, pp))),
        jax_lines: !args.quiet,
    };
    let outcome = run_study(m, opts, &mut progress);
    // A failed run does not wait for the checks (a hanging plugin's would
    // take their whole timeout); they die with rwg.
    let checks = if outcome.is_ok() {
        std::mem::take(&mut progress.checks)
    } else {
        vec![]
    };
    for w in checks
        .into_iter()
        .flat_map(|c| c.join().unwrap_or_default())
    {
        crate::errln!("warning: {w}");
    }
    outcome
}

/// How a run's session ended, for [`finished`]'s caller.
enum Finished {
    /// The run finished in this session: its report.
    Report(Box<RunReport>),
    /// The directory held the study, complete, already.
    AlreadyComplete,
    /// Stopped, how to resume printed: the exit status (130 after an
    /// interrupt, 1 after a failed cell).
    Stopped(i32),
}

/// What a run's outcome means: its report, a directory that was complete
/// already (its report written if missing), or a run stopped by an
/// interrupt or a failed cell, which prints how to resume.
fn finished(
    outcome: Result<RunOutcome, StudyError>,
    args: &Args,
    out: &Path,
    pp: Option<&str>,
) -> Result<Finished> {
    Ok(match outcome {
        Ok(RunOutcome::AlreadyComplete(_lock)) => {
            crate::outln!(
                "{} already holds this study, complete; nothing to do.",
                out.display()
            );
            if args.shard.is_none() && !args.no_report && !out.join(REPORT_HTML).exists() {
                write_report(out, KeptEpisodes::new())?;
            }
            Finished::AlreadyComplete
        }
        Ok(RunOutcome::Finished(report)) => Finished::Report(report),
        Err(StudyError::Interrupted) => {
            crate::errln!(
                "stopped; every finished block is saved in {}. Resume with:\n  {}",
                out.display(),
                resume_command(args, out, true, pp)
            );
            fault_guard::disarm();
            Finished::Stopped(130)
        }
        Err(e @ StudyError::Cell { .. }) => {
            // (an isolated plugin's crash or hang, a Gymnasium worker's, an env error)
            let text = crate::error_text(&e.into());
            crate::errln!("error: {}", crate::details::one_line(&text, Some(out)));
            crate::errln!(
                "Every committed block is kept; once the cause is fixed, resume with: {}",
                resume_command(args, out, true, pp)
            );
            fault_guard::disarm();
            Finished::Stopped(1)
        }
        Err(e) => return Err(e.into()),
    })
}

/// Prints the summary table (whole studies) and the session's totals.
fn print_summary(report: &RunReport, m: &Manifest, args: &Args) {
    let lines = &report.lines;
    if args.shard.is_none() {
        crate::outln!("{}", crate::summary::header());
        for l in lines {
            crate::outln!("{}", crate::summary::line(l));
        }
        if lines.len() < report.cells {
            crate::outln!(
                "({} cells were already complete)",
                report.cells - lines.len()
            );
        }
    }
    crate::outln!(
        "\n{} cells, {} networks x {} episodes; this session: {} env steps in {:.2} s ({:.3e} steps/s, {} thread{})",
        report.cells,
        m.samples,
        m.episodes,
        report.env_steps,
        report.meta.wall_s,
        report.meta.steps_per_s,
        report.threads,
        if report.threads == 1 { "" } else { "s" }
    );
}

/// Where the results are, and for a whole study its report (`report.html`,
/// unless `--no-report`); returns the time the report took.
fn finish_output(report: &mut RunReport, args: &Args, out: &Path) -> Result<Option<Duration>> {
    let mut report_time = None;
    match args.shard {
        None => {
            crate::outln!(
                "Results: {}  (run.json, cells/*/scores.csv, cells/*/samples.csv)",
                out.display()
            );
            if !args.no_report {
                let t = Instant::now();
                // On as many threads as the sampling had.
                let episodes = std::mem::take(&mut report.episodes);
                rayon::ThreadPoolBuilder::new()
                    .num_threads(report.threads)
                    .build()
                    .with_context(|| {
                        format!(
                            "cannot start the report's threads ({})",
                            rwg_env::text::THREAD_LIMIT_ADVICE
                        )
                    })?
                    .install(|| write_report(out, episodes))?;
                report_time = Some(t.elapsed());
            }
        }
        Some(s) => crate::outln!(
            "Shard {}/{} done: {}. Combine all shards with: rwg merge DIR... --out DIR",
            s.index,
            s.count,
            out.display()
        ),
    }
    Ok(report_time)
}

/// What the fault handlers print after a plugin's fault and after an
/// interruption that does not stop in time, with `resume`, the command
/// that resumes the run.
fn guard_texts(out: &Path, resume: &str) -> (String, String) {
    (
        format!(
            "Every committed block is kept in {}; once the plugin is fixed (or its env \
             removed from the manifest), resume with: {resume}",
            out.display(),
        ),
        format!(
            "Every committed block is kept in {}; resume with: {resume}",
            out.display(),
        ),
    )
}

/// The command that resumes this run, shell-quoted, working as printed.
/// Once the run directory holds the study (`in_dir`), it runs the
/// directory's `manifest.toml` (the study, every override applied: see
/// [`crate::cmd::status::finish_command`]) with the options that are not
/// part of the study; before, it is the command as given. With
/// `pythonpath`, it sets `PYTHONPATH` as the run had it.
fn resume_command(args: &Args, out: &Path, in_dir: bool, pythonpath: Option<&str>) -> String {
    let mut cmd = if in_dir {
        crate::cmd::status::finish_command(out, args.shard)
    } else {
        format!("rwg run {} --out {}", sh_path(&args.manifest), sh_path(out))
    };
    let mut opt = |o: String| {
        cmd.push(' ');
        cmd.push_str(&o);
    };
    if !in_dir {
        let study = [
            ("samples", args.samples),
            ("episodes", args.episodes.map(u64::from)),
            ("seed", args.seed),
        ];
        for (name, v) in study {
            if let Some(v) = v {
                opt(format!("--{name} {v}"));
            }
        }
        if let Some(s) = args.shard {
            opt(format!("--shard {}/{}", s.index, s.count));
        }
        if args.force_new {
            opt("--force-new".into());
        }
    }
    if let Some(t) = args.threads {
        opt(format!("--threads {t}"));
    }
    if args.step_timeout != fault_guard::DEFAULT_STEP_TIMEOUT_S {
        opt(format!("--step-timeout {}", args.step_timeout));
    }
    let switches = [
        ("--isolate", args.isolate),
        ("--no-report", args.no_report),
        ("--quiet", args.quiet),
        ("--timing", args.timing),
    ];
    for (flag, given) in switches {
        if given {
            opt(flag.into());
        }
    }
    rwg_study::shell::with_pythonpath(pythonpath, cmd)
}

/// The `PYTHONPATH` a printed command that starts this study's envs again
/// needs: this process's, when the study has a `gymnasium:` or JAX env
/// (whose module may be found through it); `None` otherwise.
fn python_path(m: &Manifest) -> Option<String> {
    let python = m
        .envs
        .iter()
        .any(|e| e.id.starts_with("gymnasium:") || rwg_study::jax_source::is_jax(&e.id));
    let pp = std::env::var("PYTHONPATH").ok().filter(|p| !p.is_empty());
    pp.filter(|_| python)
}

/// Starts the contract checks of the study's plugin envs when the cells
/// are planned, and passes every event on to the progress display.
struct WithChecks<'a> {
    display: &'a mut dyn Progress,
    /// What the display knows of JAX warm-ups, told by each JAX env's
    /// source (registered when the cells are planned).
    compiling: Arc<Compiling>,
    /// `rwg check`'s determinism and thread-safety checks, one per plugin
    /// env, each giving the warnings to print.
    checks: Vec<std::thread::JoinHandle<Vec<String>>>,
    /// What the fault handlers print once the run directory holds the
    /// study (see [`resume_command`]), set when the run starts.
    started: Option<(String, String)>,
    /// Say how each JAX env runs (devices, networks per call, cache).
    jax_lines: bool,
}

impl Progress for WithChecks<'_> {
    fn planned(&mut self, cells: &[Cell]) {
        // In child processes, in the background: the run does not wait.
        let mut seen = std::collections::HashSet::new();
        let mut jax: Vec<&Arc<rwg_jax::JaxSource>> = vec![];
        for c in cells {
            if let EnvSource::Jax(j) = &c.source {
                if !jax.iter().any(|k| Arc::ptr_eq(k, j)) {
                    j.observe(Arc::clone(&self.compiling) as Arc<dyn WarmUpObserver>);
                    jax.push(j);
                }
            }
            let EnvSource::Plugin(p) = &c.source else {
                continue;
            };
            let key = (
                p.path().to_path_buf(),
                p.ty.id().to_string(),
                p.config.clone(),
            );
            if seen.insert(key.clone()) {
                let (path, id, config) = key;
                self.checks.push(std::thread::spawn(move || {
                    crate::cmd::check::contract_warnings(&path, &id, &config)
                }));
            }
        }
        if self.jax_lines {
            let mut said = std::collections::HashSet::new();
            for c in cells {
                if let EnvSource::Jax(j) = &c.source {
                    if said.insert(c.id.env.clone()) {
                        crate::errln!("{}", j.run_line(&c.plan));
                    }
                }
            }
        }
        self.display.planned(cells);
    }

    fn start(&mut self, networks: u64) {
        // The run directory holds the study (its manifest.toml is written).
        if let Some((resume, resume_stopped)) = self.started.take() {
            fault_guard::set_resume(resume, resume_stopped);
        }
        self.display.start(networks);
    }

    fn note(&mut self, message: &str) {
        // Before `start`: no progress display to interleave with; shown
        // with --quiet too.
        crate::errln!("note: {message}");
    }

    fn cell(&mut self, label: &str) {
        self.display.cell(label);
    }

    fn block(&mut self, label: &str, networks: u64, env_steps: u64) {
        self.display.block(label, networks, env_steps);
    }

    fn finish(&mut self, ok: bool) {
        self.display.finish(ok);
    }
}
