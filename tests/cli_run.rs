//! `rwg run` end to end: determinism across thread counts and manifests, the
//! paper's CartPole figure, the documented files, and manifest errors.

mod common;
use common::*;
use std::path::Path;

fn manifest(dir: &Path, name: &str, body: &str) -> String {
    let p = dir.join(name);
    std::fs::write(&p, body).unwrap();
    p.to_str().unwrap().to_string()
}

const CARTPOLE: &str = r#"
seed = 11
samples = 40
episodes = 3
[[architectures]]
name = "1HL"
hidden = [4]
[[envs]]
id = "CartPole-v0"
"#;

fn read(p: impl AsRef<Path>) -> String {
    std::fs::read_to_string(p.as_ref()).unwrap_or_else(|e| panic!("{}: {e}", p.as_ref().display()))
}

#[test]
fn scores_do_not_depend_on_thread_count() {
    let dir = temp_dir("threads");
    let m = manifest(&dir, "m.toml", CARTPOLE);
    for t in ["1", "2"] {
        let out = dir.join(format!("t{t}"));
        rwg_ok(&["run", &m, "--threads", t, "--out", out.to_str().unwrap()]);
    }
    for f in ["scores.csv", "samples.csv"] {
        let cell = "cells/CartPole-v0__1HL__nobias";
        assert_eq!(
            read(dir.join("t1").join(cell).join(f)),
            read(dir.join("t2").join(cell).join(f)),
            "{f}"
        );
    }
}

#[test]
fn a_cell_gives_the_same_scores_alone_and_in_a_bigger_manifest() {
    let dir = temp_dir("paired");
    let alone = manifest(&dir, "alone.toml", CARTPOLE);
    let bigger = manifest(
        &dir,
        "big.toml",
        &(CARTPOLE.replace("samples = 40", "samples = 50").replace(
            "[[architectures]]",
            "bias = [true, false]\n[[architectures]]\nname = \"0HL\"\nhidden = []\n[[architectures]]",
        ) + "[[envs]]\nid = \"Acrobot-v1\"\nmax_episode_steps = 50\n"),
    );
    rwg_ok(&["run", &alone, "--out", dir.join("a").to_str().unwrap()]);
    rwg_ok(&["run", &bigger, "--out", dir.join("b").to_str().unwrap()]);
    let cell = "cells/CartPole-v0__1HL__nobias/scores.csv";
    let a = read(dir.join("a").join(cell));
    let b = read(dir.join("b").join(cell));
    // the first 40 samples of the 50-sample run are the 40 samples of the small run
    let b40: Vec<&str> = b.lines().take(1 + 40 * 3).collect();
    assert_eq!(a.lines().collect::<Vec<_>>(), b40);
}

#[test]
fn run_directory_has_the_documented_files() {
    let dir = temp_dir("files");
    let m = manifest(
        &dir,
        "m.toml",
        &CARTPOLE.replace("samples = 40", "samples = 5"),
    );
    let out = dir.join("run");
    let stdout = rwg_ok(&[
        "run",
        &m,
        "--out",
        out.to_str().unwrap(),
        "--episodes",
        "2",
        "--seed",
        "5",
    ]);
    assert!(stdout.contains(out.to_str().unwrap()), "{stdout}");
    let resolved = read(out.join("manifest.toml"));
    assert!(
        resolved.contains("seed = 5") && resolved.contains("episodes = 2"),
        "{resolved}"
    );
    let meta: serde_json::Value = serde_json::from_str(&read(out.join("run.json"))).unwrap();
    assert_eq!(meta["samples"], 5);
    assert!(meta["end_time"].is_string());
    let cell = &meta["cells"][0];
    assert_eq!(cell["dir"], "CartPole-v0__1HL__nobias");
    assert_eq!(cell["n_weights"], 24);
    assert_eq!(cell["solved"], 195.0);
    assert_eq!(cell["solved_source"], "env");
    let scores = read(out.join("cells/CartPole-v0__1HL__nobias/scores.csv"));
    let rows: Vec<&str> = scores.lines().collect();
    assert_eq!(rows[0], "sample,episode,score,steps");
    assert_eq!(rows.len(), 1 + 5 * 2);
    let steps: u64 = rows[1..]
        .iter()
        .map(|r| r.split(',').nth(3).unwrap().parse::<u64>().unwrap())
        .sum();
    assert_eq!(meta["env_steps"], steps);
    let samples = read(out.join("cells/CartPole-v0__1HL__nobias/samples.csv"));
    let srows: Vec<Vec<&str>> = samples.lines().map(|l| l.split(',').collect()).collect();
    assert_eq!(
        srows[0],
        ["sample", "mean", "variance", "std", "min", "max", "rank"]
    );
    let mut ranks: Vec<u64> = srows[1..].iter().map(|r| r[6].parse().unwrap()).collect();
    ranks.sort();
    assert_eq!(ranks, [0, 1, 2, 3, 4]);
    // the manifest written into the run directory runs the same study
    let again = dir.join("again");
    rwg_ok(&[
        "run",
        out.join("manifest.toml").to_str().unwrap(),
        "--out",
        again.to_str().unwrap(),
    ]);
    assert_eq!(
        read(again.join("cells/CartPole-v0__1HL__nobias/scores.csv")),
        scores
    );
}

/// The paper: "over 3%" of linear CartPole-v0 controllers reach a mean of 195;
/// Python implementations on Gymnasium give 3.8-4.2%.
#[test]
fn cartpole_linear_solved_fraction_is_the_papers() {
    let dir = temp_dir("paper-cartpole");
    let m = manifest(
        &dir,
        "m.toml",
        "seed = 0\nsamples = 1000\nepisodes = 20\n[[architectures]]\nname = \"0HL\"\nhidden = []\n[[envs]]\nid = \"CartPole-v0\"\nsolved = 195\n",
    );
    let out = dir.join("run");
    rwg_ok(&["run", &m, "--out", out.to_str().unwrap()]);
    let samples = read(out.join("cells/CartPole-v0__0HL__nobias/samples.csv"));
    let means: Vec<f64> = samples
        .lines()
        .skip(1)
        .map(|l| l.split(',').nth(1).unwrap().parse().unwrap())
        .collect();
    assert_eq!(means.len(), 1000);
    let frac = means.iter().filter(|&&m| m >= 195.0).count() as f64 / 1000.0;
    assert!((0.02..=0.07).contains(&frac), "fraction solved {frac}");
}

#[test]
fn a_finished_run_is_not_redone_and_another_study_is_refused() {
    let dir = temp_dir("overwrite");
    let m = manifest(
        &dir,
        "m.toml",
        &CARTPOLE.replace("samples = 40", "samples = 2"),
    );
    let out = dir.join("run");
    rwg_ok(&["run", &m, "--out", out.to_str().unwrap()]);
    let again = rwg_ok(&["run", &m, "--out", out.to_str().unwrap()]);
    assert!(again.contains("complete; nothing to do"), "{again}");
    let err = rwg_err(&["run", &m, "--out", out.to_str().unwrap(), "--episodes", "4"]);
    assert!(
        err.contains("holds a different study (episodes: 3 vs 4)"),
        "{err}"
    );
    assert!(err.contains("--force-new"), "{err}");
    // a key of one entry: named, not the whole envs array
    let other = manifest(
        &dir,
        "other.toml",
        &CARTPOLE
            .replace("samples = 40", "samples = 2")
            .replace("id = \"CartPole-v0\"", "id = \"CartPole-v0\"\nsolved = 100"),
    );
    let err = rwg_err(&["run", &other, "--out", out.to_str().unwrap()]);
    assert!(
        err.contains("holds a different study (envs[0] (CartPole-v0).solved: (absent) vs 100.0)"),
        "{err}"
    );
    rwg_ok(&[
        "run",
        &m,
        "--out",
        out.to_str().unwrap(),
        "--episodes",
        "4",
        "--force-new",
    ]);
    let scores = read(out.join("cells/CartPole-v0__1HL__nobias/scores.csv"));
    assert_eq!(scores.lines().count(), 1 + 2 * 4);
}

#[test]
fn manifest_errors_name_file_line_and_key_and_nothing_runs() {
    let dir = temp_dir("errors");
    let cases = [
        (
            "samples = 40",
            "samples = 0",
            "m.toml:3:11: samples: must be at least 1",
        ),
        (
            "hidden = [4]",
            "hidden = [0]",
            "m.toml:7:11: architectures[0].hidden[0]: a layer needs 1 to 4096 units (rwg's limit), got 0",
        ),
        (
            "id = \"CartPole-v0\"",
            "id = \"CartPole-v9\"",
            "m.toml:9:6: envs: unknown environment 'CartPole-v9' (did you mean 'CartPole-v0'?)",
        ),
        (
            "episodes = 3",
            "episodes = 3\n[weights]\ndistribution = \"cauchy\"",
            "m.toml:6:16: weights.distribution: unknown distribution 'cauchy'",
        ),
        (
            "episodes = 3",
            "episodes = 3\nepisodez = 4",
            "m.toml:5:1: episodez: unknown key `episodez`",
        ),
    ];
    for (from, to, expected) in cases {
        let m = manifest(&dir, "m.toml", &CARTPOLE.replace(from, to));
        let out = dir.join("never");
        let err = rwg_err(&["run", &m, "--out", out.to_str().unwrap()]);
        assert!(err.contains(expected), "expected {expected:?} in:\n{err}");
        assert!(!out.exists(), "{to}: the run must not start");
    }
}

#[test]
fn timing_shows_every_cell_and_its_serial_share_and_records_every_cell_in_order() {
    let dir = temp_dir("timing");
    let m = manifest(&dir, "m.toml", &format!("bias = [true, false]\n{CARTPOLE}"));
    let out = dir.join("run");
    let o = rwg(&["run", &m, "--timing", "-q", "--out", out.to_str().unwrap()]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    let cells = ["CartPole-v0__1HL__nobias", "CartPole-v0__1HL__bias"];
    for c in cells {
        let line = err
            .lines()
            .find(|l| l.starts_with(c))
            .unwrap_or_else(|| panic!("no timing line for {c}:\n{err}"));
        // sampling, compile, run (a JAX cell's only), serial, serial share |
        // commit I/O, commit end, finalise, run.json
        let cols: Vec<_> = line.split_whitespace().collect();
        assert_eq!(cols.len(), 11, "{line}");
        assert_eq!((cols[2], cols[3]), ("-", "-"), "{line}");
        assert!(cols[5].ends_with('%') && cols[6] == "|", "{line}");
    }
    assert!(err.contains("last cells' ends"), "{err}");
    assert!(err.contains("whole run:"), "{err}");
    // run.json records the cells in the manifest's order, each finalised
    let run: serde_json::Value = serde_json::from_str(&read(out.join("run.json"))).unwrap();
    let recorded: Vec<_> = run["cells"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| c["dir"].as_str().unwrap_or_default().to_string())
        .collect();
    // (the timing table lists the cells in the order they ran: the study's)
    let ran: Vec<_> = err
        .lines()
        .filter(|l| cells.iter().any(|c| l.starts_with(c)))
        .map(|l| l.split_whitespace().next().unwrap().to_string())
        .collect();
    assert_eq!(recorded, ran, "{run}");
    for c in &recorded {
        assert!(out.join("cells").join(c).join("cell.json").exists(), "{c}");
    }
}

#[test]
fn a_cell_end_failing_after_the_sampling_fails_the_run_naming_the_cell_and_resumes() {
    // One block per cell, computed within the committer's linger: kept back
    // from the disk for the cell's end, which finalises from it. A non-empty
    // directory where scores.csv goes makes the finalisation's rename fail:
    // the failure is found by the cell's end (the recorder), not while
    // sampling, and the kept-back block is committed before the run stops.
    let dir = temp_dir("end-fails");
    let m = manifest(
        &dir,
        "m.toml",
        &(CARTPOLE.replace("samples = 40", "samples = 20") + "[[envs]]\nid = \"MountainCar-v0\"\n"),
    );
    let run = dir.join("run");
    let cell = run.join("cells/CartPole-v0__1HL__nobias");
    let obstacle = cell.join("scores.csv");
    std::fs::create_dir_all(obstacle.join("x")).unwrap();
    let err = rwg_err(&["run", &m, "-q", "--out", run.to_str().unwrap()]);
    assert!(
        err.contains("cannot finalise cell CartPole-v0__1HL__nobias"),
        "{err}"
    );
    assert!(err.contains("scores.csv"), "{err}");
    let meta: serde_json::Value = serde_json::from_str(&read(run.join("run.json"))).unwrap();
    assert_eq!(meta["cells"].as_array().unwrap().len(), 0, "{meta}");
    assert!(meta["end_time"].is_null(), "{meta}");
    let index = read(cell.join("blocks/SHA256SUMS"));
    assert!(index.ends_with("  b0000000.csv\n"), "{index}");
    assert!(cell.join("blocks/b0000000.csv").is_file());
    // Fixed, the run resumes to the bytes of a clean run.
    std::fs::remove_dir_all(&obstacle).unwrap();
    rwg_ok(&["run", &m, "-q", "--out", run.to_str().unwrap()]);
    let clean = dir.join("clean");
    rwg_ok(&["run", &m, "-q", "--out", clean.to_str().unwrap()]);
    for cell in ["CartPole-v0__1HL__nobias", "MountainCar-v0__1HL__nobias"] {
        for f in ["scores.csv", "samples.csv"] {
            let p = format!("cells/{cell}/{f}");
            assert_eq!(read(run.join(&p)), read(clean.join(&p)), "{p}");
        }
    }
    // A shard commits every block (it finalises nothing): a commit failing on
    // an I/O thread after the sampling is found by the cell's end too.
    let shard = dir.join("shard");
    let obstacle = shard.join("cells/CartPole-v0__1HL__nobias/blocks/b0000000.csv");
    std::fs::create_dir_all(obstacle.join("x")).unwrap();
    let err = rwg_err(&[
        "run",
        &m,
        "-q",
        "--shard",
        "0/1",
        "--out",
        shard.to_str().unwrap(),
    ]);
    assert!(
        err.contains("cell CartPole-v0__1HL__nobias failed") && err.contains("b0000000.csv"),
        "{err}"
    );
}

#[test]
fn a_bad_commit_linger_is_refused_naming_the_variable() {
    let dir = temp_dir("linger");
    let m = manifest(&dir, "m.toml", CARTPOLE);
    let out = dir.join("run");
    let o = rwg_env(
        &["run", &m, "-q", "--out", out.to_str().unwrap()],
        &[("RWG_COMMIT_LINGER", std::ffi::OsStr::new("soon"))],
    );
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success());
    assert!(
        err.contains("RWG_COMMIT_LINGER=soon: expected seconds from 0 to 3600"),
        "{err}"
    );
    // 0: every block committed at once, the same results.
    let o = rwg_env(
        &["run", &m, "-q", "--out", out.to_str().unwrap()],
        &[("RWG_COMMIT_LINGER", std::ffi::OsStr::new("0"))],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let clean = dir.join("clean");
    rwg_ok(&["run", &m, "-q", "--out", clean.to_str().unwrap()]);
    for f in ["scores.csv", "samples.csv"] {
        let p = format!("cells/CartPole-v0__1HL__nobias/{f}");
        assert_eq!(read(out.join(&p)), read(clean.join(&p)), "{p}");
    }
}

/// `rwg run` with `args` in folder `dir`.
fn rwg_in(dir: &Path, args: &[&str]) -> std::process::Output {
    std::process::Command::new(rwg_bin())
        .args(args)
        .current_dir(dir)
        .output()
        .unwrap()
}

#[test]
fn the_manifest_given_is_never_written_over() {
    let dir = temp_dir("own-manifest");
    let text = format!("# the user's own comments\n{CARTPOLE}");
    manifest(&dir, "manifest.toml", &text);
    // --out . would put the run's manifest.toml over the user's.
    let out = rwg_in(&dir, &["run", "manifest.toml", "--out", ".", "-q"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    // (paths made absolute before any plugin code runs)
    assert!(
        err.contains("/manifest.toml is the manifest given and /")
            && err.contains(" holds no run")
            && err.contains("--out runs/"),
        "{err}"
    );
    assert_eq!(read(dir.join("manifest.toml")), text);
    assert!(!dir.join("cells").exists() && !dir.join("run.json").exists());
    // A run directory's own manifest resumes it, and is not rewritten.
    let run = dir.join("runs/x");
    let r = run.to_str().unwrap();
    rwg_ok(&[
        "run",
        &dir.join("manifest.toml").to_string_lossy(),
        "--out",
        r,
        "-q",
    ]);
    let own = run.join("manifest.toml");
    let o = own.to_str().unwrap();
    let before = std::fs::metadata(&own).unwrap().modified().unwrap();
    let again = rwg_ok(&["run", o, "--out", r, "-q"]);
    assert!(again.contains("complete; nothing to do"), "{again}");
    assert_eq!(std::fs::metadata(&own).unwrap().modified().unwrap(), before);
    // --force-new would delete the manifest given.
    let err = rwg_err(&["run", o, "--out", r, "--force-new", "-q"]);
    assert!(err.contains("--force-new would delete"), "{err}");
    assert!(own.is_file());
}

#[test]
fn an_edited_run_directory_manifest_is_refused_and_named() {
    let dir = temp_dir("edited-manifest");
    let m = manifest(&dir, "m.toml", CARTPOLE);
    let run = dir.join("run");
    let r = run.to_str().unwrap();
    rwg_ok(&["run", &m, "--out", r, "-q", "--no-report"]);
    let own = run.join("manifest.toml");
    let o = own.to_str().unwrap();
    let good = read(&own);
    std::fs::write(&own, good.replace("samples = 40", "samples = 96")).unwrap();
    let want = format!(
        "{o} was changed after rwg wrote it (samples: 40 vs 96; run.json's record vs the file)"
    );
    for args in [
        vec!["run", o, "--out", r, "-q"],
        vec!["run", &m, "--out", r, "-q"],
    ] {
        let err = rwg_err(&args);
        assert!(err.contains(&want), "{args:?}: {err}");
        assert!(err.contains("rwg run edited.toml --out"), "{err}");
    }
    // verify counts it as a problem.
    let out = rwg(&["verify", r]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stdout).contains(&want));
    // status warns and counts the recorded study's blocks, not the edit's.
    let status = rwg_ok(&["status", r]);
    assert!(status.contains(&want), "{status}");
    assert!(
        status.contains("40 networks") && status.contains("2/2"),
        "{status}"
    );
    // An emptied manifest.toml: run.json's record says how to restore it.
    std::fs::write(&own, "").unwrap();
    let err = rwg_err(&["run", &m, "--out", r, "-q"]);
    assert!(
        err.contains("does not read, but run.json records the study it held"),
        "{err}"
    );
    let meta: serde_json::Value = serde_json::from_str(&read(run.join("run.json"))).unwrap();
    assert_eq!(meta["study"].as_str().unwrap(), good);
    std::fs::write(&own, &good).unwrap();
    rwg_ok(&["run", o, "--out", r, "-q"]);
}

#[test]
fn an_empty_or_cut_run_json_says_how_to_rebuild_it() {
    let dir = temp_dir("bad-run-json");
    let m = manifest(&dir, "m.toml", CARTPOLE);
    let run = dir.join("run");
    let r = run.to_str().unwrap();
    rwg_ok(&["run", &m, "--out", r, "-q", "--no-report"]);
    let json = read(run.join("run.json"));
    let rebuild = format!("Delete it, then run rwg run {r}/manifest.toml --out {r}");
    for cut in ["", &json[..json.len() / 2]] {
        std::fs::write(run.join("run.json"), cut).unwrap();
        for args in [
            vec!["run", &m, "--out", r, "-q"],
            vec!["stats", r, "--no-write"],
            vec!["verify", r],
        ] {
            let out = rwg(&args);
            assert!(!out.status.success(), "{args:?}");
            // (verify lists its problems on stdout)
            let err = String::from_utf8_lossy(&out.stderr).into_owned()
                + &String::from_utf8_lossy(&out.stdout);
            assert!(
                err.contains("is not a readable run.json"),
                "{args:?}: {err}"
            );
            assert!(err.contains(&rebuild), "{args:?}: {err}");
        }
    }
    std::fs::remove_file(run.join("run.json")).unwrap();
    rwg_ok(&[
        "run",
        &format!("{r}/manifest.toml"),
        "--out",
        r,
        "-q",
        "--no-report",
    ]);
    rwg_ok(&["verify", r]);
    rwg_ok(&["stats", r, "--no-write"]);
}

#[test]
fn what_stands_in_the_way_of_the_run_directory_is_named() {
    let dir = temp_dir("in-the-way");
    let m = manifest(&dir, "m.toml", CARTPOLE);
    // A file where the run's cells/ folder goes.
    let run = dir.join("cf");
    std::fs::create_dir_all(&run).unwrap();
    std::fs::write(run.join("cells"), "mine").unwrap();
    let err = rwg_err(&["run", &m, "--out", run.to_str().unwrap(), "-q"]);
    let cells = run.join("cells");
    assert!(
        err.contains(&format!(
            "cannot create {0}: {0} is a file, not a folder",
            cells.display()
        )),
        "{err}"
    );
    assert_eq!(read(&cells), "mine");
    // --out a symbolic link to a folder that does not exist.
    let link = dir.join("dl");
    std::os::unix::fs::symlink(dir.join("nowhere"), &link).unwrap();
    let shard = dir.join("s0");
    let s0 = shard.to_str().unwrap();
    rwg_ok(&["run", &m, "--shard", "0/1", "--out", s0, "-q"]);
    let want = format!(
        "{} is a symbolic link to {}, which does not exist",
        link.display(),
        dir.join("nowhere").display()
    );
    for args in [
        vec!["run", &m, "--out", link.to_str().unwrap(), "-q"],
        vec!["merge", s0, "--out", link.to_str().unwrap()],
    ] {
        let err = rwg_err(&args);
        assert!(err.contains(&want), "{args:?}: {err}");
        assert!(!err.contains("File exists"), "{args:?}: {err}");
    }
}

/// A `policy = "random"` architecture adds one cell per env (whatever
/// `bias` says) of uniformly random actions: the same bytes for any thread
/// count, CartPole's known random baseline (about 22 steps an episode;
/// constant actions last about 9), a box's actions within its bounds (a
/// replay gives the stored scores), and no weights to export.
#[test]
fn a_random_cell_is_the_random_baseline_for_any_threads() {
    let dir = temp_dir("random");
    let m = manifest(
        &dir,
        "m.toml",
        r#"
seed = 3
samples = 40
episodes = 3
bias = [true, false]
[[architectures]]
name = "0HL"
hidden = []
[[architectures]]
name = "random"
policy = "random"
[[envs]]
id = "CartPole-v1"
[[envs]]
id = "MountainCarContinuous-v0"
max_episode_steps = 50
"#,
    );
    for t in ["1", "2"] {
        let out = dir.join(format!("t{t}"));
        rwg_ok(&["run", &m, "--threads", t, "--out", out.to_str().unwrap()]);
    }
    let cells: Vec<String> = std::fs::read_dir(dir.join("t1/cells"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.contains("__random__"))
        .collect();
    assert_eq!(cells.len(), 2, "one random cell per env: {cells:?}");
    for cell in &cells {
        assert!(cell.ends_with("__random__nobias"), "{cell}");
        let f = format!("cells/{cell}/scores.csv");
        assert_eq!(read(dir.join("t1").join(&f)), read(dir.join("t2").join(&f)));
    }
    let scores = read(dir.join("t1/cells/CartPole-v1__random__nobias/scores.csv"));
    let steps: Vec<f64> = scores
        .lines()
        .skip(1)
        .map(|l| l.split(',').nth(3).unwrap().parse().unwrap())
        .collect();
    assert_eq!(steps.len(), 120);
    let mean = steps.iter().sum::<f64>() / 120.0;
    assert!((17.0..28.0).contains(&mean), "mean episode {mean} steps");
    let run = dir.join("t1");
    let run = run.to_str().unwrap();
    let replay = |extra: &[&str]| {
        let mut args = vec!["replay", run, "--env", "MountainCarContinuous-v0"];
        args.extend_from_slice(&["--arch", "random", "--sample", "7"]);
        args.extend_from_slice(extra);
        args.iter().map(|s| s.to_string()).collect::<Vec<_>>()
    };
    let args = replay(&[]);
    rwg_ok(&args.iter().map(String::as_str).collect::<Vec<_>>());
    let args = replay(&["--episode", "1", "--format", "csv"]);
    let steps = rwg_ok(&args.iter().map(String::as_str).collect::<Vec<_>>());
    assert!(steps.lines().count() > 40, "{steps}");
    let out = dir.join("w.json");
    let args = replay(&["--export-weights", out.to_str().unwrap()]);
    let e = rwg_err(&args.iter().map(String::as_str).collect::<Vec<_>>());
    assert!(e.contains("no weights to export"), "{e}");
    let stats = rwg_ok(&["stats", run]);
    assert!(stats.contains("random"), "{stats}");
    let _ = std::fs::remove_dir_all(&dir);
}
