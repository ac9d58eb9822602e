//! `rwg slurm` end to end: on a real single-node Slurm cluster (slurmctld,
//! slurmd and munged started for the test, see `slurm_cluster.rs`), a sharded
//! study and its merge job end byte-identical to a single-machine run, also
//! when an array task is requeued midway (it resumes) and another is
//! cancelled midway and resubmitted as rwg says.
//! Without Slurm the cluster test says SKIPPED (and fails under CI=true or
//! RWG_NO_SKIP=1); the `--dry-run` test runs everywhere.

mod common;
mod slurm_cluster;

use common::*;
use slurm_cluster::{Cluster, Unavailable};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

/// Four cells, three blocks each: 12 blocks, four per shard.
const SMALL: &str = r#"
seed = 5
samples = 70
episodes = 2
bias = [false, true]
[[architectures]]
name = "0HL"
hidden = []
[[envs]]
id = "CartPole-v1"
[[envs]]
id = "Pendulum-v1"
"#;

/// One cell of 72 blocks, 24 per shard: with one thread a shard commits them
/// in twelve waves of two over a second or two (debug build), so it can be
/// cancelled midway on any machine.
const LONGER: &str = r#"
seed = 9
samples = 2304
episodes = 2
[[architectures]]
name = "0HL"
hidden = []
[[envs]]
id = "Acrobot-v1"
"#;

/// scores.csv and samples.csv of every cell, by cell.
fn cells(run: &Path) -> Vec<(String, Vec<u8>, Vec<u8>)> {
    let mut dirs: Vec<PathBuf> = std::fs::read_dir(run.join("cells"))
        .unwrap_or_else(|e| panic!("{}: {e}", run.display()))
        .map(|e| e.unwrap().path())
        .collect();
    dirs.sort();
    dirs.iter()
        .map(|d| {
            let read = |f: &str| {
                std::fs::read(d.join(f)).unwrap_or_else(|e| panic!("{}/{f}: {e}", d.display()))
            };
            (
                d.file_name().unwrap().to_string_lossy().into_owned(),
                read("scores.csv"),
                read("samples.csv"),
            )
        })
        .collect()
}

fn assert_same_cells(reference: &Path, merged: &Path, n: usize) {
    let (a, b) = (cells(reference), cells(merged));
    assert_eq!(a.len(), n);
    assert_eq!(
        a.iter().map(|c| &c.0).collect::<Vec<_>>(),
        b.iter().map(|c| &c.0).collect::<Vec<_>>()
    );
    for (x, y) in a.iter().zip(&b) {
        assert!(x.1 == y.1, "{}/scores.csv differs", x.0);
        assert!(x.2 == y.2, "{}/samples.csv differs", x.0);
    }
    assert_eq!(
        std::fs::read(reference.join("manifest.toml")).unwrap(),
        std::fs::read(merged.join("manifest.toml")).unwrap()
    );
}

fn plan(dir: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(dir.join("slurm/plan.json")).unwrap()).unwrap()
}

/// The ids of the jobs in plan.json of that kind, oldest first.
fn job_ids(dir: &Path, kind: &str) -> Vec<String> {
    plan(dir)["jobs"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|j| j["kind"] == kind)
        .map(|j| j["id"].as_str().unwrap().to_string())
        .collect()
}

/// Runs `rwg` in `cwd` against the cluster. Its jobs inherit the
/// environment (sbatch's default `--export=ALL`): blocks are committed one
/// by one (`RWG_COMMIT_LINGER=0`), so that a job killed or requeued once it
/// has committed a block is still running.
fn rwg_in(cluster: &Cluster, cwd: &Path, args: &[&str]) -> String {
    let o = Command::new(rwg_bin())
        .args(args)
        .current_dir(cwd)
        .env("SLURM_CONF", &cluster.conf)
        .env("RWG_COMMIT_LINGER", "0")
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&o.stdout).into_owned();
    assert!(
        o.status.success(),
        "rwg {args:?} failed:\n{stdout}\n{}",
        String::from_utf8_lossy(&o.stderr)
    );
    stdout
}

fn logs(dir: &Path) -> String {
    let mut s = String::new();
    if let Ok(rd) = std::fs::read_dir(dir.join("slurm/logs")) {
        for e in rd {
            let p = e.unwrap().path();
            s += &format!(
                "== {}\n{}\n",
                p.display(),
                std::fs::read_to_string(&p).unwrap_or_default()
            );
        }
    }
    s
}

fn wait_merge(cluster: &Cluster, dir: &Path, merge: &str) {
    let states = cluster.wait_done(merge, Duration::from_secs(300));
    assert_eq!(states.len(), 1);
    assert_eq!(
        states[0].1,
        "COMPLETED",
        "merge job {merge}: {states:?}\n{}",
        logs(dir)
    );
}

#[test]
fn sharded_studies_on_a_real_slurm_cluster() {
    let cluster = match Cluster::start("cli") {
        Ok(c) => c,
        Err(Unavailable(why)) => {
            skip("sharded_studies_on_a_real_slurm_cluster", &why);
            return;
        }
    };
    let dir = temp_dir("slurm");
    // A path with a space; rwg slurm runs from another directory than the
    // study's, with relative paths.
    let submit = dir.join("submit here");
    std::fs::create_dir_all(&submit).unwrap();
    std::fs::write(dir.join("small.toml"), SMALL).unwrap();
    std::fs::write(dir.join("longer.toml"), LONGER).unwrap();

    // Case 1: three shards and the merge, then compare with one machine.
    let reference = dir.join("reference-small");
    rwg_ok(&[
        "run",
        dir.join("small.toml").to_str().unwrap(),
        "--out",
        reference.to_str().unwrap(),
    ]);
    let out = rwg_in(
        &cluster,
        &submit,
        &[
            "slurm",
            "../small.toml",
            "--shards",
            "3",
            "--out",
            "../runs dir/small",
        ],
    );
    eprintln!("rwg slurm printed:\n{out}");
    let study = dir.join("runs dir/small");
    let arrays = job_ids(&study, "shards");
    let merges = job_ids(&study, "merge");
    assert_eq!((arrays.len(), merges.len()), (1, 1), "{out}");
    assert!(
        out.contains(&format!("Submitted job array {}", arrays[0])),
        "{out}"
    );
    assert!(
        out.contains(&format!("squeue -j {},{}", arrays[0], merges[0])),
        "{out}"
    );
    assert!(out.contains(&format!("afterok:{}", arrays[0])), "{out}");
    wait_merge(&cluster, &study, &merges[0]);
    let tasks = cluster.jobs(&arrays[0]);
    assert_eq!(tasks.len(), 3, "{tasks:?}");
    assert!(tasks.iter().all(|t| t.1 == "COMPLETED"), "{tasks:?}");
    assert_same_cells(&reference, &study, 4);
    for f in ["stats.csv", "stats.json", "report.html", "figures"] {
        assert!(
            study.join(f).exists(),
            "merged run lacks {f}\n{}",
            logs(&study)
        );
    }
    let status = rwg_ok(&["status", study.to_str().unwrap()]);
    assert!(
        status.contains("Merged run") && status.contains(": complete"),
        "{status}"
    );
    // Submitting again has nothing to do.
    let again = rwg_in(
        &cluster,
        &submit,
        &[
            "slurm",
            "../small.toml",
            "--shards",
            "3",
            "--out",
            "../runs dir/small",
        ],
    );
    assert!(again.contains("nothing to submit"), "{again}");

    // Case 2: one CPU (one rwg thread) per task; requeue shard 0 and cancel
    // shard 1 midway, resubmit as rwg said.
    let reference = dir.join("reference-longer");
    rwg_ok(&[
        "run",
        dir.join("longer.toml").to_str().unwrap(),
        "--out",
        reference.to_str().unwrap(),
        "--no-report",
    ]);
    let out = rwg_in(
        &cluster,
        &submit,
        &[
            "slurm",
            "../longer.toml",
            "--shards",
            "3",
            "--out",
            "../runs dir/longer",
            "--cpus-per-task",
            "1",
        ],
    );
    let study = dir.join("runs dir/longer");
    let array = job_ids(&study, "shards").remove(0);
    let merge = job_ids(&study, "merge").remove(0);
    let committed = |k: u64| {
        let blocks = study.join(format!("shards/{k}/cells/Acrobot-v1__0HL__nobias/blocks"));
        std::fs::read_dir(&blocks).map_or(0, |d| {
            d.filter_map(|e| e.ok())
                .filter(|e| e.path().extension().is_some_and(|x| x == "csv"))
                .count()
        })
    };
    // Shard 0 is requeued (Slurm kills it and starts it again: it must
    // resume), shard 1 is cancelled; each once it has committed a block.
    // requeued: 0 not yet, 1 requeued (Slurm delays it by two minutes), 2 released
    let (mut requeued, mut cancelled, mut looked) = (0, false, false);
    let t0 = Instant::now();
    let mut requeued_at = t0;
    let task0 = format!("{array}_0");
    while !(requeued == 2 && cancelled) {
        // rwg status reads the study while shards are being written.
        if !looked && study.join("shards/0/manifest.toml").is_file() {
            looked = true;
            let s = rwg_ok(&["status", study.to_str().unwrap()]);
            assert!(s.contains("0/3") && s.contains("Merged run"), "{s}");
            // Without the cluster's slurm.conf squeue fails: said, not fatal.
            assert!(s.contains("Slurm's queue could not be read"), "{s}");
            // With it, the shard being computed is shown as Slurm's, and no
            // command offers to compute it a second time.
            let s = rwg_in(&cluster, &submit, &["status", study.to_str().unwrap()]);
            eprintln!("while shard 0 runs:\n{s}");
            assert!(
                s.contains(&format!("Slurm task {array}_0 (RUNNING)")),
                "{s}"
            );
            assert!(s.contains("Slurm is still computing"), "{s}");
            assert!(!s.contains("--shard 0/3"), "{s}");
        }
        if requeued == 0 && committed(0) > 0 {
            requeued = 1;
            requeued_at = Instant::now();
            assert!(
                committed(0) < 24,
                "shard 0 finished before it could be requeued"
            );
            let o = cluster.run("scontrol", &["requeue", &task0]);
            assert!(
                o.status.success(),
                "scontrol requeue: {}",
                String::from_utf8_lossy(&o.stderr)
            );
        }
        // slurmd refuses a job whose credential was created in the same
        // second as its revocation (the requeue): "Job credential revoked",
        // and the task FAILS. Slurm's own two-minute requeue delay avoids
        // that; the test waits two seconds before starting it again.
        if requeued == 1
            && requeued_at.elapsed() > Duration::from_secs(2)
            && cluster
                .jobs(&task0)
                .first()
                .is_some_and(|j| j.1 == "PENDING")
        {
            requeued = 2;
            let o = cluster.run(
                "scontrol",
                &["update", &format!("jobid={task0}"), "StartTime=now"],
            );
            assert!(
                o.status.success(),
                "scontrol update: {}",
                String::from_utf8_lossy(&o.stderr)
            );
        }
        if !cancelled && committed(1) > 0 {
            cancelled = true;
            let o = cluster.run("scancel", &[&format!("{array}_1")]);
            assert!(
                o.status.success(),
                "scancel: {}",
                String::from_utf8_lossy(&o.stderr)
            );
        }
        assert!(
            t0.elapsed() < Duration::from_secs(300),
            "shards 0 and 1 committed no block\n{}",
            logs(&study)
        );
        std::thread::sleep(Duration::from_millis(10));
    }
    let task = format!("{array}_1");
    let tasks = cluster.wait_done(&array, Duration::from_secs(300));
    assert!(
        tasks.iter().any(|t| t.0 == task && t.1 == "CANCELLED"),
        "{tasks:?}"
    );
    assert!(
        tasks
            .iter()
            .any(|t| t.0 == format!("{array}_0") && t.1 == "COMPLETED"),
        "{tasks:?}\n{}\n== slurmctld.log\n{}\n== slurmd.log\n{}",
        logs(&study),
        cluster.log("slurmctld"),
        cluster.log("slurmd")
    );
    // The requeued task ran twice, appending to its log.
    let log0 = std::fs::read_to_string(study.join("slurm/logs/shard-0.out")).unwrap();
    assert_eq!(log0.matches("rwg shard 0/3 on").count(), 2, "{log0}");
    let status = rwg_ok(&["status", study.to_str().unwrap()]);
    eprintln!("after the cancel:\n{status}");
    assert!(
        status.contains("1/3") && status.contains("incomplete:"),
        "shard 1 finished before it could be cancelled; make LONGER bigger\n{status}"
    );
    // The merge waits forever on the failed dependency.
    let t0 = Instant::now();
    while cluster
        .jobs(&merge)
        .first()
        .is_none_or(|j| j.2 != "DependencyNeverSatisfied")
    {
        assert!(
            t0.elapsed() < Duration::from_secs(60),
            "{:?}",
            cluster.jobs(&merge)
        );
        std::thread::sleep(Duration::from_millis(200));
    }
    // Resubmit with the command rwg printed, as printed.
    let resubmit = out
        .lines()
        .skip_while(|l| !l.contains("resubmit"))
        .find(|l| l.trim_start().contains(" slurm "))
        .unwrap_or_else(|| panic!("no resubmit command in:\n{out}"))
        .trim()
        .to_string();
    let o = Command::new("sh")
        .args(["-c", &resubmit])
        .current_dir(&submit)
        .env("SLURM_CONF", &cluster.conf)
        .output()
        .unwrap();
    let again = String::from_utf8_lossy(&o.stdout).into_owned();
    eprintln!("{resubmit} printed:\n{again}");
    assert!(
        o.status.success(),
        "{resubmit}: {again}\n{}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(
        again.contains(&format!("Cancelled merge job {merge}")),
        "{again}"
    );
    assert!(again.contains("shard(s) 1 of 3"), "{again}");
    let arrays = job_ids(&study, "shards");
    let merges = job_ids(&study, "merge");
    assert_eq!((arrays.len(), merges.len()), (2, 2), "{again}");
    assert_eq!(plan(&study)["jobs"][2]["tasks"], serde_json::json!([1]));
    wait_merge(&cluster, &study, &merges[1]);
    assert_eq!(cluster.jobs(&merge)[0].1, "CANCELLED");
    assert_same_cells(&reference, &study, 1);
    assert!(study.join("report.html").is_file());
    drop(cluster);
}

#[test]
fn dry_run_writes_scripts_that_call_rwg_by_absolute_path() {
    let dir = temp_dir("slurm-dry");
    std::fs::write(dir.join("small.toml"), SMALL).unwrap();
    let study = dir.join("study");
    let out = rwg_ok(&[
        "slurm",
        dir.join("small.toml").to_str().unwrap(),
        "--shards",
        "2",
        "--out",
        study.to_str().unwrap(),
        "--partition",
        "short",
        "--time",
        "0:10:00",
        "--cpus-per-task",
        "4",
        "--mem",
        "1G",
        "--account",
        "lab",
        "--sbatch=--qos=low",
        "--dry-run",
    ]);
    assert!(out.contains("A=$(sbatch --parsable"), "{out}");
    assert!(out.contains("--dependency=afterok:$A"), "{out}");
    let array = std::fs::read_to_string(study.join("slurm/shards.sh")).unwrap();
    let rwg = rwg_bin().canonicalize().unwrap();
    assert!(
        array.contains(&format!("exec {} run ", rwg.display())),
        "{array}"
    );
    for o in [
        "--array=0-1",
        "--cpus-per-task=4",
        "--partition=short",
        "--time=0:10:00",
        "--mem=1G",
        "--account=lab",
        "--qos=low",
    ] {
        assert!(array.contains(&format!("#SBATCH {o}\n")), "{o}: {array}");
    }
    let merge = std::fs::read_to_string(study.join("slurm/merge.sh")).unwrap();
    assert!(
        merge.contains(" merge ")
            && merge.contains("#SBATCH --qos=low\n")
            && !merge.contains("cpus-per-task"),
        "{merge}"
    );
    // The scripts parse as bash; the array script refuses to run outside a job array.
    for s in ["shards.sh", "merge.sh"] {
        let o = Command::new("bash")
            .arg("-n")
            .arg(study.join("slurm").join(s))
            .output()
            .unwrap();
        assert!(
            o.status.success(),
            "{s}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
    }
    let o = Command::new("bash")
        .arg(study.join("slurm/shards.sh"))
        .env_remove("SLURM_ARRAY_TASK_ID")
        .output()
        .unwrap();
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("submit this script with sbatch"));
    // Running a task by hand (as Slurm would) computes its shard.
    let o = Command::new("bash")
        .arg(study.join("slurm/shards.sh"))
        .env("SLURM_ARRAY_TASK_ID", "1")
        .env("SLURM_CPUS_PER_TASK", "1")
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let status = rwg_ok(&["status", study.to_str().unwrap()]);
    assert!(
        status.contains("0/2    ") && status.contains("missing"),
        "{status}"
    );
    assert!(status.contains("complete (6 blocks)"), "{status}");
    assert!(status.contains("--shard 0/2 --out"), "{status}");
    // A different shard count or study is refused.
    let err = rwg_err(&[
        "slurm",
        dir.join("small.toml").to_str().unwrap(),
        "--shards",
        "3",
        "--out",
        study.to_str().unwrap(),
        "--dry-run",
    ]);
    assert!(err.contains("in 2 shards, not 3"), "{err}");
    std::fs::write(
        dir.join("other.toml"),
        SMALL.replace("seed = 5", "seed = 6"),
    )
    .unwrap();
    let err = rwg_err(&[
        "slurm",
        dir.join("other.toml").to_str().unwrap(),
        "--shards",
        "2",
        "--out",
        study.to_str().unwrap(),
        "--dry-run",
    ]);
    assert!(
        err.contains("different study (seed: 6 vs 5)")
            || err.contains("different study (seed: 5 vs 6)"),
        "{err}"
    );
    // The --help example works as printed (from a folder holding examples/).
    let help = rwg_ok(&["slurm", "--help"]);
    let example = help
        .lines()
        .map(str::trim)
        .find(|l| l.starts_with("rwg slurm") && l.ends_with("--dry-run"))
        .unwrap_or_else(|| panic!("no --dry-run example in:\n{help}"));
    let cwd = dir.join("help");
    std::fs::create_dir_all(cwd.join("examples")).unwrap();
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..");
    std::fs::copy(
        root.join("examples/quick.toml"),
        cwd.join("examples/quick.toml"),
    )
    .unwrap();
    let words: Vec<&str> = example.split_whitespace().skip(1).collect();
    let o = Command::new(rwg_bin())
        .args(&words)
        .current_dir(&cwd)
        .output()
        .unwrap();
    assert!(
        o.status.success(),
        "{example}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(cwd.join("runs/quick-slurm/slurm/shards.sh").is_file());
    // Without sbatch, submitting says what to do.
    let o = Command::new(rwg_bin())
        .args([
            "slurm",
            dir.join("small.toml").to_str().unwrap(),
            "--shards",
            "2",
            "--out",
            study.to_str().unwrap(),
        ])
        .env("PATH", "/nonexistent")
        .output()
        .unwrap();
    assert!(!o.status.success());
    assert!(
        String::from_utf8_lossy(&o.stderr).contains("--dry-run writes the scripts"),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
}
