//! Worker processes as one family, end to end with the real `rwg` binary:
//! the workers (Gymnasium's and isolated plugins') die with rwg on SIGTERM,
//! SIGINT, SIGHUP and SIGKILL.
//!
//! Needs `RWG_TEST_PYTHON` (see `cli_gym_bridge_faults.rs`) for the
//! Gymnasium cases; the test envs are `tests/python/rwg_family_envs`.

mod common;
mod gym_bridge_common;
use common::*;
use gym_bridge_common::*;
use std::time::{Duration, Instant};

/// A study of `env` (a `rwg_family_envs` id) with `kwargs`, 0HL, `samples`
/// networks x 2 episodes.
fn manifest(env: &str, kwargs: &str, samples: u32) -> String {
    format!(
        "samples = {samples}\nepisodes = 2\n[[architectures]]\nname = \"0HL\"\nhidden = []\n\
         [[envs]]\nid = \"gymnasium:rwg_family_envs:{env}\"\nkwargs = {{ {kwargs} }}\n"
    )
}

/// The process ids of `pid`'s children.
#[cfg(target_os = "linux")]
fn children(pid: u32) -> Vec<u32> {
    let mut out = vec![];
    for e in std::fs::read_dir("/proc").unwrap().flatten() {
        let Ok(child) = e.file_name().to_string_lossy().parse::<u32>() else {
            continue;
        };
        let Ok(stat) = std::fs::read_to_string(e.path().join("stat")) else {
            continue;
        };
        // pid (comm) state ppid ...
        let rest = &stat[stat.rfind(')').unwrap() + 2..];
        if rest.split_whitespace().nth(1) == Some(&pid.to_string()) {
            out.push(child);
        }
    }
    out
}

/// Whether process `pid` is running (not gone, not a zombie).
#[cfg(target_os = "linux")]
fn alive(pid: u32) -> bool {
    match std::fs::read_to_string(format!("/proc/{pid}/stat")) {
        Ok(stat) => !matches!(
            stat[stat.rfind(')').unwrap() + 2..].chars().next(),
            Some('Z' | 'X')
        ),
        Err(_) => false,
    }
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
    let mut child = cmd
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
            assert!(err.contains("resume with: rwg run"), "{err}");
        }
    }
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
