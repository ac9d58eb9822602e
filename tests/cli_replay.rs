//! `rwg replay` and `rwg top` end to end: a network regenerated from the seed
//! reproduces its stored scores; its weights export; the best samples list
//! commands that replay them.

mod common;
use common::*;
use serde_json::Value;

const STUDY: &str = r#"
seed = 9
samples = 40
episodes = 3
bias = [false, true]
[[architectures]]
name = "1HL"
hidden = [4]
[[envs]]
id = "CartPole-v0"
[[envs]]
id = "MountainCarContinuous-v0"
max_episode_steps = 150
"#;

fn study(name: &str) -> (std::path::PathBuf, String) {
    let dir = temp_dir(name);
    let m = dir.join("m.toml");
    std::fs::write(&m, STUDY).unwrap();
    let run = dir.join("run");
    rwg_ok(&["run", m.to_str().unwrap(), "--out", run.to_str().unwrap()]);
    (dir, run.to_str().unwrap().to_string())
}

#[test]
fn replay_reproduces_the_stored_scores() {
    let (_dir, run) = study("replay");
    for (env, bias, sample) in [
        ("CartPole-v0", "false", "7"),
        ("MountainCarContinuous-v0", "true", "39"),
    ] {
        let out = rwg_ok(&[
            "replay", &run, "--env", env, "--arch", "1HL", "--bias", bias, "--sample", sample,
        ]);
        let rows: Vec<&str> = out.lines().collect();
        assert_eq!(rows[0], "episode,reset_seed,score,steps,stored_score,same");
        assert_eq!(rows.len(), 4, "{out}");
        assert!(rows[1..].iter().all(|r| r.ends_with(",true")), "{out}");
    }
}

#[test]
fn replay_of_one_episode_prints_its_steps_and_matches_the_score() {
    let (_dir, run) = study("replay-episode");
    let summary = rwg_ok(&[
        "replay",
        &run,
        "--env",
        "CartPole-v0",
        "--arch",
        "1HL",
        "--bias",
        "false",
        "--sample",
        "3",
    ]);
    let row: Vec<&str> = summary.lines().nth(2).unwrap().split(',').collect(); // episode 1
    let (score, steps): (f64, usize) = (row[2].parse().unwrap(), row[3].parse().unwrap());
    let out = rwg_ok(&[
        "replay",
        &run,
        "--env",
        "CartPole-v0",
        "--arch",
        "1HL",
        "--bias",
        "false",
        "--sample",
        "3",
        "--episode",
        "1",
    ]);
    let lines: Vec<Value> = out
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(lines.len(), steps + 1);
    let total: f64 = lines[1..]
        .iter()
        .map(|l| l["reward"].as_f64().unwrap())
        .sum();
    assert_eq!(total, score);
    // the episode starts where `rwg rollout` with its reset seed starts
    let seed = row[1];
    let rollout = rwg_ok(&["rollout", "CartPole-v0", "--seed", seed]);
    assert_eq!(rollout.lines().next().unwrap(), out.lines().next().unwrap());
}

#[test]
fn export_weights_writes_the_network() {
    let (dir, run) = study("export");
    let f = dir.join("w.json");
    rwg_ok(&[
        "replay",
        &run,
        "--env",
        "CartPole-v0",
        "--arch",
        "1HL",
        "--bias",
        "true",
        "--sample",
        "0",
        "--export-weights",
        f.to_str().unwrap(),
    ]);
    let w: Value = serde_json::from_str(&std::fs::read_to_string(&f).unwrap()).unwrap();
    let shapes: Vec<Value> = w["layers"]
        .as_array()
        .unwrap()
        .iter()
        .map(|l| l["shape"].clone())
        .collect();
    assert_eq!(
        shapes,
        [serde_json::json!([4, 5]), serde_json::json!([2, 5])]
    );
    assert_eq!(w["layers"][0]["weights"].as_array().unwrap().len(), 4);
    assert_eq!(w["reset_seeds"].as_array().unwrap().len(), 3);
    assert_eq!(w["activation"], "tanh");
}

#[test]
fn replay_errors_are_clear() {
    let (_dir, run) = study("replay-errors");
    let err = rwg_err(&[
        "replay",
        &run,
        "--env",
        "CartPole-v0",
        "--arch",
        "1HL",
        "--sample",
        "0",
    ]);
    assert!(err.contains("--bias true or --bias false"), "{err}");
    let err = rwg_err(&[
        "replay",
        &run,
        "--env",
        "CartPole-v0",
        "--arch",
        "2HL",
        "--bias",
        "true",
        "--sample",
        "0",
    ]);
    assert!(
        err.contains("no cell CartPole-v0 / 2HL") && err.contains("architectures: 1HL"),
        "{err}"
    );
    let err = rwg_err(&[
        "replay",
        &run,
        "--env",
        "CartPole-v0",
        "--arch",
        "1HL",
        "--bias",
        "true",
        "--sample",
        "40",
    ]);
    assert!(err.contains("samples 0..39"), "{err}");
}

#[test]
fn top_lists_the_best_samples_with_replay_commands() {
    let (_dir, run) = study("top");
    let out = rwg_ok(&["top", &run, "-n", "3"]);
    let block: Vec<&str> = out
        .lines()
        .skip_while(|l| !l.starts_with("CartPole-v0__1HL__nobias"))
        .take(5)
        .collect();
    assert_eq!(block.len(), 5, "{out}");
    let means: Vec<f64> = block[2..]
        .iter()
        .map(|l| l.split_whitespace().nth(1).unwrap().parse().unwrap())
        .collect();
    assert!(means.windows(2).all(|w| w[0] >= w[1]), "{means:?}");
    // the listed command works as printed
    let cmd: Vec<&str> = block[2]
        .split("  rwg ")
        .nth(1)
        .unwrap()
        .split_whitespace()
        .collect();
    let replay = rwg_ok(&cmd);
    assert!(
        replay.lines().skip(1).all(|r| r.ends_with(",true")),
        "{replay}"
    );
}
