//! `rwg rollout` end to end: every golden trajectory is reproduced through the
//! real binary from its seed (or, for Pendulum-v0, from `--state` when asked),
//! with the trajectory's action dtype; and bad input gives clear errors.

mod common;
use common::*;
use serde_json::Value;

fn f64s(v: &Value) -> Vec<f64> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect()
}

fn action_text(a: &Value) -> String {
    match a {
        Value::Array(xs) => xs
            .iter()
            .map(|x| format!("{:?}", x.as_f64().unwrap()))
            .collect::<Vec<_>>()
            .join(" "),
        x => x.as_i64().unwrap().to_string(),
    }
}

fn ulps32(a: f64, b: f64) -> u32 {
    let key = |x: f64| {
        let i = (x as f32).to_bits() as i32;
        if i < 0 {
            i32::MIN - i
        } else {
            i
        }
    };
    key(a).abs_diff(key(b))
}

#[test]
fn rollout_reproduces_every_golden_trajectory() {
    let mut files: Vec<_> = std::fs::read_dir(data_dir())
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "json"))
        .collect();
    files.sort();
    assert_eq!(files.len(), 7, "expected the 7 golden files in tests/data");
    let dir = temp_dir("rollout-golden");
    for f in files {
        let doc: Value = serde_json::from_str(&std::fs::read_to_string(&f).unwrap()).unwrap();
        let id = doc["env_id"].as_str().unwrap();
        for tr in doc["trajectories"].as_array().unwrap() {
            let seed = tr["seed"].as_u64().unwrap();
            let steps = tr["steps"].as_array().unwrap();
            let actions: Vec<String> = steps.iter().map(|s| action_text(&s["action"])).collect();
            let actions_file = dir.join(format!("{id}-{seed}.txt"));
            std::fs::write(&actions_file, actions.join("\n")).unwrap();
            let dtype = match tr["action_dtype"].as_str().unwrap() {
                "float32" => "float32",
                _ => "float64",
            };
            let seed_s = seed.to_string();
            let out = rwg_ok(&[
                "rollout",
                id,
                "--seed",
                &seed_s,
                "--action-dtype",
                dtype,
                "--actions-file",
                actions_file.to_str().unwrap(),
            ]);
            let lines: Vec<Value> = out
                .lines()
                .map(|l| serde_json::from_str(l).unwrap())
                .collect();
            assert_eq!(
                lines.len(),
                steps.len() + 1,
                "{id} seed {seed}: number of lines"
            );
            let reset_obs = f64s(&lines[0]["obs"]);
            for (k, (a, b)) in reset_obs.iter().zip(f64s(&tr["reset_obs"])).enumerate() {
                let ok = if id == "Acrobot-v1" {
                    ulps32(*a, b) <= 1
                } else {
                    a.to_bits() == b.to_bits()
                };
                assert!(ok, "{id} seed {seed} reset_obs[{k}]: {a:?} vs {b:?}");
            }
            for (t, (line, st)) in lines[1..].iter().zip(steps).enumerate() {
                let t = t + 1;
                assert_eq!(
                    f64s(&line["obs"]),
                    f64s(&st["obs"]),
                    "{id} seed {seed} step {t}: obs"
                );
                assert_eq!(
                    line["reward"].as_f64(),
                    st["reward"].as_f64(),
                    "{id} seed {seed} step {t}: reward"
                );
                assert_eq!(
                    line["terminated"], st["terminated"],
                    "{id} seed {seed} step {t}: terminated"
                );
                assert_eq!(
                    line["truncated"], st["truncated"],
                    "{id} seed {seed} step {t}: truncated"
                );
            }
        }
    }
}

#[test]
fn state_option_starts_from_the_given_state() {
    let out = rwg_ok(&[
        "rollout",
        "CartPole-v0",
        "--state",
        "0.1,0,-0.05,0",
        "--actions",
        "1",
    ]);
    let first: Value = serde_json::from_str(out.lines().next().unwrap()).unwrap();
    assert_eq!(
        f64s(&first["obs"]),
        vec![0.1f32 as f64, 0.0, -0.05f32 as f64, 0.0]
    );
}

#[test]
fn csv_format_has_a_header_and_one_row_per_step() {
    let out = rwg_ok(&[
        "rollout",
        "CartPole-v0",
        "--seed",
        "1",
        "--actions",
        "0,1,0",
        "--format",
        "csv",
    ]);
    let rows: Vec<&str> = out.lines().collect();
    assert_eq!(
        rows[0],
        "step,action,obs_0,obs_1,obs_2,obs_3,reward,terminated,truncated"
    );
    assert_eq!(rows.len(), 5);
    assert!(rows[3].starts_with("2,1,"));
    assert!(rows[3].ends_with(",1.0,false,false"));
}

#[test]
fn stops_when_the_episode_ends() {
    let many = vec!["1"; 300].join(",");
    let out = rwg_ok(&[
        "rollout",
        "CartPole-v0",
        "--max-episode-steps",
        "5",
        "--actions",
        &many,
    ]);
    let last: Value = serde_json::from_str(out.lines().last().unwrap()).unwrap();
    assert!(last["truncated"].as_bool().unwrap() || last["terminated"].as_bool().unwrap());
    assert!(out.lines().count() <= 6);
}

#[test]
fn unknown_env_lists_known_ids_and_suggests_the_nearest() {
    let err = rwg_err(&["rollout", "CartPol-v1"]);
    assert!(err.contains("unknown environment 'CartPol-v1'"), "{err}");
    assert!(err.contains("did you mean 'CartPole-v1'"), "{err}");
    assert!(err.contains("CartPole-v0"), "{err}");
}

#[test]
fn discrete_action_errors_name_the_step() {
    let err = rwg_err(&["rollout", "CartPole-v0", "--actions", "0,1,2"]);
    assert!(err.contains("step 3"), "{err}");
    assert!(err.contains("outside the action space"), "{err}");
    let err = rwg_err(&["rollout", "CartPole-v0", "--actions", "0,0.5"]);
    assert!(
        err.contains("step 2") && err.contains("not an integer"),
        "{err}"
    );
}

#[test]
fn unparsable_action_file_names_the_line() {
    let dir = temp_dir("bad-actions");
    let f = dir.join("a.txt");
    std::fs::write(&f, "1\n0\n# comment\nleft\n").unwrap();
    let err = rwg_err(&[
        "rollout",
        "CartPole-v0",
        "--actions-file",
        f.to_str().unwrap(),
    ]);
    assert!(err.contains("a.txt:4"), "{err}");
    assert!(err.contains("'left'"), "{err}");
}

#[test]
fn wrong_state_length_names_the_expected_length() {
    let err = rwg_err(&["rollout", "CartPole-v0", "--state", "1,2"]);
    assert!(err.contains("expects 4"), "{err}");
}
