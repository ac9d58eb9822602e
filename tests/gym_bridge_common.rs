//! Helpers of the Gymnasium bridge's end-to-end tests (`cli_gym_bridge.rs`,
//! `cli_gym_bridge_faults.rs`): the test Python, `rwg` with it, small files.

#![allow(dead_code, reason = "each test file uses part of these helpers")]

use crate::common::*;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// The test Python (`RWG_TEST_PYTHON`), or `None` after a visible skip.
pub fn python() -> Option<String> {
    match std::env::var("RWG_TEST_PYTHON") {
        Ok(p) if !p.is_empty() => Some(p),
        _ => {
            // the test harness names the thread after the test; `skip` writes
            // past its capture (an `eprintln!` here was swallowed, so a test
            // without Gymnasium showed a plain `ok`) and fails under CI
            let thread = std::thread::current();
            skip(
                thread.name().unwrap_or("cli_gym_bridge"),
                "set RWG_TEST_PYTHON to a Python with gymnasium[box2d,mujoco]==1.4.0 to run this test",
            );
            None
        }
    }
}

/// `tests/python`: the test env package and the replay scripts.
pub fn python_dir() -> PathBuf {
    data_dir().join("../python")
}

/// `rwg` with the test Python and the test env package on PYTHONPATH.
pub fn rwg_cmd(py: &str, args: &[&str]) -> Command {
    let mut c = Command::new(rwg_bin());
    c.args(args)
        .env("RWG_PYTHON", py)
        .env("PYTHONPATH", python_dir())
        .env_remove(rwg_gym::TIMEOUT_VAR);
    c
}

/// Runs `rwg` with the test Python, requires success, returns stdout.
pub fn run_ok(py: &str, args: &[&str]) -> String {
    let out = rwg_cmd(py, args).output().unwrap();
    assert!(
        out.status.success(),
        "rwg {args:?} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).unwrap()
}

/// Requires that `out` failed; returns its stderr.
pub fn run_err(out: Output) -> String {
    assert!(!out.status.success(), "should have failed");
    String::from_utf8(out.stderr).unwrap()
}

/// Writes `body` to `dir/name`; returns the path.
pub fn write(dir: &Path, name: &str, body: &str) -> String {
    let p = dir.join(name);
    std::fs::write(&p, body).unwrap();
    p.to_str().unwrap().to_string()
}

/// Reads a file, naming it on failure.
pub fn read(p: PathBuf) -> Vec<u8> {
    std::fs::read(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}
