//! The run directory's guarantees end to end: one writer at a time (the
//! lock), checksums (`rwg verify`; damaged files named by every reader),
//! unambiguous portable cell names, temporary files that never follow a
//! planted link, and randomised SIGKILL fault injection on `run` and `merge`.

mod common;
use common::*;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// Small: two cells of 3 blocks each.
const SMALL: &str = SMALL_STUDY;

/// Enough work (about a second in a debug build) for kills to land mid-run.
const LONG: &str = r#"
seed = 3
samples = 320
episodes = 4
bias = [false, true]
[[architectures]]
name = "0HL"
hidden = []
[[architectures]]
name = "1HL"
hidden = [3]
[[envs]]
id = "CartPole-v1"
[[envs]]
id = "Acrobot-v1"
max_episode_steps = 100
"#;

fn manifest(dir: &Path, name: &str, body: &str) -> String {
    let p = dir.join(name);
    std::fs::write(&p, body).unwrap();
    p.to_str().unwrap().to_string()
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// Every file under `dir` with its bytes.
fn snapshot(dir: &Path) -> BTreeMap<PathBuf, Vec<u8>> {
    let mut out = BTreeMap::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else {
                out.insert(p.clone(), std::fs::read(&p).unwrap());
            }
        }
    }
    out
}

/// The result files that must be byte-identical between two runs of a study.
fn results(run: &Path) -> BTreeMap<String, Vec<u8>> {
    let mut out = BTreeMap::new();
    out.insert(
        "manifest.toml".into(),
        std::fs::read(run.join("manifest.toml")).unwrap(),
    );
    for e in std::fs::read_dir(run.join("cells")).unwrap() {
        let c = e.unwrap().path();
        let name = c.file_name().unwrap().to_string_lossy().into_owned();
        assert!(!c.join("blocks").exists(), "{name}: blocks left behind");
        for f in ["scores.csv", "samples.csv", "SHA256SUMS"] {
            let mut bytes = std::fs::read(c.join(f)).unwrap_or_else(|e| panic!("{name}/{f}: {e}"));
            if f == "SHA256SUMS" {
                // cell.json holds timings: its line differs from run to run.
                let text = String::from_utf8(bytes).unwrap();
                bytes = text
                    .lines()
                    .filter(|l| !l.ends_with("  cell.json"))
                    .collect::<Vec<_>>()
                    .join("\n")
                    .into_bytes();
            }
            out.insert(format!("{name}/{f}"), bytes);
        }
    }
    out
}

fn assert_same_results(a: &Path, b: &Path) {
    let (ra, rb) = (results(a), results(b));
    assert_eq!(ra.keys().collect::<Vec<_>>(), rb.keys().collect::<Vec<_>>());
    for (k, v) in &ra {
        assert!(
            *v == rb[k],
            "{k} differs between {} and {}",
            a.display(),
            b.display()
        );
    }
}

fn verify_ok(dir: &Path) {
    let out = rwg_ok(&["verify", s(dir)]);
    assert!(out.contains("all match their checksums"), "{out}");
}

/// `rwg verify` fails; returns stdout + stderr.
fn verify_fails(dir: &Path) -> String {
    let out = rwg(&["verify", s(dir)]);
    assert_eq!(out.status.code(), Some(1), "rwg verify should fail");
    String::from_utf8_lossy(&out.stdout).into_owned() + &String::from_utf8_lossy(&out.stderr)
}

#[test]
fn a_second_writer_fails_at_once_names_the_holder_and_changes_nothing() {
    let dir = temp_dir("rundir-lock");
    let m = manifest(&dir, "small.toml", SMALL);
    let run = dir.join("run");
    rwg_ok(&["run", &m, "--out", s(&run)]);
    let shards: Vec<PathBuf> = (0..2).map(|k| dir.join(format!("s{k}"))).collect();
    for (k, d) in shards.iter().enumerate() {
        rwg_ok(&["run", &m, "--shard", &format!("{k}/2"), "--out", s(d)]);
    }
    // This test process holds the lock, as a running `rwg run` would.
    let lock = rwg_study::rundir::lock::RunLock::acquire(&run).unwrap();
    let before = snapshot(&run);
    let holder = format!("pid {}: ", std::process::id());
    let weights = run.join("w.json");
    let writers: Vec<Vec<&str>> = vec![
        vec!["run", &m, "--out", s(&run), "--force-new"],
        vec!["run", &m, "--out", s(&run)],
        vec!["stats", s(&run)],
        vec!["report", s(&run)],
        vec!["plot", s(&run)],
        vec!["merge", s(&shards[0]), s(&shards[1]), "--out", s(&run)],
        vec![
            "replay",
            s(&run),
            "--env",
            "CartPole-v1",
            "--arch",
            "0HL",
            "--sample",
            "1",
            "--export-weights",
            s(&weights),
        ],
    ];
    for args in &writers {
        let t = Instant::now();
        let err = rwg_err(args);
        assert!(
            t.elapsed() < Duration::from_secs(20),
            "rwg {args:?} waited for the lock"
        );
        assert!(
            err.contains("is being written by another rwg process")
                && err.contains(&holder)
                && err.contains("nothing was changed"),
            "rwg {args:?}: {err}"
        );
    }
    let after = snapshot(&run);
    let changed: Vec<_> = before
        .keys()
        .chain(after.keys())
        .filter(|k| before.get(*k) != after.get(*k))
        .collect();
    assert!(changed.is_empty(), "a refused writer changed {changed:?}");
    // Readers take no lock.
    verify_ok(&run);
    rwg_ok(&["top", s(&run), "-n", "2"]);
    rwg_ok(&["stats", s(&run), "--no-write"]);
    drop(lock);
    rwg_ok(&["stats", s(&run)]);

    // Two real processes: the second names the first's pid and command.
    let long = manifest(&dir, "long.toml", LONG);
    let busy = dir.join("busy");
    let mut first = Command::new(rwg_bin())
        .args(["run", &long, "--out", s(&busy), "--threads", "1"])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let pid = format!("pid {}: ", first.id());
    let t = Instant::now();
    while !std::fs::read_to_string(busy.join("rwg.lock")).is_ok_and(|l| l.starts_with(&pid)) {
        assert!(t.elapsed() < Duration::from_secs(30), "no lock recorded");
        std::thread::sleep(Duration::from_millis(10));
    }
    let out = rwg(&["run", &long, "--out", s(&busy)]);
    let running = first.try_wait().unwrap().is_none();
    let err = String::from_utf8_lossy(&out.stderr);
    if running {
        assert!(!out.status.success());
        assert!(err.contains(&pid) && err.contains(" run "), "{err}");
    }
    assert!(first.wait().unwrap().success());
    verify_ok(&busy);
}

#[test]
fn a_symlink_planted_at_a_tmp_path_is_not_followed() {
    let dir = temp_dir("rundir-symlink");
    let m = manifest(&dir, "small.toml", SMALL);
    let reference = dir.join("reference");
    rwg_ok(&["run", &m, "--out", s(&reference), "--no-report"]);

    let run = dir.join("run");
    let cell = run.join("cells").join("CartPole-v1__0HL__nobias");
    std::fs::create_dir_all(cell.join("blocks")).unwrap();
    let victim = dir.join("victim.txt");
    std::fs::write(&victim, "precious\n").unwrap();
    let dangling = dir.join("created-through-a-link");
    let links = [
        run.join("run.json.tmp"),
        run.join("manifest.toml.tmp"),
        cell.join("blocks").join("b0000000.csv.tmp"),
        cell.join("scores.csv.tmp"),
        cell.join("samples.csv.tmp"),
        cell.join("SHA256SUMS.tmp"),
    ];
    for (i, l) in links.iter().enumerate() {
        let target = if i % 2 == 0 { &victim } else { &dangling };
        std::os::unix::fs::symlink(target, l).unwrap();
    }
    rwg_ok(&["run", &m, "--out", s(&run), "--no-report"]);
    assert_eq!(std::fs::read_to_string(&victim).unwrap(), "precious\n");
    assert!(!dangling.exists(), "a write went through a dangling link");
    assert_same_results(&reference, &run);
    verify_ok(&run);
}

/// Replaces a file's bytes.
fn damage(path: &Path, how: &str) {
    let good = std::fs::read(path).unwrap();
    let bad = match how {
        // a value changed, the row still parses
        "edit" => {
            let t = String::from_utf8(good).unwrap();
            let mut lines: Vec<String> = t.lines().map(String::from).collect();
            let f: Vec<String> = lines[5].split(',').map(String::from).collect();
            let score: f64 = f[2].parse().unwrap();
            lines[5] = format!("{},{},{},{}", f[0], f[1], score + 1.0, f[3]);
            (lines.join("\n") + "\n").into_bytes()
        }
        // cut at a line end in the middle
        "truncate" => {
            let cut = good[..good.len() / 2]
                .iter()
                .rposition(|&c| c == b'\n')
                .unwrap();
            good[..=cut].to_vec()
        }
        // as a crashed machine can leave a file
        "zero" => vec![0u8; good.len()],
        _ => unreachable!(),
    };
    std::fs::write(path, bad).unwrap();
}

#[test]
fn edited_truncated_and_zero_filled_files_are_named_and_never_count() {
    let dir = temp_dir("rundir-damage");
    let m = manifest(&dir, "small.toml", SMALL);
    let reference = dir.join("reference");
    rwg_ok(&["run", &m, "--out", s(&reference), "--no-report"]);
    let copy = |name: &str| {
        let d = dir.join(name);
        Command::new("cp")
            .args(["-r", s(&reference), s(&d)])
            .status()
            .unwrap();
        d
    };
    let cell = "cells/CartPole-v1__1HL__nobias";

    // An edited scores.csv: every reader names the file; stats the row too.
    let run = copy("edited");
    damage(&run.join(cell).join("scores.csv"), "edit");
    let v = verify_fails(&run);
    assert!(
        v.contains(&format!("{cell}/scores.csv: checksum mismatch")),
        "{v}"
    );
    let e = rwg_err(&["stats", s(&run), "--no-write"]);
    assert!(
        e.contains("scores.csv: checksum mismatch") && e.contains("scores.csv:5: sample 1"),
        "{e}"
    );
    let e = rwg_err(&["run", &m, "--out", s(&run), "--no-report"]);
    assert!(e.contains("scores.csv: checksum mismatch"), "{e}");
    let e = rwg_err(&[
        "replay",
        s(&run),
        "--env",
        "CartPole-v1",
        "--arch",
        "1HL",
        "--sample",
        "0",
    ]);
    assert!(e.contains("scores.csv: checksum mismatch"), "{e}");

    // A truncated scores.csv does not count as complete.
    let run = copy("truncated");
    damage(&run.join(cell).join("scores.csv"), "truncate");
    let v = verify_fails(&run);
    assert!(v.contains("scores.csv: checksum mismatch"), "{v}");
    let e = rwg_err(&["run", &m, "--out", s(&run), "--no-report"]);
    assert!(
        e.contains("do not verify") && e.contains("scores.csv: checksum mismatch"),
        "{e}"
    );
    let e = rwg_err(&["report", s(&run)]);
    assert!(e.contains("scores.csv: checksum mismatch"), "{e}");

    // A zero-filled samples.csv: top (which reads only it) names it and the row.
    let run = copy("zeroed");
    damage(&run.join(cell).join("samples.csv"), "zero");
    let v = verify_fails(&run);
    assert!(v.contains("samples.csv: checksum mismatch"), "{v}");
    let e = rwg_err(&["top", s(&run)]);
    assert!(
        e.contains("samples.csv: checksum mismatch") && e.contains("samples.csv:1: header"),
        "{e}"
    );

    // A scores.csv that cannot be read (a folder in its place): verify and
    // stats name it and say why.
    let run = copy("unreadable");
    let scores = run.join(cell).join("scores.csv");
    std::fs::remove_file(&scores).unwrap();
    std::fs::create_dir(&scores).unwrap();
    let v = verify_fails(&run);
    assert!(v.contains("scores.csv: not a regular file"), "{v}");
    let e = rwg_err(&["stats", s(&run), "--no-write"]);
    assert!(
        e.contains("scores.csv: not a regular file")
            && e.contains("cannot read ")
            && e.matches("not a regular file").count() == 2,
        "{e}"
    );

    // Blocks of a shard: edited, truncated, zero-filled; verify and merge name them.
    let shards: Vec<PathBuf> = (0..2).map(|k| dir.join(format!("s{k}"))).collect();
    for (k, d) in shards.iter().enumerate() {
        rwg_ok(&["run", &m, "--shard", &format!("{k}/2"), "--out", s(d)]);
    }
    let merged = dir.join("merged");
    for how in ["edit", "truncate", "zero"] {
        let block = shards[1].join(cell).join("blocks/b0000000.csv");
        let good = std::fs::read(&block).unwrap();
        damage(&block, how);
        let v = verify_fails(&shards[1]);
        assert!(v.contains("b0000000.csv: checksum mismatch"), "{how}: {v}");
        let _ = std::fs::remove_dir_all(&merged);
        let e = rwg_err(&["merge", s(&shards[0]), s(&shards[1]), "--out", s(&merged)]);
        assert!(e.contains("b0000000.csv: checksum mismatch"), "{how}: {e}");
        // Running the shard again computes the block again, saying so (block
        // files are not synced: this is also what a crash of the machine
        // before they reached the disk leaves).
        let out = rwg(&["run", &m, "--shard", "1/2", "--out", s(&shards[1]), "-q"]);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "{how}: {err}");
        assert!(
            err.contains(&format!(
                "note: 1 committed block(s) of cell {} do not match",
                cell.trim_start_matches("cells/")
            )) && err.contains("computing them again (b0000000.csv)"),
            "{how}: {err}"
        );
        assert_eq!(std::fs::read(&block).unwrap(), good, "{how}");
    }
    // A block that cannot be read (a folder in its place): verify and merge
    // name it and say why.
    let block = shards[1].join(cell).join("blocks/b0000000.csv");
    let good = std::fs::read(&block).unwrap();
    std::fs::remove_file(&block).unwrap();
    std::fs::create_dir(&block).unwrap();
    let v = verify_fails(&shards[1]);
    assert!(v.contains("b0000000.csv: not a regular file"), "{v}");
    let _ = std::fs::remove_dir_all(&merged);
    let e = rwg_err(&["merge", s(&shards[0]), s(&shards[1]), "--out", s(&merged)]);
    assert!(e.contains("b0000000.csv: not a regular file"), "{e}");
    std::fs::remove_dir(&block).unwrap();
    std::fs::write(&block, good).unwrap();
    verify_ok(&shards[1]);
    let _ = std::fs::remove_dir_all(&merged);
    rwg_ok(&["merge", s(&shards[0]), s(&shards[1]), "--out", s(&merged)]);
    assert_same_results(&reference, &merged);
    verify_ok(&merged);
}

#[test]
fn names_that_sanitise_alike_get_their_own_cells() {
    let dir = temp_dir("rundir-names");
    // Architectures `a/b` and `a_b` once shared a directory.
    let m = manifest(
        &dir,
        "archs.toml",
        &SMALL
            .replace("name = \"0HL\"", "name = \"a/b\"")
            .replace("name = \"1HL\"", "name = \"a_b\""),
    );
    let run = dir.join("archs");
    rwg_ok(&["run", &m, "--out", s(&run), "--no-report"]);
    let cell_json = |run: &Path, d: &str| -> serde_json::Value {
        serde_json::from_str(
            &std::fs::read_to_string(run.join("cells").join(d).join("cell.json")).unwrap(),
        )
        .unwrap()
    };
    let run_json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(run.join("run.json")).unwrap()).unwrap();
    let dirs: Vec<&str> = run_json["cells"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| c["dir"].as_str().unwrap())
        .collect();
    assert_eq!(dirs.len(), 2);
    assert_ne!(dirs[0].to_lowercase(), dirs[1].to_lowercase());
    assert_eq!(dirs[1], "CartPole-v1__a_b__nobias");
    assert_eq!(cell_json(&run, dirs[0])["arch"], "a/b");
    assert_eq!(cell_json(&run, dirs[1])["arch"], "a_b");
    assert_eq!(cell_json(&run, dirs[1])["hidden"], serde_json::json!([3]));
    // Each cell holds its own architecture's results: the ones a run under
    // the plain names gives.
    let plain = dir.join("plain");
    rwg_ok(&[
        "run",
        &manifest(&dir, "plain.toml", SMALL),
        "--out",
        s(&plain),
        "--no-report",
    ]);
    for (named, plain_dir) in dirs
        .iter()
        .zip(["CartPole-v1__0HL__nobias", "CartPole-v1__1HL__nobias"])
    {
        assert_eq!(
            std::fs::read(run.join("cells").join(named).join("scores.csv")).unwrap(),
            std::fs::read(plain.join("cells").join(plain_dir).join("scores.csv")).unwrap(),
            "{named}"
        );
    }
    verify_ok(&run);

    // Names that differ only in case are refused at load, naming both lines,
    // before anything is created.
    let m = manifest(
        &dir,
        "case.toml",
        &SMALL
            .replace("name = \"0HL\"", "name = \"net\"")
            .replace("name = \"1HL\"", "name = \"NET\""),
    );
    let out = dir.join("case");
    let e = rwg_err(&["run", &m, "--out", s(&out)]);
    assert!(
        e.contains("architectures[0].name 'net' and architectures[1].name 'NET' (lines 7 and 10)")
            && e.contains("case-insensitive"),
        "{e}"
    );
    assert!(!out.exists());

    // Plugin ids `adv/Ok-v0` and `adv_Ok-v0`, and one with characters no
    // file system takes.
    let ids = ["adv/Ok-v0", "adv_Ok-v0", "odd/a:b*c?\"<>|\\-v0"];
    let mut body = String::from(
        "seed = 1\nsamples = 40\nepisodes = 2\nbias = [false]\n\
         [[architectures]]\nname = \"0HL\"\nhidden = []\n",
    );
    for (i, id) in ids.iter().enumerate() {
        let lib = compile_c(
            &format!("rundir-names-{i}"),
            "examples/plugin-c/chain.c",
            "chain",
            &[&format!("CHAIN_ID={id:?}")],
        );
        body.push_str(&format!(
            "[[envs]]\nid = {:?}\nplugin = {:?}\n",
            id,
            lib.to_str().unwrap()
        ));
    }
    let m = manifest(&dir, "plugins.toml", &body);
    let run = dir.join("plugins");
    rwg_ok(&["run", &m, "--out", s(&run), "--no-report"]);
    let mut found = vec![];
    for e in std::fs::read_dir(run.join("cells")).unwrap() {
        let name = e.unwrap().file_name().to_string_lossy().into_owned();
        assert!(
            !name.contains(['/', '\\', ':', '*', '?', '"', '<', '>', '|']),
            "{name}"
        );
        found.push((
            cell_json(&run, &name)["env"].as_str().unwrap().to_string(),
            name,
        ));
    }
    found.sort();
    let envs: Vec<&str> = found.iter().map(|(e, _)| e.as_str()).collect();
    assert_eq!(envs, ["adv/Ok-v0", "adv_Ok-v0", "odd/a:b*c?\"<>|\\-v0"]);
    assert_eq!(found[0].1, "adv+Ok-v0__0HL__nobias");
    assert_eq!(found[1].1, "adv_Ok-v0__0HL__nobias");
    verify_ok(&run);
}

/// xorshift64*: a small RNG with a printed seed, so a failure can be replayed.
struct Rng(u64);

impl Rng {
    fn below(&mut self, n: u64) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_f491_4f6c_dd1d) % n
    }
}

fn finished(run: &Path) -> bool {
    std::fs::read_to_string(run.join("run.json"))
        .ok()
        .and_then(|t| serde_json::from_str::<serde_json::Value>(&t).ok())
        .is_some_and(|v| v["end_time"].is_string())
}

/// Starts `rwg args`, SIGKILLs it after `ms` milliseconds; whether it was
/// still running.
fn kill_after(args: &[&str], ms: u64) -> bool {
    let mut child = Command::new(rwg_bin())
        .args(args)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    std::thread::sleep(Duration::from_millis(ms));
    let running = child.try_wait().unwrap().is_none();
    let _ = child.kill();
    child.wait().unwrap();
    running
}

/// Whatever a kill left behind, every committed file still verifies (an
/// unfinished run may lack files, never hold a damaged one).
fn no_damage(dir: &Path) {
    if !dir.join("run.json").exists() {
        return;
    }
    let out = rwg(&["verify", s(dir)]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        !text.contains("checksum mismatch") && !text.contains("first bad row"),
        "{}: {text}",
        dir.display()
    );
}

#[test]
fn random_sigkills_during_run_and_merge_then_resume_are_byte_identical() {
    let seed: u64 = std::env::var("RWG_FAULT_SEED")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(20261123);
    eprintln!("fault-injection seed {seed} (set RWG_FAULT_SEED={seed} to replay)");
    let mut rng = Rng(seed.max(1));
    let dir = temp_dir("rundir-faults");
    let m = manifest(&dir, "long.toml", LONG);
    let reference = dir.join("reference");
    let t0 = Instant::now();
    rwg_ok(&[
        "run",
        &m,
        "--out",
        s(&reference),
        "--no-report",
        "--threads",
        "2",
    ]);
    // Kills are spread over the time an uninterrupted run takes.
    let span = (t0.elapsed().as_millis() as u64).max(200);

    let run = dir.join("run");
    let mut mid_run = 0;
    for _ in 0..16 {
        let threads = (1 + rng.below(2)).to_string();
        // Each resumed run has less left to do: most kills land early.
        let ms = 20 + rng.below(span / 3);
        let args = [
            "run",
            &m,
            "--out",
            s(&run),
            "--no-report",
            "--threads",
            &threads,
        ];
        if kill_after(&args, ms) && !finished(&run) {
            mid_run += 1;
        }
        no_damage(&run);
        if finished(&run) {
            break;
        }
    }
    assert!(
        mid_run >= 3,
        "only {mid_run} kills landed mid-run (seed {seed})"
    );
    rwg_ok(&["run", &m, "--out", s(&run), "--no-report"]);
    assert_same_results(&reference, &run);
    verify_ok(&run);

    // Merge: killed at random points into one --out, merged again each
    // time; it ends byte-identical to the unsharded run.
    let shards: Vec<PathBuf> = (0..3).map(|k| dir.join(format!("s{k}"))).collect();
    for (k, d) in shards.iter().enumerate() {
        rwg_ok(&["run", &m, "--shard", &format!("{k}/3"), "--out", s(d)]);
    }
    let t0 = Instant::now();
    let whole = dir.join("merged-whole");
    let merge = |out: &Path| -> Vec<String> {
        [
            "merge",
            s(&shards[0]),
            s(&shards[1]),
            s(&shards[2]),
            "--out",
            s(out),
        ]
        .map(String::from)
        .to_vec()
    };
    let args = merge(&whole);
    rwg_ok(&args.iter().map(String::as_str).collect::<Vec<_>>());
    assert_same_results(&reference, &whole);
    let span = (t0.elapsed().as_millis() as u64).max(100);
    let merged = dir.join("merged");
    let mut mid_merge = 0;
    for _ in 0..10 {
        let ms = 5 + rng.below(span / 2);
        let args = merge(&merged);
        if kill_after(&args.iter().map(String::as_str).collect::<Vec<_>>(), ms)
            && !merged.join("report.html").exists()
        {
            mid_merge += 1;
        }
        no_damage(&merged);
        if merged.join("report.html").exists() {
            break;
        }
    }
    assert!(
        mid_merge >= 2,
        "only {mid_merge} kills landed mid-merge (seed {seed})"
    );
    let args = merge(&merged);
    rwg_ok(&args.iter().map(String::as_str).collect::<Vec<_>>());
    assert_same_results(&reference, &merged);
    verify_ok(&merged);
    for d in &shards {
        verify_ok(d);
    }
    eprintln!("{mid_run} kills mid-run, {mid_merge} mid-merge");
}
