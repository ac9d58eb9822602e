//! `non_finite = "end"` end to end with the real `rwg` binary: an episode
//! that meets a value that is not finite (a plugin's NaN observation or
//! reward, a built-in env's network output that overflows) ends there,
//! flagged in `scores.csv`, counted in `samples.csv`, `cell.json`,
//! `stats.csv` and `stats.json`; every reader takes the files; the bytes
//! do not depend on threads, shards and merge, resume, or isolation; the
//! default (`stop`) writes no new column or file.

mod common;
use common::*;
use std::path::Path;
use std::process::Command;

/// Built-in envs whose networks' outputs overflow now and then (weights of
/// scale 1e307 into 64 hidden units: an output is a sum of 65 such terms),
/// and a plugin env whose reward turns NaN at step 2.
fn study(samples: u64) -> String {
    format!(
        "samples = {samples}\nepisodes = 2\nbias = [true]\n[weights]\nscale = 1e307\n\
         [[architectures]]\nname = \"1HL\"\nhidden = [64]\n\
         [[envs]]\nid = \"CartPole-v1\"\nnon_finite = \"end\"\n\
         [[envs]]\nid = \"Pendulum-v1\"\nnon_finite = \"end\"\n\
         [[envs]]\nid = \"broken/NaNReward-v0\"\nplugin = \"{}\"\nnon_finite = \"end\"\n",
        broken_plugin().display()
    )
}

const CELLS: [&str; 3] = [
    "CartPole-v1__1HL__bias",
    "Pendulum-v1__1HL__bias",
    "broken+NaNReward-v0__1HL__bias",
];

fn read(p: &Path) -> String {
    std::fs::read_to_string(p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

/// The result files of a run whose bytes must not depend on how it ran
/// (`stats.csv` written by `rwg stats`).
fn results(run: &Path) -> Vec<(String, Vec<u8>)> {
    rwg_ok(&["stats", path_str(run), "--format", "csv"]);
    let mut out = vec![];
    for c in CELLS {
        for f in ["scores.csv", "samples.csv"] {
            let p = run.join("cells").join(c).join(f);
            out.push((format!("{c}/{f}"), std::fs::read(&p).unwrap()));
        }
    }
    out.push((
        "stats.csv".into(),
        std::fs::read(run.join("stats.csv")).unwrap(),
    ));
    out
}

/// Each flagged cell's rows: (score, steps, flag) per episode.
fn rows(run: &Path, cell: &str) -> Vec<(f64, u32, u8)> {
    let text = read(&run.join("cells").join(cell).join("scores.csv"));
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some("sample,episode,score,steps,non_finite"));
    lines
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            (
                f[2].parse().unwrap(),
                f[3].parse().unwrap(),
                f[4].parse().unwrap(),
            )
        })
        .collect()
}

#[test]
fn episodes_meeting_values_not_finite_end_flagged_and_every_reader_takes_them() {
    let dir = temp_dir("non-finite-end");
    let m = write_manifest(&dir, "m.toml", &study(64));
    let run = dir.join("run");
    rwg_ok(&["run", path_str(&m), "--out", path_str(&run)]);
    let mut counts = vec![];
    for cell in CELLS {
        let rows = rows(&run, cell);
        let cut = rows.iter().filter(|r| r.2 == 1).count();
        assert!(rows.iter().all(|r| r.2 <= 1 && r.0.is_finite()), "{cell}");
        counts.push(cut);
        // samples.csv counts each network's flagged episodes
        let samples = read(&run.join("cells").join(cell).join("samples.csv"));
        assert!(samples.starts_with("sample,mean,variance,std,min,max,rank,non_finite\n"));
        let per_net: usize = samples
            .lines()
            .skip(1)
            .map(|l| l.rsplit(',').next().unwrap().parse::<usize>().unwrap())
            .sum();
        assert_eq!(per_net, cut, "{cell}");
        let json = read(&run.join("cells").join(cell).join("cell.json"));
        assert!(
            json.contains(&format!("\"non_finite_episodes\": {cut}")),
            "{json}"
        );
    }
    // built-in envs: a mix of cut and whole episodes, some cut before their
    // first step; the plugin's NaN reward at step 2 cuts every episode (there,
    // with the reward of step 1, unless the network's output overflowed first)
    let cart = rows(&run, CELLS[0]);
    assert!(counts[0] > 0 && counts[0] < cart.len(), "{counts:?}");
    assert!(
        cart.iter().any(|r| r.2 == 1 && r.1 == 0),
        "none cut before a step"
    );
    let nan = rows(&run, CELLS[2]);
    assert!(
        nan.iter().all(|r| r.2 == 1 && (r.1 < 2 || r.0 == 1.0)),
        "{nan:?}"
    );
    assert!(nan.iter().any(|r| r.1 == 2), "{nan:?}");
    // stats.csv: the count after the usual columns
    let stats = read(&run.join("stats.csv"));
    let mut lines = stats.lines();
    let header = lines.next().unwrap();
    assert!(header.ends_with(",max_episode_length,non_finite_episodes"));
    let last: Vec<&str> = lines.map(|l| l.rsplit(',').next().unwrap()).collect();
    let want: Vec<String> = counts.iter().map(|c| c.to_string()).collect();
    assert_eq!(last, want);
    assert!(read(&run.join("stats.json")).contains("\"non_finite_episodes\""));
    assert!(read(&run.join("report.html")).contains("non-finite"));
    // the readers
    rwg_ok(&["verify", path_str(&run)]);
    assert!(rwg_ok(&["status", path_str(&run)]).contains("The run is complete"));
    let stats = rwg_ok(&["stats", path_str(&run)]);
    assert!(stats.contains("ended at a value not finite"), "{stats}");
    let top = rwg_ok(&["top", path_str(&run)]);
    assert!(top.contains("non-finite"), "{top}");
    rwg_ok(&["report", path_str(&run)]);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_cell_with_the_default_keeps_its_files_beside_a_flagged_one() {
    let dir = temp_dir("non-finite-default");
    let head = "samples = 40\nepisodes = 2\n[[architectures]]\nname = \"0HL\"\nhidden = []\n\
                [[envs]]\nid = \"CartPole-v1\"\n";
    let alone = finished_run(&dir, "alone", head);
    let nan = format!(
        "[[envs]]\nid = \"broken/NaNObservation-v0\"\nplugin = \"{}\"\nnon_finite = \"end\"\n",
        broken_plugin().display()
    );
    let both = finished_run(&dir, "both", &format!("{head}{nan}"));
    rwg_ok(&["stats", path_str(&alone)]);
    rwg_ok(&["stats", path_str(&both)]);
    let cart = "cells/CartPole-v1__0HL__nobias";
    for f in ["scores.csv", "samples.csv"] {
        let (a, b) = (alone.join(cart).join(f), both.join(cart).join(f));
        assert_eq!(read(&a), read(&b), "{f}");
    }
    assert!(!read(&both.join(cart).join("cell.json")).contains("non_finite"));
    // stats.csv: the default cell's count is empty; without a flagged cell
    // there is no such column
    let stats = read(&both.join("stats.csv"));
    let last: Vec<&str> = stats
        .lines()
        .map(|l| l.rsplit(',').next().unwrap())
        .collect();
    assert_eq!(last, ["non_finite_episodes", "", "80"]);
    assert!(!read(&alone.join("stats.csv")).contains("non_finite"));
    // the NaN observation of step 2 ends each episode there, with the reward
    // of step 1 (the step's own reward is left out)
    let nan_cell = both.join("cells/broken+NaNObservation-v0__0HL__nobias");
    let scores = read(&nan_cell.join("scores.csv"));
    assert!(
        scores.lines().skip(1).all(|l| l.ends_with(",1.0,2,1")),
        "{scores}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn flagged_files_are_the_same_bytes_whatever_the_threads_shards_resume_or_isolation() {
    let dir = temp_dir("non-finite-bytes");
    let m = write_manifest(&dir, "m.toml", &study(100));
    let m = path_str(&m);
    let one = dir.join("one");
    rwg_ok(&[
        "run",
        m,
        "--out",
        path_str(&one),
        "--threads",
        "1",
        "--no-report",
    ]);
    let two = dir.join("two");
    rwg_ok(&[
        "run",
        m,
        "--out",
        path_str(&two),
        "--threads",
        "2",
        "--no-report",
    ]);
    assert!(results(&one) == results(&two), "threads change the bytes");
    // shards and merge
    let shards: Vec<String> = (0..3)
        .map(|k| {
            let d = path_str(&dir.join(format!("s{k}"))).to_string();
            rwg_ok(&["run", m, "--shard", &format!("{k}/3"), "--out", &d]);
            d
        })
        .collect();
    let merged = dir.join("merged");
    let mut args = vec!["merge"];
    args.extend(shards.iter().map(String::as_str));
    args.extend(["--out", path_str(&merged), "--no-report"]);
    rwg_ok(&args);
    assert!(
        results(&one) == results(&merged),
        "shards and merge change the bytes"
    );
    // isolated: the plugin's cell in worker processes
    let iso = dir.join("iso");
    rwg_ok(&[
        "run",
        m,
        "--out",
        path_str(&iso),
        "--isolate",
        "--no-report",
    ]);
    assert!(
        results(&one) == results(&iso),
        "isolation changes the bytes"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_flagged_run_stopped_by_ctrl_c_resumes_to_the_same_bytes() {
    let dir = temp_dir("non-finite-resume");
    let m = write_manifest(&dir, "m.toml", &study(320));
    let run = dir.join("run");
    let mut cmd = Command::new(rwg_bin());
    cmd.args(["run", path_str(&m), "--out", path_str(&run), "--no-report"])
        .env("RWG_COMMIT_LINGER", "0");
    ctrl_c_after_first_block(cmd, &run.join("cells").join(CELLS[0]).join("blocks"));
    rwg_ok(&["run", path_str(&m), "--out", path_str(&run), "--no-report"]);
    let whole = dir.join("whole");
    rwg_ok(&[
        "run",
        path_str(&m),
        "--out",
        path_str(&whole),
        "--no-report",
    ]);
    assert!(
        results(&run) == results(&whole),
        "a resume changes the bytes"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn the_choice_is_checked_at_its_line_part_of_the_study_and_named_when_stopping() {
    let dir = temp_dir("non-finite-manifest");
    let body = "samples = 8\nepisodes = 1\n[[architectures]]\nname = \"0HL\"\nhidden = []\n\
                [[envs]]\nid = \"broken/NaNObservation-v0\"\nplugin = \"PLUGIN\"\n"
        .replace("PLUGIN", path_str(&broken_plugin()));
    let bad = write_manifest(&dir, "bad.toml", &format!("{body}non_finite = \"skip\"\n"));
    let err = rwg_err(&["run", path_str(&bad), "--out", path_str(&dir.join("bad"))]);
    assert!(err.contains("bad.toml:9:"), "{err}");
    assert!(
        err.contains("envs[0].non_finite: 'skip' is not a choice"),
        "{err}"
    );
    // the default stops, naming the episode and the way out
    let stop = write_manifest(&dir, "stop.toml", &body);
    let run = dir.join("run");
    let err = rwg_err(&["run", path_str(&stop), "--out", path_str(&run)]);
    assert!(err.contains("sample 0, episode 0, step 2: "), "{err}");
    assert!(err.contains("non-finite observation"), "{err}");
    // a rerun with the choice changed is another study
    let end = write_manifest(&dir, "end.toml", &format!("{body}non_finite = \"end\"\n"));
    let err = rwg_err(&["run", path_str(&end), "--out", path_str(&run)]);
    assert!(err.contains("non_finite"), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}
