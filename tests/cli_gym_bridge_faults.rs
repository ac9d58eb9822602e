//! Gymnasium environments through the bridge when things go wrong, end to
//! end with the real `rwg` binary and real Gymnasium: envs that raise, return
//! NaN, exit or hang are named and committed blocks kept; set-up errors come
//! before anything runs; SIGKILL + resume and shards + merge give the bytes of
//! an uninterrupted run; Ctrl-C stops a bridge run like a built-in one.
//!
//! Needs `RWG_TEST_PYTHON`: a Python with `gymnasium[box2d,mujoco]==1.4.0`
//! (`.ci/run` makes one). Without it each test prints SKIPPED and passes,
//! except under `CI=true` or `RWG_NO_SKIP=1`, where it fails.

mod common;
mod gym_bridge_common;
use common::*;
use gym_bridge_common::*;
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// The reset seed of sample `n`, episode 0, for the test env `Faulty-v0`
/// (the id without the `gymnasium:` prefix enters the seed).
fn faulty_seed(seed: u64, n: u64) -> u64 {
    rwg_core::sampler::reset_seed(seed, "rwg_test_envs:Faulty-v0", n, 0)
}

fn faulty_manifest(mode: &str) -> String {
    format!(
        r#"
samples = 96
episodes = 2
[[architectures]]
name = "0HL"
hidden = []
[[envs]]
id = "gymnasium:rwg_test_envs:Faulty-v0"
kwargs = {{ mode = "{mode}", at_seed = "{}", at_step = 3 }}
"#,
        faulty_seed(0, 40)
    )
}

#[test]
fn failing_envs_are_named_and_committed_blocks_kept() {
    let Some(py) = python() else { return };
    let dir = temp_dir("gym-faulty");
    let cell = "cells/gymnasium=rwg_test_envs=Faulty-v0__0HL__nobias";
    for (mode, says) in [
        (
            "raise",
            "step raised RuntimeError: deliberate failure at step 3",
        ),
        (
            "nan",
            "step returned a non-finite observation: value 4 of 5 is NaN",
        ),
        (
            "shape",
            "observation of 8 values (shape (8,)) where the observation space",
        ),
        (
            "segfault",
            "the Python worker was killed by signal 11 (SIGSEGV)",
        ),
        ("hang", "did not answer within 3 s"),
    ] {
        let m = write(&dir, &format!("{mode}.toml"), &faulty_manifest(mode));
        let run = dir.join(mode);
        let t0 = Instant::now();
        let out = rwg_cmd(
            &py,
            &["run", &m, "--out", run.to_str().unwrap(), "--threads", "2"],
        )
        .env(rwg_gym::TIMEOUT_VAR, "3")
        .output()
        .unwrap();
        let err = run_err(out);
        assert!(err.contains(says), "{mode}: {err}");
        // network 40 (in block 1), episode 0, step 3
        assert!(
            err.contains("rwg_test_envs:Faulty-v0: sample 40, episode 0, step 3"),
            "{mode}: {err}"
        );
        assert!(err.contains("saved in"), "{mode}: {err}");
        // one error line: a traceback is kept in a file that it names
        let after: Vec<&str> = err
            .lines()
            .skip_while(|l| !l.starts_with("error: "))
            .collect();
        assert!(
            after.len() == 2 && after[1].starts_with("Every committed block is kept"),
            "{mode}: the error line and the resume line only: {err}"
        );
        let all = with_details(&err);
        if mode == "raise" {
            assert!(!err.contains("Traceback (most"), "{err}");
            assert!(err.contains("; the Python traceback is in "), "{err}");
            assert!(all.contains("Traceback (most recent call last)"), "{all}");
        }
        if mode == "segfault" || mode == "hang" {
            // faulthandler's traceback of where the worker crashed or hung
            assert!(all.contains("rwg_test_envs/__init__.py"), "{mode}: {all}");
        }
        // block 0 (networks 0-31) finished before and is kept
        assert!(
            run.join(cell).join("blocks/b0000000.csv").exists(),
            "{mode}: block 0 not kept"
        );
        assert!(
            t0.elapsed() < Duration::from_secs(60),
            "{mode} took too long"
        );
        // a rerun resumes (block 0 is not redone) and fails the same way
        let err2 = run_err(
            rwg_cmd(
                &py,
                &["run", &m, "--out", run.to_str().unwrap(), "--threads", "1"],
            )
            .env(rwg_gym::TIMEOUT_VAR, "3")
            .output()
            .unwrap(),
        );
        assert!(
            err2.contains("sample 40, episode 0, step 3"),
            "{mode}: {err2}"
        );
    }
}

#[test]
fn setup_errors_are_reported_before_anything_runs() {
    let Some(py) = python() else { return };
    let dir = temp_dir("gym-setup");
    let cases: [(&str, &str, &[&str]); 6] = [
        (
            "[[envs]]\nid = \"gymnasium:NoSuchEnv-v0\"\n",
            "m.toml:10:6",
            &["Gymnasium has no such environment", "NoSuchEnv"],
        ),
        (
            "[[envs]]\nid = \"gymnasium:no_such_module_xyz:Env-v0\"\n",
            "m.toml:10:6",
            &[
                "cannot import module 'no_such_module_xyz'",
                "ModuleNotFoundError",
            ],
        ),
        (
            "[[envs]]\nid = \"gymnasium:CartPole-v1\"\nkwargs = { no_such_arg = 1 }\n",
            "m.toml:11:10",
            &["raised TypeError", "no_such_arg", "Traceback"],
        ),
        (
            "[[envs]]\nid = \"gymnasium:CartPole-v1\"\npython = \"/nonexistent/python3\"\n",
            "m.toml:11:10",
            &[
                "cannot run Python '/nonexistent/python3'",
                "pip install gymnasium",
            ],
        ),
        (
            "[[envs]]\nid = \"gymnasium:rwg_test_envs:Unseeded-v0\"\n",
            "m.toml:10:6",
            &["reset(seed=20200509) gave different observations"],
        ),
        (
            "[[envs]]\nid = \"gymnasium:CarRacing-v3\"\n",
            "m.toml:10:6",
            &["27648 values, more than the limit of 4096"],
        ),
    ];
    for (i, (env, at, says)) in cases.iter().enumerate() {
        let body = format!(
            "samples = 4\nepisodes = 1\n\n\n[[architectures]]\nname = \"0HL\"\nhidden = []\n\n{env}"
        );
        let m = write(&dir, "m.toml", &body);
        let run = dir.join(format!("r{i}"));
        let err = run_err(
            rwg_cmd(&py, &["run", &m, "--out", run.to_str().unwrap()])
                .output()
                .unwrap(),
        );
        assert!(err.contains(at), "{env}: {err}");
        let all = with_details(&err);
        for s in *says {
            assert!(all.contains(s), "{env}: {all}");
        }
        assert!(!err.contains("Traceback (most"), "{env}: {err}");
        assert!(!run.join("cells").exists(), "{env}: something ran");
    }
    // Python without gymnasium: the command that installs it
    let venv = dir.join("bare");
    let ok = Command::new(&py)
        .args(["-m", "venv", "--without-pip", venv.to_str().unwrap()])
        .status()
        .unwrap()
        .success();
    assert!(ok, "cannot make a bare venv");
    let bare = venv.join("bin/python");
    let m = write(
        &dir,
        "m.toml",
        "samples = 4\nepisodes = 1\n[[architectures]]\nname = \"0HL\"\nhidden = []\n[[envs]]\nid = \"gymnasium:CartPole-v1\"\n",
    );
    let err = run_err(
        rwg_cmd(
            bare.to_str().unwrap(),
            &["run", &m, "--out", dir.join("bare-run").to_str().unwrap()],
        )
        .output()
        .unwrap(),
    );
    assert!(err.contains("Gymnasium is not installed for"), "{err}");
    assert!(
        err.contains("-m pip install \"gymnasium[box2d,mujoco]\""),
        "{err}"
    );
}

const LONG: &str = r#"
seed = 2
samples = 320
episodes = 4
[[architectures]]
name = "1HL"
hidden = [4]
[[envs]]
id = "gymnasium:CartPole-v1"
"#;

fn cell_files(run: &Path) -> Vec<Vec<u8>> {
    let c = run.join("cells/gymnasium=CartPole-v1__1HL__nobias");
    assert!(!c.join("blocks").exists(), "blocks left behind");
    vec![read(c.join("scores.csv")), read(c.join("samples.csv"))]
}

#[test]
fn sigkill_resume_and_shards_merge_give_identical_bytes() {
    let Some(py) = python() else { return };
    let dir = temp_dir("gym-long");
    let m = write(&dir, "m.toml", LONG);
    let whole = dir.join("whole");
    run_ok(
        &py,
        &["run", &m, "--out", whole.to_str().unwrap(), "--no-report"],
    );

    // SIGKILL once some blocks are committed, then resume
    let run = dir.join("killed");
    let blocks = run.join("cells/gymnasium=CartPole-v1__1HL__nobias/blocks");
    // Blocks committed one by one (not gathered for 2 s): the kill lands
    // between commits, before the run's end.
    let mut child = rwg_cmd(
        &py,
        &["run", &m, "--out", run.to_str().unwrap(), "--no-report"],
    )
    .env("RWG_COMMIT_LINGER", "0")
    .stdout(Stdio::null())
    .stderr(Stdio::null())
    .spawn()
    .unwrap();
    let t0 = Instant::now();
    let mut mid_run = false;
    while t0.elapsed() < Duration::from_secs(120) {
        let n = std::fs::read_dir(&blocks).map_or(0, |d| d.count());
        if n >= 2 {
            mid_run = child.try_wait().unwrap().is_none();
            break;
        }
        if child.try_wait().unwrap().is_some() {
            break;
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    let _ = child.kill();
    child.wait().unwrap();
    assert!(mid_run, "the kill did not land mid-run");
    run_ok(
        &py,
        &[
            "run",
            &m,
            "--out",
            run.to_str().unwrap(),
            "--threads",
            "1",
            "--no-report",
        ],
    );
    assert!(
        cell_files(&whole) == cell_files(&run),
        "resumed run differs"
    );

    // shards + merge
    let mut shards = vec![];
    for k in 0..2 {
        let d = dir.join(format!("s{k}"));
        run_ok(
            &py,
            &[
                "run",
                &m,
                "--shard",
                &format!("{k}/2"),
                "--out",
                d.to_str().unwrap(),
            ],
        );
        shards.push(d.to_str().unwrap().to_string());
    }
    let merged = dir.join("merged");
    let mut args = vec!["merge"];
    args.extend(shards.iter().map(String::as_str));
    args.extend(["--out", merged.to_str().unwrap()]);
    run_ok(&py, &args);
    assert!(
        cell_files(&whole) == cell_files(&merged),
        "merged run differs"
    );
}

/// Ctrl-C on a terminal signals the whole process group, the Python workers
/// included: rwg stops after the blocks in flight, as with a built-in env,
/// and the workers do not turn it into a "worker died" report.
#[cfg(unix)]
#[test]
fn ctrl_c_stops_a_bridge_run_like_a_builtin_one() {
    let Some(py) = python() else { return };
    let dir = temp_dir("gym-ctrlc");
    let m = write(
        &dir,
        "m.toml",
        &LONG.replace("samples = 320", "samples = 100000"),
    );
    let out = dir.join("run");
    let mut cmd = rwg_cmd(&py, &["run", &m, "--out", out.to_str().unwrap(), "-q"]);
    cmd.args(["--threads", "2", "--no-report"]);
    // Once the workers run (their first block committed).
    let blocks = out.join("cells/gymnasium=CartPole-v1__1HL__nobias/blocks");
    let err = ctrl_c_after_first_block(cmd, &blocks);
    assert!(!err.contains("worker"), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// A Python that cannot start is reported with why, once: the error's text
/// holds the reason, and rwg's printer of the error's causes must not add
/// it again at the end. Needs no Python.
#[test]
fn a_python_that_cannot_start_is_reported_with_why_once() {
    let out = rwg_env(
        &["rollout", "gymnasium:CartPole-v1", "--actions", "0"],
        &[("RWG_PYTHON", "/nonexistent/python3".as_ref())],
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{err}");
    assert!(
        err.starts_with("error: cannot run Python '/nonexistent/python3': "),
        "{err}"
    );
    assert!(
        err.trim_end()
            .ends_with("in the manifest or the RWG_PYTHON environment variable"),
        "{err}"
    );
}
