//! `examples/jax-atlas.toml`, the study of every JAX suite beside its
//! random-action baseline (docs/jax-families.md), stays what it says: the
//! paper's three architectures without bias and the `random` cell, 20 or more
//! envs of 5 or more libraries; and the commands that run it work, on a tiny
//! scale: one env of the manifest (Pgx's 2048: a legal-action mask) and the
//! built-in classic set, `--samples 4 --episodes 1 --threads 1`, then
//! `rwg stats` and `rwg compare --ranking-figure`.
//!
//! The last test needs the JAX Python (`RWG_PEER_PYTHON`, with gymnax and
//! pgx); without it the test prints `SKIPPED ...` and passes, except under CI
//! (`CI=true`) or with `RWG_NO_SKIP=1`, where it fails.

mod common;
mod jax_common;
use common::*;
use jax_common::{python, rwg_cmd};
use rwg_core::policy::PolicyKind;
use rwg_study::manifest::Manifest;
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn manifest() -> Manifest {
    Manifest::load(&repo().join("examples/jax-atlas.toml")).expect("examples/jax-atlas.toml loads")
}

#[test]
fn the_manifest_is_the_atlas_it_says() {
    let m = manifest();
    assert_eq!(m.bias, vec![false]);
    let archs: Vec<(&[usize], PolicyKind)> = m
        .architectures
        .iter()
        .map(|a| (&a.hidden[..], a.policy))
        .collect();
    assert_eq!(
        archs,
        [
            (&[][..], PolicyKind::Network),
            (&[4][..], PolicyKind::Network),
            (&[4, 4][..], PolicyKind::Network),
            (&[][..], PolicyKind::Random)
        ]
    );
    let ids: Vec<&str> = m.envs.iter().map(|e| e.id.as_str()).collect();
    assert!(ids.len() >= 20, "{} envs", ids.len());
    let libraries: BTreeSet<&str> = ids.iter().map(|i| i.split(':').next().unwrap()).collect();
    assert!(libraries.len() >= 5, "{libraries:?}");
    for id in [
        "gymnax:CartPole-v1",
        "gymnax:Catch-bsuite",
        "gymnax:Breakout-MinAtar",
        "brax:inverted_pendulum",
        "playground:CartpoleBalance",
        "navix:Navix-Empty-5x5-v0",
        "xminigrid:MiniGrid-Empty-8x8",
        "jumanji:Snake-v1",
        "craftax:Craftax-Classic-Symbolic-v1",
        "pgx:2048",
    ] {
        assert!(ids.contains(&id), "the atlas lacks {id}");
    }
}

/// `examples/jax-atlas.toml` with only the envs `keep` (their entries as
/// the manifest writes them).
fn subset(keep: &[&str]) -> String {
    let text = std::fs::read_to_string(repo().join("examples/jax-atlas.toml")).unwrap();
    let mut parts = text.split("[[envs]]");
    let mut out = parts.next().unwrap().to_string();
    for entry in parts {
        let id = entry.lines().find(|l| l.starts_with("id = ")).unwrap();
        if keep.iter().any(|k| id == format!("id = \"{k}\"")) {
            out.push_str("[[envs]]");
            out.push_str(entry);
        }
    }
    out
}

/// The atlas's commands on one env of it at 4 networks x 1 episode (one
/// worker, so each program is compiled once): run (JAX and the classic
/// set), stats, and compare with the ranking figure.
#[test]
fn the_atlas_commands_run_at_a_tiny_scale() {
    let Some(py) = python() else { return };
    let dir = temp_dir("jax-atlas-cmds");
    let m = write_manifest(&dir, "atlas.toml", &subset(&["pgx:2048"]));
    let atlas = dir.join("atlas");
    let classic = dir.join("classic");
    let tiny = ["--samples", "4", "--episodes", "1", "--threads", "1"];
    let run = |manifest: &str, out: &Path| {
        let mut c = rwg_cmd(&["run", manifest, "--out", path_str(out)]);
        c.args(tiny).env("RWG_PYTHON", &py);
        let o = c.output().unwrap();
        assert!(o.status.success(), "{}", output_text(&o));
    };
    run(path_str(&m), &atlas);
    let classic_toml = repo().join("examples/jax-atlas-classic.toml");
    run(path_str(&classic_toml), &classic);
    let stats = rwg_ok(&["stats", path_str(&atlas), "--format", "markdown"]);
    assert!(
        stats.contains("pgx:2048") && stats.contains("random"),
        "{stats}"
    );
    // the random cell of 2048 plays legal moves only: no game is lost by
    // an illegal move (reward -1) at its first steps
    let scores = std::fs::read_to_string(atlas.join("cells/pgx=2048__random__nobias/scores.csv"))
        .expect("the random cell of pgx:2048");
    for row in scores.lines().skip(1) {
        let steps: u32 = row.split(',').nth(3).unwrap().parse().unwrap();
        assert!(steps > 20, "a random 2048 game of {steps} steps: {row}");
    }
    let ranking = dir.join("ranking.png");
    rwg_ok(&[
        "compare",
        path_str(&classic),
        path_str(&atlas),
        "--ranking-figure",
        path_str(&ranking),
    ]);
    assert!(std::fs::metadata(&ranking).unwrap().len() > 1000);
    let _ = std::fs::remove_dir_all(&dir);
}
