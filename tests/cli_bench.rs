//! `rwg bench` end to end: both benchmarks run and report every env /
//! configuration (no timing assertions: the figures depend on the machine).

mod common;
use common::*;

const IDS: [&str; 7] = [
    "CartPole-v0",
    "CartPole-v1",
    "Acrobot-v1",
    "Pendulum-v0",
    "Pendulum-v1",
    "MountainCar-v0",
    "MountainCarContinuous-v0",
];

/// The sampler's configurations: env and hidden-layer column.
const CONFIGS: [(&str, &str); 5] = [
    ("CartPole-v0", "0HL"),
    ("CartPole-v0", "[4,4]"),
    ("Acrobot-v1", "0HL"),
    ("MountainCarContinuous-v0", "[4,4]"),
    ("Pendulum-v1", "[4]"),
];

#[test]
fn bench_envs_reports_every_env() {
    let out = rwg_ok(&["bench", "envs", "--steps", "1000"]);
    for id in IDS {
        let line = out
            .lines()
            .find(|l| l.split_whitespace().next() == Some(id))
            .unwrap_or_else(|| panic!("{id} missing from:\n{out}"));
        assert!(line.contains("1,000"), "{line}");
    }
}

#[test]
fn bench_envs_json_counts_steps_and_filters() {
    let out = rwg_ok(&[
        "bench",
        "envs",
        "--steps",
        "1000",
        "--env",
        "Acrobot-v1",
        "--json",
    ]);
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    let rows = v.as_array().unwrap();
    assert_eq!(rows.len(), 1);
    assert_eq!(rows[0]["env"], "Acrobot-v1");
    assert_eq!(rows[0]["steps"], 1000);
    // 1000 steps of Acrobot's 500-step limit: at least 3 episodes started.
    assert!(rows[0]["episodes"].as_u64().unwrap() >= 3);
    assert!(rows[0]["steps_per_s"].as_f64().unwrap() > 0.0);
}

#[test]
fn bench_sampler_reports_every_config() {
    let out = rwg_ok(&[
        "bench",
        "sampler",
        "--samples",
        "4",
        "--episodes",
        "1",
        "--threads",
        "1",
    ]);
    for (env, hidden) in CONFIGS {
        assert!(
            out.lines().any(|l| {
                let mut w = l.split_whitespace();
                w.next() == Some(env) && w.next() == Some(hidden)
            }),
            "{env} {hidden} missing from:\n{out}"
        );
    }
}

#[test]
fn bench_sampler_json_counts_every_step() {
    let out = rwg_ok(&[
        "bench",
        "sampler",
        "--samples",
        "4",
        "--episodes",
        "2",
        "--threads",
        "2",
        "--json",
    ]);
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    let rows = v.as_array().unwrap();
    assert_eq!(rows.len(), CONFIGS.len());
    for r in rows {
        let steps = r["env_steps"].as_u64().unwrap();
        assert!((8..=8 * 999).contains(&steps), "{r}");
        assert!(r["ratio_vs_gymnax_raw"].as_f64().unwrap() > 0.0);
        assert_eq!(r["threads"], 2);
        assert!(r["lanes"].as_u64().unwrap() >= 1);
        assert!(r["mean_score"].as_f64().unwrap().is_finite());
    }
    // Pendulum never terminates: every episode lasts its 200-step limit.
    let pendulum = rows.iter().find(|r| r["env"] == "Pendulum-v1").unwrap();
    assert_eq!(pendulum["env_steps"], 4 * 2 * 200);
}

#[test]
fn bench_rejects_unknown_envs() {
    let err = rwg_err(&["bench", "envs", "--steps", "10", "--env", "CartPol-v0"]);
    assert!(err.contains("did you mean 'CartPole-v0'"), "{err}");
    let err = rwg_err(&["bench", "sampler", "--env", "MountainCar-v0"]);
    assert!(err.contains("no benchmark configuration"), "{err}");
}
