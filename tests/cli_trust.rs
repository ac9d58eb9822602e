//! What the readers of a run directory (`verify`, `stats`, `top`, `compare`,
//! `report`) trust and what they refuse, end to end: a committed block that
//! is gone, a hand-edited `run.json`, `env.json` under the cell's checksums,
//! a plugin path that is a folder or empty, printed commands a shell runs as
//! printed, and the edges of each command's arguments.

mod common;
use common::*;
use std::path::{Path, PathBuf};
use std::process::Command;

const SMALL: &str = SMALL_STUDY;

fn s(p: &Path) -> &str {
    path_str(p)
}

fn manifest(dir: &Path, name: &str, body: &str) -> PathBuf {
    write_manifest(dir, name, body)
}

/// The cell directories of a run, sorted.
fn cells(run: &Path) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(run.join("cells"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    v.sort();
    v
}

#[test]
fn verify_and_merge_refuse_a_listed_block_whose_file_is_gone() {
    let dir = temp_dir("trust-block-gone");
    let m = manifest(&dir, "m.toml", SMALL);
    let (a, b) = (dir.join("s0"), dir.join("s1"));
    rwg_ok(&["run", s(&m), "--shard", "0/2", "--out", s(&a)]);
    rwg_ok(&["run", s(&m), "--shard", "1/2", "--out", s(&b)]);
    rwg_ok(&["verify", s(&a)]);
    // Shard 0 owns block 0 of the first cell; its line stays in the index.
    let first = cells(&a)[0].join("blocks");
    std::fs::remove_file(first.join("b0000000.csv")).unwrap();
    assert!(std::fs::read_to_string(first.join("SHA256SUMS"))
        .unwrap()
        .contains("b0000000.csv"));
    let text = rwg_fails(&["verify", s(&a)]);
    assert!(
        text.contains("b0000000.csv: missing: listed in"),
        "verify does not name the block:\n{text}"
    );
    // merge says the same of it, in the same words
    let err = rwg_err(&["merge", s(&a), s(&b), "--out", s(&dir.join("merged"))]);
    assert!(err.contains("b0000000.csv: missing: listed in"), "{err}");
}

#[test]
fn env_json_is_listed_in_the_cells_checksums_and_verified() {
    let dir = temp_dir("trust-env-json");
    let run = finished_run(&dir, "r", SMALL);
    let cell = cells(&run)[0].clone();
    let sums = std::fs::read_to_string(cell.join("SHA256SUMS")).unwrap();
    assert!(sums.contains("  env.json\n"), "{sums}");
    let p = cell.join("env.json");
    let text = std::fs::read_to_string(&p).unwrap();
    std::fs::write(&p, text.replace("500", "600")).unwrap();
    let text = rwg_fails(&["verify", s(&run)]);
    assert!(text.contains("env.json: checksum mismatch"), "{text}");
}

/// `run.json` with its `cells` list rewritten by `edit`.
fn edit_cells(run: &Path, edit: impl FnOnce(&mut Vec<serde_json::Value>)) {
    let p = run.join("run.json");
    let mut v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&p).unwrap()).unwrap();
    edit(v["cells"].as_array_mut().unwrap());
    std::fs::write(&p, serde_json::to_string_pretty(&v).unwrap()).unwrap();
}

#[test]
fn a_run_json_listing_a_cell_twice_or_missing_one_is_refused_and_rebuilt() {
    let dir = temp_dir("trust-cell-list");
    let run = finished_run(&dir, "r", SMALL);
    let before =
        std::fs::read_to_string(run.join("cells/CartPole-v1__1HL__nobias/samples.csv")).unwrap();
    edit_cells(&run, |c| {
        let first = c[0].clone();
        c[1] = first;
    });
    for args in [
        vec!["stats", s(&run), "--no-write"],
        vec!["top", s(&run)],
        vec!["verify", s(&run)],
    ] {
        let text = rwg_fails(&args);
        assert!(
            text.contains("lists cell CartPole-v1__0HL__nobias more than once")
                && text.contains("lacks cell CartPole-v1__1HL__nobias")
                && text.contains("the study has 2 cells"),
            "{args:?}:\n{text}"
        );
        assert!(text.contains("--out"), "no way to rebuild:\n{text}");
    }
    edit_cells(&run, |c| {
        c.pop();
    });
    let err = rwg_err(&["stats", s(&run), "--no-write"]);
    assert!(err.contains("lists 1 cell"), "{err}");
    // What the message says rebuilds it.
    std::fs::remove_file(run.join("run.json")).unwrap();
    rwg_ok(&["run", s(&run.join("manifest.toml")), "--out", s(&run)]);
    rwg_ok(&["verify", s(&run)]);
    rwg_ok(&["stats", s(&run), "--no-write"]);
    assert_eq!(
        before,
        std::fs::read_to_string(run.join("cells/CartPole-v1__1HL__nobias/samples.csv")).unwrap()
    );
}

#[test]
fn a_plugin_path_that_is_a_folder_or_empty_says_so_at_its_line() {
    let dir = temp_dir("trust-plugin-path");
    std::fs::create_dir_all(dir.join("some/folder")).unwrap();
    for (value, says) in [
        ("some/folder", "is a directory, not a plugin library"),
        ("", "is empty"),
    ] {
        let body = format!(
            "samples = 32\nepisodes = 1\n[[architectures]]\nname = \"0HL\"\nhidden = []\n\
             [[envs]]\nid = \"acme/Maze-v0\"\nplugin = \"{value}\"\n"
        );
        let m = manifest(&dir, "m.toml", &body);
        let err = rwg_err(&["run", s(&m), "--out", s(&dir.join("out"))]);
        assert!(err.contains(says), "plugin = {value:?}: {err}");
        assert!(!err.contains("no such file"), "plugin = {value:?}: {err}");
        assert!(err.contains("m.toml:8"), "not at its line: {err}");
    }
}

#[test]
fn top_prints_replay_commands_a_shell_runs_as_printed() {
    let dir = temp_dir("trust-top-quoting");
    let body = SMALL
        .replace("samples = 70", "samples = 32")
        .replace("name = \"1HL\"", "name = \"my net\"");
    let run = finished_run(&dir, "my run", &body);
    let out = rwg_ok(&["top", s(&run), "-n", "1"]);
    let line = out
        .lines()
        .find(|l| l.contains("rwg replay") && l.contains("net"))
        .unwrap_or_else(|| panic!("no replay line for 'my net':\n{out}"));
    let cmd = &line[line.find("rwg replay").unwrap()..];
    assert!(cmd.contains("'my net'"), "{cmd}");
    let shell = format!("{} {}", rwg_bin().display(), &cmd["rwg ".len()..]);
    let res = Command::new("sh").args(["-c", &shell]).output().unwrap();
    assert!(
        res.status.success(),
        "{cmd}\n{}",
        String::from_utf8_lossy(&res.stderr)
    );
}

#[test]
fn an_unfinished_run_names_commands_quoted() {
    let dir = temp_dir("trust-unfinished-quoting");
    let run = finished_run(&dir, "my run", SMALL);
    let p = run.join("run.json");
    let mut v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&p).unwrap()).unwrap();
    v["end_time"] = serde_json::Value::Null;
    std::fs::write(&p, serde_json::to_string_pretty(&v).unwrap()).unwrap();
    let err = rwg_err(&["report", s(&run)]);
    let quoted = format!("rwg status '{}'", run.display());
    assert!(err.contains(&quoted), "{err}");
}

#[test]
fn compare_force_names_each_runs_episodes() {
    let dir = temp_dir("trust-compare-episodes");
    let a = finished_run(&dir, "a", SMALL);
    let b = finished_run(&dir, "b", &SMALL.replace("episodes = 3", "episodes = 2"));
    let out = rwg_ok(&["compare", s(&a), s(&b), "--force"]);
    let title = out.lines().find(|l| l.contains("Comparison")).unwrap();
    assert!(
        title.contains("a 3") && title.contains("b 2"),
        "title: {title}\n{out}"
    );
}

#[test]
fn compare_refuses_a_run_given_twice() {
    let dir = temp_dir("trust-compare-twice");
    let a = finished_run(&dir, "a", SMALL);
    let err = rwg_err(&["compare", s(&a), s(&a)]);
    assert!(err.contains("given twice"), "{err}");
    // also when named two ways
    let other = format!("{}/../a", s(&dir.join("a")));
    let err = rwg_err(&["compare", s(&a), &other]);
    assert!(err.contains("given twice"), "{err}");
}

#[test]
fn top_refuses_zero_networks() {
    let dir = temp_dir("trust-top-zero");
    let a = finished_run(&dir, "a", SMALL);
    let err = rwg_err(&["top", s(&a), "-n", "0"]);
    assert!(err.contains("at least 1"), "{err}");
}

#[test]
fn verify_in_the_first_moments_of_a_run_says_it_is_being_started() {
    let dir = temp_dir("trust-verify-start");
    let run = dir.join("r");
    std::fs::create_dir_all(&run).unwrap();
    // A lock left by a process that has ended is no run being started.
    std::fs::write(run.join("rwg.lock"), "pid 999999999: rwg plot r\n").unwrap();
    let err = rwg_err(&["verify", s(&run)]);
    assert!(err.contains("is not a run directory"), "{err}");
    // The lock of a live `rwg run` (this test's pid stands in for it):
    // verify checks what it has committed so far (nothing).
    let record = format!("pid {}: rwg run m.toml --out r\n", std::process::id());
    std::fs::write(run.join("rwg.lock"), &record).unwrap();
    let out = rwg_ok(&["verify", s(&run)]);
    assert!(out.contains("being set up, without run.json yet"), "{out}");
    assert!(out.contains("0 file(s) checked"), "{out}");
    // rwg status says it too (before manifest.toml is written)
    let err = rwg_err(&["status", s(&run)]);
    assert!(err.contains("being started"), "{err}");
    std::fs::remove_file(run.join("rwg.lock")).unwrap();
    std::fs::write(run.join("manifest.toml"), SMALL).unwrap();
    let err = rwg_err(&["verify", s(&run)]);
    assert!(err.contains("being started"), "{err}");
}

#[test]
fn report_into_a_missing_folder_names_the_folder() {
    let dir = temp_dir("trust-report-folder");
    let a = finished_run(&dir, "a", SMALL);
    let target = dir.join("missing/r.html");
    let err = rwg_err(&["report", s(&a), "--out", s(&target)]);
    assert!(!err.contains("r.html.tmp"), "{err}");
    assert!(
        err.contains(&format!("{} does not exist", dir.join("missing").display())),
        "{err}"
    );
}

#[test]
fn stats_on_a_read_only_run_suggests_no_write() {
    let dir = temp_dir("trust-read-only");
    let a = finished_run(&dir, "a", SMALL);
    let ro = match Mounted::read_only(&a, &dir.join("ro")) {
        Ok(m) => m,
        Err(why) => return skip("stats_on_a_read_only_run_suggests_no_write", &why),
    };
    let err = rwg_err(&["stats", s(&ro.0)]);
    assert!(err.contains("--no-write"), "{err}");
    rwg_ok(&["stats", s(&ro.0), "--no-write"]);
    rwg_ok(&["verify", s(&ro.0)]);
    rwg_ok(&["top", s(&ro.0)]);
    let err = rwg_err(&["report", s(&ro.0)]);
    assert!(err.contains("--out"), "{err}");
}
