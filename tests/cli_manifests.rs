//! Every manifest shipped in `examples/` runs, and what `docs/paper.md` says of
//! the paper manifests holds, at a small scale.
//!
//! `docs/paper.md` claims that network `n` of a cell has the same weights and
//! reset seeds in `paper.toml`, `paper-exact.toml` and the two
//! `paper-blocks-*.toml`, so that the cells `paper-exact` shares with `paper`
//! (every env whose time limit is at most 500 steps already) give
//! byte-identical `scores.csv`, and that the first block of every
//! `paper-blocks-*` cell is that cell of `paper-exact`. The
//! manifests with Gymnasium envs need a Python and are run by the tests that
//! own them (`cli_atlas.rs`, `cli_examples.rs` through the README); those with
//! JAX envs run here with `RWG_PEER_PYTHON`, as `docs/jax.md` runs them.

mod common;

use common::*;
use std::path::{Path, PathBuf};

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// Runs `manifest` with 8 networks × 2 episodes into `out`.
fn run_small(manifest: &Path, out: &Path) {
    run_small_with(manifest, out, &[]);
}

/// [`run_small`] with environment variables set for rwg.
fn run_small_with(manifest: &Path, out: &Path, vars: &[(&str, &std::ffi::OsStr)]) {
    let args = [
        "run",
        manifest.to_str().unwrap(),
        "--samples",
        "8",
        "--episodes",
        "2",
        "--threads",
        "2",
        "--quiet",
        "--no-report",
        "--out",
        out.to_str().unwrap(),
    ];
    let o = rwg_env(&args, vars);
    assert!(
        o.status.success(),
        "rwg {args:?} failed: {}",
        String::from_utf8_lossy(&o.stderr)
    );
}

/// Whether a manifest names a JAX env (`gymnax:`, `brax:`, `jax:`).
fn has_jax_envs(text: &str) -> bool {
    ["\"gymnax:", "\"brax:", "\"jax:"]
        .iter()
        .any(|p| text.contains(p))
}

/// The cell directory names of a run.
fn cells(run: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(run.join("cells"))
        .unwrap_or_else(|e| panic!("{}/cells: {e}", run.display()))
        .map(|d| d.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

fn scores(run: &Path, cell: &str) -> Vec<u8> {
    let p = run.join("cells").join(cell).join("scores.csv");
    std::fs::read(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

#[test]
fn every_example_manifest_without_python_runs() {
    let dir = temp_dir("manifests");
    let mut ran = Vec::new();
    let mut paths: Vec<PathBuf> = std::fs::read_dir(repo().join("examples"))
        .unwrap()
        .map(|d| d.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    paths.sort();
    for manifest in paths {
        let text = std::fs::read_to_string(&manifest).unwrap();
        let name = manifest.file_stem().unwrap().to_string_lossy().into_owned();
        if text.contains("\"gymnasium:") {
            eprintln!("{name}.toml: has Gymnasium envs, run by the test that owns it");
            continue;
        }
        if name == "jax-atlas" {
            // 33 envs, 132 compiled programs: tests/cli_jax_atlas.rs checks
            // the manifest and runs one env of it
            eprintln!("{name}.toml: run on one env by tests/cli_jax_atlas.rs");
            continue;
        }
        let out = dir.join(&name);
        if has_jax_envs(&text) {
            // JAX's Python (RWG_PEER_PYTHON) for every env, the example's own
            // env module on its path, as docs/jax.md runs them.
            let Some(py) = std::env::var_os("RWG_PEER_PYTHON") else {
                skip(
                    &format!("every_example_manifest_without_python_runs ({name}.toml)"),
                    "its JAX envs need RWG_PEER_PYTHON (a Python with jax and gymnax)",
                );
                continue;
            };
            let env_dir = repo().join("examples").join("jax-env");
            run_small_with(
                &manifest,
                &out,
                &[("RWG_PYTHON", &py), ("PYTHONPATH", env_dir.as_os_str())],
            );
        } else {
            run_small(&manifest, &out);
        }
        assert!(!cells(&out).is_empty(), "{name}.toml: no cells");
        for cell in cells(&out) {
            let s = scores(&out, &cell);
            // A header and 8 × 2 rows.
            let rows = s.iter().filter(|&&b| b == b'\n').count();
            assert_eq!(
                rows,
                1 + 16,
                "{name}.toml, {cell}: {rows} lines in scores.csv"
            );
        }
        ran.push(name);
    }
    for must in [
        "paper",
        "paper-exact",
        "paper-blocks-nobias",
        "paper-blocks-bias",
        "quick",
    ] {
        assert!(
            ran.iter().any(|n| n == must),
            "examples/{must}.toml not run"
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn paper_manifests_share_networks_as_docs_paper_md_says() {
    let dir = temp_dir("paper-manifests");
    let ex = repo().join("examples");
    let (paper, exact) = (dir.join("paper"), dir.join("exact"));
    run_small(&ex.join("paper.toml"), &paper);
    run_small(&ex.join("paper-exact.toml"), &exact);

    let doc = std::fs::read_to_string(repo().join("docs/paper.md")).unwrap();
    assert!(
        doc.contains("the 24 cells of\n`runs/paper-exact` other than MountainCarContinuous-v0"),
        "docs/paper.md no longer states the claim this test checks; update both"
    );
    let exact_cells = cells(&exact);
    assert_eq!(
        cells(&paper),
        exact_cells,
        "paper and paper-exact: other cells"
    );
    let shared: Vec<&String> = exact_cells
        .iter()
        .filter(|c| !c.starts_with("MountainCarContinuous-v0__"))
        .collect();
    assert_eq!(shared.len(), 24, "cells outside MountainCarContinuous-v0");
    for cell in shared {
        assert!(
            scores(&paper, cell) == scores(&exact, cell),
            "{cell}: paper and paper-exact scores.csv differ"
        );
    }
    // The 500-step cap is what paper-exact changes: MountainCarContinuous-v0's
    // 999-step episodes are cut, so its cells differ (else the comparison above
    // would prove nothing about the manifests).
    assert!(
        exact_cells
            .iter()
            .filter(|c| c.starts_with("MountainCarContinuous-v0__"))
            .any(|c| scores(&paper, c) != scores(&exact, c)),
        "paper-exact's cap changed no MountainCarContinuous-v0 cell"
    );
    // The block manifests: each cell's first networks are paper-exact's.
    let mut blocks_cells = Vec::new();
    for name in ["paper-blocks-nobias", "paper-blocks-bias"] {
        let out = dir.join(name);
        run_small(&ex.join(format!("{name}.toml")), &out);
        for cell in cells(&out) {
            assert!(
                scores(&out, &cell) == scores(&exact, &cell),
                "{cell}: {name}'s first networks are not paper-exact's"
            );
            blocks_cells.push(cell);
        }
    }
    blocks_cells.sort();
    assert_eq!(
        blocks_cells, exact_cells,
        "the block manifests cover paper-exact's cells"
    );
    let _ = std::fs::remove_dir_all(&dir);
}
