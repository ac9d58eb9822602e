//! The RWG atlas cannot rot: `examples/atlas.toml` is the study that
//! `docs/atlas.md` describes, every number of the doc's table is the one the
//! committed run files (`docs/atlas/stats.csv`, `docs/atlas/run.json`) hold,
//! the figures it shows exist (and stay small), and the commands it prints
//! run as printed, on a tiny scale (`rwg run` gets `--samples 2 --episodes
//! 1`; the real atlas takes most of an hour).
//!
//! The last test needs a Python with `gymnasium[box2d,mujoco]`: set
//! `RWG_TEST_PYTHON` to it. Without it the test prints `SKIPPED ...` and
//! passes, except under CI (`CI=true`) or with `RWG_NO_SKIP=1`, where it fails.

mod common;
use common::*;
use rwg_study::manifest::Manifest;
use serde_json::Value;
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::process::Command;

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn doc() -> String {
    std::fs::read_to_string(repo().join("docs/atlas.md")).expect("docs/atlas.md")
}

fn manifest() -> Manifest {
    Manifest::load(&repo().join("examples/atlas.toml")).expect("examples/atlas.toml loads")
}

/// The rows of `stats.csv`, keyed by (env, arch).
fn stats_rows() -> BTreeMap<(String, String), BTreeMap<String, String>> {
    let text = std::fs::read_to_string(repo().join("docs/atlas/stats.csv")).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    lines
        .map(|l| {
            let row: BTreeMap<String, String> = header
                .iter()
                .zip(l.split(','))
                .map(|(k, v)| (k.to_string(), v.to_string()))
                .collect();
            ((row["env"].clone(), row["arch"].clone()), row)
        })
        .collect()
}

/// The rows of the doc's per-cell table (the one whose header starts
/// `| env | solved at | arch |`), as their cells' text.
fn doc_table() -> Vec<Vec<String>> {
    let text = doc();
    let mut lines = text
        .lines()
        .skip_while(|l| !l.starts_with("| env | solved at | arch |"));
    let header = lines.next().expect("docs/atlas.md: no per-cell table");
    let columns = header.split('|').count();
    lines
        .skip(1) // the alignment row
        .take_while(|l| l.starts_with('|'))
        .map(|l| {
            let cells: Vec<String> = l.split('|').map(|c| c.trim().to_string()).collect();
            assert_eq!(
                cells.len(),
                columns,
                "docs/atlas.md: a row of another width: {l}"
            );
            cells[1..columns - 1].to_vec()
        })
        .collect()
}

/// The numbers shown in `text` (`0.0195 [0.0084, 0.0449]`, `none seen (≥ 97.2)`).
fn numbers(text: &str) -> Vec<&str> {
    text.split(|c: char| " ,[]()≥".contains(c))
        .filter(|t| t.parse::<f64>().is_ok())
        .collect()
}

fn field(row: &BTreeMap<String, String>, key: &str) -> f64 {
    row[key]
        .parse()
        .unwrap_or_else(|_| panic!("stats.csv: {key} = '{}'", row[key]))
}

#[test]
fn the_manifest_is_the_study_of_the_committed_run() {
    let m = manifest();
    let run = Manifest::load(&repo().join("docs/atlas/manifest.toml")).unwrap();
    assert_eq!(
        m.study_differences(&run),
        Vec::<String>::new(),
        "examples/atlas.toml is not the study of docs/atlas/ (run it again and update the doc)"
    );
    assert_eq!(m.bias, vec![false]);
    let hidden: Vec<&[usize]> = m.architectures.iter().map(|a| &a.hidden[..]).collect();
    assert_eq!(hidden, [&[][..], &[4], &[4, 4]]);
    let gym = m
        .envs
        .iter()
        .filter(|e| e.id.starts_with("gymnasium:"))
        .count();
    assert!(
        gym >= 8,
        "the atlas has {gym} Gymnasium envs beyond the classic set"
    );
    // the counts the doc states
    let counts = format!("{} networks × {} episodes", m.samples, m.episodes);
    assert!(
        doc().contains(&counts),
        "docs/atlas.md does not state `{counts}`"
    );
}

#[test]
fn every_number_of_the_table_is_the_runs() {
    let m = manifest();
    let stats = stats_rows();
    let run: Value =
        serde_json::from_str(&std::fs::read_to_string(repo().join("docs/atlas/run.json")).unwrap())
            .unwrap();
    let wall: BTreeMap<(String, String), f64> = run["cells"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| {
            let key = (
                c["env"].as_str().unwrap().to_string(),
                c["arch"].as_str().unwrap().to_string(),
            );
            (key, c["wall_s"].as_f64().unwrap())
        })
        .collect();
    let rows = doc_table();
    let mut seen = BTreeSet::new();
    for r in &rows {
        let [env, solved, arch, best, p999, p, guesses, wall_s] = &r[..] else {
            panic!("docs/atlas.md: a row of {} columns, want 8: {r:?}", r.len());
        };
        let env = env.trim_matches('`').to_string();
        let key = (env.clone(), arch.clone());
        let s = stats
            .get(&key)
            .unwrap_or_else(|| panic!("no cell {key:?} in stats.csv"));
        let at = |what: &str, shown: &str, value: f64| {
            assert!(
                shows(shown, value),
                "docs/atlas.md, {env} {arch}, {what}: shows {shown}, the run has {value}"
            )
        };
        at("solved at", numbers(solved)[0], field(s, "solved"));
        let source = if solved.contains("Gymnasium") {
            "env"
        } else {
            "manifest"
        };
        let entry = m
            .envs
            .iter()
            .find(|e| e.id == env)
            .expect("an env of the manifest");
        assert_eq!(
            source,
            if entry.solved.is_some() {
                "manifest"
            } else {
                "env"
            },
            "docs/atlas.md, {env}: the solved score's source"
        );
        at("best mean", best, field(s, "best_mean"));
        at("p99.9", p999, field(s, "p99.9_mean"));
        let pn = numbers(p);
        assert_eq!(pn.len(), 3, "{env} {arch}: p(solved) shows {p}");
        at("p(solved)", pn[0], field(s, "p_solved"));
        at("p(solved) low", pn[1], field(s, "p_solved_lo"));
        at("p(solved) high", pn[2], field(s, "p_solved_hi"));
        let gn = numbers(guesses);
        if guesses.starts_with("none seen") {
            assert!(
                s["expected_guesses"].is_empty(),
                "{env} {arch}: a network solved it"
            );
            at("1/p bound", gn[0], field(s, "expected_guesses_lo"));
        } else {
            assert_eq!(gn.len(), 3, "{env} {arch}: 1/p shows {guesses}");
            at("1/p", gn[0], field(s, "expected_guesses"));
            at("1/p low", gn[1], field(s, "expected_guesses_lo"));
            at("1/p high", gn[2], field(s, "expected_guesses_hi"));
        }
        at("wall s", wall_s, wall[&key]);
        assert_eq!(
            field(s, "samples") as u64,
            m.samples,
            "{env} {arch}: samples"
        );
        assert_eq!(
            field(s, "episodes") as u32,
            m.episodes,
            "{env} {arch}: episodes"
        );
        assert!(seen.insert(key.clone()), "docs/atlas.md: {key:?} twice");
    }
    let cells: BTreeSet<(String, String)> = m
        .envs
        .iter()
        .flat_map(|e| {
            m.architectures
                .iter()
                .map(|a| (e.id.clone(), a.name.clone()))
        })
        .collect();
    assert_eq!(
        seen, cells,
        "docs/atlas.md's table and the manifest's cells differ"
    );
}

#[test]
fn the_figures_shown_exist_and_stay_small() {
    let text = doc();
    let mut total = 0;
    let mut shown = 0;
    for part in text.split("](").skip(1) {
        let target = part.split(')').next().unwrap();
        if target.starts_with("http") || target.starts_with('#') {
            continue;
        }
        let path = repo().join("docs").join(target);
        assert!(
            path.exists(),
            "docs/atlas.md links {target}, which does not exist"
        );
        if target.ends_with(".png") {
            total += std::fs::metadata(&path).unwrap().len();
            shown += 1;
        }
    }
    assert!(shown >= 2, "docs/atlas.md shows {shown} figures");
    let mut all = 0;
    for f in std::fs::read_dir(repo().join("docs/atlas")).unwrap() {
        all += f.unwrap().metadata().unwrap().len();
    }
    assert!(all >= total);
    assert!(
        all < 2 << 20,
        "docs/atlas/ holds {all} bytes, keep it under 2 MiB"
    );
}

/// The commands of the doc's ```sh blocks.
fn doc_commands() -> Vec<String> {
    let mut out = vec![];
    let mut in_sh = false;
    for line in doc().lines() {
        if line.starts_with("```") {
            in_sh = !in_sh && line.trim() == "```sh";
            continue;
        }
        if in_sh {
            let cmd = match line.find(" #") {
                Some(i) => &line[..i],
                None => line,
            }
            .trim();
            if !cmd.is_empty() {
                out.push(cmd.to_string());
            }
        }
    }
    out
}

#[test]
fn the_commands_run_as_printed_on_a_tiny_scale() {
    const TEST: &str = "the_commands_run_as_printed_on_a_tiny_scale";
    let commands = doc_commands();
    assert!(
        commands
            .iter()
            .any(|c| c.starts_with("rwg run examples/atlas.toml")),
        "docs/atlas.md prints no `rwg run examples/atlas.toml`: {commands:?}"
    );
    let Some(python) = std::env::var_os("RWG_TEST_PYTHON") else {
        skip(
            TEST,
            "set RWG_TEST_PYTHON to a Python with gymnasium[box2d,mujoco]",
        );
        return;
    };
    let dir = temp_dir("atlas");
    let status = Command::new("cp")
        .arg("-r")
        .arg(repo().join("examples"))
        .arg(&dir)
        .status()
        .unwrap();
    assert!(status.success());
    let bin = dir.join("bin");
    std::fs::create_dir_all(&bin).unwrap();
    std::os::unix::fs::symlink(rwg_bin(), bin.join("rwg")).unwrap();
    let path = format!(
        "{}:{}",
        bin.display(),
        std::env::var("PATH").unwrap_or_default()
    );
    let mut ran = 0;
    for c in &commands {
        if c.starts_with("python3 -m pip install") {
            continue; // provided: RWG_TEST_PYTHON holds the packages
        }
        assert!(
            c.starts_with("rwg "),
            "docs/atlas.md: an unexpected command: {c}"
        );
        let c = if c.starts_with("rwg run ") {
            format!("{c} --samples 2 --episodes 1")
        } else {
            c.clone()
        };
        let t = std::time::Instant::now();
        let out = Command::new("sh")
            .arg("-c")
            .arg(&c)
            .current_dir(&dir)
            .env("PATH", &path)
            .env("RWG_PYTHON", &python)
            .env_remove("RWG_PLUGIN_PATH")
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "docs/atlas.md: `{c}` failed:\n{}\n{}",
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        );
        eprintln!("`{c}`: {:.1} s", t.elapsed().as_secs_f64());
        ran += 1;
    }
    assert!(ran >= 2);
    // the run the commands made is the atlas, cell for cell, with the doc's
    // solved scores
    let run = dir.join("runs/atlas");
    let stats = std::fs::read_to_string(run.join("stats.csv")).unwrap();
    let mut lines = stats.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |k: &str| header.iter().position(|h| *h == k).unwrap();
    let committed = stats_rows();
    let mut n = 0;
    for l in lines {
        let v: Vec<&str> = l.split(',').collect();
        let key = (v[col("env")].to_string(), v[col("arch")].to_string());
        let want = committed
            .get(&key)
            .unwrap_or_else(|| panic!("{key:?} not in the atlas"));
        assert_eq!(v[col("solved")], want["solved"], "{key:?}: solved score");
        n += 1;
    }
    assert_eq!(n, committed.len(), "the tiny run has {n} cells");
    assert!(Path::new(&run.join("report.html")).is_file());
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn table_numbers_are_read_as_shown() {
    assert_eq!(
        numbers("0.0195 [0.0084, 0.0449]"),
        ["0.0195", "0.0084", "0.0449"]
    );
    assert_eq!(numbers("none seen (≥ 97.2)"), ["97.2"]);
    assert!(shows("0.0195", 0.01953));
    assert!(!shows("0.0195", 0.01956));
    assert!(shows("3.84e-4", 0.000383998));
    assert!(!shows("3.84e-4", 0.000385));
    assert!(shows("-140", -140.0));
}
