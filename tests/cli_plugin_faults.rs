//! Plugin faults during `rwg run`, in-process (issue 12): a plugin that
//! calls exit(), segfaults, aborts or hangs ends the run non-zero with a
//! message naming plugin, env, network, episode and step; committed blocks
//! are kept and a rerun resumes; the first Ctrl-C returns; a plugin's stdout
//! never reaches rwg's; failing determinism checks are warned about; an env
//! without a time limit is refused with what to set.

mod common;
use common::*;
use std::path::Path;
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

fn study(dir: &Path, name: &str, env: &str, config: &str, samples: u32) -> String {
    let body = format!(
        "samples = {samples}\nepisodes = 3\n[[architectures]]\nname = \"0HL\"\nhidden = []\n\
         [[envs]]\nid = \"{env}\"\nplugin = \"{}\"\nconfig = \"{config}\"\n",
        broken_plugin().display()
    );
    let p = dir.join(name);
    std::fs::write(&p, body).unwrap();
    p.to_str().unwrap().to_string()
}

fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

/// Runs `rwg run MANIFEST --out OUT` plus `extra`, on the plugin's single
/// calls (the default; `RWG_PLUGIN_BATCH=0` says so explicitly), whose fault
/// reports name the network, episode and step; `tests/cli_plugin_batch.rs`
/// checks the report of a fault in a batched call.
fn run(manifest: &str, out: &Path, extra: &[&str]) -> Output {
    let mut args = vec![
        "run",
        manifest,
        "--out",
        out.to_str().unwrap(),
        "--no-report",
    ];
    args.extend_from_slice(extra);
    rwg_env(&args, &[("RWG_PLUGIN_BATCH", "0".as_ref())])
}

fn assert_names_the_context(err: &str, env: &str) {
    for part in [
        "plugin 'broken' (",
        &format!("env '{env}'"),
        "cell broken+",
        "Every committed block is kept in ",
        "resume with: rwg run ",
    ] {
        assert!(err.contains(part), "{part:?} missing in:\n{err}");
    }
}

#[test]
fn exit_in_reset_is_a_failed_run_that_resumes_to_identical_results() {
    let dir = temp_dir("fault-exit");
    // Exits at the 250th reset: blocks 0 and 1 (2 x 32 networks x 3
    // episodes = 192 resets) are committed first with one thread.
    let faulty = study(&dir, "f.toml", "broken/ExitInReset-v0", "at_reset=250", 96);
    let out = dir.join("run");
    let res = run(&faulty, &out, &["--threads", "1"]);
    let err = text(&res.stderr);
    assert_eq!(res.status.code(), Some(1), "{err}");
    assert!(err.contains("error: exit() was called in reset: "), "{err}");
    // Reset 250 is the 58th of block 2 (networks 64..96): item 57 in
    // network-major order, network 64 + 57 / 3.
    assert!(
        err.contains("network 83, episode 0, at reset (step 0)"),
        "{err}"
    );
    assert_names_the_context(&err, "broken/ExitInReset-v0");
    // Never a run.json that says complete (it is written after each cell).
    if let Ok(meta) = std::fs::read_to_string(out.join("run.json")) {
        assert!(meta.contains("\"end_time\": null"), "{meta}");
    }
    let blocks = out.join("cells/broken+ExitInReset-v0__0HL__nobias/blocks");
    for b in ["b0000000.csv", "b0000001.csv"] {
        assert!(
            blocks.join(b).is_file(),
            "{b} was committed before the exit"
        );
    }

    // The rerun (a new process: 96 resets left) finishes the run ...
    let res = run(&faulty, &out, &["--threads", "1"]);
    assert!(res.status.success(), "{}", text(&res.stderr));
    // ... exactly as a run that never failed.
    let clean = study(
        &dir,
        "c.toml",
        "broken/ExitInReset-v0",
        "at_reset=100000",
        96,
    );
    let out2 = dir.join("clean");
    assert!(run(&clean, &out2, &["--threads", "2"]).status.success());
    for f in ["scores.csv", "samples.csv"] {
        let p = format!("cells/broken+ExitInReset-v0__0HL__nobias/{f}");
        assert_eq!(
            std::fs::read(out.join(&p)).unwrap(),
            std::fs::read(out2.join(&p)).unwrap(),
            "{f}"
        );
    }
}

#[cfg(unix)]
#[test]
fn segfault_and_abort_are_reported_with_the_step() {
    use std::os::unix::process::ExitStatusExt;
    let dir = temp_dir("fault-signals");
    let m = study(&dir, "s.toml", "broken/SegfaultInStep-v0", "", 40);
    // One thread: with two, either thread's first step may be the one reported.
    let res = run(&m, &dir.join("s"), &["--threads", "1"]);
    let err = text(&res.stderr);
    assert_eq!(res.status.signal(), Some(11), "{err}");
    assert!(
        err.contains("error: rwg was killed by SIGSEGV (invalid memory access) in step: "),
        "{err}"
    );
    assert!(err.contains("network 0, episode 0, step 1."), "{err}");
    assert_names_the_context(&err, "broken/SegfaultInStep-v0");

    let m = study(&dir, "a.toml", "broken/AbortInStep-v0", "", 40);
    let res = run(&m, &dir.join("a"), &["--threads", "1"]);
    let err = text(&res.stderr);
    assert_eq!(res.status.signal(), Some(6), "{err}");
    assert!(
        err.contains("error: rwg was killed by SIGABRT (abort) in step: "),
        "{err}"
    );
    // The 2nd episode an instance runs: with 16 lanes, item 16 of the block
    // (network 5, episode 1) goes to the first lane to finish.
    assert!(err.contains(", step 5."), "{err}");
    assert_names_the_context(&err, "broken/AbortInStep-v0");
}

#[test]
fn a_hung_step_times_out() {
    let dir = temp_dir("fault-hang");
    let m = study(&dir, "h.toml", "broken/HangInStep-v0", "", 40);
    let t0 = Instant::now();
    let res = run(
        &m,
        &dir.join("h"),
        &["--step-timeout", "2", "--threads", "1"],
    );
    let err = text(&res.stderr);
    assert_eq!(res.status.code(), Some(1), "{err}");
    assert!(t0.elapsed() < Duration::from_secs(30));
    assert!(
        err.contains(
            "error: a plugin call has not returned for 2 s (--step-timeout 2; raise it if the \
             env is just slow): in step: "
        ),
        "{err}"
    );
    assert!(err.contains("network 0, episode 0, step 1."), "{err}");
    assert_names_the_context(&err, "broken/HangInStep-v0");
}

#[cfg(unix)]
#[test]
fn the_first_ctrl_c_returns_from_a_hung_step() {
    let dir = temp_dir("fault-ctrlc");
    let m = study(&dir, "h.toml", "broken/HangInStep-v0", "", 40);
    let out = dir.join("h");
    let child = Command::new(rwg_bin())
        .args(["run", &m, "--out", out.to_str().unwrap()])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    std::thread::sleep(Duration::from_millis(1500));
    let t0 = Instant::now();
    let kill = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(kill.success());
    let res = child.wait_with_output().unwrap();
    let err = text(&res.stderr);
    assert!(t0.elapsed() < Duration::from_secs(10), "{err}");
    assert_eq!(res.status.code(), Some(130), "{err}");
    assert!(
        err.contains("error: interrupted while a plugin call has not returned for"),
        "{err}"
    );
    assert_names_the_context(&err, "broken/HangInStep-v0");
}

#[test]
fn plugin_stdout_never_reaches_rwg_stdout() {
    let lib = broken_plugin();
    let out = rwg(&[
        "rollout",
        "broken/PrintInReset-v0",
        "--plugin",
        lib.to_str().unwrap(),
        "--actions",
        "0,1",
        "--format",
        "csv",
    ]);
    assert!(out.status.success());
    assert_eq!(
        text(&out.stdout),
        "step,action,obs_0,reward,terminated,truncated\n0,,0.0,,,\n1,0,1.0,1.0,false,false\n\
         2,1,2.0,1.0,false,false\n"
    );
    assert!(text(&out.stderr).contains("broken/PrintInReset-v0 says hello on stdout"));

    // A C plugin's printf (buffered by libc, flushed at exit).
    let c = compile_c(
        "printf",
        "plugins/testing/c/handshake.c",
        "talks",
        &["PRINTF_IN_STEP"],
    );
    let out = rwg(&[
        "rollout",
        "handshake/Ok-v0",
        "--plugin",
        c.to_str().unwrap(),
        "--actions",
        "1,0",
        "--format",
        "csv",
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert!(
        !text(&out.stdout).contains("handshake plugin"),
        "{}",
        text(&out.stdout)
    );
    assert!(text(&out.stdout).starts_with("step,action,obs_0,"));
    assert!(text(&out.stderr).contains("handshake plugin: step with action 1"));

    // rwg run's summary too.
    let dir = temp_dir("fault-print");
    let m = study(&dir, "p.toml", "broken/PrintInReset-v0", "", 4);
    let res = run(&m, &dir.join("p"), &[]);
    assert!(res.status.success(), "{}", text(&res.stderr));
    assert!(!text(&res.stdout).contains("says hello"));
    assert!(text(&res.stdout).contains("broken+PrintInReset-v0__0HL__nobias"));
}

#[test]
fn run_warns_about_failing_determinism_checks() {
    let dir = temp_dir("fault-warn");
    let m = study(&dir, "g.toml", "broken/HiddenGlobalState-v0", "", 4);
    let res = run(&m, &dir.join("g"), &[]);
    let err = text(&res.stderr);
    assert!(res.status.success(), "{err}");
    assert!(
        err.contains("warning: broken/HiddenGlobalState-v0 (")
            && err.contains("fails rwg check's 'independent instances' check"),
        "{err}"
    );
    // A plugin env that passes them gets no warning.
    let m = study(&dir, "p.toml", "broken/PrintInReset-v0", "", 4);
    let res = run(&m, &dir.join("p"), &[]);
    assert!(
        !text(&res.stderr).contains("warning:"),
        "{}",
        text(&res.stderr)
    );
}

#[test]
fn an_env_without_a_time_limit_is_refused_saying_what_to_set() {
    let dir = temp_dir("fault-limit0");
    let lib = compile_c(
        "limit0",
        "plugins/testing/c/handshake.c",
        "nolimit",
        &["NO_TIME_LIMIT"],
    );
    let body = format!(
        "samples = 2\nepisodes = 1\n[[architectures]]\nname = \"0HL\"\nhidden = []\n\
         [[envs]]\nid = \"handshake/Ok-v0\"\nplugin = \"{}\"\n",
        lib.display()
    );
    let m = dir.join("m.toml");
    std::fs::write(&m, &body).unwrap();
    let out = dir.join("run");
    let err = rwg_err(&["run", m.to_str().unwrap(), "--out", out.to_str().unwrap()]);
    assert!(
        err.contains(
            "envs[0]: 'handshake/Ok-v0' has no time limit (its max_episode_steps is 0: none), \
             and rwg run needs one to bound every episode; set max_episode_steps in this \
             [[envs]] entry"
        ),
        "{err}"
    );
    assert!(!out.exists());
    std::fs::write(&m, format!("{body}max_episode_steps = 3\n")).unwrap();
    rwg_ok(&[
        "run",
        m.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--no-report",
    ]);
    let scores =
        std::fs::read_to_string(out.join("cells/handshake+Ok-v0__0HL__nobias/scores.csv")).unwrap();
    assert!(scores.ends_with("1,0,3.0,3\n"), "{scores}");
    // rwg check says the same.
    let res = rwg(&["check", lib.to_str().unwrap(), "--json"]);
    let results: Vec<serde_json::Value> = serde_json::from_slice(&res.stdout).unwrap();
    let t = results.iter().find(|r| r["name"] == "truncation").unwrap();
    assert_eq!(t["status"], "warned");
    assert!(t["message"]
        .as_str()
        .unwrap()
        .contains("`rwg run` needs max_episode_steps"));
}
