//! The JAX atlas cannot rot: `examples/jax-atlas.toml` is the study that
//! `docs/jax-atlas.md` describes (the paper's three architectures without
//! bias and the `random` cell, 20 or more envs of 5 or more libraries, each
//! named on the page), the committed run (`docs/jax-atlas/`) is a whole run
//! of it, every generated number of the page is what
//! `examples/jax-atlas-page.py` makes of those files; and the page's commands
//! work, on a tiny scale: one env of the manifest (Pgx's 2048: a legal-action
//! mask) and the built-in classic set, `--samples 4 --episodes 1 --threads 1`,
//! then `rwg stats`, `rwg compare --ranking-figure` and the page script.
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
use serde_json::Value;
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::process::Command;

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn manifest() -> Manifest {
    Manifest::load(&repo().join("examples/jax-atlas.toml")).expect("examples/jax-atlas.toml loads")
}

fn doc() -> String {
    std::fs::read_to_string(repo().join("docs/jax-atlas.md")).expect("docs/jax-atlas.md")
}

/// A Python 3 for the page script (standard library only).
fn python3() -> String {
    std::env::var("RWG_TEST_PYTHON").unwrap_or_else(|_| "python3".into())
}

fn page_script(args: &[&str]) -> std::process::Output {
    Command::new(python3())
        .arg(repo().join("examples/jax-atlas-page.py"))
        .args(args)
        .output()
        .expect("python3 runs")
}

/// The (env, arch) cells of a `run.json`.
fn run_cells(path: &Path) -> BTreeSet<(String, String)> {
    let run: Value = serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    run["cells"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| {
            (
                c["env"].as_str().unwrap().into(),
                c["arch"].as_str().unwrap().into(),
            )
        })
        .collect()
}

#[test]
fn the_manifest_is_the_atlas_the_page_describes() {
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
    // the page names every env (without its prefix)
    let page = doc();
    for id in &ids {
        let name = id.split(':').nth(1).unwrap();
        let short = name
            .trim_start_matches("Navix-")
            .trim_end_matches("-bsuite");
        let short = short.trim_end_matches("-MinAtar").trim_end_matches("-v0");
        assert!(page.contains(short), "docs/jax-atlas.md does not name {id}");
    }
    // the committed run is the whole study, at the manifest's counts, and the
    // classic set's run the whole of examples/jax-atlas-classic.toml
    let study = |m: &Manifest| -> BTreeSet<(String, String)> {
        m.envs
            .iter()
            .flat_map(|e| {
                m.architectures
                    .iter()
                    .map(|a| (e.id.clone(), a.name.clone()))
            })
            .collect()
    };
    let files = repo().join("docs/jax-atlas");
    assert_eq!(run_cells(&files.join("run.json")), study(&m));
    let committed = Manifest::load(&files.join("manifest.toml")).unwrap();
    assert_eq!(
        (committed.samples, committed.episodes),
        (m.samples, m.episodes)
    );
    let classic = Manifest::load(&repo().join("examples/jax-atlas-classic.toml")).unwrap();
    assert_eq!((classic.samples, classic.episodes), (m.samples, m.episodes));
    assert_eq!(run_cells(&files.join("classic/run.json")), study(&classic));
    let counts = format!("**{} networks × {} episodes**", m.samples, m.episodes);
    assert!(
        page.contains(&counts),
        "docs/jax-atlas.md does not state {counts}"
    );
}

/// Every generated table and list of the page is what the script makes of
/// `docs/jax-atlas/` (and the check fails on a page whose numbers differ).
#[test]
fn every_number_of_the_page_is_the_runs() {
    let out = page_script(&["--check"]);
    assert!(out.status.success(), "{}", output_text(&out));
    let dir = temp_dir("jax-atlas-page");
    let page = dir.join("jax-atlas.md");
    let edited = doc().replacen("| gymnax:CartPole-v1 |", "| gymnax:CartPole-v1 | 1 |", 1);
    assert_ne!(edited, doc(), "the page has no CartPole-v1 row");
    std::fs::write(&page, edited).unwrap();
    copy_dir(&repo().join("docs/jax-atlas"), &dir.join("jax-atlas"));
    let out = page_script(&["--page", path_str(&page), "--check"]);
    assert!(!out.status.success(), "an edited number passed the check");
    assert!(output_text(&out).contains("does not match"), "{out:?}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// The files of `from` (and of its folders) copied into `to`.
fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let e = e.unwrap();
        if e.file_type().unwrap().is_dir() {
            copy_dir(&e.path(), &to.join(e.file_name()));
        } else {
            std::fs::copy(e.path(), to.join(e.file_name())).unwrap();
        }
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

/// The page's commands on one env of the atlas at 4 networks x 1 episode
/// (one worker, so each program is compiled once): run (JAX and the classic
/// set), stats, compare with the ranking figure, and the page script on a
/// copy of the page.
#[test]
fn the_pages_commands_run_at_a_tiny_scale() {
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
    let page = dir.join("page/jax-atlas.md");
    std::fs::create_dir_all(page.parent().unwrap()).unwrap();
    std::fs::write(&page, doc()).unwrap();
    let out = page_script(&[
        "--page",
        path_str(&page),
        path_str(&atlas),
        "--classic",
        path_str(&classic),
    ]);
    assert!(out.status.success(), "{}", output_text(&out));
    let text = std::fs::read_to_string(&page).unwrap();
    assert!(
        text.contains("**4 networks × 1 episodes**: 4 cells, 1 env of 1 library"),
        "{text}"
    );
    assert!(text.contains("| pgx:2048 | none |"), "{text}");
    assert!(dir.join("page/jax-atlas/manifest.toml").exists());
    assert!(dir.join("page/jax-atlas/classic/stats.csv").exists());
    let _ = std::fs::remove_dir_all(&dir);
}
