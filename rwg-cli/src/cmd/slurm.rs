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
    check_envs(&mut m)?;
    if args.isolate {
        // (how the shards run, not what: a resubmission may change it)
        m.isolate_all();
    }
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
    // The scripts name everything by absolute path, without `..`.
    std::fs::create_dir_all(&out).with_context(|| format!("cannot create {}", out.display()))?;
    let root = out
        .canonicalize()
        .with_context(|| format!("cannot resolve {}", out.display()))?;
    check_sbatch_path(&root)?;
    let manifest_path = args
        .manifest
        .canonicalize()
        .with_context(|| format!("cannot resolve {}", args.manifest.display()))?;
    let rwg = std::env::current_exe().context("cannot find the rwg binary's path")?;
    let sd = ShardedDir { root: root.clone() };

    let (common, array_only) = sbatch_options(&args)?;
    let mut plan = if sd.exists() {
        let plan = sd.read_plan()?;
        if plan.shards != args.shards {
            bail!(
                "{} holds this study in {} shards, not {}; use --shards {} (or another --out)",
                root.display(),
                plan.shards,
                args.shards,
                plan.shards
            );
        }
        let old = Manifest::load(&sd.manifest())?;
        let diffs = old.study_differences(&m);
        if !diffs.is_empty() {
            bail!(
                "{} holds a different study ({}); choose another --out",
                root.display(),
                diffs.join("; ")
            );
        }
        plan
    } else {
        if root.join(MANIFEST).exists() || root.join(RUN_JSON).exists() {
            bail!(
                "{} already holds a run that rwg slurm did not start; choose another --out",
                root.display()
            );
        }
        Plan {
            shards: args.shards,
            ..Plan::default()
        }
    };
    if merged_complete(&root) {
        crate::outln!(
            "{} already holds this study, merged and complete; nothing to submit.",
            root.display()
        );
        return Ok(());
    }
    // Options given now replace the ones of an earlier submission.
    if !common.is_empty() || !array_only.is_empty() {
        plan.sbatch = common;
        plan.sbatch_array = array_only;
    }

    let unfinished: Vec<u64> = (0..args.shards)
        .filter(|&k| {
            !matches!(
                shard_state(&sd.shard(k), &m, k, args.shards),
                ShardState::Complete(_)
            )
        })
        .collect();

    if !args.dry_run {
        which_sbatch()?;
        cancel_or_refuse(&plan, &root)?;
    }

    // Write the study, the scripts and the plan.
    for d in [sd.logs(), root.join("shards")] {
        std::fs::create_dir_all(&d).with_context(|| format!("cannot create {}", d.display()))?;
    }
    write_atomic(&sd.manifest(), m.to_toml().as_bytes())
        .with_context(|| format!("cannot write {}", sd.manifest().display()))?;
    let scripts = Scripts {
        rwg: &rwg,
        dir: &sd,
        shards: args.shards,
        common: &plan.sbatch,
        array_only: &plan.sbatch_array,
    };
    write_script(&sd.array_script(), &scripts.array())?;
    write_script(&sd.merge_script(), &scripts.merge())?;
    sd.write_plan(&plan)?;

    let array_cmd = |dep: bool| -> Vec<String> {
        let mut c = vec!["sbatch".to_string(), "--parsable".into()];
        if dep && unfinished.len() as u64 != args.shards {
            c.push(format!("--array={}", array_spec(&unfinished)));
        }
        c.push(sd.array_script().to_string_lossy().into_owned());
        c
    };
    let merge_cmd = |after: Option<&str>| -> Vec<String> {
        let mut c = vec!["sbatch".to_string(), "--parsable".into()];
        if let Some(id) = after {
            c.push(format!("--dependency=afterok:{id}"));
        }
        c.push(sd.merge_script().to_string_lossy().into_owned());
        c
    };
    let resubmit = format!(
        "{} slurm {} --shards {} --out {}",
        sh_path(&rwg),
        sh_path(&manifest_path),
        args.shards,
        sh_path(&root)
    );

    if args.dry_run {
        crate::outln!(
            "Wrote {} and {}.",
            sd.array_script().display(),
            sd.merge_script().display()
        );
        crate::outln!(
            "Would submit ({}):",
            describe_unfinished(&unfinished, args.shards)
        );
        if !unfinished.is_empty() {
            crate::outln!("  A=$({})", show_command(&array_cmd(true)));
            crate::outln!(
                "  sbatch --parsable --dependency=afterok:$A {}",
                sh_path(&sd.merge_script())
            );
        } else {
            crate::outln!("  {}", show_command(&merge_cmd(None)));
        }
        return Ok(());
    }

    let mut ids = vec![];
    let array_id = if unfinished.is_empty() {
        crate::outln!("Every shard is complete; submitting the merge only.");
        None
    } else {
        let id = sbatch(&array_cmd(true))?;
        plan.jobs.push(Job {
            kind: "shards".into(),
            id: id.clone(),
            tasks: unfinished.clone(),
        });
        sd.write_plan(&plan)?;
        crate::outln!(
            "Submitted job array {id}: {} (task K runs shard K/{} into {}/K)",
            describe_unfinished(&unfinished, args.shards),
            args.shards,
            root.join("shards").display()
        );
        ids.push(id.clone());
        Some(id)
    };
    let merge_id = sbatch(&merge_cmd(array_id.as_deref()))?;
    plan.jobs.push(Job {
        kind: "merge".into(),
        id: merge_id.clone(),
        tasks: vec![],
    });
    sd.write_plan(&plan)?;
    ids.push(merge_id.clone());
    crate::outln!(
        "Submitted merge job {merge_id}{}: merges the shards into {} (cells, stats, figures, report.html)",
        array_id
            .as_ref()
            .map_or(String::new(), |a| format!(" (afterok:{a}: starts when every task of {a} succeeded)")),
        root.display()
    );
    let ids = ids.join(",");
    crate::outln!("\nWatch:");
    crate::outln!("  squeue -j {ids}");
    crate::outln!(
        "  sacct -j {ids} --format=JobID,JobName,State,ExitCode,Elapsed   # needs Slurm accounting"
    );
    crate::outln!("  {} status {}", sh_path(&rwg), sh_path(&root));
    crate::outln!("  tail -f {}/shard-*.out", sh_path(&sd.logs()));
    crate::outln!(
        "\nIf a shard task fails or is cancelled, merge job {merge_id} cannot start (squeue shows it\n\
         pending with reason DependencyNeverSatisfied). Once no task is queued or running, resubmit\n\
         the unfinished shards (they resume from their committed blocks) and a new merge with:\n  {resubmit}"
    );
    Ok(())
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
