//! Long runs end to end: a run killed with SIGKILL (or stopped with SIGINT) at
//! several points resumes to byte-identical results; shards merge into the
//! unsharded run byte for byte.

mod common;
use common::*;
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::Duration;

/// Two envs, two architectures: enough work (a second or two in a debug
/// build) for kills to land mid-run.
const STUDY: &str = r#"
seed = 3
samples = 400
episodes = 4
bias = [false, true]
[[architectures]]
name = "0HL"
hidden = []
[[architectures]]
name = "1HL"
hidden = [3]
[[envs]]
id = "CartPole-v1"
[[envs]]
id = "Acrobot-v1"
max_episode_steps = 100
"#;

fn write_manifest(dir: &Path, body: &str) -> String {
    let p = dir.join("study.toml");
    std::fs::write(&p, body).unwrap();
    p.to_str().unwrap().to_string()
}

/// The result files that must be byte-identical (timing metadata aside).
fn result_files(run: &Path) -> Vec<(String, Vec<u8>)> {
    let mut files = vec![(
        "manifest.toml".to_string(),
        std::fs::read(run.join("manifest.toml")).unwrap(),
    )];
    let mut cells: Vec<_> = std::fs::read_dir(run.join("cells"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    cells.sort();
    for c in cells {
        let name = c.file_name().unwrap().to_string_lossy().into_owned();
        assert!(!c.join("blocks").exists(), "{name}: blocks left behind");
        for f in ["scores.csv", "samples.csv"] {
            files.push((
                format!("{name}/{f}"),
                std::fs::read(c.join(f)).unwrap_or_else(|e| panic!("{name}/{f}: {e}")),
            ));
        }
    }
    assert_eq!(files.len(), 1 + 8 * 2);
    files
}

fn assert_same(a: &Path, b: &Path) {
    for ((na, fa), (nb, fb)) in result_files(a).iter().zip(result_files(b)) {
        assert_eq!(*na, nb);
        assert!(
            *fa == fb,
            "{na} differs between {} and {}",
            a.display(),
            b.display()
        );
    }
}

fn run_finished(run: &Path) -> bool {
    std::fs::read_to_string(run.join("run.json"))
        .map(|t| serde_json::from_str::<serde_json::Value>(&t).unwrap()["end_time"].is_string())
        .unwrap_or(false)
}

#[test]
fn sigkill_at_several_points_then_resume_gives_identical_results() {
    let dir = temp_dir("sigkill");
    let m = write_manifest(&dir, STUDY);
    let reference = dir.join("reference");
    rwg_ok(&[
        "run",
        &m,
        "--out",
        reference.to_str().unwrap(),
        "--threads",
        "2",
    ]);

    let run = dir.join("killed");
    let mut mid_run_kills = 0;
    for delay_ms in [150, 300, 450, 600, 800, 1000, 1300] {
        let mut child = Command::new(rwg_bin())
            .args(["run", &m, "--out", run.to_str().unwrap(), "--threads", "2"])
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap();
        std::thread::sleep(Duration::from_millis(delay_ms));
        let killed = child.try_wait().unwrap().is_none();
        let _ = child.kill(); // SIGKILL
        child.wait().unwrap();
        if killed && !run_finished(&run) {
            mid_run_kills += 1;
        }
        if run_finished(&run) {
            break;
        }
    }
    assert!(
        mid_run_kills >= 2,
        "only {mid_run_kills} kills landed mid-run; the test needs more work per run"
    );
    // a resumed run with another thread count finishes the study
    rwg_ok(&["run", &m, "--out", run.to_str().unwrap(), "--threads", "1"]);
    assert!(run_finished(&run));
    assert_same(&reference, &run);
}

#[test]
fn ctrl_c_stops_cleanly_and_says_how_to_resume() {
    let dir = temp_dir("sigint");
    let m = write_manifest(&dir, STUDY);
    let run = dir.join("run");
    let child = Command::new(rwg_bin())
        .args(["run", &m, "--out", run.to_str().unwrap()])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    std::thread::sleep(Duration::from_millis(400));
    let status = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(status.success());
    let out = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    if out.status.success() {
        return; // finished before the signal arrived: nothing to check
    }
    assert_eq!(out.status.code(), Some(130), "{stderr}");
    assert!(
        stderr.contains("Resume with") && stderr.contains("rwg run"),
        "{stderr}"
    );
    rwg_ok(&["run", &m, "--out", run.to_str().unwrap()]);
    let reference = dir.join("reference");
    rwg_ok(&["run", &m, "--out", reference.to_str().unwrap()]);
    assert_same(&reference, &run);
}

#[test]
fn three_shards_merge_into_the_unsharded_run() {
    let dir = temp_dir("shards");
    let m = write_manifest(&dir, &STUDY.replace("samples = 400", "samples = 100"));
    let whole = dir.join("whole");
    rwg_ok(&["run", &m, "--out", whole.to_str().unwrap()]);
    let shard_dirs: Vec<String> = (0..3)
        .map(|k| dir.join(format!("s{k}")).to_str().unwrap().to_string())
        .collect();
    for (k, d) in shard_dirs.iter().enumerate() {
        let out = rwg_ok(&["run", &m, "--shard", &format!("{k}/3"), "--out", d]);
        assert!(out.contains(&format!("Shard {k}/3 done")), "{out}");
    }
    // errors: a missing shard, a duplicate, a shard of another study
    let err = rwg_err(&[
        "merge",
        &shard_dirs[0],
        &shard_dirs[2],
        "--out",
        dir.join("x").to_str().unwrap(),
    ]);
    assert!(err.contains("missing shard(s) 1/3"), "{err}");
    let err = rwg_err(&[
        "merge",
        &shard_dirs[0],
        &shard_dirs[0],
        &shard_dirs[2],
        "--out",
        dir.join("x").to_str().unwrap(),
    ]);
    assert!(err.contains("shard 0/3 is given twice"), "{err}");
    let other = dir.join("other");
    let m2 = dir.join("other.toml");
    std::fs::write(
        &m2,
        STUDY
            .replace("samples = 400", "samples = 100")
            .replace("seed = 3", "seed = 4"),
    )
    .unwrap();
    rwg_ok(&[
        "run",
        m2.to_str().unwrap(),
        "--shard",
        "1/3",
        "--out",
        other.to_str().unwrap(),
    ]);
    let err = rwg_err(&[
        "merge",
        &shard_dirs[0],
        other.to_str().unwrap(),
        &shard_dirs[2],
        "--out",
        dir.join("x").to_str().unwrap(),
    ]);
    assert!(
        err.contains("hold different studies: seed: 3 vs 4"),
        "{err}"
    );

    let merged = dir.join("merged");
    rwg_ok(&[
        "merge",
        &shard_dirs[0],
        &shard_dirs[1],
        &shard_dirs[2],
        "--out",
        merged.to_str().unwrap(),
    ]);
    assert_same(&whole, &merged);
    let meta: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(merged.join("run.json")).unwrap()).unwrap();
    let whole_meta: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(whole.join("run.json")).unwrap()).unwrap();
    assert_eq!(meta["env_steps"], whole_meta["env_steps"]);
    assert_eq!(meta["cells"].as_array().unwrap().len(), 8);
}
