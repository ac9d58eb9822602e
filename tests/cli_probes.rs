//! The run directory at its edges, end to end: readers while a merge
//! writes, a clock stepped back, a file system out of inodes or read-only,
//! symbolic links for cell directories, a huge `run.json`, a `SHA256SUMS`
//! with CRLF line endings, stray directories, cells of constant score, and
//! what `rwg status`/`verify` need in memory as a study grows.

mod common;
use common::*;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

const SMALL: &str = SMALL_STUDY;

fn s(p: &Path) -> &str {
    path_str(p)
}

fn manifest(dir: &Path, name: &str, body: &str) -> PathBuf {
    write_manifest(dir, name, body)
}

fn text(out: &Output) -> String {
    output_text(out)
}

#[test]
fn readers_during_a_merge_see_a_run_in_progress_or_the_merged_run() {
    let dir = temp_dir("probe-merge-readers");
    let body = SMALL
        .replace("samples = 70", "samples = 640")
        .replace("bias = [false]", "bias = [false, true]");
    let m = manifest(&dir, "m.toml", &body);
    let shards: Vec<PathBuf> = (0..2).map(|k| dir.join(format!("s{k}"))).collect();
    for (k, d) in shards.iter().enumerate() {
        rwg_ok(&["run", s(&m), "--shard", &format!("{k}/2"), "--out", s(d)]);
    }
    let out = dir.join("merged");
    let mut merge = Command::new(rwg_bin())
        .args(["merge", s(&shards[0]), s(&shards[1]), "--out", s(&out)])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut seen = 0;
    while merge.try_wait().unwrap().is_none() {
        for args in [
            vec!["stats", s(&out), "--no-write"],
            vec!["verify", s(&out)],
            vec!["status", s(&out)],
        ] {
            let o = rwg(&args);
            let t = text(&o);
            seen += 1;
            assert!(!t.contains("panicked"), "{args:?}: {t}");
            if !o.status.success() {
                // What a reader may say of a merge under way, never a crash.
                assert!(
                    t.contains("in progress")
                        || t.contains("being started")
                        || t.contains("no such directory")
                        || t.contains("is empty: no run is written there yet")
                        || t.contains("not a run directory")
                        || t.contains("no run.json"),
                    "{args:?} during the merge: {t}"
                );
            }
        }
    }
    assert!(merge.wait().unwrap().success());
    assert!(seen > 0);
    for args in [
        vec!["stats", s(&out), "--no-write"],
        vec!["verify", s(&out)],
        vec!["status", s(&out)],
    ] {
        rwg_ok(&args);
    }
}

#[test]
fn a_lock_held_by_a_writer_stops_no_reader() {
    let dir = temp_dir("probe-held-lock");
    let run = finished_run(&dir, "r", SMALL);
    // Another process holding the writers' lock, as a writer of the run does.
    let mut holder = Command::new("flock")
        .args([s(&run.join("rwg.lock")), "sleep", "30"])
        .spawn();
    let Ok(holder) = holder.as_mut() else {
        return skip("a_lock_held_by_a_writer_stops_no_reader", "no flock(1)");
    };
    std::thread::sleep(std::time::Duration::from_millis(300));
    for args in [
        vec!["stats", s(&run), "--no-write"],
        vec!["verify", s(&run)],
        vec!["status", s(&run)],
        vec!["top", s(&run), "-n", "1"],
    ] {
        rwg_ok(&args);
    }
    let err = rwg_err(&["stats", s(&run)]);
    assert!(
        err.contains("being written by another rwg process"),
        "{err}"
    );
    assert!(err.contains("--no-write"), "{err}");
    holder.kill().unwrap();
    let _ = holder.wait();
}

#[test]
fn an_end_time_before_the_start_time_changes_no_result() {
    let dir = temp_dir("probe-clock");
    let run = finished_run(&dir, "r", SMALL);
    let before = rwg_ok(&["stats", s(&run), "--no-write", "--format", "csv"]);
    let p = run.join("run.json");
    let mut v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&p).unwrap()).unwrap();
    v["end_time"] = "2001-01-01T00:00:00Z".into(); // the clock was stepped back
    std::fs::write(&p, serde_json::to_string_pretty(&v).unwrap()).unwrap();
    rwg_ok(&["verify", s(&run)]);
    let after = rwg_ok(&["stats", s(&run), "--no-write", "--format", "csv"]);
    let cells = |t: &str| t.lines().map(|l| l.to_string()).collect::<Vec<_>>();
    assert_eq!(cells(&before).len(), cells(&after).len());
    rwg_ok(&["report", s(&run)]);
    let html = std::fs::read_to_string(run.join("report.html")).unwrap();
    assert!(
        html.contains("2001-01-01T00:00:00Z"),
        "the end time as recorded"
    );
}

#[test]
fn a_file_system_out_of_inodes_is_named_and_the_run_resumes_once_freed() {
    let dir = temp_dir("probe-inodes");
    let disk = dir.join("disk");
    std::fs::create_dir_all(&disk).unwrap();
    if let Err(why) = mount(&[
        "-t",
        "tmpfs",
        "-o",
        "size=50m,nr_inodes=40",
        "tmpfs",
        s(&disk),
    ]) {
        return skip("a_file_system_out_of_inodes_...", &why);
    }
    let _m = Mounted(disk.clone());
    let m = manifest(
        &dir,
        "m.toml",
        &SMALL.replace("samples = 70", "samples = 640"),
    );
    let out = disk.join("r");
    let t = rwg_fails(&["run", s(&m), "--shard", "0/1", "--out", s(&out)]);
    assert!(t.contains("No space left on device"), "{t}");
    assert!(t.contains("resume with"), "{t}");
    rwg_ok(&["verify", s(&out)]);
    rwg_ok(&["status", s(&out)]);
    mount(&["-o", "remount,nr_inodes=10000", s(&disk)]).unwrap();
    rwg_ok(&["run", s(&m), "--shard", "0/1", "--out", s(&out)]);
    let v = rwg_ok(&["verify", s(&out)]);
    assert!(!v.contains("uncommitted"), "{v}");
}

/// Peak RSS in KiB of `rwg args`, by GNU time, and whether it succeeded;
/// `None` without GNU time.
fn peak_rss_kib(args: &[&str]) -> Option<(u64, bool)> {
    let o = Command::new("/usr/bin/time")
        .args(["-f", "RSS %M"])
        .arg(rwg_bin())
        .args(args)
        .output()
        .ok()?;
    let e = String::from_utf8_lossy(&o.stderr);
    let kib = e
        .lines()
        .rev()
        .find_map(|l| l.strip_prefix("RSS ")?.trim().parse().ok())?;
    Some((kib, o.status.success()))
}

/// [`peak_rss_kib`] of three runs: the median, and whether every run succeeded.
fn median_peak_rss_kib(args: &[&str]) -> Option<(u64, bool)> {
    let mut runs = (0..3)
        .map(|_| peak_rss_kib(args))
        .collect::<Option<Vec<_>>>()?;
    runs.sort();
    Some((runs[1].0, runs.iter().all(|r| r.1)))
}

#[test]
fn status_and_verify_need_little_memory_per_committed_block() {
    // A shard keeps its blocks: 250 and then 4000 of them in one cell (a peak
    // RSS moves by a few hundred KiB from run to run: the blocks' difference
    // must stand well above that, and each figure is the median of three runs).
    let dir = temp_dir("probe-memory");
    let mut rss = vec![];
    for n in [8000u64, 128000] {
        let body = format!(
            "seed = 1\nsamples = {n}\nepisodes = 1\nbias = [false]\n[[architectures]]\n\
             name = \"0HL\"\nhidden = []\n[[envs]]\nid = \"CartPole-v1\"\nmax_episode_steps = 10\n"
        );
        let m = manifest(&dir, &format!("m{n}.toml"), &body);
        let out = dir.join(format!("s{n}"));
        rwg_ok(&["run", s(&m), "--shard", "0/1", "--out", s(&out)]);
        let (Some((st, st_ok)), Some((v, v_ok))) = (
            median_peak_rss_kib(&["status", s(&out)]),
            median_peak_rss_kib(&["verify", s(&out)]),
        ) else {
            return skip(
                "status_and_verify_need_little_memory...",
                "no /usr/bin/time",
            );
        };
        assert!(
            st_ok && v_ok,
            "status or verify failed on {}",
            out.display()
        );
        rss.push((n / 32, st, v));
    }
    let blocks = (rss[1].0 - rss[0].0) as f64;
    let per_block = |a: u64, b: u64| (b.saturating_sub(a)) as f64 / blocks;
    let (status, verify) = (per_block(rss[0].1, rss[1].1), per_block(rss[0].2, rss[1].2));
    eprintln!("RSS per committed block: status {status:.2} KiB, verify {verify:.2} KiB ({rss:?})");
    // 10^7 networks are 312,500 blocks a cell: at 1 KiB a block, 300 MiB.
    assert!(status < 1.0 && verify < 1.0, "{rss:?}");
}

#[test]
fn symlinked_cell_directories_are_read_and_resumed_through() {
    let dir = temp_dir("probe-symlinks");
    let run = finished_run(&dir, "r", SMALL);
    let elsewhere = dir.join("elsewhere");
    std::fs::create_dir_all(&elsewhere).unwrap();
    let cell = run.join("cells/CartPole-v1__0HL__nobias");
    std::fs::rename(&cell, elsewhere.join("c")).unwrap();
    std::os::unix::fs::symlink(elsewhere.join("c"), &cell).unwrap();
    rwg_ok(&["verify", s(&run)]);
    rwg_ok(&["stats", s(&run), "--no-write"]);
    // a shard whose cell is a link resumes into the link's target
    let m = manifest(&dir, "m.toml", SMALL);
    let shard = dir.join("s");
    rwg_ok(&["run", s(&m), "--shard", "0/2", "--out", s(&shard)]);
    let c = shard.join("cells/CartPole-v1__0HL__nobias");
    std::fs::rename(&c, elsewhere.join("s")).unwrap();
    std::os::unix::fs::symlink(elsewhere.join("s"), &c).unwrap();
    std::fs::remove_file(elsewhere.join("s/blocks/b0000002.csv")).unwrap();
    let t = rwg_fails(&["verify", s(&shard)]);
    assert!(t.contains("b0000002.csv: missing: listed in"), "{t}");
    assert!(t.contains("1 problem(s)"), "named once: {t}");
    rwg_ok(&["run", s(&m), "--shard", "0/2", "--out", s(&shard)]);
    rwg_ok(&["verify", s(&shard)]);
    assert!(elsewhere.join("s/blocks/b0000002.csv").is_file());
}

#[test]
fn a_run_on_a_read_only_mount_is_read_and_writers_say_why_not() {
    let dir = temp_dir("probe-read-only");
    let m = manifest(&dir, "m.toml", SMALL);
    let shard = dir.join("s");
    rwg_ok(&["run", s(&m), "--shard", "0/2", "--out", s(&shard)]);
    let ro = match Mounted::read_only(&shard, &dir.join("ro")) {
        Ok(m) => m,
        Err(why) => return skip("a_run_on_a_read_only_mount_...", &why),
    };
    let ro = &ro.0;
    rwg_ok(&["verify", s(ro)]);
    rwg_ok(&["status", s(ro)]);
    let err = rwg_err(&["run", s(&m), "--shard", "0/2", "--out", s(ro)]);
    assert!(err.contains("read-only file system"), "{err}");
    assert!(err.contains("rwg verify"), "{err}");
}

#[test]
fn a_huge_run_json_is_refused_by_its_size_before_it_is_read() {
    let dir = temp_dir("probe-huge-json");
    let run = finished_run(&dir, "r", SMALL);
    // a sparse file of 300 MiB: nothing to read but its size
    let f = std::fs::OpenOptions::new()
        .write(true)
        .open(run.join("run.json"))
        .unwrap();
    f.set_len(300 << 20).unwrap();
    for args in [
        vec!["verify", s(&run)],
        vec!["stats", s(&run), "--no-write"],
    ] {
        let t = rwg_fails(&args);
        assert!(
            t.contains("run.json") && t.contains("more than 268435456 bytes"),
            "{t}"
        );
    }
    if let Some((kib, ok)) = peak_rss_kib(&["status", s(&run)]) {
        assert!(!ok && kib < 100 << 10, "{kib} KiB to refuse it");
    }
}

#[test]
fn shards_of_different_studies_are_not_merged() {
    let dir = temp_dir("probe-two-studies");
    let a = manifest(&dir, "a.toml", SMALL);
    let b = manifest(&dir, "b.toml", &SMALL.replace("seed = 5", "seed = 6"));
    rwg_ok(&["run", s(&a), "--shard", "0/2", "--out", s(&dir.join("s0"))]);
    rwg_ok(&["run", s(&b), "--shard", "1/2", "--out", s(&dir.join("s1"))]);
    let out = dir.join("m");
    let err = rwg_err(&[
        "merge",
        s(&dir.join("s0")),
        s(&dir.join("s1")),
        "--out",
        s(&out),
    ]);
    assert!(
        err.contains("hold different studies: seed: 5 vs 6"),
        "{err}"
    );
    assert!(!out.exists(), "nothing is written");
}

#[test]
fn a_cell_of_constant_scores_is_reported() {
    let dir = temp_dir("probe-constant");
    // 20 steps of MountainCar score -20 whatever the network does
    let body = "seed = 1\nsamples = 64\nepisodes = 2\nbias = [false]\n[[architectures]]\n\
                name = \"0HL\"\nhidden = []\n[[envs]]\nid = \"MountainCar-v0\"\n\
                max_episode_steps = 20\n[[envs]]\nid = \"CartPole-v1\"\n";
    let m = manifest(&dir, "m.toml", body);
    let run = dir.join("r");
    rwg_ok(&["run", s(&m), "--out", s(&run)]);
    let csv = rwg_ok(&["stats", s(&run), "--no-write", "--format", "csv"]);
    assert!(
        !csv.contains("NaN") && !csv.to_lowercase().contains("inf"),
        "{csv}"
    );
    let html = std::fs::read_to_string(run.join("report.html")).unwrap();
    assert!(!html.contains("NaN"), "NaN in report.html");
    for e in std::fs::read_dir(run.join("figures")).unwrap() {
        let svg = std::fs::read_to_string(e.unwrap().path()).unwrap();
        assert!(!svg.contains("NaN"), "NaN in a figure");
    }
}

#[test]
fn a_stray_directory_under_cells_is_named_not_passed_as_a_cell() {
    let dir = temp_dir("probe-stray");
    let run = finished_run(&dir, "r", SMALL);
    std::fs::create_dir_all(run.join("cells/old-cell")).unwrap();
    let out = rwg_ok(&["verify", s(&run)]);
    assert!(
        out.contains("cells/old-cell: not a cell of this study"),
        "{out}"
    );
    assert!(!out.contains("ok  cells/old-cell"), "{out}");
}

#[test]
fn a_sums_file_with_crlf_line_endings_says_so() {
    let dir = temp_dir("probe-crlf");
    let run = finished_run(&dir, "r", SMALL);
    let p = run.join("cells/CartPole-v1__0HL__nobias/SHA256SUMS");
    let t = std::fs::read_to_string(&p).unwrap().replace('\n', "\r\n");
    std::fs::write(&p, t).unwrap();
    let t = rwg_fails(&["verify", s(&run)]);
    assert!(t.contains("SHA256SUMS:1: ends in a carriage return"), "{t}");
    assert!(!t.contains("No such file"), "{t}");
}

#[test]
fn a_finished_shard_missing_an_owned_block_fails_verify_as_merge_would() {
    let dir = temp_dir("probe-shard-block");
    let m = manifest(&dir, "m.toml", SMALL);
    let (a, b) = (dir.join("s0"), dir.join("s1"));
    rwg_ok(&["run", s(&m), "--shard", "0/2", "--out", s(&a)]);
    rwg_ok(&["run", s(&m), "--shard", "1/2", "--out", s(&b)]);
    // block 2 of the first cell and its index line both gone
    let blocks = a.join("cells/CartPole-v1__0HL__nobias/blocks");
    std::fs::remove_file(blocks.join("b0000002.csv")).unwrap();
    let sums = std::fs::read_to_string(blocks.join("SHA256SUMS")).unwrap();
    let kept: String = sums
        .lines()
        .filter(|l| !l.ends_with("b0000002.csv"))
        .map(|l| format!("{l}\n"))
        .collect();
    std::fs::write(blocks.join("SHA256SUMS"), kept).unwrap();
    let t = rwg_fails(&["verify", s(&a)]);
    assert!(
        t.contains("block 2 of cell CartPole-v1__0HL__nobias"),
        "{t}"
    );
    let err = rwg_err(&["merge", s(&a), s(&b), "--out", s(&dir.join("m"))]);
    assert!(
        err.contains("block 2 of cell CartPole-v1__0HL__nobias is missing"),
        "{err}"
    );
    // what both print finishes it
    rwg_ok(&["run", s(&m), "--shard", "0/2", "--out", s(&a)]);
    rwg_ok(&["verify", s(&a)]);
}

#[test]
fn a_run_json_listing_a_cell_of_another_study_or_in_another_order() {
    let dir = temp_dir("probe-foreign-cell");
    let run = finished_run(&dir, "r", SMALL);
    let p = run.join("run.json");
    let original = std::fs::read_to_string(&p).unwrap();
    let mut v: serde_json::Value = serde_json::from_str(&original).unwrap();
    v["cells"].as_array_mut().unwrap().reverse();
    std::fs::write(&p, serde_json::to_string_pretty(&v).unwrap()).unwrap();
    rwg_ok(&["verify", s(&run)]); // the same cells, in another order
    v["cells"][0]["dir"] = "Acrobot-v1__0HL__nobias".into();
    std::fs::write(&p, serde_json::to_string_pretty(&v).unwrap()).unwrap();
    let err = rwg_err(&["stats", s(&run), "--no-write"]);
    assert!(
        err.contains("lists cell Acrobot-v1__0HL__nobias, which is not a cell of the study"),
        "{err}"
    );
}

#[test]
fn a_plugin_path_that_is_a_fifo_is_named() {
    let dir = temp_dir("probe-plugin-fifo");
    let fifo = dir.join("lib.so");
    let ok = Command::new("mkfifo")
        .arg(&fifo)
        .status()
        .is_ok_and(|s| s.success());
    if !ok {
        return skip("a_plugin_path_that_is_a_fifo_is_named", "no mkfifo");
    }
    let body = "samples = 32\nepisodes = 1\n[[architectures]]\nname = \"0HL\"\nhidden = []\n\
                [[envs]]\nid = \"acme/Maze-v0\"\nplugin = \"lib.so\"\n";
    let m = manifest(&dir, "m.toml", body);
    let err = rwg_err(&["run", s(&m), "--out", s(&dir.join("out"))]);
    assert!(err.contains("is not a regular file"), "{err}");
    assert!(err.contains("m.toml:8"), "{err}");
}

#[test]
fn printed_commands_survive_quotes_and_dollars_in_a_path() {
    let dir = temp_dir("probe-quote-path");
    let run = finished_run(&dir, "it's $HOME", SMALL);
    let out = rwg_ok(&["top", s(&run), "-n", "1"]);
    let line = out.lines().find(|l| l.contains("rwg replay")).unwrap();
    let cmd = &line[line.find("rwg replay").unwrap() + "rwg ".len()..];
    let shell = format!("{} {cmd}", rwg_bin().display());
    let o = Command::new("sh").args(["-c", &shell]).output().unwrap();
    assert!(o.status.success(), "{cmd}: {}", text(&o));
}

#[test]
fn a_run_json_that_is_a_folder_is_named_not_taken_for_a_run_in_progress() {
    let dir = temp_dir("probe-run-json-folder");
    let run = finished_run(&dir, "r", SMALL);
    std::fs::remove_file(run.join("run.json")).unwrap();
    std::fs::create_dir(run.join("run.json")).unwrap();
    for args in [
        vec!["verify", s(&run)],
        vec!["stats", s(&run), "--no-write"],
    ] {
        let err = rwg_err(&args);
        assert!(
            err.contains("run.json: not a regular file"),
            "{args:?}: {err}"
        );
        assert!(!err.contains("in progress"), "{args:?}: {err}");
    }
    std::fs::remove_dir(run.join("run.json")).unwrap();
    rwg_ok(&["run", s(&run.join("manifest.toml")), "--out", s(&run)]);
    rwg_ok(&["verify", s(&run)]);
}

#[test]
fn a_sharded_studys_folder_given_to_a_reader_names_its_shards() {
    let dir = temp_dir("probe-shard-root");
    let m = manifest(&dir, "m.toml", SMALL);
    let root = dir.join("study");
    for k in 0..2 {
        let out = root.join(format!("shards/{k}"));
        rwg_ok(&["run", s(&m), "--shard", &format!("{k}/2"), "--out", s(&out)]);
    }
    let err = rwg_err(&["verify", s(&root)]);
    assert!(
        err.contains("holds the 2 shard directories of a study"),
        "{err}"
    );
    // the merge it names runs as printed
    let merge = err[err.find("`rwg merge ").unwrap() + 1..]
        .split('`')
        .next()
        .unwrap();
    let shell = format!("{} {}", rwg_bin().display(), &merge["rwg ".len()..]);
    let o = Command::new("sh").args(["-c", &shell]).output().unwrap();
    assert!(o.status.success(), "{merge}: {}", text(&o));
    rwg_ok(&["verify", s(&root)]);
}
