//! Helpers shared by the end-to-end tests: run the real `rwg` binary.

#![allow(dead_code)]

use std::path::PathBuf;
use std::process::{Command, Output};

/// Path of the `rwg` binary built for these tests.
pub fn rwg_bin() -> PathBuf {
    PathBuf::from(env!("CARGO_BIN_EXE_rwg"))
}

/// Runs `rwg` with `args`; returns its output.
pub fn rwg(args: &[&str]) -> Output {
    Command::new(rwg_bin())
        .args(args)
        .output()
        .expect("cannot run rwg")
}

/// Runs `rwg`, requires success, returns stdout.
pub fn rwg_ok(args: &[&str]) -> String {
    let out = rwg(args);
    assert!(
        out.status.success(),
        "rwg {args:?} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).unwrap()
}

/// Runs `rwg`, requires failure, returns stderr.
pub fn rwg_err(args: &[&str]) -> String {
    let out = rwg(args);
    assert!(!out.status.success(), "rwg {args:?} should have failed");
    String::from_utf8(out.stderr).unwrap()
}

/// The workspace's `tests/data` directory (copies of the golden trajectories).
pub fn data_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../tests/data")
}

/// A fresh temporary directory for one test.
pub fn temp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("rwg-test-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Writes a synthetic run (CartPole-like and Pendulum-like cells, each
/// architecture with and without bias) into a fresh directory.
pub fn synthetic_run(name: &str, samples: u64, episodes: u32) -> PathBuf {
    use rwg_core::run_data::synthetic::{write_synthetic_run, SyntheticCell, SyntheticRun};
    let dir = temp_dir(name);
    let mut cells = Vec::new();
    for bias in [false, true] {
        cells.push(SyntheticCell::cartpole("0HL", &[], bias));
        cells.push(SyntheticCell::cartpole("1HL-4", &[4], bias));
        cells.push(SyntheticCell::pendulum("0HL", &[], bias));
        cells.push(SyntheticCell::pendulum("1HL-4", &[4], bias));
    }
    write_synthetic_run(
        &dir,
        &SyntheticRun {
            samples,
            episodes,
            seed: 3,
            cells,
        },
    )
    .unwrap();
    dir
}
