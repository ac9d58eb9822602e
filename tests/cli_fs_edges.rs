//! rwg at the file system's edges, end to end: no path a user names
//! (`--out`, `--html`, `--figure`, `--export-weights`) lands on a run's own
//! files or in a run another rwg is writing; a plugin that changes the
//! working directory moves nothing rwg writes; `--force-new` removes what
//! the old run wrote, its statistics and report included, and nothing else;
//! statistics files of another run are named by `rwg verify`; a command
//! printed for a path that is not UTF-8 runs as printed;
//! `rwg verify` beside a run that commits reads each cell as one snapshot.

mod common;
use common::*;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;

const SMALL: &str = SMALL_STUDY;

fn s(p: &Path) -> &str {
    path_str(p)
}

/// Every file under `dir` (but the writers' lock, whose holder record any
/// writer updates) with its bytes.
fn snapshot(dir: &Path) -> BTreeMap<PathBuf, Vec<u8>> {
    let mut out = BTreeMap::new();
    let mut todo = vec![dir.to_path_buf()];
    while let Some(d) = todo.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                todo.push(p);
            } else if p.file_name().unwrap() != "rwg.lock" {
                out.insert(p.clone(), std::fs::read(&p).unwrap());
            }
        }
    }
    out
}

/// The first cell directory of a run.
fn first_cell(run: &Path) -> PathBuf {
    let mut v: Vec<PathBuf> = std::fs::read_dir(run.join("cells"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    v.sort();
    v.remove(0)
}

#[test]
fn no_output_path_a_user_names_is_written_over_a_runs_own_files() {
    let dir = temp_dir("out-over-run");
    let (r1, r2) = (
        finished_run(&dir, "r1", SMALL),
        finished_run(&dir, "r2", SMALL),
    );
    rwg_ok(&["report", s(&r1)]);
    let before = snapshot(&r1);
    let samples = first_cell(&r1).join("samples.csv");
    let link = dir.join("page.html");
    std::os::unix::fs::symlink(r1.join("run.json"), &link).unwrap();
    let in1 = |rel: &str| s(&r1).to_string() + "/" + rel;
    let (r1s, r2s) = (s(&r1).to_string(), s(&r2).to_string());
    let replay = format!("replay {r1s} --env CartPole-v1 --arch 0HL --sample 3 --export-weights");
    let cases: Vec<Vec<String>> = [
        format!("report {r1s} --out {}", s(&samples)),
        format!("report {r2s} --out {}", in1("report.html")),
        format!("compare {r2s} --html {}", in1("run.json")),
        format!("compare {r2s} --figure {}", in1("manifest.toml")),
        format!("compare {r2s} --ranking-figure {}", in1("stats.csv")),
        format!("compare {r2s} --html {}", s(&link)),
        format!("{replay} {}", in1("manifest.toml")),
        format!("plot {r1s} --out {}", in1("cells")),
        format!("plot {r2s} --out {}", in1("figures")),
        format!("plot {r2s} --out {r1s}"),
        format!("run {r2s}/manifest.toml --out {}", in1("cells/x")),
    ]
    .iter()
    .map(|c| c.split(' ').map(String::from).collect())
    .collect();
    for args in &cases {
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let err = rwg_fails(&args);
        assert!(
            err.contains(&format!("of the run directory {}", r1.display()))
                || err.contains(&format!("it is the run directory {}", r1.display())),
            "{args:?}:\n{err}"
        );
        assert!(err.contains("refused"), "{args:?}:\n{err}");
        assert_eq!(snapshot(&r1), before, "{args:?} changed {}", r1.display());
    }
    rwg_ok(&["verify", s(&r1)]);
    // A new name beside a run's files is fine, and its own report too.
    rwg_ok(&["compare", s(&r2), "--html", s(&r1.join("r2-page.html"))]);
    rwg_ok(&["report", s(&r1), "--out", s(&r1.join("report.html"))]);
    rwg_ok(&["verify", s(&r1)]);
    // A folder where one file goes.
    for out in [
        dir.clone(),
        PathBuf::from(format!("{}/new/", dir.display())),
    ] {
        let err = rwg_fails(&["report", s(&r1), "--out", s(&out)]);
        assert!(
            err.contains("it names a folder, and this writes one file"),
            "{err}"
        );
    }
    // Two outputs of one command naming one file.
    let page = dir.join("p.html");
    let err = rwg_fails(&["compare", s(&r2), "--html", s(&page), "--figure", s(&page)]);
    assert!(
        err.contains("--html and --figure name the same file"),
        "{err}"
    );
}

#[test]
fn an_output_into_a_run_another_rwg_writes_is_refused_before_anything_is_written() {
    let dir = temp_dir("out-locked-run");
    let (r1, r2) = (
        finished_run(&dir, "r1", SMALL),
        finished_run(&dir, "r2", SMALL),
    );
    let mut holder = Command::new("flock")
        .args([s(&r1.join("rwg.lock")), "sleep", "30"])
        .spawn();
    let Ok(holder) = holder.as_mut() else {
        return skip(
            "an_output_into_a_run_another_rwg_writes_is_refused_before_anything_is_written",
            "no flock(1)",
        );
    };
    std::thread::sleep(std::time::Duration::from_millis(300));
    let page = r1.join("cmp.html");
    let err = rwg_fails(&["compare", s(&r2), "--html", s(&page)]);
    holder.kill().unwrap();
    let _ = holder.wait();
    assert!(
        err.contains("is being written by another rwg process"),
        "{err}"
    );
    assert!(err.contains("takes that run's writers' lock"), "{err}");
    assert!(
        err.contains("--html FILE outside the run writes it now"),
        "{err}"
    );
    assert!(!page.exists());
}

/// The handshake plugin, compiled to change the working directory to
/// `to` in every `create`.
fn chdir_plugin(to: &Path) -> PathBuf {
    compile_c(
        "chdir",
        "plugins/testing/c/handshake.c",
        "chdir",
        &[&format!("CHDIR_IN_CREATE=\"{}\"", to.display())],
    )
}

#[test]
fn a_plugin_that_changes_the_working_directory_moves_nothing_rwg_writes() {
    let dir = temp_dir("out-chdir");
    let elsewhere = dir.join("elsewhere");
    std::fs::create_dir_all(&elsewhere).unwrap();
    let lib = chdir_plugin(&elsewhere);
    // A second plugin found on a relative RWG_PLUGIN_PATH, after the first
    // one's create moved the working directory.
    std::fs::create_dir_all(dir.join("plugins")).unwrap();
    let cc = classic_control_plugin();
    std::fs::copy(&cc, dir.join("plugins").join(cc.file_name().unwrap())).unwrap();
    let body = format!(
        "samples = 40\nepisodes = 2\n[[architectures]]\nname = \"0HL\"\nhidden = []\n\
         [[envs]]\nid = \"handshake/Ok-v0\"\nplugin = \"{}\"\n\
         [[envs]]\nid = \"classic_control/CartPole-v1\"\n",
        lib.display()
    );
    write_manifest(&dir, "m.toml", &body);
    let rwg_in_dir = |args: &[&str]| {
        let out = Command::new(rwg_bin())
            .current_dir(&dir)
            .args(args)
            .env("RWG_PLUGIN_PATH", "plugins")
            .env("RWG_COMMIT_LINGER", "0")
            .output()
            .unwrap();
        let text = output_text(&out);
        assert!(out.status.success(), "{args:?}:\n{text}");
        text
    };
    rwg_in_dir(&["run", "m.toml", "--out", "r"]);
    for f in ["run.json", "report.html", "stats.csv"] {
        assert!(dir.join("r").join(f).is_file(), "r/{f}");
    }
    rwg_in_dir(&["run", "m.toml", "--out", "s0", "--shard", "0/2"]);
    rwg_in_dir(&["run", "m.toml", "--out", "s1", "--shard", "1/2"]);
    rwg_in_dir(&["merge", "s0", "s1", "--out", "merged", "--no-report"]);
    let (env, arch) = ("handshake/Ok-v0", "0HL");
    let export = ["--sample", "1", "--export-weights", "w.json"];
    rwg_in_dir(&[&["replay", "r", "--env", env, "--arch", arch][..], &export].concat());
    rwg_in_dir(&["verify", "merged"]);
    assert!(dir.join("w.json").is_file());
    let strays: Vec<_> = std::fs::read_dir(&elsewhere).unwrap().collect();
    assert!(
        strays.is_empty(),
        "written where the plugin moved: {strays:?}"
    );
}

/// The `samples` column of a run's `stats.csv`, one value per cell.
fn stats_samples(run: &Path) -> Vec<String> {
    let text = std::fs::read_to_string(run.join("stats.csv")).unwrap();
    let mut lines = text.lines();
    let col = lines
        .next()
        .unwrap()
        .split(',')
        .position(|c| c == "samples")
        .unwrap();
    lines
        .map(|l| l.split(',').nth(col).unwrap().to_string())
        .collect()
}

#[test]
fn force_new_removes_the_old_runs_statistics_and_report_too() {
    let dir = temp_dir("force-new-derived");
    let m = write_manifest(&dir, "m.toml", SMALL);
    let run = dir.join("r");
    rwg_ok(&["run", s(&m), "--out", s(&run), "-q"]);
    assert_eq!(stats_samples(&run), ["70", "70"]);
    rwg_ok(&[
        "run",
        s(&m),
        "--out",
        s(&run),
        "-q",
        "--force-new",
        "--no-report",
        "--samples",
        "40",
    ]);
    for f in ["stats.json", "stats.csv", "report.html", "figures"] {
        assert!(!run.join(f).exists(), "{f} of the old study is left");
    }
    rwg_ok(&["verify", s(&run)]);
    // The report is missing, so running the same study again writes it.
    let again = rwg_ok(&["run", s(&m), "--out", s(&run), "--samples", "40"]);
    assert!(again.contains("nothing to do"), "{again}");
    assert_eq!(stats_samples(&run), ["40", "40"]);
    let status = rwg_ok(&["status", s(&run)]);
    assert!(status.contains("40"), "{status}");
}

#[test]
fn statistics_files_of_another_run_are_named_by_verify() {
    let dir = temp_dir("stats-of-another");
    let m = write_manifest(&dir, "m.toml", SMALL);
    let (run, other) = (dir.join("r"), dir.join("o"));
    rwg_ok(&["run", s(&m), "--out", s(&run), "-q"]);
    rwg_ok(&["run", s(&m), "--out", s(&other), "-q", "--samples", "40"]);
    for f in ["stats.json", "stats.csv"] {
        std::fs::copy(other.join(f), run.join(f)).unwrap();
    }
    let text = rwg_fails(&["verify", s(&run)]);
    for f in ["stats.json", "stats.csv"] {
        let line = format!("{}: written for another run", s(&run.join(f)));
        assert!(text.contains(&line), "{f} not named:\n{text}");
    }
    rwg_ok(&["stats", s(&run)]);
    rwg_ok(&["verify", s(&run)]);
    assert_eq!(stats_samples(&run), ["70", "70"]);
}

#[test]
fn a_command_printed_for_a_path_that_is_not_utf8_runs_as_printed() {
    use std::os::unix::ffi::OsStrExt;
    let dir = temp_dir("not-utf8");
    let m = write_manifest(&dir, "m.toml", SMALL);
    let run = dir.join(std::ffi::OsStr::from_bytes(b"r \xff'x"));
    let out = Command::new(rwg_bin())
        .arg("run")
        .arg(&m)
        .arg("--out")
        .arg(&run)
        .arg("-q")
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", output_text(&out));
    std::fs::write(run.join("stats.csv"), "x\n").unwrap();
    let out = Command::new(rwg_bin())
        .arg("verify")
        .arg(&run)
        .output()
        .unwrap();
    let text = output_text(&out);
    assert!(!out.status.success(), "{text}");
    // The hint names the folder byte for byte, as a shell reads it.
    let cmd = text
        .split('`')
        .find(|w| w.starts_with("rwg stats "))
        .unwrap_or_else(|| panic!("no command in: {text}"));
    let cmd = cmd.replacen("rwg", s(&rwg_bin()), 1);
    let sh = Command::new("sh").args(["-c", &cmd]).output().unwrap();
    assert!(sh.status.success(), "{cmd}: {}", output_text(&sh));
    let out = Command::new(rwg_bin())
        .arg("verify")
        .arg(&run)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", output_text(&out));
}

#[test]
fn force_new_deletes_nothing_rwg_did_not_write() {
    let dir = temp_dir("force-new-foreign");
    let m = write_manifest(&dir, "m.toml", SMALL);
    // A folder that is no run, with a cells/ folder and a stats.csv of the user's.
    let mine = dir.join("mine");
    std::fs::create_dir_all(mine.join("cells/x")).unwrap();
    std::fs::write(mine.join("cells/x/data.csv"), "1,2\n").unwrap();
    std::fs::write(mine.join("stats.csv"), "a,b\n").unwrap();
    for force in [true, false] {
        let mut args = vec!["run", s(&m), "--out", s(&mine), "-q"];
        if force {
            args.push("--force-new");
        }
        let err = rwg_fails(&args);
        assert!(err.contains("holds no run"), "{err}");
        assert!(err.contains(&format!("{}/cells", mine.display())), "{err}");
        assert!(
            err.contains(&format!("{}/stats.csv", mine.display())),
            "{err}"
        );
        assert!(mine.join("cells/x/data.csv").is_file() && mine.join("stats.csv").is_file());
        assert!(!mine.join("run.json").exists());
    }
    // Nor does a merge start there.
    let (s0, s1) = (dir.join("s0"), dir.join("s1"));
    rwg_ok(&["run", s(&m), "--out", s(&s0), "--shard", "0/2", "-q"]);
    rwg_ok(&["run", s(&m), "--out", s(&s1), "--shard", "1/2", "-q"]);
    let err = rwg_fails(&["merge", s(&s0), s(&s1), "--out", s(&mine)]);
    assert!(err.contains("holds no run"), "{err}");
    assert!(mine.join("cells/x/data.csv").is_file() && !mine.join("run.json").exists());
    // In a run, --force-new removes the old run's files and keeps the user's,
    // named, until they are moved.
    let run = finished_run(&dir, "r", SMALL);
    std::fs::write(run.join("notes.txt"), "mine").unwrap();
    let cell = first_cell(&run);
    std::fs::write(cell.join("plot.py"), "mine").unwrap();
    let err = rwg_fails(&["run", s(&m), "--out", s(&run), "-q", "--force-new"]);
    assert!(
        err.contains(&format!(
            "kept {} (not written by rwg",
            cell.join("plot.py").display()
        )),
        "{err}"
    );
    assert!(!run.join("run.json").exists() && !cell.join("scores.csv").exists());
    assert_eq!(
        std::fs::read_to_string(cell.join("plot.py")).unwrap(),
        "mine"
    );
    std::fs::rename(cell.join("plot.py"), dir.join("plot.py")).unwrap();
    rwg_ok(&["run", s(&m), "--out", s(&run), "-q", "--force-new"]);
    rwg_ok(&["verify", s(&run)]);
    assert_eq!(
        std::fs::read_to_string(run.join("notes.txt")).unwrap(),
        "mine"
    );
}

/// `rwg args`, started under the shim `tests/data/pause_at_open.c`, which
/// pauses it just after it opens a file whose path ends in `pause_at`: the
/// paused process and the file that lets it go on, or (when the shim did
/// not pause it) its output.
fn spawn_paused(
    dir: &Path,
    args: &[&str],
    pause_at: &str,
) -> Result<(std::process::Child, PathBuf), String> {
    let shim = compile_c("pause", "tests/data/pause_at_open.c", "pause_at_open", &[]);
    let (paused, go) = (dir.join("paused"), dir.join("go"));
    let child = Command::new(rwg_bin())
        .args(args)
        .env("LD_PRELOAD", &shim)
        .env("RWG_TEST_PAUSE_AT", pause_at)
        .env("RWG_TEST_PAUSED", &paused)
        .env("RWG_TEST_GO", &go)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let t0 = std::time::Instant::now();
    while !paused.exists() && t0.elapsed().as_secs() < 60 {
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    if !paused.exists() {
        let out = child.wait_with_output().unwrap();
        return Err(format!(
            "the LD_PRELOAD shim did not pause rwg: {}",
            output_text(&out)
        ));
    }
    Ok((child, go))
}

#[test]
fn verify_beside_a_run_that_finalises_a_cell_reads_one_snapshot() {
    const TEST: &str = "verify_beside_a_run_that_finalises_a_cell_reads_one_snapshot";
    let dir = temp_dir("verify-snapshot");
    let body = SMALL.replace("samples = 70", "samples = 1500");
    let m = write_manifest(&dir, "m.toml", &body);
    let run = dir.join("r");
    let mut cmd = Command::new(rwg_bin());
    cmd.args([
        "run",
        s(&m),
        "--out",
        s(&run),
        "--no-report",
        "--threads",
        "1",
    ])
    .env("RWG_COMMIT_LINGER", "0");
    ctrl_c_after_first_block(cmd, &run.join("cells/CartPole-v1__0HL__nobias/blocks"));
    // verify, paused just after it opened the block index of the unfinished
    // cell, while the run is resumed to its end (the cell finalised, its
    // blocks removed); then verify goes on.
    let (verify, go) = match spawn_paused(&dir, &["verify", s(&run)], "blocks/SHA256SUMS") {
        Ok(p) => p,
        Err(why) => return skip(TEST, &why),
    };
    rwg_ok(&["run", s(&m), "--out", s(&run), "--no-report", "-q"]);
    std::fs::write(&go, "").unwrap();
    let out = verify.wait_with_output().unwrap();
    let text = output_text(&out);
    assert!(out.status.success(), "{text}");
    assert!(text.contains("all match their checksums"), "{text}");
}

#[test]
fn verify_of_a_run_being_set_up_checks_what_it_has_committed() {
    const TEST: &str = "verify_of_a_run_being_set_up_checks_what_it_has_committed";
    let dir = temp_dir("verify-set-up");
    let m = write_manifest(&dir, "m.toml", SMALL);
    let run = dir.join("r");
    // rwg run, paused as it records its first cell's env: it has its lock,
    // manifest.toml and cells/, and no run.json yet.
    let args = ["run", s(&m), "--out", s(&run), "--no-report", "-q"];
    let (writer, go) = match spawn_paused(&dir, &args, "nobias/env.json.tmp") {
        Ok(p) => p,
        Err(why) => return skip(TEST, &why),
    };
    let res = rwg(&["verify", s(&run)]);
    std::fs::write(&go, "").unwrap();
    let text = output_text(&res);
    assert!(res.status.success(), "{text}");
    assert!(
        text.contains("being set up, without run.json yet"),
        "{text}"
    );
    let out = writer.wait_with_output().unwrap();
    assert!(out.status.success(), "{}", output_text(&out));
    rwg_ok(&["verify", s(&run)]);
}

/// Runs `rwg` with `args` under the file-system fault shim
/// (`tests/data/fs_faults.c`) set up by `vars`.
fn rwg_faulty_fs(args: &[&str], vars: &[(&str, &str)]) -> std::process::Output {
    let shim = compile_c("fs-faults", "tests/data/fs_faults.c", "fs_faults", &[]);
    let mut cmd = Command::new(rwg_bin());
    cmd.args(args)
        .env("LD_PRELOAD", &shim)
        .env("RWG_COMMIT_LINGER", "0");
    for (k, v) in vars {
        cmd.env(k, v);
    }
    cmd.output().unwrap()
}

#[test]
fn a_file_system_that_cannot_sync_folders_runs_and_one_whose_rename_fails_resumes() {
    let dir = temp_dir("fs-faults");
    let m = write_manifest(&dir, "m.toml", SMALL);
    // fsync of a folder refused with EINVAL, as on some FUSE and CIFS mounts.
    let run = dir.join("no-dir-sync");
    let args = ["run", s(&m), "--out", s(&run), "--no-report", "-q"];
    let out = rwg_faulty_fs(&args, &[("RWG_TEST_DIR_FSYNC", "EINVAL")]);
    assert!(out.status.success(), "{}", output_text(&out));
    rwg_ok(&["verify", s(&run)]);
    // A block's rename fails (EXDEV, as across mounts): an error naming the
    // block, the committed blocks kept, and a resume gives the same bytes.
    // Enough networks that block 1 is committed while the cell still runs
    // (a cell that ends first writes its results without block files).
    let body = SMALL.replace("samples = 70", "samples = 1500");
    let m = write_manifest(&dir, "big.toml", &body);
    let reference = finished_run(&dir, "reference-big", &body);
    let run = dir.join("no-rename");
    let args = [
        "run",
        s(&m),
        "--out",
        s(&run),
        "--no-report",
        "-q",
        "--threads",
        "1",
    ];
    let out = rwg_faulty_fs(&args, &[("RWG_TEST_RENAME_TO", "b0000001.csv")]);
    let text = output_text(&out);
    assert_eq!(out.status.code(), Some(1), "{text}");
    assert!(
        text.contains("b0000001.csv: Invalid cross-device link"),
        "{text}"
    );
    assert!(text.contains("resume with: rwg run"), "{text}");
    rwg_ok(&["run", s(&m), "--out", s(&run), "--no-report", "-q"]);
    for c in ["CartPole-v1__0HL__nobias", "CartPole-v1__1HL__nobias"] {
        let p = format!("cells/{c}/scores.csv");
        assert_eq!(
            std::fs::read(run.join(&p)).unwrap(),
            std::fs::read(reference.join(&p)).unwrap()
        );
    }
}

#[test]
fn a_run_directory_moved_while_the_run_writes_it_is_said_so_and_resumes_where_it_went() {
    let dir = temp_dir("moved-run");
    let body = SMALL.replace("samples = 70", "samples = 1500");
    let m = write_manifest(&dir, "m.toml", &body);
    let (run, moved) = (dir.join("r"), dir.join("moved"));
    let writer = Command::new(rwg_bin())
        .args([
            "run",
            s(&m),
            "--out",
            s(&run),
            "--no-report",
            "-q",
            "--threads",
            "1",
        ])
        .env("RWG_COMMIT_LINGER", "0")
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let block = run.join("cells/CartPole-v1__0HL__nobias/blocks/b0000001.csv");
    let t0 = std::time::Instant::now();
    while !block.exists() && t0.elapsed().as_secs() < 60 {
        std::thread::sleep(std::time::Duration::from_millis(10));
    }
    std::fs::rename(&run, &moved).unwrap();
    let out = writer.wait_with_output().unwrap();
    let text = output_text(&out);
    assert_eq!(out.status.code(), Some(1), "{text}");
    assert!(
        text.contains(&format!(
            "{} was moved while this run was writing it: it is now {}",
            run.display(),
            moved.display()
        )),
        "{text}"
    );
    assert!(!run.exists(), "the run went on writing at its old path");
    rwg_ok(&[
        "run",
        s(&moved.join("manifest.toml")),
        "--out",
        s(&moved),
        "-q",
    ]);
    let reference = dir.join("reference");
    rwg_ok(&["run", s(&m), "--out", s(&reference), "--no-report", "-q"]);
    for c in ["CartPole-v1__0HL__nobias", "CartPole-v1__1HL__nobias"] {
        let p = format!("cells/{c}/scores.csv");
        assert_eq!(
            std::fs::read(moved.join(&p)).unwrap(),
            std::fs::read(reference.join(&p)).unwrap()
        );
    }
}
