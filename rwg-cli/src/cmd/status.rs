//! `rwg status`: how far a run, a shard or a sharded study has got, and the
//! command that finishes it. Read-only: safe while the run is being written.

use crate::cluster::{
    live_jobs, merged_complete, shard_state, LiveJob, Plan, ShardState, ShardedDir,
};
use anyhow::{bail, Result};
use rwg_analysis::jax_cells::{jax_settings, setting_line};
use rwg_analysis::report::REPORT_HTML;
use rwg_analysis::table::{Align, TextColumns};
use rwg_study::manifest::Manifest;
use rwg_study::rundir::blocks::n_blocks;
use rwg_study::rundir::meta::read_run_meta as read_meta;
use rwg_study::rundir::meta::ShardMeta;
use rwg_study::rundir::status::{cell_dirs, progress, CellProgress, Totals};
use rwg_study::rundir::study::{edited_message, manifest_edits};
use rwg_study::rundir::{MANIFEST, RUN_JSON};
use rwg_study::shell::sh_path;
use std::path::{Path, PathBuf};

/// Arguments of `rwg status`.
#[derive(clap::Args)]
#[command(after_help = "\
RUN_DIR is one of:
  a run directory (rwg run):            cells complete, blocks committed per cell
  a shard's directory (rwg run --shard): the same for the blocks the shard owns
  a sharded study (rwg slurm --out DIR, or shards in DIR/shards/K):
                                         every shard (missing, incomplete, complete)
                                         and the merged run in DIR
It ends with the command that finishes the work. It only reads, so it can be run
while the study is being computed; it shows what was committed at that instant.

Examples:
  rwg run examples/quick.toml --out runs/quick-64 --samples 64; rwg status runs/quick-64
  rwg status runs/paper-cluster   # after rwg slurm ... --out runs/paper-cluster")]
pub struct Args {
    /// Run directory, shard directory, or a sharded study's directory (the
    /// --out of `rwg slurm`, or any DIR holding shards in `DIR/shards/<K>`).
    run_dir: PathBuf,
}

/// Runs `rwg status`.
pub fn run(args: Args) -> Result<()> {
    let dir = &args.run_dir;
    let sharded = ShardedDir { root: dir.clone() };
    if sharded.exists() {
        return sharded_status(&sharded, sharded.read_plan()?, sharded.manifest(), true);
    }
    let manifest_path = dir.join(MANIFEST);
    if let Some((count, shard0)) = shards_without_plan(&sharded)? {
        let plan = Plan {
            shards: count,
            ..Plan::default()
        };
        return sharded_status(&sharded, plan, shard0.join(MANIFEST), false);
    }
    if !manifest_path.is_file() {
        if !dir.is_dir() {
            // a file, or nothing: said as every command that reads a run says it
            rwg_study::rundir::data::require_run_dir(dir)?;
        }
        if let Some(holder) = rwg_study::rundir::lock::live_writer(dir) {
            bail!(
                "{} is a run (or merge) being started by {holder}: it has no manifest.toml yet; \
                 run rwg status again in a moment",
                dir.display()
            );
        }
        if std::fs::read_dir(dir).is_ok_and(|mut d| d.next().is_none()) {
            bail!(
                "{} is empty: no run is written there yet (a run or merge starting there \
                 writes its manifest.toml first)",
                dir.display()
            );
        }
        let inside = rwg_study::rundir::data::run_above(dir).map_or(String::new(), |r| {
            format!(
                "; it is inside the run directory {}: give that",
                r.display()
            )
        });
        bail!(
            "{} is not an rwg run directory: it has no manifest.toml (nor slurm/plan.json){inside}",
            dir.display()
        );
    }
    let mut m = Manifest::load(&manifest_path)?;
    let meta = if dir.join(RUN_JSON).exists() {
        Some(read_meta(dir)?)
    } else {
        None
    };
    // An edited manifest.toml is not the study: progress is the recorded study's.
    if let Some(meta) = &meta {
        let edits = manifest_edits(dir, meta, &m);
        if !edits.is_empty() {
            crate::outln!("warning: {}", edited_message(dir, &edits));
            let recorded = meta.study.as_deref().and_then(|s| {
                Manifest::parse(s, &dir.join(RUN_JSON).display().to_string(), dir).ok()
            });
            match recorded {
                Some(r) => m = r,
                None => bail!(
                    "{}: run.json does not record the study, so how far the run has got \
                     cannot be told from the edited manifest.toml; undo the edit first",
                    dir.display()
                ),
            }
        }
    }
    let shard = meta.as_ref().and_then(|m| m.shard);
    let cells = progress(dir, &m, shard);
    let t = Totals::of(&cells, shard.is_some());
    match shard {
        Some(s) => crate::outln!(
            "{}: shard {}/{} of a study ({} cells, {} networks x {} episodes, blocks of 32)",
            dir.display(),
            s.index,
            s.count,
            cells.len(),
            m.samples,
            m.episodes
        ),
        None => crate::outln!(
            "{}: a run of the whole study ({} cells, {} networks x {} episodes, blocks of 32)",
            dir.display(),
            cells.len(),
            m.samples,
            m.episodes
        ),
    }
    print_cells(&cells, shard.is_some());
    print_jax(dir, &cells);
    let ended = meta.as_ref().is_some_and(|m| m.end_time.is_some());
    print_totals(&t, if shard.is_some() { "shard" } else { "run" }, ended);
    let finish = rwg_study::shell::with_pythonpath(
        rwg_study::rundir::env_record::recorded_pythonpath(dir).as_deref(),
        finish_command(dir, shard),
    );
    if !t.complete() || !ended {
        crate::outln!("Finish it with:\n  {finish}");
    } else if shard.is_some() {
        crate::outln!(
            "Nothing left to do in this shard; combine the shards with rwg merge DIR... --out DIR"
        );
    } else if !dir.join(REPORT_HTML).exists() {
        crate::outln!(
            "No report yet; write stats, figures and report.html with:\n  rwg report {}",
            sh_path(dir)
        );
    }
    Ok(())
}

/// The command that finishes the run (or shard) in `dir` once the directory
/// holds its study: `rwg run DIR/manifest.toml --out DIR [--shard K/N]`,
/// shell-quoted. The directory's `manifest.toml` is the study with every
/// override applied, so no override needs repeating.
pub(crate) fn finish_command(dir: &Path, shard: Option<ShardMeta>) -> String {
    format!(
        "rwg run {} --out {}{}",
        sh_path(&dir.join(MANIFEST)),
        sh_path(dir),
        shard.map_or(String::new(), |s| format!(
            " --shard {}/{}",
            s.index, s.count
        ))
    )
}

fn print_cells(cells: &[CellProgress], shard: bool) {
    let columns = TextColumns::new(
        &[(46, Align::Left), (13, Align::Right), (0, Align::Left)],
        " ",
    )
    .gap(1, "  ");
    crate::outln!("  {}", columns.line(&["cell", "blocks", "state"]));
    for c in cells {
        let state = if c.finalised {
            "complete"
        } else if c.done(shard) {
            if shard {
                "complete"
            } else {
                "all blocks committed, not finalised"
            }
        } else if c.blocks_done == 0 {
            "not started"
        } else {
            "in progress"
        };
        let blocks = format!("{}/{}", c.blocks_done, c.blocks_total);
        crate::outln!("  {}", columns.line(&[c.dir.as_str(), &blocks, state]));
    }
}

/// How the JAX cells started so far compute, from their `env.json`.
fn print_jax(dir: &Path, cells: &[CellProgress]) {
    let settings = jax_settings(dir, cells.iter().map(|c| c.dir.as_str()));
    if !settings.is_empty() {
        crate::outln!("  JAX (each cell's env.json):");
        for s in &settings {
            crate::outln!("    {}", setting_line(s));
        }
    }
}

fn print_totals(t: &Totals, what: &str, ended: bool) {
    let state = if t.complete() && ended {
        "complete"
    } else {
        "incomplete"
    };
    crate::outln!(
        "The {what} is {state}: {} of {} cells done, {} of {} blocks committed{}.",
        t.cells_done,
        t.cells,
        t.blocks_done,
        t.blocks,
        if t.complete() && !ended {
            " (run.json has no end time yet: the run is finishing or was stopped)"
        } else {
            ""
        }
    );
}

/// `DIR/shards/<K>` written without `rwg slurm` (no plan file), e.g. by a
/// Kubernetes Indexed Job: the shard count and a shard's directory, from the
/// first shard found (`None` if DIR has no `shards/` with a shard in it).
fn shards_without_plan(sd: &ShardedDir) -> Result<Option<(u64, PathBuf)>> {
    let Ok(entries) = std::fs::read_dir(sd.root.join("shards")) else {
        return Ok(None);
    };
    let mut dirs: Vec<PathBuf> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.join(RUN_JSON).is_file())
        .collect();
    dirs.sort();
    for d in dirs {
        if let Some(s) = read_meta(&d)?.shard {
            return Ok(Some((s.count, d)));
        }
    }
    Ok(None)
}

fn sharded_status(sd: &ShardedDir, plan: Plan, manifest: PathBuf, slurm: bool) -> Result<()> {
    let m = Manifest::load(&manifest)?;
    let count = plan.shards;
    let root = &sd.root;
    print_study_cells(sd, &m, count);
    // What Slurm still runs or queues: those shards finish on their own.
    let (live, queue_error) = if slurm {
        match live_jobs(&plan) {
            Ok(live) => (live, None),
            Err(e) => (vec![], Some(format!("{e:#}"))),
        }
    } else {
        (vec![], None)
    };
    let (unfinished, computing) = print_shards(sd, &m, count, &live);
    let merged = merged_complete(root);
    crate::outln!(
        "Merged run {}: {}",
        root.display(),
        merge_state(root, &m, merged)
    );
    print_jobs(&plan, queue_error.as_deref());
    if merged {
        if !root.join(REPORT_HTML).exists() {
            crate::outln!(
                "No report yet; write it with:\n  rwg report {}",
                sh_path(root)
            );
        }
        return Ok(());
    }
    if !computing.is_empty() && !print_computing(&computing, &live, unfinished.is_empty()) {
        return Ok(());
    }
    print_finish(sd, &manifest, count, &unfinished, slurm);
    Ok(())
}

/// The study's heading and its cells: finalised in the merged run, or the
/// blocks the shards committed.
fn print_study_cells(sd: &ShardedDir, m: &Manifest, count: u64) {
    let root = &sd.root;
    crate::outln!(
        "{}: a study in {count} shards ({} cells, {} networks x {} episodes), merged into {}",
        root.display(),
        cell_dirs(m).len(),
        m.samples,
        m.episodes,
        root.display()
    );
    let nb = n_blocks(m.samples);
    let mut cells: Vec<CellProgress> = progress(root, m, None);
    for c in cells.iter_mut().filter(|c| !c.finalised) {
        c.blocks_done = 0;
        c.blocks_total = nb;
    }
    for k in 0..count {
        let s = ShardMeta { index: k, count };
        for (c, sp) in cells.iter_mut().zip(progress(&sd.shard(k), m, Some(s))) {
            if !c.finalised {
                c.blocks_done += sp.blocks_done;
            }
        }
    }
    print_cells(&cells, true);
}

/// The table of shards, with the Slurm task of each that Slurm still runs
/// or queues: the unfinished shards no task computes, and the tasks that
/// compute the others.
fn print_shards<'a>(
    sd: &ShardedDir,
    m: &Manifest,
    count: u64,
    live: &'a [LiveJob],
) -> (Vec<u64>, Vec<&'a LiveJob>) {
    let task_of = |k: u64| live.iter().find(|j| j.shard == Some(k));
    let columns = TextColumns::new(
        &[(6, Align::Left), (50, Align::Left), (0, Align::Left)],
        " ",
    );
    crate::outln!("  {}", columns.line(&["shard", "directory", "state"]));
    let (mut unfinished, mut computing) = (vec![], vec![]);
    for k in 0..count {
        let dir = sd.shard(k);
        let mut state = match shard_state(&dir, m, k, count) {
            ShardState::Missing => {
                unfinished.push(k);
                "missing (not started)".to_string()
            }
            ShardState::Incomplete(t) => {
                unfinished.push(k);
                format!(
                    "incomplete: {} of {} blocks, {} of {} cells",
                    t.blocks_done, t.blocks, t.cells_done, t.cells
                )
            }
            ShardState::Complete(t) => format!("complete ({} blocks)", t.blocks),
        };
        if let Some(task) = task_of(k) {
            state.push_str(&format!("; Slurm task {}", task.describe()));
            if unfinished.last() == Some(&k) {
                unfinished.pop();
                computing.push(task);
            }
        }
        let (shard, dir) = (format!("{k}/{count}"), dir.display().to_string());
        crate::outln!("  {}", columns.line(&[shard, dir, state]));
    }
    (unfinished, computing)
}

/// The merged run's state (`merged`: complete).
fn merge_state(root: &Path, m: &Manifest, merged: bool) -> String {
    if merged {
        "complete".to_string()
    } else if root.join(MANIFEST).is_file() {
        let t = Totals::of(&progress(root, m, None), false);
        format!(
            "incomplete: {} of {} cells merged (rerun the merge to finish it)",
            t.cells_done, t.cells
        )
    } else {
        "not started".to_string()
    }
}

/// The Slurm jobs submitted, and why the queue is not known if it is not.
fn print_jobs(plan: &Plan, queue_error: Option<&str>) {
    let ids: Vec<&str> = plan.jobs.iter().map(|j| j.id.as_str()).collect();
    if !ids.is_empty() {
        crate::outln!(
            "Slurm jobs submitted: {}  (watch: squeue -j {})",
            plan.jobs
                .iter()
                .map(|j| format!("{} {}", j.kind, j.id))
                .collect::<Vec<_>>()
                .join(", "),
            ids.join(",")
        );
    }
    if let Some(e) = queue_error {
        crate::outln!(
            "Slurm's queue could not be read ({e}); shards its tasks may still be computing \
             are listed below as unfinished."
        );
    }
}

/// The shards Slurm still computes and what to do when they end; whether
/// other shards are left to finish (`all_computing`: none is).
fn print_computing(computing: &[&LiveJob], live: &[LiveJob], all_computing: bool) -> bool {
    crate::outln!(
        "Slurm is still computing {}: {}.",
        if computing.len() == 1 {
            "a shard"
        } else {
            "shards"
        },
        computing
            .iter()
            .map(|j| j.describe())
            .collect::<Vec<_>>()
            .join(", ")
    );
    if all_computing {
        let merge: Vec<&LiveJob> = live.iter().filter(|j| j.kind == "merge").collect();
        match merge.first() {
            Some(j) if j.reason != "DependencyNeverSatisfied" => crate::outln!(
                "Merge job {} runs when they end: nothing to do but wait.",
                j.describe()
            ),
            _ => crate::outln!("When they end, run rwg status again."),
        }
        return false;
    }
    crate::outln!("When they end, finish the other shards:");
    true
}

/// The commands that finish the study: on Slurm (`slurm`), or here.
fn print_finish(sd: &ShardedDir, manifest: &Path, count: u64, unfinished: &[u64], slurm: bool) {
    let root = &sd.root;
    let manifest = sh_path(manifest);
    if slurm {
        crate::outln!(
            "Finish it on Slurm (submits {} and the merge; the sbatch options given \
         before are kept):\n  rwg slurm {manifest} --shards {count} --out {}",
            if unfinished.is_empty() {
                "no shard: all are complete,".to_string()
            } else {
                format!(
                    "shard(s) {}",
                    unfinished
                        .iter()
                        .map(|k| k.to_string())
                        .collect::<Vec<_>>()
                        .join(",")
                )
            },
            sh_path(root)
        );
    }
    crate::outln!(
        "{}",
        if slurm {
            "or on this machine:"
        } else {
            "Finish it with:"
        }
    );
    for &k in unfinished {
        crate::outln!(
            "  rwg run {manifest} --shard {k}/{count} --out {}",
            sh_path(&sd.shard(k))
        );
    }
    let shards: Vec<String> = (0..count).map(|k| sh_path(&sd.shard(k))).collect();
    crate::outln!("  rwg merge {} --out {}", shards.join(" "), sh_path(root));
}
