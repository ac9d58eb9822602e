//! A study computed in shards under one directory, as `rwg slurm` lays it
//! out and `rwg status` reads it:
//!
//! ```text
//! DIR/                  the merged run, once merged (manifest.toml, run.json, cells/, report.html...)
//! DIR/slurm/manifest.toml   the resolved study every shard runs
//! DIR/slurm/plan.json       shard count, sbatch options, submitted job ids
//! DIR/slurm/shards.sh       the job-array script (one task per shard)
//! DIR/slurm/merge.sh        the merge job's script
//! DIR/slurm/logs/           the jobs' output
//! DIR/shards/<K>/           shard K's run directory (`rwg run --shard K/N`)
//! ```

use anyhow::{bail, Context, Result};
use rwg_study::manifest::Manifest;
use rwg_study::rundir::meta::read_run_meta as read_meta;
use rwg_study::rundir::meta::ShardMeta;
use rwg_study::rundir::status::{progress, Totals};
use rwg_study::rundir::MANIFEST;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// The directory of a sharded study.
#[derive(Debug, Clone)]
pub struct ShardedDir {
    /// `DIR`: where the merged run ends up.
    pub root: PathBuf,
}

impl ShardedDir {
    /// `DIR/slurm`.
    pub fn slurm_dir(&self) -> PathBuf {
        self.root.join("slurm")
    }
    /// `DIR/slurm/manifest.toml`.
    pub fn manifest(&self) -> PathBuf {
        self.slurm_dir().join(MANIFEST)
    }
    /// `DIR/slurm/plan.json`.
    pub fn plan_file(&self) -> PathBuf {
        self.slurm_dir().join("plan.json")
    }
    /// `DIR/slurm/shards.sh`.
    pub fn array_script(&self) -> PathBuf {
        self.slurm_dir().join("shards.sh")
    }
    /// `DIR/slurm/merge.sh`.
    pub fn merge_script(&self) -> PathBuf {
        self.slurm_dir().join("merge.sh")
    }
    /// `DIR/slurm/logs`.
    pub fn logs(&self) -> PathBuf {
        self.slurm_dir().join("logs")
    }
    /// `DIR/shards/<k>`.
    pub fn shard(&self, k: u64) -> PathBuf {
        self.root.join("shards").join(k.to_string())
    }
    /// Whether `root` holds a sharded study (its plan file exists).
    pub fn exists(&self) -> bool {
        self.plan_file().is_file()
    }
    /// Reads the plan file.
    pub fn read_plan(&self) -> Result<Plan> {
        let p = self.plan_file();
        let text = rwg_study::limits::read_own_text(&p, rwg_study::limits::MAX_JSON_BYTES)
            .with_context(|| format!("cannot read {}", p.display()))?;
        serde_json::from_str(&text)
            .with_context(|| format!("{} is not an rwg slurm plan.json", p.display()))
    }
    /// Writes the plan file atomically.
    pub fn write_plan(&self, plan: &Plan) -> Result<()> {
        let p = self.plan_file();
        rwg_study::rundir::export::write_atomic(&p, serde_json::to_string_pretty(plan)?.as_bytes())
            .with_context(|| format!("cannot write {}", p.display()))
    }
}

/// `DIR/slurm/plan.json`.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct Plan {
    /// Number of shards.
    pub shards: u64,
    /// The `#SBATCH` options of both scripts, in order.
    pub sbatch: Vec<String>,
    /// The `#SBATCH` options of the job array only (`--cpus-per-task`).
    #[serde(default)]
    pub sbatch_array: Vec<String>,
    /// Every submission, oldest first.
    pub jobs: Vec<Job>,
}

/// One submitted Slurm job.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Job {
    /// `shards` (a job array) or `merge`.
    pub kind: String,
    /// Slurm job id.
    pub id: String,
    /// The array's task ids (shard indices); empty for the merge.
    #[serde(default)]
    pub tasks: Vec<u64>,
}

/// Where one shard stands.
#[derive(Debug, Clone)]
pub enum ShardState {
    /// Its directory does not exist, or holds no run yet.
    Missing,
    /// Some owned blocks are not committed.
    Incomplete(Totals),
    /// Every owned block is committed.
    Complete(Totals),
}

/// The state of shard `k` of `count` of study `m` in `dir`.
pub fn shard_state(dir: &Path, m: &Manifest, k: u64, count: u64) -> ShardState {
    if !dir.join(MANIFEST).is_file() {
        return ShardState::Missing;
    }
    let s = ShardMeta { index: k, count };
    let t = Totals::of(&progress(dir, m, Some(s)), true);
    if t.complete() {
        ShardState::Complete(t)
    } else {
        ShardState::Incomplete(t)
    }
}

/// Whether `dir` holds a finished merged run (run.json has an end time and
/// is not a shard's).
pub fn merged_complete(dir: &Path) -> bool {
    read_meta(dir).is_ok_and(|m| m.shard.is_none() && m.end_time.is_some())
}

/// A job, or one task of a job array, of a [`Plan`] that Slurm still lists
/// (pending, running, completing, ...).
#[derive(Debug, Clone, PartialEq)]
pub struct LiveJob {
    /// As `squeue` prints it: `123` for a job, `123_2` for an array task.
    pub id: String,
    /// The plan's kind of the job: `shards` or `merge`.
    pub kind: String,
    /// The shard an array task computes (its array index).
    pub shard: Option<u64>,
    /// Slurm's state, e.g. `PENDING`, `RUNNING`.
    pub state: String,
    /// Slurm's reason for the state (`None` when there is none).
    pub reason: String,
}

impl LiveJob {
    /// `123_2 (PENDING, Resources)` or `123_2 (RUNNING)`.
    pub fn describe(&self) -> String {
        if self.reason.is_empty() || self.reason == "None" {
            format!("{} ({})", self.id, self.state)
        } else {
            format!("{} ({}, {})", self.id, self.state, self.reason)
        }
    }
}

/// The jobs of `plan` that `squeue` still lists, one line per array task
/// (`squeue -r`). Jobs Slurm has forgotten are simply absent.
pub fn live_jobs(plan: &Plan) -> Result<Vec<LiveJob>> {
    if plan.jobs.is_empty() {
        return Ok(vec![]);
    }
    let ids: Vec<&str> = plan.jobs.iter().map(|j| j.id.as_str()).collect();
    let o = std::process::Command::new("squeue")
        .args(["-h", "-r", "-o", "%i|%T|%r", "-j", &ids.join(",")])
        .output()
        .context("cannot run squeue")?;
    let stderr = String::from_utf8_lossy(&o.stderr);
    // squeue fails on ids it has forgotten altogether.
    if !o.status.success() && !stderr.contains("Invalid job id") {
        bail!("squeue -j {} failed: {}", ids.join(","), stderr.trim());
    }
    Ok(parse_squeue(&String::from_utf8_lossy(&o.stdout), plan))
}

/// Parses `squeue -h -r -o '%i|%T|%r'` lines, keeping the plan's jobs.
fn parse_squeue(stdout: &str, plan: &Plan) -> Vec<LiveJob> {
    let mut live = vec![];
    for line in stdout.lines() {
        let mut it = line.trim().split('|');
        let (Some(id), Some(state)) = (it.next(), it.next()) else {
            continue;
        };
        let reason = it.next().unwrap_or("");
        let (base, task) = match id.split_once('_') {
            Some((b, t)) => (b, t.parse::<u64>().ok()),
            None => (id, None),
        };
        let Some(job) = plan.jobs.iter().find(|j| j.id == base) else {
            continue;
        };
        live.push(LiveJob {
            id: id.to_string(),
            kind: job.kind.clone(),
            shard: if job.kind == "shards" { task } else { None },
            state: state.to_string(),
            reason: reason.to_string(),
        });
    }
    live
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn squeue_lines_map_array_tasks_to_shards() {
        let job = |kind: &str, id: &str| Job {
            kind: kind.into(),
            id: id.into(),
            tasks: vec![],
        };
        let plan = Plan {
            shards: 3,
            jobs: vec![job("shards", "40"), job("merge", "41")],
            ..Plan::default()
        };
        let live = parse_squeue(
            "40_0|RUNNING|None\n40_2|PENDING|Resources\n41|PENDING|Dependency\n99_1|RUNNING|None\n",
            &plan,
        );
        let shards: Vec<_> = live.iter().map(|j| (j.kind.as_str(), j.shard)).collect();
        assert_eq!(
            shards,
            [("shards", Some(0)), ("shards", Some(2)), ("merge", None)]
        );
        assert_eq!(live[0].describe(), "40_0 (RUNNING)");
        assert_eq!(live[1].describe(), "40_2 (PENDING, Resources)");
    }
}
