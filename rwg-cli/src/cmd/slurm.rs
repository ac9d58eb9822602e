//! `rwg slurm`: submit a study to Slurm as a job array of shards plus a merge
//! job that depends on it; run again to resubmit what did not finish.

use crate::cluster::{live_jobs, merged_complete, shard_state, Job, Plan, ShardState, ShardedDir};
use crate::slurm_script::{
    array_spec, check_sbatch_option, check_sbatch_path, parse_job_id, show_command, Scripts,
};
use anyhow::{bail, Context, Result};
use rwg_study::cells::plan_cells;
use rwg_study::manifest::Manifest;
use rwg_study::rundir::export::write_atomic;
use rwg_study::rundir::outputs::{Output, OutputKind};
use rwg_study::rundir::{MANIFEST, RUN_JSON};
use rwg_study::shell::sh_path;
use std::path::{Path, PathBuf};
use std::process::Command;

/// Arguments of `rwg slurm`.
#[derive(clap::Args)]
#[command(after_help = "\
Writes into DIR:
  slurm/manifest.toml  the resolved study every shard runs
  slurm/shards.sh      job array: task K runs `rwg run --shard K/N --out DIR/shards/K`
  slurm/merge.sh       `rwg merge DIR/shards/0 ... --out DIR` (cells, stats, figures, report)
  slurm/plan.json      shard count, sbatch options, submitted job ids
  slurm/logs/          shard-K.out, merge-JOBID.out
then submits shards.sh and merge.sh (--dependency=afterok on the array) with sbatch.
The merged run ends in DIR itself. The scripts call this rwg binary by its absolute
path, so it and DIR must be on a file system the compute nodes share.

A requeued or restarted task resumes its shard. If a task fails or is cancelled, the
merge cannot start; once no task is queued or running, run the same command again: it
cancels the waiting merge, resubmits only the unfinished shards (which resume from their
committed blocks) and a new merge. Sbatch options given again replace the earlier
ones; given none, the earlier ones are kept.

Examples:
  rwg slurm examples/quick.toml --shards 3 --out runs/quick-slurm --dry-run
  rwg slurm examples/paper.toml --shards 10 --out runs/paper-cluster --time 24:00:00
  rwg slurm examples/paper.toml --shards 10 --out runs/paper-cluster --sbatch=--qos=long
  rwg status runs/paper-cluster")]
pub struct Args {
    /// The study's TOML manifest.
    manifest: PathBuf,
    /// Number of shards (array tasks).
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u64).range(1..=rwg_study::limits::MAX_SHARDS))]
    shards: u64,
    /// Study directory; the merged run ends here (default: the manifest's `out`,
    /// else runs/NAME for a manifest NAME.toml).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Slurm partition (sbatch --partition).
    #[arg(long)]
    partition: Option<String>,
    /// Time limit of each job (sbatch --time), e.g. 12:00:00.
    #[arg(long)]
    time: Option<String>,
    /// CPUs per shard task (sbatch --cpus-per-task); rwg runs that many threads.
    #[arg(long, value_name = "N")]
    cpus_per_task: Option<u32>,
    /// Memory per job (sbatch --mem), e.g. 4G.
    #[arg(long)]
    mem: Option<String>,
    /// Account to charge (sbatch --account).
    #[arg(long)]
    account: Option<String>,
    /// Any other sbatch option for both scripts, e.g. --sbatch=--qos=long (repeatable).
    #[arg(long = "sbatch", value_name = "ARG", allow_hyphen_values = true)]
    sbatch: Vec<String>,
    /// Run every plugin env isolated in the shard tasks (as `rwg run
    /// --isolate`; written into slurm/manifest.toml as `isolate = true`).
    #[arg(long)]
    isolate: bool,
    /// Write the scripts and print the sbatch commands, submit nothing.
    #[arg(long)]
    dry_run: bool,
}

/// Checks that every env of `m` builds here and resolves its plugin files
/// into `m`. A JAX env is checked on JAX's default device: the device the
/// manifest names is the compute nodes' (a GPU), which this machine (a
/// login node) need not have; the shards check it when they start.
fn check_envs(m: &mut Manifest) -> Result<()> {
    let mut here = m.clone();
    for e in &mut here.envs {
        e.device = None;
    }
    plan_cells(&mut here)?;
    for (e, checked) in m.envs.iter_mut().zip(here.envs) {
        e.plugin = checked.plugin;
    }
    Ok(())
}

/// Runs `rwg slurm`.
pub fn run(args: Args) -> Result<()> {
    let mut m = Manifest::load(&args.manifest)?;
    // Paths resolved before plugin code runs (checking the envs creates
    // each once), which may change the working directory.
    let out = crate::cmd::run::default_out(args.out.as_ref(), &m, &args.manifest);
    crate::cmd::claim_output(Output::new(&out, OutputKind::RunDir), "")?;
    let out = crate::cmd::absolute(&out)?;
    let args = Args {
        manifest: crate::cmd::absolute(&args.manifest)?,
        ..args
    };
    check_envs(&mut m)?;
    if args.isolate {
        // (how the shards run, not what: a resubmission may change it)
        m.isolate_all();
    }
    let sub = Submission::resolve(&args, &out)?;
    let (common, array_only) = sbatch_options(&args)?;
    let mut plan = read_or_start_plan(&sub.sd, &m, args.shards)?;
    if merged_complete(&sub.sd.root) {
        crate::outln!(
            "{} already holds this study, merged and complete; nothing to submit.",
            sub.sd.root.display()
        );
        return Ok(());
    }
    // Options given now replace the ones of an earlier submission.
    if !common.is_empty() || !array_only.is_empty() {
        plan.sbatch = common;
        plan.sbatch_array = array_only;
    }
    let sub = Submission {
        unfinished: unfinished_shards(&sub.sd, &m, args.shards),
        ..sub
    };
    if !args.dry_run {
        which_sbatch()?;
        cancel_or_refuse(&plan, &sub.sd.root)?;
    }
    write_study(&sub, &m, &plan)?;
    if args.dry_run {
        sub.print_dry_run();
        return Ok(());
    }
    sub.submit(&mut plan)
}

/// The study directory `out`, resolved: the scripts name everything by
/// absolute path, without `..`.
fn resolve_root(out: &Path) -> Result<PathBuf> {
    std::fs::create_dir_all(out).with_context(|| format!("cannot create {}", out.display()))?;
    let root = out
        .canonicalize()
        .with_context(|| format!("cannot resolve {}", out.display()))?;
    check_sbatch_path(&root)?;
    Ok(root)
}

/// The plan of the study `root` holds (refused if its shard count or study
/// differs from this one), or a new one if it holds none (refused if it
/// holds a run that `rwg slurm` did not start).
fn read_or_start_plan(sd: &ShardedDir, m: &Manifest, shards: u64) -> Result<Plan> {
    let root = &sd.root;
    if !sd.exists() {
        if root.join(MANIFEST).exists() || root.join(RUN_JSON).exists() {
            bail!(
                "{} already holds a run that rwg slurm did not start; choose another --out",
                root.display()
            );
        }
        return Ok(Plan {
            shards,
            ..Plan::default()
        });
    }
    let plan = sd.read_plan()?;
    if plan.shards != shards {
        bail!(
            "{} holds this study in {} shards, not {}; use --shards {} (or another --out)",
            root.display(),
            plan.shards,
            shards,
            plan.shards
        );
    }
    let old = Manifest::load(&sd.manifest())?;
    let diffs = old.study_differences(m);
    if !diffs.is_empty() {
        bail!(
            "{} holds a different study ({}); choose another --out",
            root.display(),
            diffs.join("; ")
        );
    }
    Ok(plan)
}

/// The shards of the study in `sd` that are not complete.
fn unfinished_shards(sd: &ShardedDir, m: &Manifest, shards: u64) -> Vec<u64> {
    (0..shards)
        .filter(|&k| {
            !matches!(
                shard_state(&sd.shard(k), m, k, shards),
                ShardState::Complete(_)
            )
        })
        .collect()
}

/// Writes the study, the scripts and the plan into the study directory.
fn write_study(sub: &Submission, m: &Manifest, plan: &Plan) -> Result<()> {
    let sd = &sub.sd;
    for d in [sd.logs(), sd.root.join("shards")] {
        std::fs::create_dir_all(&d).with_context(|| format!("cannot create {}", d.display()))?;
    }
    write_atomic(&sd.manifest(), m.to_toml().as_bytes())
        .with_context(|| format!("cannot write {}", sd.manifest().display()))?;
    let scripts = Scripts {
        rwg: &sub.rwg,
        dir: sd,
        shards: sub.shards,
        common: &plan.sbatch,
        array_only: &plan.sbatch_array,
    };
    write_script(&sd.array_script(), &scripts.array())?;
    write_script(&sd.merge_script(), &scripts.merge())?;
    sd.write_plan(plan)
}

/// What `rwg slurm` submits: the shards still to run and the merge.
struct Submission {
    /// This rwg binary, which the scripts call.
    rwg: PathBuf,
    /// The study directory (absolute).
    sd: ShardedDir,
    /// The manifest file as given, resolved (for the resubmit command).
    manifest_path: PathBuf,
    /// The study's shard count.
    shards: u64,
    /// The shards that are not complete.
    unfinished: Vec<u64>,
}

impl Submission {
    /// The paths of a submission of `args` into `out` (no shard known yet
    /// to be unfinished).
    fn resolve(args: &Args, out: &Path) -> Result<Self> {
        let root = resolve_root(out)?;
        let manifest_path = args
            .manifest
            .canonicalize()
            .with_context(|| format!("cannot resolve {}", args.manifest.display()))?;
        let rwg = std::env::current_exe().context("cannot find the rwg binary's path")?;
        Ok(Submission {
            rwg,
            sd: ShardedDir { root },
            manifest_path,
            shards: args.shards,
            unfinished: vec![],
        })
    }

    /// The sbatch command of the job array: the unfinished shards only,
    /// when some are complete.
    fn array_cmd(&self) -> Vec<String> {
        let mut c = vec!["sbatch".to_string(), "--parsable".into()];
        if self.unfinished.len() as u64 != self.shards {
            c.push(format!("--array={}", array_spec(&self.unfinished)));
        }
        c.push(self.sd.array_script().to_string_lossy().into_owned());
        c
    }

    /// The sbatch command of the merge job, after job `after` if any.
    fn merge_cmd(&self, after: Option<&str>) -> Vec<String> {
        let mut c = vec!["sbatch".to_string(), "--parsable".into()];
        if let Some(id) = after {
            c.push(format!("--dependency=afterok:{id}"));
        }
        c.push(self.sd.merge_script().to_string_lossy().into_owned());
        c
    }

    /// `rwg slurm` again, to resubmit what did not finish.
    fn resubmit(&self) -> String {
        format!(
            "{} slurm {} --shards {} --out {}",
            sh_path(&self.rwg),
            sh_path(&self.manifest_path),
            self.shards,
            sh_path(&self.sd.root)
        )
    }

    /// `--dry-run`: what was written and what would be submitted.
    fn print_dry_run(&self) {
        let sd = &self.sd;
        crate::outln!(
            "Wrote {} and {}.",
            sd.array_script().display(),
            sd.merge_script().display()
        );
        crate::outln!(
            "Would submit ({}):",
            describe_unfinished(&self.unfinished, self.shards)
        );
        if !self.unfinished.is_empty() {
            crate::outln!("  A=$({})", show_command(&self.array_cmd()));
            crate::outln!(
                "  sbatch --parsable --dependency=afterok:$A {}",
                sh_path(&sd.merge_script())
            );
        } else {
            crate::outln!("  {}", show_command(&self.merge_cmd(None)));
        }
    }

    /// Submits the job array (if a shard is unfinished) and the merge,
    /// recording each job in the plan, then prints how to watch them.
    fn submit(&self, plan: &mut Plan) -> Result<()> {
        let array_id = self.submit_array(plan)?;
        let merge_id = sbatch(&self.merge_cmd(array_id.as_deref()))?;
        plan.jobs.push(Job {
            kind: "merge".into(),
            id: merge_id.clone(),
            tasks: vec![],
        });
        self.sd.write_plan(plan)?;
        crate::outln!(
            "Submitted merge job {merge_id}{}: merges the shards into {} (cells, stats, figures, report.html)",
            array_id
                .as_ref()
                .map_or(String::new(), |a| format!(" (afterok:{a}: starts when every task of {a} succeeded)")),
            self.sd.root.display()
        );
        let ids: Vec<String> = array_id.into_iter().chain([merge_id.clone()]).collect();
        self.print_watch(&ids.join(","), &merge_id);
        Ok(())
    }

    /// Submits the job array of the unfinished shards, if any: its job id.
    fn submit_array(&self, plan: &mut Plan) -> Result<Option<String>> {
        if self.unfinished.is_empty() {
            crate::outln!("Every shard is complete; submitting the merge only.");
            return Ok(None);
        }
        let id = sbatch(&self.array_cmd())?;
        plan.jobs.push(Job {
            kind: "shards".into(),
            id: id.clone(),
            tasks: self.unfinished.clone(),
        });
        self.sd.write_plan(plan)?;
        crate::outln!(
            "Submitted job array {id}: {} (task K runs shard K/{} into {}/K)",
            describe_unfinished(&self.unfinished, self.shards),
            self.shards,
            self.sd.root.join("shards").display()
        );
        Ok(Some(id))
    }

    /// How to watch the jobs `ids` and what to do if a shard task fails.
    fn print_watch(&self, ids: &str, merge_id: &str) {
        crate::outln!("\nWatch:");
        crate::outln!("  squeue -j {ids}");
        crate::outln!(
            "  sacct -j {ids} --format=JobID,JobName,State,ExitCode,Elapsed   # needs Slurm accounting"
        );
        crate::outln!("  {} status {}", sh_path(&self.rwg), sh_path(&self.sd.root));
        crate::outln!("  tail -f {}/shard-*.out", sh_path(&self.sd.logs()));
        crate::outln!(
            "\nIf a shard task fails or is cancelled, merge job {merge_id} cannot start (squeue shows it\n\
             pending with reason DependencyNeverSatisfied). Once no task is queued or running, resubmit\n\
             the unfinished shards (they resume from their committed blocks) and a new merge with:\n  {}",
            self.resubmit()
        );
    }
}

fn describe_unfinished(unfinished: &[u64], n: u64) -> String {
    if unfinished.len() as u64 == n {
        format!("all {n} shards")
    } else if unfinished.is_empty() {
        "no shard, all are complete; the merge only".into()
    } else {
        format!("shard(s) {} of {n}", array_spec(unfinished))
    }
}

/// The `#SBATCH` options from the flags: (both scripts, array only).
fn sbatch_options(args: &Args) -> Result<(Vec<String>, Vec<String>)> {
    let mut common = vec![];
    let mut flag = |name: &str, v: &Option<String>| -> Result<()> {
        if let Some(v) = v {
            if v.is_empty() || v.contains(char::is_whitespace) {
                bail!("--{name} '{v}': give a value without spaces");
            }
            common.push(format!("--{name}={v}"));
        }
        Ok(())
    };
    flag("partition", &args.partition)?;
    flag("time", &args.time)?;
    flag("mem", &args.mem)?;
    flag("account", &args.account)?;
    for o in &args.sbatch {
        check_sbatch_option(o)?;
        common.push(o.clone());
    }
    let array_only = match args.cpus_per_task {
        Some(0) => bail!("--cpus-per-task must be at least 1"),
        Some(c) => vec![format!("--cpus-per-task={c}")],
        None => vec![],
    };
    Ok((common, array_only))
}

fn write_script(path: &Path, text: &str) -> Result<()> {
    write_atomic(path, text.as_bytes())
        .with_context(|| format!("cannot write {}", path.display()))?;
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        std::fs::set_permissions(path, std::fs::Permissions::from_mode(0o755))
            .with_context(|| format!("cannot make {} executable", path.display()))?;
    }
    Ok(())
}

fn which_sbatch() -> Result<()> {
    match Command::new("sbatch").arg("--version").output() {
        Ok(o) if o.status.success() => Ok(()),
        Ok(o) => bail!(
            "sbatch --version failed: {}",
            String::from_utf8_lossy(&o.stderr).trim()
        ),
        Err(e) => bail!(
            "cannot run sbatch ({e}): this machine is not a Slurm submission host; \
             --dry-run writes the scripts without submitting them"
        ),
    }
}

/// Runs `sbatch --parsable ...`; returns the job id.
fn sbatch(cmd: &[String]) -> Result<String> {
    let o = Command::new(&cmd[0])
        .args(&cmd[1..])
        .output()
        .with_context(|| format!("cannot run {}", show_command(cmd)))?;
    let stdout = String::from_utf8_lossy(&o.stdout);
    if !o.status.success() {
        bail!(
            "{} failed ({}): {}",
            show_command(cmd),
            o.status,
            String::from_utf8_lossy(&o.stderr).trim()
        );
    }
    parse_job_id(&stdout).with_context(|| {
        format!(
            "{} printed {:?}, not a job id",
            show_command(cmd),
            stdout.trim()
        )
    })
}

/// Before resubmitting: refuses while a shard task of an earlier submission
/// is queued or running (two writers on one shard directory), cancels an
/// earlier merge job that still waits (its dependency failed, or a new merge
/// replaces it), and refuses while a merge runs.
fn cancel_or_refuse(plan: &Plan, root: &Path) -> Result<()> {
    let mut busy = vec![];
    let mut cancel = vec![];
    for job in live_jobs(plan)? {
        if job.kind == "merge" && job.state == "PENDING" {
            cancel.push(job.id);
        } else {
            busy.push(job.describe());
        }
    }
    if !busy.is_empty() {
        let ids: Vec<&str> = plan.jobs.iter().map(|j| j.id.as_str()).collect();
        bail!(
            "jobs of {} are still queued or running: {}; wait for them (squeue -j {}) or cancel \
             them (scancel ID), then run this command again",
            root.display(),
            busy.join(", "),
            ids.join(",")
        );
    }
    for id in cancel {
        let o = Command::new("scancel")
            .arg(&id)
            .output()
            .context("cannot run scancel")?;
        if !o.status.success() {
            bail!(
                "scancel {id} failed: {}",
                String::from_utf8_lossy(&o.stderr).trim()
            );
        }
        crate::outln!(
            "Cancelled merge job {id}, which was still waiting; a new merge replaces it."
        );
    }
    Ok(())
}
