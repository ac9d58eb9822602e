//! Traps a plugin author falls into (issue 15): a C reward_threshold left at
//! 0.0 is warned about, `rollout --config` works for a plugin found on
//! `RWG_PLUGIN_PATH`, and the example Makefile builds any `NAME.c` given the
//! header's folder.

mod common;
use common::*;
use serde_json::Value;
use std::ffi::OsStr;
use std::path::PathBuf;
use std::process::Command;

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn spec_check(lib: &std::path::Path) -> Value {
    let out = rwg_env(&["check", "--json", lib.to_str().unwrap()], &[]);
    let v: Value = serde_json::from_slice(&out.stdout)
        .unwrap_or_else(|e| panic!("{e}: {}", String::from_utf8_lossy(&out.stderr)));
    v.as_array()
        .unwrap()
        .iter()
        .find(|r| r["name"] == "spaces")
        .unwrap_or_else(|| panic!("no spaces check in {v}"))
        .clone()
}

#[test]
fn a_reward_threshold_left_at_zero_is_warned_about() {
    let zero = compile_c(
        "traps",
        "plugins/testing/c/handshake.c",
        "zero",
        &["THRESHOLD_LEFT_AT_ZERO"],
    );
    let r = spec_check(&zero);
    assert_eq!(r["status"], "warned", "{r}");
    let msg = r["message"].as_str().unwrap();
    assert!(
        msg.contains("reward_threshold is exactly 0.0") && msg.contains(".reward_threshold = NAN"),
        "{msg}"
    );
    let nan = compile_c("traps", "plugins/testing/c/handshake.c", "nan", &[]);
    let r = spec_check(&nan);
    assert!(
        !r["message"].as_str().unwrap().contains("reward_threshold"),
        "{r}"
    );
}

#[test]
fn rollout_config_works_for_a_plugin_on_the_path() {
    let lib = compile_c("traps-path", "examples/plugin-c/chain.c", "chain", &[]);
    let dir = lib.parent().unwrap().as_os_str().to_owned();
    let vars: &[(&str, &OsStr)] = &[("RWG_PLUGIN_PATH", &dir)];
    // a chain 3 long: three steps right reach its end
    let out = rwg_env(
        &[
            "rollout",
            "c_example/Chain-v0",
            "--config",
            "length=3",
            "--seed",
            "1",
            "--actions",
            "1,1,1,1,1,1,1,1",
        ],
        vars,
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8(out.stdout).unwrap();
    let last: Value = serde_json::from_str(text.lines().last().unwrap()).unwrap();
    assert_eq!(last["terminated"], true, "{text}");
    assert!(
        text.lines().count() < 9,
        "the episode ends at the chain's end: {text}"
    );
    // built-in envs take no configuration, and say so
    let err = rwg_err(&["rollout", "CartPole-v0", "--config", "x", "--actions", "1"]);
    assert!(
        err.contains("--config is for plugin envs: CartPole-v0 is built in"),
        "{err}"
    );
}

#[test]
fn the_example_makefile_builds_any_name_given_the_header_folder() {
    let dir = temp_dir("traps-make");
    std::fs::copy(
        repo().join("examples/plugin-c/Makefile"),
        dir.join("Makefile"),
    )
    .unwrap();
    std::fs::copy(
        repo().join("examples/plugin-c/chain.c"),
        dir.join("myenv.c"),
    )
    .unwrap();
    let include = repo().join("rwg-env/include").canonicalize().unwrap();
    let out = Command::new("make")
        .current_dir(&dir)
        .arg("NAME=myenv")
        .arg(format!("RWG_INCLUDE={}", include.display()))
        .output();
    let out = match out {
        Ok(o) => o,
        Err(e) => {
            skip(
                "the_example_makefile_builds_any_name_given_the_header_folder",
                &format!("cannot run make: {e}"),
            );
            return;
        }
    };
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let lib = dir.join(rwg_plugin_host::library_file_name("myenv"));
    assert!(lib.is_file(), "{} not built", lib.display());
    let r = spec_check(&lib);
    assert_eq!(r["status"], "passed", "{r}");
}

#[test]
fn check_and_run_agree_on_an_env_without_a_time_limit() {
    let lib = compile_c(
        "traps-nolimit",
        "plugins/testing/c/handshake.c",
        "nolimit",
        &["NO_TIME_LIMIT"],
    );
    let out = rwg_env(&["check", "--json", lib.to_str().unwrap()], &[]);
    let v: Value = serde_json::from_slice(&out.stdout).unwrap();
    let t = v
        .as_array()
        .unwrap()
        .iter()
        .find(|r| r["name"] == "truncation")
        .unwrap()
        .clone();
    assert_eq!(t["status"], "warned", "{t}");
    let fix = "max_episode_steps";
    assert!(
        t["message"].as_str().unwrap().contains(fix)
            && t["message"].as_str().unwrap().contains("[[envs]]"),
        "{t}"
    );
    let dir = temp_dir("traps-nolimit-run");
    let study = |extra: &str| {
        format!(
            "samples = 2\nepisodes = 1\n[[architectures]]\nname = \"0HL\"\nhidden = []\n[[envs]]\nid = \"handshake/Ok-v0\"\nplugin = \"{}\"\n{extra}",
            lib.display()
        )
    };
    let m = dir.join("m.toml");
    std::fs::write(&m, study("")).unwrap();
    let err = rwg_err(&[
        "run",
        m.to_str().unwrap(),
        "--out",
        dir.join("r1").to_str().unwrap(),
    ]);
    assert!(
        err.contains("no time limit") && err.contains(fix) && err.contains("[[envs]]"),
        "{err}"
    );
    std::fs::write(&m, study("max_episode_steps = 5\n")).unwrap();
    rwg_ok(&[
        "run",
        m.to_str().unwrap(),
        "--out",
        dir.join("r2").to_str().unwrap(),
        "--no-report",
        "--quiet",
    ]);
}

/// `rwg check ID --config ...` finds a plugin env on RWG_PLUGIN_PATH as
/// `rwg rollout ID` does, and checks that env only.
#[test]
fn check_takes_a_plugin_env_id_found_on_the_path() {
    let lib = compile_c(
        "traps-check-path",
        "examples/plugin-c/chain.c",
        "chain",
        &[],
    );
    let dir = lib.parent().unwrap().as_os_str().to_owned();
    let vars: &[(&str, &OsStr)] = &[("RWG_PLUGIN_PATH", &dir)];
    let out = rwg_env(
        &[
            "check",
            "c_example/Chain-v0",
            "--config",
            "length=3",
            "--json",
        ],
        vars,
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    let v: Value = serde_json::from_slice(&out.stdout).unwrap();
    let results = v.as_array().unwrap();
    assert!(results.len() > 10, "{v}");
    assert!(
        results
            .iter()
            .filter(|r| r["name"] != "load")
            .all(|r| r["env"] == "c_example/Chain-v0" && r["status"] != "failed"),
        "{v}"
    );
    // the config reaches the instances: a chain that cannot exist fails
    let out = rwg_env(
        &[
            "check",
            "c_example/Chain-v0",
            "--config",
            "length=0",
            "--json",
        ],
        vars,
    );
    assert!(!out.status.success());
    // a built-in id, an unknown one: said what check takes
    let err = rwg_err(&["check", "CartPole-v0"]);
    assert!(
        err.contains("CartPole-v0 is a built-in environment"),
        "{err}"
    );
    let out = rwg_env(&["check", "c_example/Chian-v0"], vars);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("did you mean 'c_example/Chain-v0'")
            && err.contains("the id of a plugin env on RWG_PLUGIN_PATH"),
        "{err}"
    );
}
