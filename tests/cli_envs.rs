//! `rwg envs` end to end.

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

#[test]
fn envs_lists_every_builtin_env() {
    let out = rwg_ok(&["envs"]);
    for id in IDS {
        assert!(
            out.lines().any(|l| l.starts_with(id)),
            "{id} missing from:\n{out}"
        );
    }
    let cartpole = out.lines().find(|l| l.starts_with("CartPole-v0 ")).unwrap();
    assert!(
        cartpole.contains("Discrete(2)") && cartpole.contains("200") && cartpole.contains("195")
    );
}

#[test]
fn envs_json_has_spaces_limits_and_thresholds() {
    let out = rwg_ok(&["envs", "--json"]);
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    let rows = v.as_array().unwrap();
    assert_eq!(rows.len(), IDS.len());
    let acro = rows.iter().find(|r| r["id"] == "Acrobot-v1").unwrap();
    assert_eq!(acro["max_episode_steps"], 500);
    assert_eq!(acro["reward_threshold"], -100.0);
    assert_eq!(acro["action_space"]["n"], 3);
    let pend = rows.iter().find(|r| r["id"] == "Pendulum-v1").unwrap();
    assert!(pend["reward_threshold"].is_null());
    assert_eq!(pend["action_space"]["high"][0], 2.0);
}
