//! Worker processes as one family, end to end with the real `rwg` binary:
//! every Gymnasium worker of an env hashes strings alike and reports the
//! spaces of the first; a cell's spaces are recorded when it starts, so a
//! resume or merge under other spaces is refused; start-up honours the
//! timeouts and names the right knob; and the workers (Gymnasium's and
//! isolated plugins') die with rwg on SIGTERM, SIGINT, SIGHUP and SIGKILL.
//!
//! Needs `RWG_TEST_PYTHON` (see `cli_gym_bridge_faults.rs`) for the
//! Gymnasium cases; the test envs are `tests/python/rwg_family_envs`.

mod common;
mod gym_bridge_common;
use common::*;
use gym_bridge_common::*;
use std::path::Path;
use std::time::{Duration, Instant};

/// A study of `env` (a `rwg_family_envs` id) with `kwargs`, 0HL, `samples`
/// networks x 2 episodes.
fn manifest(env: &str, kwargs: &str, samples: u32) -> String {
    format!(
        "samples = {samples}\nepisodes = 2\n[[architectures]]\nname = \"0HL\"\nhidden = []\n\
         [[envs]]\nid = \"gymnasium:rwg_family_envs:{env}\"\nkwargs = {{ {kwargs} }}\n"
    )
}

fn cell_dir(run: &Path, env: &str) -> std::path::PathBuf {
    run.join(format!(
        "cells/gymnasium=rwg_family_envs={env}__0HL__nobias"
    ))
}

/// An env whose reset uses Python's `hash(str)`: the same bytes for 1 and 2
/// threads and for a second run (each worker process would otherwise draw
/// its own hash seed), and the seed rwg fixed is in the cell's record.
#[test]
fn string_hashes_do_not_change_results_between_workers_or_runs() {
    let Some(py) = python() else { return };
    let dir = temp_dir("gym-family-hash");
    let m = write(&dir, "m.toml", &manifest("HashReset-v0", "", 96));
    let mut scores = vec![];
    for (name, threads) in [("t1", "1"), ("t2", "2"), ("t2-again", "2")] {
        let run = dir.join(name);
        run_ok(
            &py,
            &[
                "run",
                &m,
                "--out",
                run.to_str().unwrap(),
                "--threads",
                threads,
                "--no-report",
            ],
        );
        scores.push(read(cell_dir(&run, "HashReset-v0").join("scores.csv")));
    }
    assert!(scores[0] == scores[1], "1 vs 2 threads differ");
    assert!(scores[1] == scores[2], "two runs differ");
    let record = String::from_utf8(read(
        cell_dir(&dir.join("t1"), "HashReset-v0").join("env.json"),
    ))
    .unwrap();
    assert!(record.contains("\"python_hash_seed\": \"0\""), "{record}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// Workers of one env that report other spaces than the first worker are
/// refused, naming the difference, before their blocks count.
#[test]
fn workers_with_other_spaces_than_the_first_are_refused() {
    let Some(py) = python() else { return };
    let dir = temp_dir("gym-family-split");
    for (what, says) in [
        ("bounds", "action space"),
        ("obs", "observation space"),
        ("discrete", "action space: Discrete(2)"),
    ] {
        let marker = dir.join(format!("{what}.first"));
        let kwargs = format!("marker = {:?}, what = \"{what}\"", marker.to_str().unwrap());
        let m = write(
            &dir,
            &format!("{what}.toml"),
            &manifest("Split-v0", &kwargs, 192),
        );
        let run = dir.join(what);
        let out = rwg_cmd(
            &py,
            &["run", &m, "--out", run.to_str().unwrap(), "--threads", "2"],
        )
        .output()
        .unwrap();
        let err = run_err(out);
        assert!(err.contains("another worker process"), "{what}: {err}");
        assert!(err.contains(says), "{what}: {err}");
        assert!(!run.join("stats.csv").exists(), "{what}: the run finished");
    }
    // the time limit, read when the env's module registers it
    let marker = dir.join("limit.first");
    let m = write(&dir, "limit.toml", &manifest("SplitLimit-v0", "", 192));
    let run = dir.join("limit");
    let out = rwg_cmd(
        &py,
        &["run", &m, "--out", run.to_str().unwrap(), "--threads", "2"],
    )
    .env("RWG_TEST_SPLIT_MARKER", &marker)
    .output()
    .unwrap();
    let err = run_err(out);
    assert!(err.contains("time limit: 60 steps"), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// A reset that depends on the process (its id; Python's string hashes
/// when the user asks for random ones) is found when a second worker starts:
/// its checked reset differs from the first worker's.
#[test]
fn a_reset_that_depends_on_the_process_is_refused() {
    let Some(py) = python() else { return };
    let dir = temp_dir("gym-family-pid");
    for (env, hash_seed) in [("PidReset-v0", None), ("HashReset-v0", Some("random"))] {
        let m = write(&dir, "m.toml", &manifest(env, "", 192));
        let mut cmd = rwg_cmd(
            &py,
            &[
                "run",
                &m,
                "--out",
                dir.join(env).to_str().unwrap(),
                "--threads",
                "2",
            ],
        );
        if let Some(v) = hash_seed {
            cmd.env("PYTHONHASHSEED", v);
        }
        let err = run_err(cmd.output().unwrap());
        assert!(err.contains("another worker process"), "{env}: {err}");
        assert!(
            err.contains("reset(seed=20200509) observes"),
            "{env}: {err}"
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// Instances of one worker whose spaces differ are refused when it starts.
#[test]
fn instances_of_other_spaces_in_one_worker_are_refused() {
    let Some(py) = python() else { return };
    let dir = temp_dir("gym-family-mixed");
    let m = write(&dir, "m.toml", &manifest("Mixed-v0", "", 32));
    let run = dir.join("r");
    let err = run_err(
        rwg_cmd(&py, &["run", &m, "--out", run.to_str().unwrap()])
            .output()
            .unwrap(),
    );
    assert!(err.contains("m.toml:7:6"), "{err}");
    assert!(
        err.contains("gym.make gave instances of other spaces"),
        "{err}"
    );
    assert!(
        err.contains("Box(-100.0, 100.0, (1,), float64) (instance 1)"),
        "{err}"
    );
    assert!(!run.join("cells").exists(), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// The reset seed of network `n`, episode 0, of `Knob-v0`.
fn knob_seed(n: u64) -> u64 {
    rwg_core::sampler::reset_seed(0, "rwg_family_envs:Knob-v0", n, 0)
}

/// A resume or a merge under other spaces than the cell started with is
/// refused, naming the difference; under the same spaces it goes on.
#[test]
fn a_resume_or_merge_under_other_spaces_is_refused() {
    let Some(py) = python() else { return };
    let dir = temp_dir("gym-family-knob");
    let kwargs = format!("fail_seed = \"{}\"", knob_seed(40));
    let m = write(&dir, "m.toml", &manifest("Knob-v0", &kwargs, 64));
    let run = dir.join("run");
    let go = |knob: &str, args: &[&str]| {
        rwg_cmd(&py, args)
            .env("RWG_TEST_KNOB", knob)
            .output()
            .unwrap()
    };
    let args = ["run", &m, "--out", run.to_str().unwrap(), "--no-report"];
    // knob a: fails in block 1, block 0 committed
    let err = run_err(go("a", &args));
    assert!(err.contains("deliberate failure of Knob-v0"), "{err}");
    let cell = cell_dir(&run, "Knob-v0");
    assert!(cell.join("blocks/b0000000.csv").exists(), "{err}");
    // knob b: other action bounds
    let err = run_err(go("b", &args));
    for s in [
        "env.json",
        "action space",
        "Box(-1.0, 1.0, (1,), float64)",
        "Box(-100.0, 100.0, (1,), float64)",
    ] {
        assert!(err.contains(s), "{s:?} missing: {err}");
    }
    assert!(!cell.join("scores.csv").exists(), "{err}");
    // knob c: the spaces the cell started with
    let out = go("c", &args);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(cell.join("scores.csv").exists());

    // shards computed under other spaces do not merge
    let mut shards = vec![];
    for (k, knob) in [(0, "c"), (1, "b")] {
        let d = dir.join(format!("s{k}"));
        let shard = format!("{k}/2");
        let out = go(
            knob,
            &["run", &m, "--shard", &shard, "--out", d.to_str().unwrap()],
        );
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        shards.push(d.to_str().unwrap().to_string());
    }
    let merged = dir.join("merged");
    let margs = [
        "merge",
        &shards[0],
        &shards[1],
        "--out",
        merged.to_str().unwrap(),
    ];
    let err = run_err(go("c", &margs));
    assert!(err.contains("action space"), "{err}");
    assert!(err.contains("Box(-100.0, 100.0, (1,), float64)"), "{err}");
    assert!(!cell_dir(&merged, "Knob-v0").join("scores.csv").exists());
    let _ = std::fs::remove_dir_all(&dir);
}

/// A worker that hangs in the steps rwg takes when it starts is killed
/// after RWG_GYM_TIMEOUT, and one that hangs before it is ready after
/// RWG_GYM_START_TIMEOUT; each message names its own variable.
#[test]
fn start_up_honours_the_timeouts_and_names_the_right_variable() {
    let Some(py) = python() else { return };
    let dir = temp_dir("gym-family-start");
    for (where_, var, says) in [
        ("probe", "RWG_GYM_TIMEOUT", "in a reset or step"),
        ("make", "RWG_GYM_START_TIMEOUT", "did not start within 3 s"),
    ] {
        let marker = dir.join(where_);
        std::fs::create_dir_all(&marker).unwrap();
        let kwargs = format!(
            "marker = {:?}, where = \"{where_}\"",
            marker.to_str().unwrap()
        );
        let m = write(&dir, "m.toml", &manifest("Stall-v0", &kwargs, 32));
        let t0 = Instant::now();
        let out = rwg_cmd(&py, &["run", &m, "--out", dir.join("r").to_str().unwrap()])
            .env(var, "3")
            .output()
            .unwrap();
        let err = run_err(out);
        assert!(t0.elapsed() < Duration::from_secs(60), "{where_}: {err}");
        assert!(err.contains(says), "{where_}: {err}");
        assert!(err.contains(&format!("set {var}")), "{where_}: {err}");
        // faulthandler's traceback names where it hung (in the file the
        // one error line names)
        assert!(
            with_details(&err).contains("rwg_family_envs/__init__.py"),
            "{where_}: {err}"
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// An isolated plugin whose create hangs in its worker: the create call
/// gets --step-timeout, as in-process, and the message says so. Before,
/// the whole start-up had max(--step-timeout, 60 s) and spoke of a reset
/// or step.
#[test]
fn an_isolated_create_that_hangs_gets_the_step_timeout() {
    let dir = temp_dir("isolate-create-hang");
    // the first create (the one rwg makes when it plans the cells) returns
    let lib = compile_c(
        "isolate-create-hang",
        "plugins/testing/c/handshake.c",
        "hangs",
        &["HANG_IN_CREATE_AFTER=1"],
    );
    let m = write(
        &dir,
        "m.toml",
        &format!(
            "samples = 40\nepisodes = 1\n[[architectures]]\nname = \"0HL\"\nhidden = []\n\
             [[envs]]\nid = \"handshake/Ok-v0\"\nplugin = {:?}\nisolate = true\n",
            lib.to_str().unwrap()
        ),
    );
    let t0 = Instant::now();
    let out = std::process::Command::new(rwg_bin())
        .args(["run", &m, "--out", dir.join("r").to_str().unwrap()])
        .args(["--step-timeout", "2"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{err}");
    assert!(t0.elapsed() < Duration::from_secs(30), "{err}");
    assert!(
        err.contains("creating an instance (the plugin's create) did not return within 2 s"),
        "{err}"
    );
    assert!(err.contains("raise --step-timeout"), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// Starts `cmd` (an `rwg run` whose env hangs), waits until `ready` says
/// the workers run, sends `signal` to rwg alone, and checks that rwg and
/// every worker it started end. Returns rwg's exit code and stderr.
#[cfg(target_os = "linux")]
fn signal_rwg(
    mut cmd: std::process::Command,
    signal: &str,
    ready: impl Fn() -> bool,
) -> (Option<i32>, String) {
    use std::process::Stdio;
    let mut child = with_default_signals(&mut cmd)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let t0 = Instant::now();
    while !ready() {
        assert!(
            t0.elapsed() < Duration::from_secs(60),
            "{signal}: never ready"
        );
        assert!(child.try_wait().unwrap().is_none(), "{signal}: rwg ended");
        std::thread::sleep(Duration::from_millis(100));
    }
    let workers = children(child.id());
    assert!(!workers.is_empty(), "{signal}: no worker processes");
    let kill = std::process::Command::new("kill")
        .args([&format!("-{signal}"), &child.id().to_string()])
        .status()
        .unwrap();
    assert!(kill.success());
    let t0 = Instant::now();
    while child.try_wait().unwrap().is_none() {
        if t0.elapsed() > Duration::from_secs(40) {
            let _ = child.kill();
            panic!("{signal}: rwg did not end");
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    let res = child.wait_with_output().unwrap();
    let t0 = Instant::now();
    while workers.iter().any(|&w| alive(w)) && t0.elapsed() < Duration::from_secs(10) {
        std::thread::sleep(Duration::from_millis(50));
    }
    let left: Vec<u32> = workers.iter().copied().filter(|&w| alive(w)).collect();
    for &w in &left {
        let _ = std::process::Command::new("kill")
            .args(["-KILL", &w.to_string()])
            .status();
    }
    assert!(left.is_empty(), "{signal}: workers {left:?} outlived rwg");
    (
        res.status.code(),
        String::from_utf8_lossy(&res.stderr).into_owned(),
    )
}

/// Processes a Gymnasium env starts (a simulator, a server) end with its
/// worker: when the run ends, and when the worker dies (whose report must
/// not wait for them: they hold its stderr open).
#[cfg(target_os = "linux")]
#[test]
fn processes_an_env_starts_end_with_its_worker() {
    let Some(py) = python() else { return };
    let dir = temp_dir("gym-family-orphans");
    let seed = rwg_core::sampler::reset_seed(0, "rwg_family_envs:Orphans-v0", 40, 0);
    for (name, exit_seed) in [("ends", "0".to_string()), ("dies", seed.to_string())] {
        let marker = dir.join(name);
        std::fs::create_dir_all(&marker).unwrap();
        let kwargs = format!(
            "marker = {:?}, exit_seed = \"{exit_seed}\"",
            marker.to_str().unwrap()
        );
        let m = write(&dir, "m.toml", &manifest("Orphans-v0", &kwargs, 96));
        let mut child = rwg_cmd(
            &py,
            &[
                "run",
                &m,
                "--out",
                dir.join(format!("r{name}")).to_str().unwrap(),
            ],
        )
        .args(["--threads", "2", "--no-report"])
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
        let t0 = Instant::now();
        let status = loop {
            if let Some(s) = child.try_wait().unwrap() {
                break s;
            }
            if t0.elapsed() > Duration::from_secs(90) {
                let _ = child.kill();
                panic!("{name}: rwg did not end (waiting for the env's processes?)");
            }
            std::thread::sleep(Duration::from_millis(50));
        };
        assert_eq!(status.success(), name == "ends", "{name}: {status:?}");
        let started = started_in(&marker);
        assert!(!started.is_empty(), "{name}: the env started nothing");
        all_end(name, &started);
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// SIGTERM, SIGINT, SIGHUP or SIGKILL to rwg alone while a Gymnasium env
/// hangs in a step: rwg ends and so do its Python workers (not left
/// running, re-parented to PID 1); SIGINT waits for the blocks in flight,
/// then quits with a message that speaks of the env, not of a plugin.
#[cfg(target_os = "linux")]
#[test]
fn gymnasium_workers_die_with_rwg_on_any_signal() {
    let Some(py) = python() else { return };
    let dir = temp_dir("gym-family-signals");
    for signal in ["TERM", "INT", "HUP", "KILL"] {
        let marker = dir.join(signal);
        std::fs::create_dir_all(&marker).unwrap();
        let kwargs = format!(
            "marker = {:?}, where = \"step\", at_seed = \"{}\"",
            marker.to_str().unwrap(),
            rwg_core::sampler::reset_seed(0, "rwg_family_envs:Stall-v0", 40, 0)
        );
        let m = write(&dir, "m.toml", &manifest("Stall-v0", &kwargs, 96));
        let mut cmd = rwg_cmd(
            &py,
            &[
                "run",
                &m,
                "--out",
                dir.join(format!("r{signal}")).to_str().unwrap(),
            ],
        );
        cmd.args(["--threads", "2", "-q"]);
        let stalled = || std::fs::read_dir(&marker).unwrap().count() > 0;
        let (code, err) = signal_rwg(cmd, signal, stalled);
        if signal == "INT" {
            assert_eq!(code, Some(130), "{err}");
            assert!(err.contains("did not finish within"), "{err}");
            assert!(!err.contains("plugin"), "{err}");
            // the resume command sets the PYTHONPATH the env's module was
            // found through, as the run had it
            let pp = python_dir();
            let resume = format!("resume with: PYTHONPATH={} rwg run ", pp.display());
            assert!(err.contains(&resume), "{err}");
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// A Python started through a wrapper that runs it as a child instead of
/// exec-ing it (a cluster's module-loading shell script): rwg's death
/// signal kills the wrapper, and the worker, stuck in a step, ends with it
/// when rwg is SIGKILLed, instead of running on under init.
#[cfg(target_os = "linux")]
#[test]
fn a_worker_behind_a_wrapper_ends_with_rwg() {
    use std::os::unix::fs::PermissionsExt;
    let Some(py) = python() else { return };
    let dir = temp_dir("gym-family-wrapper");
    let wrapper = dir.join("python-wrapper.sh");
    std::fs::write(&wrapper, format!("#!/bin/sh\n{py:?} \"$@\"\n")).unwrap();
    std::fs::set_permissions(&wrapper, std::fs::Permissions::from_mode(0o755)).unwrap();
    let marker = dir.join("stalled");
    std::fs::create_dir_all(&marker).unwrap();
    let kwargs = format!(
        "marker = {:?}, where = \"step\", at_seed = \"{}\"",
        marker.to_str().unwrap(),
        rwg_core::sampler::reset_seed(0, "rwg_family_envs:Stall-v0", 40, 0)
    );
    let m = write(&dir, "m.toml", &manifest("Stall-v0", &kwargs, 96));
    let out = dir.join("run");
    let mut cmd = rwg_cmd(
        wrapper.to_str().unwrap(),
        &["run", &m, "--out", path_str(&out)],
    );
    cmd.args(["--threads", "1", "-q"]);
    let stalled = || std::fs::read_dir(&marker).unwrap().count() > 0;
    signal_rwg(cmd, "KILL", stalled);
    all_end("behind a wrapper", &started_in(&marker));
    let _ = std::fs::remove_dir_all(&dir);
}

/// The same for an isolated plugin's `rwg __plugin-worker` processes.
#[cfg(target_os = "linux")]
#[test]
fn isolated_plugin_workers_die_with_rwg_on_any_signal() {
    let dir = temp_dir("isolate-signals");
    let m = write(
        &dir,
        "m.toml",
        &format!(
            "samples = 40\nepisodes = 3\n[[architectures]]\nname = \"0HL\"\nhidden = []\n\
             [[envs]]\nid = \"broken/HangInStep-v0\"\nplugin = {:?}\n",
            broken_plugin().to_str().unwrap()
        ),
    );
    for signal in ["TERM", "INT", "HUP", "KILL"] {
        let mut cmd = std::process::Command::new(rwg_bin());
        let out = dir.join(format!("r{signal}"));
        cmd.args(["run", &m, "--out", out.to_str().unwrap(), "--isolate", "-q"]);
        cmd.args(["--step-timeout", "0", "--threads", "2"]);
        // the first step hangs: once the workers have had a moment to reach it
        let since = std::cell::Cell::new(None::<Instant>);
        let (code, err) = signal_rwg(cmd, signal, || {
            let t = since.get().unwrap_or_else(Instant::now);
            since.set(Some(t));
            t.elapsed() > Duration::from_secs(3)
        });
        if signal == "INT" {
            assert_eq!(code, Some(130), "{err}");
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// The process ids an env wrote into the folder `marker`.
#[cfg(target_os = "linux")]
fn started_in(marker: &Path) -> Vec<u32> {
    std::fs::read_dir(marker)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().parse().unwrap())
        .collect()
}

/// Fails (after killing them) if any of `pids` still runs 10 s on.
#[cfg(target_os = "linux")]
fn all_end(what: &str, pids: &[u32]) {
    let t0 = Instant::now();
    while pids.iter().any(|&p| alive(p)) && t0.elapsed() < Duration::from_secs(10) {
        std::thread::sleep(Duration::from_millis(50));
    }
    let left: Vec<u32> = pids.iter().copied().filter(|&p| alive(p)).collect();
    for &p in &left {
        let _ = std::process::Command::new("kill")
            .args(["-KILL", &p.to_string()])
            .status();
    }
    assert!(
        left.is_empty(),
        "{what}: the env's processes {left:?} outlived rwg"
    );
}

/// The processes a Gymnasium env starts — in the worker's process group, in
/// a session of their own (setsid), and a double-forked daemon — end with
/// rwg on every catchable signal that ends it (not only SIGINT), and when
/// the run ends.
#[cfg(target_os = "linux")]
#[test]
fn processes_an_env_starts_end_with_rwg_on_any_catchable_signal() {
    let Some(py) = python() else { return };
    let dir = temp_dir("gym-family-helpers");
    let hang = rwg_core::sampler::reset_seed(0, "rwg_trust_envs:Helpers-v0", 40, 0);
    for signal in ["TERM", "HUP", "QUIT", "USR2", "INT", "ends"] {
        let marker = dir.join(signal);
        std::fs::create_dir_all(&marker).unwrap();
        let at = if signal == "ends" { 0 } else { hang };
        let m = write(
            &dir,
            &format!("{signal}.toml"),
            &format!(
                "samples = 96\nepisodes = 2\n[[architectures]]\nname = \"0HL\"\nhidden = []\n\
                 [[envs]]\nid = \"gymnasium:rwg_trust_envs:Helpers-v0\"\n\
                 kwargs = {{ marker = {:?}, at_seed = \"{at}\" }}\n",
                marker.to_str().unwrap()
            ),
        );
        let mut cmd = rwg_cmd(
            &py,
            &[
                "run",
                &m,
                "--out",
                dir.join(format!("r{signal}")).to_str().unwrap(),
            ],
        );
        cmd.args(["--threads", "2", "-q", "--no-report"]);
        if signal == "ends" {
            let out = cmd.output().unwrap();
            assert!(
                out.status.success(),
                "{}",
                String::from_utf8_lossy(&out.stderr)
            );
        } else {
            // both workers' helpers started, and a moment for the hang
            let since = std::cell::Cell::new(None::<Instant>);
            signal_rwg(cmd, signal, || {
                if started_in(&marker).len() < 6 {
                    return false;
                }
                let t = since.get().unwrap_or_else(Instant::now);
                since.set(Some(t));
                t.elapsed() > Duration::from_secs(1)
            });
        }
        let started = started_in(&marker);
        assert!(started.len() >= 3, "{signal}: the env started {started:?}");
        all_end(signal, &started);
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// A worker killed from outside while it waits for rwg's next exchange (no
/// reset or step in flight) is reported as such, with the episodes in
/// progress, not blamed on one of them as if it had failed there; SIGKILL's
/// name says where to look for an out-of-memory kill.
#[cfg(target_os = "linux")]
#[test]
fn a_worker_killed_between_calls_is_not_blamed_on_an_episode() {
    let Some(py) = python() else { return };
    let dir = temp_dir("gym-family-between");
    // Long enough (about a minute) that the kill below always lands mid-run.
    let m = write(
        &dir,
        "m.toml",
        "samples = 400000\nepisodes = 2\n[[architectures]]\nname = \"0HL\"\nhidden = []\n\
         [[envs]]\nid = \"gymnasium:rwg_trust_envs:Trust-v0\"\n",
    );
    let kill = |sig: &str, pid: u32| {
        let st = std::process::Command::new("kill")
            .args([&format!("-{sig}"), &pid.to_string()])
            .status()
            .unwrap();
        assert!(st.success(), "kill -{sig} {pid}");
    };
    let mut child = rwg_cmd(&py, &["run", &m, "--out", dir.join("r").to_str().unwrap()])
        .args(["--threads", "1", "-q", "--no-report"])
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let t0 = Instant::now();
    let worker = loop {
        assert!(t0.elapsed() < Duration::from_secs(60), "no worker");
        assert!(child.try_wait().unwrap().is_none(), "rwg ended");
        if let (Some(&w), true) = (
            children(child.id()).first(),
            t0.elapsed() > Duration::from_secs(3),
        ) {
            break w;
        }
        std::thread::sleep(Duration::from_millis(100));
    };
    // rwg stopped: the worker answers what it was sent and then waits
    kill("STOP", child.id());
    std::thread::sleep(Duration::from_millis(500));
    kill("KILL", worker);
    std::thread::sleep(Duration::from_millis(200));
    kill("CONT", child.id());
    let out = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{err}");
    assert!(
        err.contains(
            "the Python worker was killed by signal 9 (SIGKILL: sent by another process, or by \
             the kernel when memory ran out: `dmesg` or `journalctl -k` shows an \
             out-of-memory kill); no reset or step was in flight"
        ),
        "{err}"
    );
    assert!(
        err.contains("the episodes in progress were: sample "),
        "{err}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}
