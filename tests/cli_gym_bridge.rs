//! Gymnasium environments through the bridge (`gymnasium:ID`), end to end
//! with the real `rwg` binary and real Gymnasium: the same bytes as the
//! built-ins, Box2D and MuJoCo studies whose episodes replay exactly in plain
//! Python, a custom `module:Id` env, `rwg check`, the help examples, MuJoCo's
//! warnings. Failing envs, SIGKILL + resume, shards and Ctrl-C are in
//! `cli_gym_bridge_faults.rs`.
//!
//! Needs `RWG_TEST_PYTHON`: a Python with `gymnasium[box2d,mujoco]==1.4.0`
//! (`.ci/run` makes one). Without it each test prints SKIPPED and passes,
//! except under `CI=true` or `RWG_NO_SKIP=1`, where it fails.

mod common;
mod gym_bridge_common;
use common::*;
use gym_bridge_common::*;
use std::process::Command;

const SAME_AS_BUILTINS: &str = r#"
seed = 4
samples = 70
episodes = 3
bias = [false, true]
[[architectures]]
name = "0HL"
hidden = []
[[architectures]]
name = "1HL"
hidden = [4]
[[envs]]
id = "CartPole-v1"
[[envs]]
id = "gymnasium:CartPole-v1"
[[envs]]
id = "Pendulum-v1"
[[envs]]
id = "gymnasium:Pendulum-v1"
"#;

#[test]
fn gymnasium_cartpole_and_pendulum_give_the_builtins_bytes() {
    let Some(py) = python() else { return };
    let dir = temp_dir("gym-same");
    let m = write(&dir, "m.toml", SAME_AS_BUILTINS);
    let run = dir.join("run");
    run_ok(
        &py,
        &[
            "run",
            &m,
            "--out",
            run.to_str().unwrap(),
            "--threads",
            "2",
            "--no-report",
        ],
    );
    // The Gymnasium cells alone on one thread: the same bytes again.
    let only = SAME_AS_BUILTINS
        .replace("id = \"CartPole-v1\"\n", "id = \"gymnasium:CartPole-v1\"\n")
        .replace("id = \"Pendulum-v1\"\n", "id = \"gymnasium:Pendulum-v1\"\n")
        .replacen("[[envs]]\nid = \"gymnasium:CartPole-v1\"\n", "", 1)
        .replacen("[[envs]]\nid = \"gymnasium:Pendulum-v1\"\n", "", 1);
    let m1 = write(&dir, "gym.toml", &only);
    let run1 = dir.join("run1");
    run_ok(
        &py,
        &[
            "run",
            &m1,
            "--out",
            run1.to_str().unwrap(),
            "--threads",
            "1",
            "--no-report",
        ],
    );
    let mut compared = 0;
    for env in ["CartPole-v1", "Pendulum-v1"] {
        for arch in ["0HL", "1HL"] {
            for bias in ["bias", "nobias"] {
                let builtin = run.join(format!("cells/{env}__{arch}__{bias}"));
                let gym = format!("cells/gymnasium={env}__{arch}__{bias}");
                for f in ["scores.csv", "samples.csv"] {
                    let want = read(builtin.join(f));
                    assert!(want == read(run.join(&gym).join(f)), "{gym}/{f}");
                    assert!(want == read(run1.join(&gym).join(f)), "1 thread: {gym}/{f}");
                    compared += 1;
                }
            }
        }
    }
    assert_eq!(compared, 16);
    // run.json names the Gymnasium env and its registry's defaults.
    let meta: serde_json::Value = serde_json::from_slice(&read(run.join("run.json"))).unwrap();
    let cell = meta["cells"]
        .as_array()
        .unwrap()
        .iter()
        .find(|c| c["env"] == "gymnasium:CartPole-v1")
        .expect("a gymnasium:CartPole-v1 cell");
    assert_eq!(cell["max_episode_steps"], 500);
    assert_eq!(cell["solved"], 475.0);
    assert_eq!(cell["solved_source"], "env");
}

/// Runs `manifest`, exports networks 0..3 of every cell and replays them in
/// plain Python (`tests/python/replay_exact.py`): every score must be rwg's
/// to the bit.
fn study_replays_exactly(py: &str, name: &str, manifest: &str, env: &str) {
    let dir = temp_dir(name);
    let m = write(&dir, "m.toml", manifest);
    let run = dir.join("run");
    let run_s = run.to_str().unwrap();
    run_ok(
        py,
        &["run", &m, "--out", run_s, "--threads", "2", "--no-report"],
    );
    let mut files = vec![];
    let mut stored = vec![];
    for bias in ["false", "true"] {
        for sample in 0..3 {
            let f = dir.join(format!("{bias}-{sample}.json"));
            let out = run_ok(
                py,
                &[
                    "replay",
                    run_s,
                    "--env",
                    env,
                    "--arch",
                    "1HL",
                    "--bias",
                    bias,
                    "--sample",
                    &sample.to_string(),
                    "--export-weights",
                    f.to_str().unwrap(),
                ],
            );
            // rwg replay itself re-ran the episodes through the bridge
            assert!(out.lines().skip(1).all(|l| l.ends_with(",true")), "{out}");
            let scores: Vec<String> = out
                .lines()
                .skip(1)
                .map(|l| l.split(',').nth(2).unwrap().to_string())
                .collect();
            files.push(f.to_str().unwrap().to_string());
            stored.push(scores);
        }
    }
    let out = Command::new(py)
        .arg(python_dir().join("replay_exact.py"))
        .args(&files)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let lines: Vec<serde_json::Value> = String::from_utf8(out.stdout)
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(lines.len(), files.len());
    for (line, ours) in lines.iter().zip(&stored) {
        let theirs: Vec<f64> = line["scores"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_f64().unwrap())
            .collect();
        let ours: Vec<f64> = ours.iter().map(|s| s.parse().unwrap()).collect();
        assert_eq!(ours.len(), theirs.len());
        for (a, b) in ours.iter().zip(&theirs) {
            assert_eq!(
                a.to_bits(),
                b.to_bits(),
                "{}: rwg {a} vs Python {b}",
                line["file"]
            );
        }
    }
}

fn box2d_mujoco_manifest(env: &str, extra: &str) -> String {
    format!(
        r#"
seed = 9
samples = 6
episodes = 2
bias = [false, true]
[[architectures]]
name = "1HL"
hidden = [4]
[[envs]]
id = "{env}"
{extra}
"#
    )
}

#[test]
fn lunar_lander_discrete_replays_exactly_in_python() {
    let Some(py) = python() else { return };
    let m = box2d_mujoco_manifest("gymnasium:LunarLander-v3", "max_episode_steps = 300");
    study_replays_exactly(&py, "gym-lunar", &m, "gymnasium:LunarLander-v3");
}

#[test]
fn lunar_lander_continuous_replays_exactly_in_python() {
    let Some(py) = python() else { return };
    let m = box2d_mujoco_manifest(
        "gymnasium:LunarLander-v3",
        "kwargs = { continuous = true }\nmax_episode_steps = 300",
    );
    study_replays_exactly(&py, "gym-lunar-c", &m, "gymnasium:LunarLander-v3");
}

#[test]
fn inverted_pendulum_replays_exactly_in_python() {
    let Some(py) = python() else { return };
    let m = box2d_mujoco_manifest("gymnasium:InvertedPendulum-v5", "");
    study_replays_exactly(&py, "gym-ip", &m, "gymnasium:InvertedPendulum-v5");
}

#[test]
fn custom_module_env_with_a_dict_observation_runs() {
    let Some(py) = python() else { return };
    let dir = temp_dir("gym-custom");
    let m = write(
        &dir,
        "m.toml",
        r#"
samples = 40
episodes = 2
[[architectures]]
name = "1HL"
hidden = [3]
[[envs]]
id = "gymnasium:rwg_test_envs:Drift-v0"
"#,
    );
    let a = dir.join("a");
    let b = dir.join("b");
    run_ok(
        &py,
        &["run", &m, "--out", a.to_str().unwrap(), "--threads", "2"],
    );
    run_ok(
        &py,
        &[
            "run",
            &m,
            "--out",
            b.to_str().unwrap(),
            "--threads",
            "1",
            "--no-report",
        ],
    );
    let cell = "cells/gymnasium=rwg_test_envs=Drift-v0__1HL__nobias";
    let scores = read(a.join(cell).join("scores.csv"));
    assert!(scores == read(b.join(cell).join("scores.csv")));
    assert_eq!(String::from_utf8(scores).unwrap().lines().count(), 81);
    let meta: serde_json::Value =
        serde_json::from_slice(&read(a.join(cell).join("cell.json"))).unwrap();
    // Dict(phase: Discrete(3), pos: Box(2)) flattens to 3 + 2 values
    assert_eq!(meta["obs_dim"], 5);
    assert_eq!(meta["solved"], 50.0);
    assert!(a.join("report.html").exists());
    // the env is listed and described like a built-in
    let out = run_ok(&py, &["envs", "--json", "gymnasium:rwg_test_envs:Drift-v0"]);
    assert!(
        out.contains("\"obs_dim\": 5") || out.contains("\"n\": 3"),
        "{out}"
    );
}

#[test]
fn envs_that_remember_earlier_episodes_get_a_fresh_instance_per_episode() {
    let Some(py) = python() else { return };
    let dir = temp_dir("gym-memory");
    let m = write(
        &dir,
        "m.toml",
        r#"
samples = 40
episodes = 3
[[architectures]]
name = "0HL"
hidden = []
[[envs]]
id = "gymnasium:rwg_test_envs:Memory-v0"
"#,
    );
    let (a, b) = (dir.join("a"), dir.join("b"));
    let out = rwg_cmd(
        &py,
        &[
            "run",
            &m,
            "--out",
            a.to_str().unwrap(),
            "--threads",
            "2",
            "--no-report",
        ],
    )
    .output()
    .unwrap();
    assert!(out.status.success());
    let note = String::from_utf8_lossy(&out.stderr);
    assert!(
        note.contains("every episode runs on a fresh gym.make instance"),
        "{note}"
    );
    run_ok(
        &py,
        &[
            "run",
            &m,
            "--out",
            b.to_str().unwrap(),
            "--threads",
            "1",
            "--no-report",
        ],
    );
    let cell = "cells/gymnasium=rwg_test_envs=Memory-v0__0HL__nobias/scores.csv";
    assert!(read(a.join(cell)) == read(b.join(cell)));
    for sample in ["0", "17", "39"] {
        run_ok(
            &py,
            &[
                "replay",
                a.to_str().unwrap(),
                "--env",
                "gymnasium:rwg_test_envs:Memory-v0",
                "--arch",
                "0HL",
                "--sample",
                sample,
            ],
        );
    }
}

#[test]
fn check_runs_the_plugin_checks_and_determinism_on_gymnasium_envs() {
    let Some(py) = python() else { return };
    let out = run_ok(&py, &["check", "gymnasium:CartPole-v1"]);
    for check in [
        "reset determinism: the same seed gives the same observation",
        "trajectory determinism: the same seed and actions give the same trajectory",
        "step before reset: refused with reset-needed",
        "12 passed, 0 warned, 0 failed",
    ] {
        assert!(out.contains(check), "{out}");
    }
    let out = rwg_cmd(&py, &["check", "gymnasium:rwg_test_envs:Unseeded-v0"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        text.contains("[FAIL] gymnasium:rwg_test_envs:Unseeded-v0: reset determinism: reset(seed=42) twice on one instance"),
        "{text}"
    );
    // an env that raises: one line per check, the tracebacks in the file named
    let out = rwg_cmd(
        &py,
        &[
            "check",
            "gymnasium:rwg_test_envs:Faulty-v0",
            "--kwargs",
            r#"{"mode": "raise"}"#,
        ],
    )
    .output()
    .unwrap();
    assert!(!out.status.success());
    let text = String::from_utf8_lossy(&out.stdout);
    let failed: Vec<&str> = text.lines().filter(|l| l.starts_with("[FAIL]")).collect();
    assert!(!failed.is_empty(), "{text}");
    assert!(!text.contains("Traceback (most"), "{text}");
    for line in failed {
        assert!(
            line.contains("step raised RuntimeError: deliberate failure"),
            "{line}"
        );
        let (_, file) = line
            .rsplit_once("; the Python traceback is in ")
            .unwrap_or_else(|| panic!("{line}"));
        let kept = std::fs::read_to_string(file).unwrap();
        assert!(kept.contains("Traceback (most recent call last)"), "{kept}");
    }
}

#[test]
fn help_examples_with_gymnasium_ids_work_as_printed() {
    let Some(py) = python() else { return };
    let bin_dir = rwg_bin().parent().unwrap().to_path_buf();
    let path = format!(
        "{}:{}",
        bin_dir.display(),
        std::env::var("PATH").unwrap_or_default()
    );
    let mut ran = 0;
    for cmd in ["envs", "check", "rollout"] {
        let help = run_ok(&py, &[cmd, "--help"]);
        for line in help.lines().map(str::trim) {
            if !(line.starts_with("rwg ") && line.contains("gymnasium:")) {
                continue;
            }
            let out = Command::new("sh")
                .args(["-c", line])
                .env("PATH", &path)
                .env("RWG_PYTHON", &py)
                .output()
                .unwrap();
            assert!(
                out.status.success(),
                "`{line}` failed: {}",
                String::from_utf8_lossy(&out.stderr)
            );
            ran += 1;
        }
    }
    assert!(ran >= 5, "only {ran} examples found");
}

#[test]
fn mujoco_warnings_go_to_stderr_not_into_the_users_folder() {
    let Some(py) = python() else { return };
    // HalfCheetah-v5's model uses an attribute MuJoCo warns about while
    // compiling; MuJoCo's default handler also appends it to MUJOCO_LOG.TXT
    // in the current directory. rwg's worker routes it to stderr alone.
    let dir = temp_dir("mujoco-log");
    let out = rwg_cmd(
        &py,
        &[
            "rollout",
            "gymnasium:HalfCheetah-v5",
            "--actions",
            "0 0 0 0 0 0,1 -1 1 -1 1 -1",
        ],
    )
    .current_dir(&dir)
    .output()
    .unwrap();
    assert!(
        out.status.success(),
        "rollout failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let left: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert!(
        left.is_empty(),
        "rwg left {left:?} in the current directory"
    );
}
