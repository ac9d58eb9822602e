//! `rwg merge` writes the whole run (stats, figures, report.html) and an
//! interrupted merge into the same --out is finished by running it again;
//! `rwg status` reports runs, shards and interrupted merges.

mod common;
use common::*;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Duration;

const STUDY: &str = r#"
seed = 11
samples = 100
episodes = 3
bias = [false, true]
[[architectures]]
name = "0HL"
hidden = []
[[envs]]
id = "CartPole-v1"
[[envs]]
id = "Acrobot-v1"
max_episode_steps = 100
"#;

struct Study {
    dir: PathBuf,
    whole: PathBuf,
    shards: Vec<String>,
}

/// The study run whole and in three shards.
fn study(name: &str) -> Study {
    let dir = temp_dir(name);
    let manifest = dir.join("study.toml");
    std::fs::write(&manifest, STUDY).unwrap();
    let manifest = manifest.to_str().unwrap().to_string();
    let whole = dir.join("whole");
    rwg_ok(&["run", &manifest, "--out", whole.to_str().unwrap()]);
    let shards: Vec<String> = (0..3)
        .map(|k| {
            let d = dir.join(format!("s{k}")).to_str().unwrap().to_string();
            rwg_ok(&["run", &manifest, "--shard", &format!("{k}/3"), "--out", &d]);
            d
        })
        .collect();
    Study { dir, whole, shards }
}

fn merge_args<'a>(s: &'a Study, out: &'a str) -> Vec<&'a str> {
    let mut a = vec!["merge"];
    a.extend(s.shards.iter().map(|d| d.as_str()));
    a.extend(["--out", out]);
    a
}

/// Every result file (not timing metadata), by relative path.
fn results(run: &Path) -> Vec<(String, Vec<u8>)> {
    let mut files = vec![];
    let mut cells: Vec<_> = std::fs::read_dir(run.join("cells"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    cells.sort();
    for c in &cells {
        assert!(!c.join("blocks").exists(), "{}: blocks left", c.display());
        for f in ["scores.csv", "samples.csv"] {
            files.push((
                format!("{}/{f}", c.file_name().unwrap().to_string_lossy()),
                std::fs::read(c.join(f)).unwrap_or_else(|e| panic!("{}/{f}: {e}", c.display())),
            ));
        }
    }
    assert_eq!(cells.len(), 4);
    for f in ["manifest.toml", "stats.csv"] {
        files.push((f.into(), std::fs::read(run.join(f)).unwrap()));
    }
    let mut figures: Vec<_> = std::fs::read_dir(run.join("figures"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    figures.sort();
    assert!(!figures.is_empty());
    for f in figures {
        files.push((
            format!("figures/{}", f.file_name().unwrap().to_string_lossy()),
            std::fs::read(&f).unwrap(),
        ));
    }
    assert!(run.join("report.html").is_file());
    files
}

fn assert_same(a: &Path, b: &Path) {
    let (ra, rb) = (results(a), results(b));
    assert_eq!(
        ra.iter().map(|f| &f.0).collect::<Vec<_>>(),
        rb.iter().map(|f| &f.0).collect::<Vec<_>>()
    );
    for ((name, x), (_, y)) in ra.iter().zip(&rb) {
        assert!(
            x == y,
            "{name} differs between {} and {}",
            a.display(),
            b.display()
        );
    }
}

#[test]
fn merge_writes_stats_figures_and_report_like_run() {
    let s = study("merge-report");
    let out = s.dir.join("merged");
    let text = rwg_ok(&merge_args(&s, out.to_str().unwrap()));
    assert!(text.contains("Report: "), "{text}");
    assert_same(&s.whole, &out);
    assert!(out.join("stats.json").is_file());
    // Again: complete, nothing to do, nothing changed.
    let before = results(&out);
    let text = rwg_ok(&merge_args(&s, out.to_str().unwrap()));
    assert!(
        text.contains("merged and complete; nothing to do"),
        "{text}"
    );
    assert_eq!(before, results(&out));
    // --no-report
    let bare = s.dir.join("bare");
    let mut a = merge_args(&s, bare.to_str().unwrap());
    a.push("--no-report");
    rwg_ok(&a);
    assert!(!bare.join("report.html").exists() && !bare.join("stats.csv").exists());
    // A complete run without a report gets one from a rerun of merge.
    rwg_ok(&merge_args(&s, bare.to_str().unwrap()));
    assert_same(&s.whole, &bare);
    // Another study, or a shard, in --out is refused.
    let err = rwg_err(&merge_args(&s, s.shards[1].as_str()));
    assert!(err.contains("holds shard 1/3 of the study"), "{err}");
    let other = s.dir.join("other");
    let m2 = s.dir.join("other.toml");
    std::fs::write(&m2, STUDY.replace("seed = 11", "seed = 12")).unwrap();
    rwg_ok(&[
        "run",
        m2.to_str().unwrap(),
        "--out",
        other.to_str().unwrap(),
        "--samples",
        "100",
        "--no-report",
    ]);
    let err = rwg_err(&merge_args(&s, other.to_str().unwrap()));
    assert!(
        err.contains("already holds a different study (seed: 12 vs 11)"),
        "{err}"
    );
}

#[test]
fn an_interrupted_merge_is_finished_by_running_it_again() {
    let s = study("merge-resume");
    // The state a merge killed mid-cell leaves: manifest, a run.json without
    // end time, one cell finalised with its blocks not yet removed, one cell
    // with some blocks and a partial temporary file. (Checksum indexes are
    // copied with the files: what is not listed there is not committed.)
    let full = s.dir.join("full");
    let mut a = merge_args(&s, full.to_str().unwrap());
    a.push("--no-report");
    rwg_ok(&a);
    let out = s.dir.join("resumed");
    std::fs::create_dir_all(out.join("cells")).unwrap();
    std::fs::copy(full.join("manifest.toml"), out.join("manifest.toml")).unwrap();
    let first = "CartPole-v1__0HL__nobias";
    let copy = |from: &Path, to: &Path| {
        std::fs::create_dir_all(to.parent().unwrap()).unwrap();
        std::fs::copy(from, to).unwrap();
    };
    for f in [
        "scores.csv",
        "samples.csv",
        "cell.json",
        "env.json",
        "SHA256SUMS",
    ] {
        copy(
            &full.join("cells").join(first).join(f),
            &out.join("cells").join(first).join(f),
        );
    }
    copy(
        &Path::new(&s.shards[0])
            .join("cells")
            .join(first)
            .join("blocks/b0000000.csv"),
        &out.join("cells").join(first).join("blocks/b0000000.csv"),
    );
    copy(
        &Path::new(&s.shards[0])
            .join("cells")
            .join(first)
            .join("blocks/SHA256SUMS"),
        &out.join("cells").join(first).join("blocks/SHA256SUMS"),
    );
    let second = out.join("cells/CartPole-v1__0HL__bias/blocks");
    std::fs::create_dir_all(&second).unwrap();
    // global block 4 (cell 1, block 0) belongs to shard 1
    copy(
        &Path::new(&s.shards[1]).join("cells/CartPole-v1__0HL__bias/blocks/b0000000.csv"),
        &second.join("b0000000.csv"),
    );
    copy(
        &Path::new(&s.shards[1]).join("cells/CartPole-v1__0HL__bias/blocks/SHA256SUMS"),
        &second.join("SHA256SUMS"),
    );
    std::fs::write(second.join("b0000001.csv.tmp"), "1,0,12.0").unwrap();
    let status = rwg_ok(&["status", out.to_str().unwrap()]);
    assert!(
        status.contains("The run is incomplete: 1 of 4 cells done, 5 of 16 blocks"),
        "{status}"
    );
    assert!(
        status
            .contains("CartPole-v1__0HL__bias                                   1/4  in progress"),
        "{status}"
    );
    let text = rwg_ok(&merge_args(&s, out.to_str().unwrap()));
    assert!(
        text.contains("(1 cells were merged by an earlier, interrupted merge)"),
        "{text}"
    );
    assert_same(&s.whole, &out);
    assert!(!second.join("b0000001.csv.tmp").exists() || !second.exists());

    // SIGKILL at several points of a merge (once it has started writing),
    // then run it again.
    let mut interrupted = 0;
    for (i, ms) in [0u64, 10, 40, 100, 250].iter().enumerate() {
        let out = s.dir.join(format!("killed{i}"));
        let mut child = Command::new(rwg_bin())
            .args(merge_args(&s, out.to_str().unwrap()))
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap();
        while !out.join("manifest.toml").exists() && child.try_wait().unwrap().is_none() {
            std::thread::sleep(Duration::from_millis(1));
        }
        std::thread::sleep(Duration::from_millis(*ms));
        let _ = child.kill();
        child.wait().unwrap();
        if !out.join("report.html").exists() {
            interrupted += 1;
        }
        rwg_ok(&merge_args(&s, out.to_str().unwrap()));
        assert_same(&s.whole, &out);
    }
    assert!(
        interrupted >= 3,
        "only {interrupted} of 5 kills landed mid-merge"
    );
}

#[test]
fn status_of_runs_and_shards_names_the_command_that_finishes_them() {
    let dir = temp_dir("status");
    let manifest = dir.join("study.toml");
    std::fs::write(&manifest, STUDY).unwrap();
    let m = manifest.to_str().unwrap();
    let shard = dir.join("s1");
    rwg_ok(&["run", m, "--shard", "1/3", "--out", shard.to_str().unwrap()]);
    let status = rwg_ok(&["status", shard.to_str().unwrap()]);
    assert!(
        status.contains("shard 1/3 of a study (4 cells, 100 networks x 3 episodes"),
        "{status}"
    );
    // 16 blocks; shard 1 owns global blocks 1, 4, 7, 10, 13: cells 0..3 hold 1, 2, 1, 1
    assert!(
        status.contains("CartPole-v1__0HL__bias                                   2/2  complete"),
        "{status}"
    );
    assert!(
        status.contains("The shard is complete: 4 of 4 cells done, 5 of 5 blocks"),
        "{status}"
    );
    assert!(status.contains("rwg merge DIR... --out DIR"), "{status}");
    // A whole run, stopped after two blocks of its first cell.
    let run = dir.join("run");
    rwg_ok(&["run", m, "--out", run.to_str().unwrap(), "--no-report"]);
    let c0 = run.join("cells/CartPole-v1__0HL__nobias");
    for f in ["scores.csv", "samples.csv", "cell.json", "SHA256SUMS"] {
        std::fs::remove_file(c0.join(f)).unwrap();
    }
    std::fs::create_dir_all(c0.join("blocks")).unwrap();
    // (committed: each listed in the block index with its SHA-256)
    let mut index = String::new();
    for b in 0..2 {
        std::fs::write(c0.join(format!("blocks/b000000{b}.csv")), "").unwrap();
        index.push_str(&format!(
            "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855  b000000{b}.csv\n"
        ));
    }
    std::fs::write(c0.join("blocks/SHA256SUMS"), index).unwrap();
    let status = rwg_ok(&["status", run.to_str().unwrap()]);
    assert!(
        status.contains("a run of the whole study (4 cells"),
        "{status}"
    );
    assert!(
        status
            .contains("CartPole-v1__0HL__nobias                                 2/4  in progress"),
        "{status}"
    );
    assert!(
        status.contains("The run is incomplete: 3 of 4 cells done, 14 of 16 blocks"),
        "{status}"
    );
    let finish = format!(
        "rwg run {}/manifest.toml --out {}",
        run.display(),
        run.display()
    );
    assert!(status.contains(&finish), "{status}");
    let err = rwg_err(&["status", dir.to_str().unwrap()]);
    assert!(err.contains("is not an rwg run directory"), "{err}");

    // Shards in DIR/shards/<K> without rwg slurm (a Kubernetes Indexed Job's
    // layout): shard 1 done, shard 0 stopped early, shard 2 never started.
    let study = dir.join("k8s");
    let shard_dir = |k: u64| study.join("shards").join(k.to_string());
    rwg_ok(&[
        "run",
        m,
        "--shard",
        "1/3",
        "--out",
        shard_dir(1).to_str().unwrap(),
    ]);
    rwg_ok(&[
        "run",
        m,
        "--shard",
        "0/3",
        "--out",
        shard_dir(0).to_str().unwrap(),
    ]);
    let blocks = shard_dir(0).join("cells/Acrobot-v1__0HL__bias/blocks");
    let last = std::fs::read_dir(&blocks)
        .unwrap()
        .map(|e| e.unwrap().path())
        .find(|p| p.extension().is_some_and(|x| x == "csv"))
        .unwrap();
    std::fs::remove_file(last).unwrap();
    // as a run stopped early leaves it: no end time
    let meta = shard_dir(0).join("run.json");
    let mut v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&meta).unwrap()).unwrap();
    v["end_time"] = serde_json::Value::Null;
    std::fs::write(&meta, v.to_string()).unwrap();
    let status = rwg_ok(&["status", study.to_str().unwrap()]);
    assert!(
        status.contains("a study in 3 shards (4 cells, 100 networks x 3 episodes)"),
        "{status}"
    );
    assert!(
        status.contains("incomplete: 5 of 6 blocks, 3 of 4 cells"),
        "{status}"
    );
    assert!(status.contains("complete (5 blocks)"), "{status}");
    assert!(status.contains("missing (not started)"), "{status}");
    assert!(
        status.contains("Merged run") && status.contains("not started"),
        "{status}"
    );
    assert!(!status.contains("rwg slurm"), "{status}");
    // The printed commands finish the study, as printed.
    let cmds: Vec<&str> = status
        .lines()
        .skip_while(|l| !l.starts_with("Finish it with:"))
        .skip(1)
        .map(|l| l.trim())
        .collect();
    assert_eq!(cmds.len(), 3, "{status}");
    assert!(
        cmds[0].contains("--shard 0/3") && cmds[1].contains("--shard 2/3"),
        "{status}"
    );
    let bin = rwg_bin().parent().unwrap().to_path_buf();
    let path = format!(
        "{}:{}",
        bin.display(),
        std::env::var("PATH").unwrap_or_default()
    );
    for c in &cmds {
        let o = Command::new("sh")
            .args(["-c", c])
            .env("PATH", &path)
            .output()
            .unwrap();
        assert!(
            o.status.success(),
            "{c}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
    }
    let status = rwg_ok(&["status", study.to_str().unwrap()]);
    assert!(status.contains(": complete"), "{status}");
    let whole = dir.join("whole");
    rwg_ok(&["run", m, "--out", whole.to_str().unwrap()]);
    assert_same(&whole, &study);
}

#[test]
fn block_rows_no_episode_can_have_are_refused_though_their_digest_matches() {
    let dir = temp_dir("merge-bad-rows");
    let manifest = dir.join("study.toml");
    std::fs::write(
        &manifest,
        "seed = 2\nsamples = 64\nepisodes = 2\nbias = [false]\n\
         [[architectures]]\nname = \"0HL\"\nhidden = []\n\
         [[envs]]\nid = \"CartPole-v1\"\nmax_episode_steps = 50\n",
    )
    .unwrap();
    let manifest = manifest.to_str().unwrap();
    let shards: Vec<String> = (0..2)
        .map(|k| {
            let d = dir.join(format!("s{k}")).to_str().unwrap().to_string();
            rwg_ok(&["run", manifest, "--shard", &format!("{k}/2"), "--out", &d]);
            d
        })
        .collect();
    let blocks = dir.join("s0/cells/CartPole-v1__0HL__nobias/blocks");
    let block = blocks.join("b0000000.csv");
    let good = std::fs::read_to_string(&block).unwrap();
    for (k, (row, want)) in [
        (
            "0,1,NaN,9",
            "b0000000.csv:2: score NaN is not a finite number",
        ),
        (
            "0,1,9.0,51",
            "b0000000.csv:2: 51 steps: an episode of this cell lasts 1 to 50",
        ),
        ("0,1,0.0,0", "b0000000.csv:2: 0 steps"),
    ]
    .into_iter()
    .enumerate()
    {
        let mut lines: Vec<&str> = good.lines().collect();
        lines[1] = row;
        std::fs::write(&block, lines.join("\n") + "\n").unwrap();
        reindex(&blocks, "b0000000.csv");
        let out = dir.join(format!("merged{k}"));
        let err = rwg_err(&[
            "merge",
            &shards[0],
            &shards[1],
            "--out",
            out.to_str().unwrap(),
        ]);
        assert!(err.contains(want), "{row}: {err}");
        assert!(!out
            .join("cells/CartPole-v1__0HL__nobias/scores.csv")
            .exists());
    }
    std::fs::write(&block, &good).unwrap();
    reindex(&blocks, "b0000000.csv");
    let out = dir.join("merged");
    rwg_ok(&[
        "merge",
        &shards[0],
        &shards[1],
        "--out",
        out.to_str().unwrap(),
    ]);
}

#[test]
fn an_edited_manifest_in_a_shard_or_the_merged_run_is_refused() {
    let s = study("merge-edited");
    let out = s.dir.join("merged");
    let o = out.to_str().unwrap();
    rwg_ok(&merge_args(&s, o));
    for dir in [PathBuf::from(&s.shards[1]), out.clone()] {
        let manifest = dir.join("manifest.toml");
        let good = std::fs::read_to_string(&manifest).unwrap();
        std::fs::write(&manifest, good.replace("seed = 11", "seed = 12")).unwrap();
        let err = rwg_err(&merge_args(&s, o));
        assert!(
            err.contains(&format!(
                "{} was changed after rwg wrote it (seed: 11 vs 12",
                manifest.display()
            )),
            "{err}"
        );
        std::fs::write(&manifest, good).unwrap();
    }
    rwg_ok(&merge_args(&s, o));
}
