//! `rwg check` end to end: the reference plugin and the C example pass; the
//! broken plugins fail, including one that segfaults, and rwg itself exits
//! cleanly with status 1; a manifest given by mistake says what to run.

mod common;
use common::*;
use serde_json::Value;
use std::path::PathBuf;

fn check_json(args: &[&str]) -> (Option<i32>, Vec<Value>) {
    let mut all = vec!["check", "--json"];
    all.extend_from_slice(args);
    let res = rwg_env(&all, &[]);
    let v: Value = serde_json::from_slice(&res.stdout).unwrap_or_else(|e| {
        panic!(
            "rwg {all:?}: {e}\nstdout: {}\nstderr: {}",
            String::from_utf8_lossy(&res.stdout),
            String::from_utf8_lossy(&res.stderr)
        )
    });
    (res.status.code(), v.as_array().unwrap().clone())
}

fn with_status<'a>(results: &'a [Value], status: &str) -> Vec<&'a Value> {
    results.iter().filter(|r| r["status"] == status).collect()
}

#[test]
fn reference_plugin_passes_every_check() {
    let lib = classic_control_plugin();
    let res = rwg_env(&["check", lib.to_str().unwrap()], &[]);
    let stdout = String::from_utf8_lossy(&res.stdout);
    assert!(res.status.success(), "{stdout}");
    assert!(
        !stdout.contains("[FAIL]") && !stdout.contains("[WARN]"),
        "{stdout}"
    );
    assert!(
        stdout.contains("[ok] load: plugin 'classic_control'"),
        "{stdout}"
    );
    assert!(stdout.contains("7 environment(s)"), "{stdout}");
    for id in ["CartPole-v0", "Acrobot-v1", "MountainCarContinuous-v0"] {
        assert!(
            stdout.contains(&format!("[ok] classic_control/{id}: independent instances")),
            "{id}: {stdout}"
        );
    }
    assert!(stdout.contains(" warned, 0 failed"), "{stdout}");
}

#[test]
fn c_example_passes_and_config_reaches_the_plugin() {
    let lib = compile_c("check", "examples/plugin-c/chain.c", "chain", &[]);
    let (code, results) = check_json(&[lib.to_str().unwrap()]);
    assert_eq!(code, Some(0), "{results:#?}");
    assert!(with_status(&results, "failed").is_empty(), "{results:#?}");
    assert!(results
        .iter()
        .any(|r| r["env"] == "c_example/Chain-v0" && r["name"] == "threads"));
    // A config the plugin refuses fails "create", with the plugin's message.
    let (code, results) = check_json(&[
        lib.to_str().unwrap(),
        "--env",
        "c_example/Chain-v0",
        "--config",
        "length=1",
    ]);
    assert_eq!(code, Some(1));
    let failed = with_status(&results, "failed");
    assert_eq!(failed[0]["name"], "create", "{results:#?}");
    for f in failed {
        assert_eq!(f["env"], "c_example/Chain-v0");
        assert!(f["message"]
            .as_str()
            .unwrap()
            .contains("chain: length must be an integer in 2..1000"));
    }
}

#[test]
fn a_segfaulting_plugin_is_a_failed_check_not_a_crash() {
    let lib = broken_plugin();
    let res = rwg_env(
        &[
            "check",
            lib.to_str().unwrap(),
            "--env",
            "broken/SegfaultInStep-v0",
        ],
        &[],
    );
    let stdout = String::from_utf8_lossy(&res.stdout);
    let stderr = String::from_utf8_lossy(&res.stderr);
    // rwg exits normally with 1, not killed by the signal.
    assert_eq!(res.status.code(), Some(1), "{stdout}\n{stderr}");
    let fail = stdout
        .lines()
        .find(|l| l.starts_with("[FAIL] broken/SegfaultInStep-v0: "))
        .unwrap_or_else(|| panic!("no failure in:\n{stdout}"));
    assert!(
        fail.contains("the checking process was killed by signal"),
        "{fail}"
    );
    #[cfg(target_os = "linux")]
    assert!(
        fail.contains("signal 11 (SIGSEGV) during the 'seed sensitivity' check"),
        "{fail}"
    );
    // The checks before the crash are reported.
    assert!(
        stdout.contains("[ok] broken/SegfaultInStep-v0: reset determinism"),
        "{stdout}"
    );
    assert!(stderr.contains("error: 1 check(s) failed"), "{stderr}");
}

#[test]
fn panicking_nan_and_hidden_state_plugins_fail_the_right_checks() {
    let lib = broken_plugin();
    let lib = lib.to_str().unwrap();
    let failed_names = |id: &str| -> (Vec<String>, Vec<Value>) {
        let (code, results) = check_json(&[lib, "--env", id]);
        assert_eq!(code, Some(1), "{id}: {results:#?}");
        let failed: Vec<Value> = with_status(&results, "failed")
            .into_iter()
            .cloned()
            .collect();
        (
            failed
                .iter()
                .map(|r| r["name"].as_str().unwrap().to_string())
                .collect(),
            failed,
        )
    };
    let (names, failed) = failed_names("broken/PanicInStep-v0");
    assert!(names.contains(&"rollout".to_string()), "{names:?}");
    assert!(failed.iter().all(|r| r["message"]
        .as_str()
        .unwrap()
        .contains("RWG_ERR_PANIC (5): panic: broken/PanicInStep-v0 panics on step 3")));
    let (names, failed) = failed_names("broken/NaNReward-v0");
    assert!(names.contains(&"rollout".to_string()), "{names:?}");
    assert!(failed[0]["message"]
        .as_str()
        .unwrap()
        .contains("non-finite reward"));
    let (names, _) = failed_names("broken/HiddenGlobalState-v0");
    // ("threads" may pass or fail, depending on how the threads interleave.)
    assert!(
        names.contains(&"independent instances".to_string()),
        "{names:?}"
    );
    assert!(!names.contains(&"rollout".to_string()), "{names:?}");

    // The whole plugin: every env is checked, the segfault and the hang
    // included, once each.
    let (code, results) = check_json(&[lib, "--timeout", "3"]);
    assert_eq!(code, Some(1));
    for id in [
        "broken/PanicInStep-v0",
        "broken/NaNObservation-v0",
        "broken/NaNReward-v0",
        "broken/HiddenGlobalState-v0",
        "broken/SegfaultInStep-v0",
        "broken/HangInStep-v0",
    ] {
        assert!(
            results
                .iter()
                .any(|r| r["env"] == id && r["status"] == "failed"),
            "{id}: {results:#?}"
        );
    }
}

#[test]
fn unloadable_files_and_unknown_envs() {
    let dir = temp_dir("check-bad");
    let junk = dir.join("libjunk.so");
    std::fs::write(&junk, "not a library").unwrap();
    let (code, results) = check_json(&[junk.to_str().unwrap()]);
    assert_eq!(code, Some(1));
    assert_eq!(results.len(), 1);
    assert_eq!(results[0]["name"], "load");
    assert_eq!(results[0]["status"], "failed");
    assert!(results[0]["message"]
        .as_str()
        .unwrap()
        .contains("cannot open the library"));

    let wrong_major = compile_c(
        "check-bad",
        "plugins/testing/c/handshake.c",
        "wrong_major",
        &["BROKEN_WRONG_MAJOR"],
    );
    let (code, results) = check_json(&[wrong_major.to_str().unwrap()]);
    assert_eq!(code, Some(1));
    assert!(results[0]["message"]
        .as_str()
        .unwrap()
        .contains("ABI version mismatch"));

    let lib = classic_control_plugin();
    let err = rwg_err(&[
        "check",
        lib.to_str().unwrap(),
        "--env",
        "classic_control/Nope-v0",
    ]);
    assert!(
        err.contains("plugin 'classic_control' has no environment 'classic_control/Nope-v0'; its environments: classic_control/CartPole-v0,"),
        "{err}"
    );
}

#[test]
fn a_hanging_plugin_is_killed_after_the_timeout() {
    let lib = broken_plugin();
    let t0 = std::time::Instant::now();
    let (code, results) = check_json(&[
        lib.to_str().unwrap(),
        "--env",
        "broken/HangInStep-v0",
        "--timeout",
        "2",
    ]);
    assert_eq!(code, Some(1));
    assert!(t0.elapsed() < std::time::Duration::from_secs(30));
    let hung = results
        .iter()
        .find(|r| r["status"] == "failed")
        .unwrap_or_else(|| panic!("{results:#?}"));
    let msg = hung["message"].as_str().unwrap();
    assert!(
        msg.contains("did not finish within 2 s (hung?) and was killed"),
        "{msg}"
    );
}

#[test]
fn a_manifest_given_to_check_says_what_to_run() {
    let manifest = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../examples/quick.toml");
    let m = manifest.to_str().unwrap();
    let err = rwg_err(&["check", m]);
    assert!(err.contains("is a manifest, not a plugin"), "{err}");
    assert!(err.contains(&format!("`rwg run {m}`")), "{err}");
    assert!(!err.contains("ELF"), "{err}");
}
