//! The Python package (`python/rwg`: `rwg.load`, `rwg.run`) end to end: runs
//! its pytest suite (`python/tests/`) with the test Python, the package on
//! PYTHONPATH and `RWG_BIN` set to this build's `rwg`, one test file per
//! test here.
//!
//! Needs `RWG_TEST_PYTHON`: a Python with numpy, pandas, pytest and
//! `gymnasium==1.4.0` (`.ci/run` makes one). Without it each test prints
//! SKIPPED and passes, except under `CI=true` or `RWG_NO_SKIP=1`, where it
//! fails.

mod common;
use common::*;
use std::path::PathBuf;
use std::process::Command;

/// The repository's top folder.
fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// The test Python, if it has what the suite needs; else `None` after a
/// visible skip (a failure where skips are forbidden).
fn python(test: &str) -> Option<String> {
    let why = match std::env::var("RWG_TEST_PYTHON") {
        Ok(p) if !p.is_empty() => {
            let ok = Command::new(&p)
                .args(["-c", "import numpy, pandas, pytest, gymnasium"])
                .output();
            match ok {
                Ok(o) if o.status.success() => return Some(p),
                Ok(o) => format!(
                    "RWG_TEST_PYTHON={p} lacks a module the Python tests need ({}); \
                     install them: {p} -m pip install numpy pandas pytest gymnasium==1.4.0",
                    String::from_utf8_lossy(&o.stderr).trim()
                ),
                Err(e) => format!("cannot run RWG_TEST_PYTHON={p}: {e}"),
            }
        }
        _ => "set RWG_TEST_PYTHON to a Python with numpy, pandas, pytest and \
              gymnasium==1.4.0 to run this test"
            .to_string(),
    };
    skip(test, &why);
    None
}

/// Runs `python/tests/<file>` with pytest; fails with its output on a failure.
fn pytest(test: &str, file: &str) {
    let Some(py) = python(test) else { return };
    let base = temp_dir(&format!("pytest-{test}"));
    let out = Command::new(&py)
        .current_dir(repo())
        .args(["-m", "pytest", "-q", "-p", "no:cacheprovider", "--basetemp"])
        .arg(&base)
        .arg(format!("python/tests/{file}"))
        .env("PYTHONPATH", repo().join("python"))
        .env("PYTHONDONTWRITEBYTECODE", "1")
        .env("RWG_BIN", rwg_bin())
        .env_remove("RWG_PYTHON")
        .env_remove("RWG_PLUGIN_PATH")
        .output()
        .unwrap_or_else(|e| panic!("cannot run {py}: {e}"));
    assert!(
        out.status.success(),
        "pytest python/tests/{file} failed:\n{}\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    let _ = std::fs::remove_dir_all(&base);
}

#[test]
fn load_reads_finished_runs_and_refuses_damaged_unfinished_and_other_dirs() {
    pytest("python_load", "test_load.py");
}

#[test]
fn run_takes_dicts_and_options_raises_rwg_s_errors_and_stops_on_ctrl_c() {
    pytest("python_run", "test_run.py");
}

#[test]
fn docs_python_md_examples_run_as_printed() {
    pytest("python_docs", "test_docs.py");
}

#[test]
fn dict_manifests_are_written_as_toml() {
    pytest("python_toml", "test_toml.py");
}

#[test]
fn every_bad_argument_is_an_argument_error_and_odd_good_ones_work() {
    pytest("python_arguments", "test_arguments.py");
}

#[test]
fn run_stops_on_any_sigint_prints_a_working_resume_command_and_never_blocks() {
    pytest("python_interrupts", "test_interrupts.py");
}

#[test]
fn tidy_gives_every_episode_of_several_runs_as_one_frame() {
    pytest("python_tidy", "test_tidy.py");
}
