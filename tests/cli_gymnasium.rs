//! Faithfulness end to end: networks sampled by `rwg run`, exported with
//! `rwg replay --export-weights` and replayed in real Gymnasium 1.4 (numpy
//! forward pass, `env.reset(seed=...)` with rwg's reset seeds) score what rwg
//! stored.
//!
//! Needs a Python with gymnasium 1.4 and numpy 2: set `RWG_TEST_PYTHON` to it
//! (`.ci/run` makes a virtualenv and sets it). Without it the test prints
//! `SKIPPED ...` in the test output and passes, except under CI (`CI=true`)
//! or with `RWG_NO_SKIP=1`, where it fails.

mod common;
use common::*;
use serde_json::Value;
use std::process::Command;

const STUDY: &str = r#"
seed = 21
samples = 8
episodes = 2
bias = [false, true]
[[architectures]]
name = "1HL"
hidden = [4]
[[envs]]
id = "CartPole-v0"
[[envs]]
id = "Acrobot-v1"
max_episode_steps = 150
[[envs]]
id = "MountainCar-v0"
[[envs]]
id = "MountainCarContinuous-v0"
max_episode_steps = 300
[[envs]]
id = "Pendulum-v1"
"#;

#[test]
fn exported_networks_score_the_same_in_gymnasium() {
    let Ok(python) = std::env::var("RWG_TEST_PYTHON") else {
        skip(
            "exported_networks_score_the_same_in_gymnasium",
            "set RWG_TEST_PYTHON to a Python with gymnasium==1.4.0 and numpy 2 (.ci/run makes one)",
        );
        return;
    };
    let dir = temp_dir("gymnasium");
    let m = dir.join("m.toml");
    std::fs::write(&m, STUDY).unwrap();
    let run = dir.join("run");
    rwg_ok(&["run", m.to_str().unwrap(), "--out", run.to_str().unwrap()]);
    let run_s = run.to_str().unwrap();

    let mut files = vec![];
    let mut stored = vec![];
    for env in [
        "CartPole-v0",
        "Acrobot-v1",
        "MountainCar-v0",
        "MountainCarContinuous-v0",
        "Pendulum-v1",
    ] {
        for bias in ["false", "true"] {
            for sample in 0..8 {
                let f = dir.join(format!("{env}-{bias}-{sample}.json"));
                let s = sample.to_string();
                let out = rwg_ok(&[
                    "replay",
                    run_s,
                    "--env",
                    env,
                    "--arch",
                    "1HL",
                    "--bias",
                    bias,
                    "--sample",
                    &s,
                    "--export-weights",
                    f.to_str().unwrap(),
                ]);
                let scores: Vec<f64> = out
                    .lines()
                    .skip(1)
                    .map(|l| l.split(',').nth(4).unwrap().parse().unwrap())
                    .collect();
                files.push(f.to_str().unwrap().to_string());
                stored.push((env, scores));
            }
        }
    }
    let script = data_dir().join("../python/replay_in_gymnasium.py");
    let out = Command::new(&python)
        .arg(&script)
        .args(&files)
        .output()
        .expect("cannot run RWG_TEST_PYTHON");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let lines: Vec<Value> = String::from_utf8(out.stdout)
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(lines.len(), files.len());
    let mut exact = 0;
    for (line, (env, ours)) in lines.iter().zip(&stored) {
        let theirs: Vec<f64> = line["scores"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_f64().unwrap())
            .collect();
        for (a, b) in ours.iter().zip(&theirs) {
            if a == b {
                exact += 1;
                continue;
            }
            // numpy's tanh and matrix product may differ from rwg's in the last
            // bit; in discrete envs that cannot change an argmax here, in
            // continuous envs it moves the action by an ulp.
            let discrete = matches!(*env, "CartPole-v0" | "Acrobot-v1" | "MountainCar-v0");
            assert!(!discrete, "{}: rwg {a:?} vs Gymnasium {b:?}", line["file"]);
            assert!(
                (a - b).abs() <= 1e-6 * a.abs().max(1.0),
                "{}: rwg {a:?} vs Gymnasium {b:?}",
                line["file"]
            );
        }
    }
    eprintln!(
        "{exact} of {} episodes identical to the bit",
        files.len() * 2
    );
}
