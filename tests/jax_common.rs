//! Helpers of the JAX env source's end-to-end tests (`cli_jax.rs`,
//! `cli_jax_checks.rs`): the JAX Python, `rwg` with the `jax:` test envs
//! importable, one-env manifests, small files.

#![allow(dead_code, reason = "each test file uses part of these helpers")]

use crate::common::*;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// The JAX Python (`RWG_PEER_PYTHON`), or `None` after a visible skip.
pub fn python() -> Option<String> {
    match std::env::var("RWG_PEER_PYTHON") {
        Ok(p) if !p.is_empty() => Some(p),
        _ => {
            let thread = std::thread::current();
            skip(
                thread.name().unwrap_or("cli_jax"),
                "set RWG_PEER_PYTHON to a Python with jax==0.10.2, gymnax==1.0.1 and \
                 brax==0.14.2 to run this test",
            );
            None
        }
    }
}

/// `rwg` with the `jax:` test envs importable and no JAX variable of the caller.
pub fn rwg_cmd(args: &[&str]) -> Command {
    let mut c = Command::new(rwg_bin());
    c.args(args)
        .env("PYTHONPATH", data_dir())
        .env_remove("RWG_JAX_TIMEOUT")
        .env_remove("RWG_PYTHON")
        .env_remove("XLA_FLAGS")
        .env_remove("JAX_PLATFORMS");
    c
}

/// Runs `rwg`, requires success, returns stdout.
pub fn ok(args: &[&str]) -> String {
    let out = rwg_cmd(args).output().unwrap();
    assert!(
        out.status.success(),
        "rwg {args:?} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).unwrap()
}

/// Runs `rwg`, requires failure, returns stderr.
pub fn err(args: &[&str]) -> String {
    let out: Output = rwg_cmd(args).output().unwrap();
    let e = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(
        !out.status.success(),
        "rwg {args:?} should have failed: {e}"
    );
    e
}

/// A study of one env: `samples` networks x `episodes`, architectures 0HL
/// (and 1HL = [4] with `two_archs`), the env entry's lines `entry` after its
/// id, with `python = py`.
pub fn manifest(
    py: &str,
    id: &str,
    entry: &str,
    samples: u32,
    episodes: u32,
    two_archs: bool,
) -> String {
    let mut m = format!(
        "seed = 5\nsamples = {samples}\nepisodes = {episodes}\n\
         [[architectures]]\nname = \"0HL\"\nhidden = []\n"
    );
    if two_archs {
        m.push_str("[[architectures]]\nname = \"1HL\"\nhidden = [4]\n");
    }
    m.push_str(&format!(
        "[[envs]]\nid = \"{id}\"\npython = {py:?}\n{entry}\n"
    ));
    m
}

/// Writes `body` to `dir/name`; returns the path.
pub fn write(dir: &Path, name: &str, body: &str) -> String {
    let p = dir.join(name);
    std::fs::write(&p, body).unwrap();
    p.to_str().unwrap().to_string()
}

/// A path as text.
pub fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// The bytes that must not depend on how a study was run: each cell's
/// `scores.csv` and `samples.csv`, and the run's `stats.csv`.
pub fn results(run: &Path) -> Vec<(String, Vec<u8>)> {
    let mut cells: Vec<PathBuf> = std::fs::read_dir(run.join("cells"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    cells.sort();
    let mut out = vec![];
    for c in cells {
        let name = c.file_name().unwrap().to_string_lossy().into_owned();
        for f in ["scores.csv", "samples.csv"] {
            let p = c.join(f);
            out.push((
                format!("{name}/{f}"),
                std::fs::read(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display())),
            ));
        }
    }
    out.push((
        "stats.csv".into(),
        std::fs::read(run.join("stats.csv")).unwrap(),
    ));
    out
}

/// Requires the same [`results`] bytes in runs `a` and `b`.
pub fn assert_same(a: &Path, b: &Path) {
    let (ra, rb) = (results(a), results(b));
    assert_eq!(ra.len(), rb.len());
    for ((na, fa), (nb, fb)) in ra.iter().zip(&rb) {
        assert_eq!(na, nb);
        assert!(
            fa == fb,
            "{na} differs between {} and {}",
            a.display(),
            b.display()
        );
    }
}
