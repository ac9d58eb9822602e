//! What the Gymnasium bridge takes on trust from an env, end to end with the
//! real `rwg` binary: `terminated`/`truncated` must be booleans, discrete
//! observations must lie in their spaces, a reward must be one number, an
//! env must keep its spaces (fresh instances and after reset included);
//! exceptions that are not `Exception`s, writes to fd 1 from C, a closed
//! stdin, numpy's small dtypes and observations at the size limit; a worker
//! that exits leaving a helper holding its pipes is reported as an exit at
//! once, a stopped one as stopped, a make that hangs in one worker by the
//! start-up timeout; the interpreter must be Python 3, not Python 2 or a
//! shell.
//!
//! Needs `RWG_TEST_PYTHON` (see `cli_gym_bridge_faults.rs`); the test envs
//! are `tests/python/rwg_trust_envs`.

mod common;
mod gym_bridge_common;
use common::*;
use gym_bridge_common::*;
use std::path::Path;
use std::time::{Duration, Instant};

/// A study of `env` (a `rwg_trust_envs` id) with `kwargs`: 0HL, 64
/// networks x 2 episodes.
fn manifest(dir: &Path, name: &str, env: &str, kwargs: &str) -> String {
    write(
        dir,
        name,
        &format!(
            "samples = 64\nepisodes = 2\n[[architectures]]\nname = \"0HL\"\nhidden = []\n\
             [[envs]]\nid = \"gymnasium:rwg_trust_envs:{env}\"\nkwargs = {{ {kwargs} }}\n"
        ),
    )
}

/// The reset seed of network `n`'s episode 0 for `env`.
fn seed_of(env: &str, n: u64) -> u64 {
    rwg_core::sampler::reset_seed(0, &format!("rwg_trust_envs:{env}"), n, 0)
}

/// `rwg run` of `m` into `dir/out`: (success, stderr).
fn run(py: &str, m: &str, dir: &Path, out: &str) -> (bool, String) {
    let o = rwg_cmd(
        py,
        &[
            "run",
            m,
            "--out",
            dir.join(out).to_str().unwrap(),
            "--threads",
            "2",
            "--no-report",
        ],
    )
    .output()
    .unwrap();
    (
        o.status.success(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

/// Fails unless `err` holds every one of `says`.
fn says(what: &str, err: &str, says: &[&str]) {
    for s in says {
        assert!(err.contains(s), "{what}: no {s:?} in:\n{err}");
    }
    assert!(!err.contains("internal error"), "{what}: {err}");
}

/// A flag that is not a boolean (the string "False" is true to Python, None
/// false) fails its episode, naming the flag, its type and value; as does
/// one of the checks when a worker starts.
#[test]
fn terminated_and_truncated_must_be_booleans() {
    let Some(py) = python() else { return };
    let dir = temp_dir("gym-trust-flags");
    let seed = seed_of("Trust-v0", 40);
    for (mode, flag, value) in [
        ("term_str", "terminated", "'False' (type str)"),
        ("trunc_str", "truncated", "'False' (type str)"),
        ("term_none", "terminated", "None (type NoneType)"),
    ] {
        let kwargs = format!("mode = \"{mode}\", at_seed = \"{seed}\"");
        let m = manifest(&dir, &format!("{mode}.toml"), "Trust-v0", &kwargs);
        let (ok, err) = run(&py, &m, &dir, mode);
        assert!(!ok, "{mode}: the run succeeded");
        says(
            mode,
            &err,
            &[
                "rwg_trust_envs:Trust-v0: sample 40, episode 0, step 1: ",
                &format!("step() returned {flag} = {value}"),
                "must be booleans (Python bool or numpy.bool_)",
            ],
        );
    }
    // in every episode: the worker's checks refuse it before the run
    let m = manifest(&dir, "int.toml", "Trust-v0", "mode = \"term_int\"");
    let (ok, err) = run(&py, &m, &dir, "int");
    assert!(!ok && !dir.join("int").join("stats.csv").exists());
    says("term_int", &err, &["terminated = 0 (type int)", "booleans"]);
    let _ = std::fs::remove_dir_all(&dir);
}

/// A Discrete observation outside its space (-1 would be the last state's
/// one-hot, 4 an IndexError inside Gymnasium's flatten) is refused where it
/// enters, naming the observation and the space, also inside a Dict.
#[test]
fn discrete_observations_must_lie_in_their_spaces() {
    let Some(py) = python() else { return };
    let dir = temp_dir("gym-trust-discrete");
    for (name, kwargs, want) in [
        (
            "neg",
            "value = -1, at_step = 2",
            "an observation -1 outside its space Discrete(4) (whole numbers 0 to 3)",
        ),
        (
            "over",
            "value = 4, at_step = 2",
            "an observation 4 outside its space Discrete(4)",
        ),
        (
            "nested",
            "value = 4, at_step = 0, nested = true",
            "an observation 4 at ['cell'] outside its space Discrete(4)",
        ),
    ] {
        let m = manifest(&dir, &format!("{name}.toml"), "Disc-v0", kwargs);
        let (ok, err) = run(&py, &m, &dir, name);
        assert!(!ok, "{name}: the run succeeded");
        says(name, &err, &[want]);
        assert!(!err.contains("IndexError"), "{name}: {err}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// A reward of two values is named as such, with what was returned.
#[test]
fn a_reward_must_be_one_number() {
    let Some(py) = python() else { return };
    let dir = temp_dir("gym-trust-reward");
    let seed = seed_of("Trust-v0", 40);
    let kwargs = format!("mode = \"reward_pair\", at_seed = \"{seed}\", at_step = 2");
    let m = manifest(&dir, "m.toml", "Trust-v0", &kwargs);
    let (ok, err) = run(&py, &m, &dir, "run");
    assert!(!ok);
    says(
        "reward_pair",
        &err,
        &[
            "sample 40, episode 0, step 2: ",
            "a reward of 2 values (a value of type ndarray, shape (2,): array([1., 2.]))",
            "a reward must be one number",
        ],
    );
    assert!(!err.contains("imaginary"), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// An env made afresh for every episode (its episodes depend on the
/// instance's history) whose later instances have other spaces, and an
/// instance that replaces its observation space in reset, are refused.
#[test]
fn an_env_must_keep_its_spaces() {
    let Some(py) = python() else { return };
    let dir = temp_dir("gym-trust-spaces");
    let m = manifest(&dir, "fresh.toml", "Fresh-v0", "after = 40");
    let (ok, err) = run(&py, &m, &dir, "fresh");
    assert!(!ok, "fresh: the run succeeded");
    says(
        "fresh",
        &err,
        &[
            "the fresh instance rwg made for this episode (gym.make) has observation space \
             Box(-5.0, 5.0, (4,), float64)",
            "where the env started with Box(-5.0, 5.0, (3,), float64)",
        ],
    );
    let seed = seed_of("Trust-v0", 40);
    let kwargs = format!("mode = \"space_change\", at_seed = \"{seed}\", at_step = 0");
    let m = manifest(&dir, "reset.toml", "Trust-v0", &kwargs);
    let (ok, err) = run(&py, &m, &dir, "reset");
    assert!(!ok, "reset: the run succeeded");
    says(
        "reset",
        &err,
        &[
            "sample 40, episode 0, step 0: ",
            &format!("the instance after reset(seed={seed}) has observation space"),
            "an env must not change them",
        ],
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// Probes: what an env may do (accepted, same bytes for 1 and 2 threads)
/// and what it must not (refused, naming it).
#[test]
fn what_envs_may_and_may_not_do() {
    let Some(py) = python() else { return };
    let dir = temp_dir("gym-trust-probes");
    let seed = seed_of("Trust-v0", 40);
    // accepted
    for (mode, extra) in [
        ("obs_f16", ""),
        ("obs_i8", ""),
        ("obs_bool", ""),
        ("cwrite", ""),
        ("close_stdin", ", at_step = 0"),
        ("big_obs", ", dim = 4096"),
        ("scalar_obs", ""),
        ("obs_tuple", ""),
        ("flood", ""),
    ] {
        let kwargs = format!("mode = \"{mode}\"{extra}");
        let m = manifest(&dir, &format!("{mode}.toml"), "Trust-v0", &kwargs);
        let (ok, err) = run(&py, &m, &dir, mode);
        assert!(ok, "{mode}: {err}");
        let scores = dir
            .join(mode)
            .join("cells/gymnasium=rwg_trust_envs=Trust-v0__0HL__nobias/scores.csv");
        assert_eq!(
            std::fs::read_to_string(&scores).unwrap().lines().count(),
            1 + 64 * 2,
            "{mode}"
        );
    }
    // refused
    for (mode, extra, want) in [
        (
            "reset3",
            ", at_step = 0",
            "returned a tuple of 3 values; reset() must return (observation, info)",
        ),
        (
            "sysexit",
            "",
            "step raised SystemExit: 5 (not an Exception: SystemExit derives from \
             BaseException only",
        ),
        (
            "baseexc",
            "",
            "step raised Boom: not an Exception (not an Exception",
        ),
        ("kbint", "", "step raised KeyboardInterrupt"),
        (
            "big_obs",
            ", dim = 4097",
            "has 4097 values, more than the limit of 4096",
        ),
        (
            "obs_object",
            "",
            "an observation of dtype object (-0.39009746785925",
        ),
        (
            "close_raises",
            "",
            "close() raised RuntimeError: close() failed (rwg closes an instance after probing it)",
        ),
        ("info_none", "", "was not a dictionary"),
    ] {
        let kwargs = format!("mode = \"{mode}\", at_seed = \"{seed}\"{extra}");
        let m = manifest(&dir, &format!("{mode}-x.toml"), "Trust-v0", &kwargs);
        let (ok, err) = run(&py, &m, &dir, &format!("{mode}-x"));
        assert!(!ok, "{mode}: the run succeeded");
        says(mode, &err, &[want]);
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// A worker that forks a helper (which keeps the worker's pipes open) and
/// exits is reported as an exit at once, not after the step timeout as a
/// hang; the helper goes with it.
#[test]
fn a_worker_that_exits_is_reported_at_once_though_a_helper_holds_its_pipes() {
    let Some(py) = python() else { return };
    let dir = temp_dir("gym-trust-fork-exit");
    let seed = seed_of("Trust-v0", 40);
    let kwargs = format!("mode = \"fork_exit\", at_seed = \"{seed}\", at_step = 2");
    let m = manifest(&dir, "m.toml", "Trust-v0", &kwargs);
    let t0 = Instant::now();
    let out = rwg_cmd(&py, &["run", &m, "--out", dir.join("r").to_str().unwrap()])
        .env(rwg_gym::TIMEOUT_VAR, "120")
        .output()
        .unwrap();
    let err = run_err(out);
    assert!(
        t0.elapsed() < Duration::from_secs(60),
        "took {:?}: {err}",
        t0.elapsed()
    );
    says(
        "fork_exit",
        &err,
        &[
            "sample 40, episode 0, step 2: ",
            "the Python worker exited with status 4",
        ],
    );
    assert!(!err.contains("did not answer"), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// The interpreter must be Python 3: a shell named by mistake runs none of
/// the worker's text and says so, Python 2 is named; a shell script that
/// runs Python is fine.
#[test]
fn the_interpreter_must_be_python_3() {
    let Some(py) = python() else { return };
    let dir = temp_dir("gym-trust-interpreter");
    let m = manifest(&dir, "m.toml", "Trust-v0", "");
    let wrapper = write(&dir, "py.sh", &format!("#!/bin/sh\nexec {py} \"$@\"\n"));
    std::fs::set_permissions(
        &wrapper,
        std::os::unix::fs::PermissionsExt::from_mode(0o755),
    )
    .unwrap();
    let (ok, err) = run(&wrapper, &m, &dir, "wrapper");
    assert!(ok, "a wrapper script: {err}");
    let (ok, err) = run("/bin/sh", &m, &dir, "sh");
    assert!(!ok);
    says(
        "sh",
        &err,
        &["exited with status 97", "is a shell, not Python 3"],
    );
    assert!(
        !err.contains("not found"),
        "the shell ran the worker: {err}"
    );
    // Python 2 where the machine has one (pyenv's, or on PATH)
    let py2 = [
        "/root/.pyenv/versions/2.7.18/bin/python2.7",
        "/usr/bin/python2",
    ]
    .into_iter()
    .find(|p| Path::new(p).exists());
    if let Some(py2) = py2 {
        let (ok, err) = run(py2, &m, &dir, "py2");
        assert!(!ok);
        says("python 2", &err, &["is Python 2.7", "needs Python 3"]);
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// A worker stopped from outside (SIGSTOP) is reported as stopped when
/// the timeout passes, not as an env that hangs.
#[test]
fn a_stopped_worker_is_named_as_stopped() {
    let Some(py) = python() else { return };
    let dir = temp_dir("gym-trust-stopped");
    let m = write(
        &dir,
        "m.toml",
        "samples = 20000\nepisodes = 2\n[[architectures]]\nname = \"0HL\"\nhidden = []\n\
         [[envs]]\nid = \"gymnasium:rwg_trust_envs:Trust-v0\"\n",
    );
    let child = rwg_cmd(&py, &["run", &m, "--out", dir.join("r").to_str().unwrap()])
        .args(["--threads", "1", "-q", "--no-report"])
        .env(rwg_gym::TIMEOUT_VAR, "3")
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let t0 = Instant::now();
    let worker = loop {
        assert!(t0.elapsed() < Duration::from_secs(60), "no worker");
        // the children of each of rwg's threads (a spawner thread forks them)
        let mut kids = String::new();
        for task in std::fs::read_dir(format!("/proc/{}/task", child.id())).unwrap() {
            let path = task.unwrap().path().join("children");
            kids.push_str(&std::fs::read_to_string(path).unwrap_or_default());
        }
        if let (Some(w), true) = (
            kids.split_whitespace().next(),
            t0.elapsed() > Duration::from_secs(2),
        ) {
            break w.to_string();
        }
        std::thread::sleep(Duration::from_millis(100));
    };
    assert!(std::process::Command::new("kill")
        .args(["-STOP", &worker])
        .status()
        .unwrap()
        .success());
    let out = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{err}");
    says(
        "stopped",
        &err,
        &[
            "the Python worker was stopped (by SIGSTOP or SIGTSTP",
            "within 3 s",
        ],
    );
    assert!(!err.contains("hangs"), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// An env whose make hangs in one worker process only (the second) is
/// named by the start-up timeout, whichever worker it is.
#[test]
fn a_make_that_hangs_in_one_worker_only_is_named() {
    let Some(py) = python() else { return };
    let dir = temp_dir("gym-trust-slow-make");
    let marker = dir.join("first");
    let kwargs = format!(
        "mode = \"slow_make\", marker = {:?}",
        marker.to_str().unwrap()
    );
    let m = manifest(&dir, "m.toml", "Trust-v0", &kwargs);
    let t0 = Instant::now();
    let out = rwg_cmd(&py, &["run", &m, "--out", dir.join("r").to_str().unwrap()])
        .args(["--threads", "2", "--no-report"])
        .env(rwg_gym::START_TIMEOUT_VAR, "4")
        .output()
        .unwrap();
    let err = run_err(out);
    says(
        "slow_make",
        &err,
        &["did not start within 4 s", "RWG_GYM_START_TIMEOUT"],
    );
    assert!(t0.elapsed() < Duration::from_secs(60), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}
