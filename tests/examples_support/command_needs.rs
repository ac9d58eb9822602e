//! What a documented command needs to run (a Python with Gymnasium, JAX's
//! Python, numpy) and what it writes, read from the command and the files it
//! names: cli_examples.rs's skip rule.

use crate::common::*;
use crate::prepare;
use std::path::Path;

/// Whether a command needs a Python with JAX: it names JAX, gymnax, Brax or
/// a JAX family (an id, a manifest or a script of docs/jax.md or
/// docs/jax-families.md).
pub(crate) fn needs_jax(cmd: &str) -> bool {
    rwg_jax::FAMILIES
        .iter()
        .map(|f| f.source)
        .chain(["jax", "gymnax", "brax"])
        .any(|w| cmd.contains(w))
}

/// The Pythons a command needs, from what it runs: the ids it names, the
/// env ids of the manifests it names (read in `dir`, as the reader's rwg
/// reads them) and the modules its Python scripts import (a script file it
/// names, or a here-document).
#[derive(Debug, Default, Clone, Copy, PartialEq)]
pub(crate) struct Needs {
    /// A Python with Gymnasium, Box2D, MuJoCo and numpy (`RWG_TEST_PYTHON`).
    pub(crate) gymnasium: bool,
    /// A Python with JAX, gymnax and Brax (`RWG_PEER_PYTHON`).
    pub(crate) jax: bool,
}

pub(crate) fn needs(ran: &str, dir: &Path) -> Needs {
    let mut n = Needs {
        gymnasium: ["gymnasium:", "gymnasium[", "rwg bench gym"]
            .iter()
            .any(|w| ran.contains(w)),
        jax: needs_jax(ran),
    };
    let words = ran.split(|c: char| c.is_whitespace() || c == ';' || c == '=');
    for word in words {
        let path = dir.join(word);
        if word.ends_with(".toml") && path.is_file() {
            if let Ok(m) = rwg_study::manifest::Manifest::load(&path) {
                for e in &m.envs {
                    n.gymnasium |= e.id.starts_with("gymnasium:");
                    n.jax |= rwg_study::jax_source::is_jax(&e.id);
                }
            }
        }
        if word.ends_with(".py") && path.is_file() {
            n.gymnasium |= imports_numeric(&std::fs::read_to_string(&path).unwrap_or_default());
        }
    }
    if ran.contains("python3 -") {
        n.gymnasium |= imports_numeric(ran);
    }
    n
}

/// What a command makes that later commands may use: the run directory of
/// an `rwg run` (its `--out`, else its manifest's `out`, else
/// `runs/NAME`), and the file or folder after `--out`, `--export-weights`,
/// `--html`, `--figure` or a `>`.
pub(crate) fn outputs(ran: &str, dir: &Path) -> Vec<String> {
    let words: Vec<&str> = ran.split_whitespace().collect();
    let mut out = vec![];
    for (i, w) in words.iter().enumerate() {
        let next = words.get(i + 1).map(|n| n.to_string());
        if ["--out", "--export-weights", "--html", "--figure", ">"].contains(w) {
            out.extend(next);
        } else if *w == "run" && i > 0 && words[i - 1].ends_with("rwg") && !words.contains(&"--out")
        {
            if let Some(m) = next.filter(|m| m.ends_with(".toml")) {
                let given = rwg_study::manifest::Manifest::load(&dir.join(&m))
                    .ok()
                    .and_then(|m| m.out)
                    .map(|o| o.to_string_lossy().into_owned());
                let stem = Path::new(&m)
                    .file_stem()
                    .unwrap_or_default()
                    .to_string_lossy();
                out.push(given.unwrap_or_else(|| format!("runs/{stem}")));
            }
        }
    }
    out
}

/// Whether Python source imports a package the test Python provides and a
/// bare Python lacks (numpy, pandas, Gymnasium).
pub(crate) fn imports_numeric(source: &str) -> bool {
    source.lines().map(str::trim_start).any(|l| {
        ["numpy", "pandas", "gymnasium"]
            .iter()
            .any(|m| l.starts_with(&format!("import {m}")) || l.starts_with(&format!("from {m}")))
    })
}

/// The skip rule reads what a command runs, not its words: a manifest of
/// Gymnasium envs whose name says nothing of them (docs/atlas.md's), a
/// script that imports numpy, and commands that need nothing but rwg.
#[test]
fn the_skip_rule_reads_what_each_command_runs() {
    let dir = temp_dir("examples-needs").join("rwg");
    std::fs::create_dir_all(&dir).unwrap();
    prepare(&dir);
    let gymnasium = Needs {
        gymnasium: true,
        jax: false,
    };
    let jax = Needs {
        gymnasium: false,
        jax: true,
    };
    for (cmd, want) in [
        ("rwg run examples/atlas.toml", gymnasium),
        ("rwg run examples/gymnasium.toml", gymnasium),
        (
            "target/release/rwg bench gym --peer benches/peers/ref_numpy.py",
            gymnasium,
        ),
        ("PYTHONPATH=examples/jax-env rwg run examples/jax.toml", jax),
        ("rwg run examples/quick.toml", Needs::default()),
        ("rwg run examples/paper.toml --out runs/p", Needs::default()),
        (
            "python3 examples/paper-tables.py runs/a runs/b",
            Needs::default(),
        ),
        (
            "python3 - <<'EOF'\nimport csv, json\nprint(1)\nEOF",
            Needs::default(),
        ),
        ("python3 - <<'EOF'\nimport numpy as np\nEOF", gymnasium),
    ] {
        assert_eq!(needs(cmd, &dir), want, "{cmd}");
    }
    // what a skipped command would have made, which later ones then lack
    assert_eq!(outputs("rwg run examples/atlas.toml", &dir), ["runs/atlas"]);
    assert_eq!(
        outputs("rwg run examples/quick.toml --out runs/q", &dir),
        ["runs/q"]
    );
    assert_eq!(
        outputs("rwg replay r --sample 0 --export-weights net.json", &dir),
        ["net.json"]
    );
    let _ = std::fs::remove_dir_all(dir.parent().unwrap());
}
