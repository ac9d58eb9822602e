//! JAX envs (`gymnax:`, `brax:`, `jax:module:callable`) in studies, end to
//! end with the real `rwg` binary: a study writes the run directory every
//! study writes, with the bytes of `scores.csv`, `samples.csv` and
//! `stats.csv` the same for any thread count, networks per call, number of
//! devices, for merged shards and for a resumed run (one that changes the
//! networks per call too); a second study of a cell compiles nothing (the
//! compilation cache); network n has the weights of the built-in env's network n;
//! what a resume must keep (precision, the versions recorded in `env.json`)
//! is checked; a non-finite observation stops the run naming the network and
//! episode; `rwg replay` works for JAX cells; the workers end with rwg.
//! (`cli_jax_checks.rs`: refusals and descriptions.)
//!
//! Needs `RWG_PEER_PYTHON`: a Python with jax 0.10.2, gymnax 1.0.1 and brax
//! 0.14.2 (`.ci/run` makes one); without it each test prints `SKIPPED` (and
//! fails under `CI=true` or `RWG_NO_SKIP=1`). The `jax:` test envs are
//! `tests/data/rwg_jax_envs.py`.

mod common;
mod jax_common;
use common::*;
use jax_common::*;
use std::path::{Path, PathBuf};
use std::process::Command;

const CARTPOLE: &str = "gymnax=CartPole-v1";

/// The `layers` of `rwg replay --export-weights` for network `sample`.
fn exported_layers(
    run: &Path,
    env: &str,
    arch: &str,
    sample: u64,
    file: &Path,
) -> serde_json::Value {
    ok(&[
        "replay",
        s(run),
        "--env",
        env,
        "--arch",
        arch,
        "--sample",
        &sample.to_string(),
        "--export-weights",
        s(file),
    ]);
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(file).unwrap()).unwrap();
    v["layers"].clone()
}

/// Ctrl-C on a terminal once `first` exists: starts `cmd` (an `rwg run`) in
/// a process group of its own, sends SIGINT to the group (rwg and its
/// workers) when `first` appears, and checks that rwg stopped (status 130,
/// saying how to resume) before the run finished. The stop may come after
/// the blocks in flight or, when a worker is still compiling its call, after
/// the 10 s rwg gives them (what a cell holds then depends on timing; what a
/// resume gives must not).
fn ctrl_c_once(cmd: Command, first: &Path) {
    let res = ctrl_c_when(cmd, first, std::time::Duration::from_secs(120));
    let err = String::from_utf8_lossy(&res.stderr);
    assert_eq!(res.status.code(), Some(130), "{err}");
    assert!(err.to_lowercase().contains("resume with"), "{err}");
    let run = first.ancestors().nth(4).unwrap();
    let meta = std::fs::read_to_string(run.join("run.json")).unwrap();
    let meta: serde_json::Value = serde_json::from_str(&meta).unwrap();
    assert!(meta["end_time"].is_null(), "the run finished: {meta}");
}

/// A gymnax CartPole study (0HL and [4], 64 networks x 3 episodes) writes
/// the run directory, its env record and stats.csv; its networks are the
/// built-in CartPole-v1's; `rwg replay` of one prints the returns of
/// scores.csv.
#[test]
fn a_gymnax_study_writes_the_run_directory_with_the_builtin_networks() {
    let Some(py) = python() else { return };
    let dir = temp_dir("jax-cartpole");
    let m = write(
        &dir,
        "m.toml",
        &manifest(&py, "gymnax:CartPole-v1", "", 64, 3, true),
    );
    let run = dir.join("run");
    // a cache of its own, empty: the workers really compile (with the
    // shared one, another test's run of the same program may have filled
    // it, and loading takes less than a progress interval)
    let out = rwg_cmd(&["run", &m, "--out", s(&run), "--threads", "2", "--timing"])
        .env("RWG_PROGRESS_INTERVAL", "0.1")
        .env("RWG_JAX_CACHE", dir.join("jax-cache"))
        .output()
        .unwrap();
    let text = output_text(&out);
    assert!(out.status.success(), "{text}");
    // while the workers compile, the progress says so, with no rate or ETA
    let compiling: Vec<&str> = text
        .lines()
        .filter(|l| l.contains("compiling for"))
        .collect();
    assert!(!compiling.is_empty(), "{text}");
    assert!(
        compiling
            .iter()
            .all(|l| !l.contains("networks/s") && !l.contains("ETA")),
        "{text}"
    );
    // --timing: each cell's sampling split into compile and run
    let mut timing = text
        .lines()
        .skip_while(|l| !l.starts_with("phase (wall ms)"));
    let header = timing
        .next()
        .unwrap_or_else(|| panic!("no timing table: {text}"));
    assert!(header.contains(" sampling   compile        run "), "{text}");
    let rows: Vec<&str> = timing.collect();
    for arch in ["0HL", "1HL"] {
        let row = rows
            .iter()
            .find(|l| l.starts_with(&format!("{CARTPOLE}__{arch}__nobias")))
            .unwrap_or_else(|| panic!("no timing row of {arch}: {text}"));
        let ms: Vec<f64> = row
            .split_whitespace()
            .skip(1)
            .take(3)
            .map(|x| x.parse().unwrap())
            .collect();
        // sampling = compile + run, to the rounding of each to 0.1 ms
        assert!(
            (ms[0] - ms[1] - ms[2]).abs() <= 0.11 && ms[1] > 0.0,
            "{row}"
        );
    }
    assert!(text.contains("(JAX compile "), "{text}");
    for f in [
        "manifest.toml",
        "run.json",
        "stats.csv",
        "stats.json",
        "report.html",
    ] {
        assert!(run.join(f).is_file(), "{f} missing");
    }
    for arch in ["0HL", "1HL"] {
        let cell = run.join(format!("cells/{CARTPOLE}__{arch}__nobias"));
        for f in [
            "scores.csv",
            "samples.csv",
            "cell.json",
            "env.json",
            "SHA256SUMS",
        ] {
            assert!(cell.join(f).is_file(), "{arch}: {f} missing");
        }
        let scores = std::fs::read_to_string(cell.join("scores.csv")).unwrap();
        assert_eq!(scores.lines().count(), 1 + 64 * 3, "{arch}");
        let record: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(cell.join("env.json")).unwrap()).unwrap();
        let jax = &record["jax"];
        assert_eq!(jax["precision"], "float32", "{record}");
        assert_eq!(jax["platform"], "cpu", "{record}");
        assert_eq!(jax["lanes"], 512, "{record}");
        assert_eq!(jax["matmul_precision"], "highest", "{record}");
        assert!(jax.get("networks_per_call").is_none(), "{record}");
        assert_eq!(jax["versions"]["jax"], "0.10.2", "{record}");
        assert_eq!(jax["versions"]["gymnax"], "1.0.1", "{record}");
    }
    let stats = std::fs::read_to_string(run.join("stats.csv")).unwrap();
    assert!(stats.contains("gymnax:CartPole-v1"), "{stats}");
    // how the JAX cells computed: in rwg status, rwg stats and report.html
    let setting =
        "cpu, float32, matmul highest, 512 lanes; jax 0.10.2, jaxlib 0.10.2, gymnax 1.0.1";
    let status = ok(&["status", s(&run)]);
    assert!(
        status.contains(&format!("gymnax:CartPole-v1 (2 cells): {setting}")),
        "{status}"
    );
    let table = ok(&["stats", s(&run), "--no-write"]);
    assert!(table.contains("How the JAX envs computed"), "{table}");
    let report = std::fs::read_to_string(run.join("report.html")).unwrap();
    assert!(
        report.contains("How the JAX envs computed"),
        "report lacks the JAX table"
    );
    assert!(
        report.contains("JAX: cpu, float32, matmul highest, 512 lanes; jax 0.10.2"),
        "report lacks the cells' JAX line"
    );

    // network n's weights are the built-in CartPole-v1's network n
    let builtin = write(
        &dir,
        "builtin.toml",
        "seed = 5\nsamples = 64\nepisodes = 3\n[[architectures]]\nname = \"0HL\"\nhidden = []\n\
         [[architectures]]\nname = \"1HL\"\nhidden = [4]\n[[envs]]\nid = \"CartPole-v1\"\n",
    );
    let brun = dir.join("builtin");
    rwg_ok(&["run", &builtin, "--out", s(&brun), "--no-report"]);
    for (arch, n) in [("0HL", 0), ("1HL", 37), ("1HL", 63)] {
        let a = exported_layers(&run, "gymnax:CartPole-v1", arch, n, &dir.join("a.json"));
        let b = exported_layers(&brun, "CartPole-v1", arch, n, &dir.join("b.json"));
        assert!(a.as_array().is_some_and(|l| !l.is_empty()), "{a}");
        assert_eq!(a, b, "{arch} network {n}");
    }

    // the paired view of the two implementations: the same networks
    let paired = ok(&[
        "compare",
        s(&brun),
        s(&run),
        "--paired",
        "CartPole-v1",
        "gymnax:CartPole-v1",
        "--format",
        "csv",
    ]);
    let rows: Vec<&str> = paired.lines().skip(1).collect();
    assert_eq!(rows.len(), 2, "{paired}");
    for r in rows {
        assert!(
            r.starts_with("builtin,CartPole-v1,run,gymnax:CartPole-v1,")
                && r.contains(",64,3,true,"),
            "{paired}"
        );
    }

    // replay runs network 17's episodes through a worker: scores.csv's returns
    let shown = ok(&[
        "replay",
        s(&run),
        "--env",
        "gymnax:CartPole-v1",
        "--arch",
        "1HL",
        "--sample",
        "17",
    ]);
    let scores =
        std::fs::read_to_string(run.join(format!("cells/{CARTPOLE}__1HL__nobias/scores.csv")))
            .unwrap();
    let stored: Vec<&str> = scores.lines().filter(|l| l.starts_with("17,")).collect();
    assert_eq!(stored.len(), 3);
    let lines: Vec<&str> = shown.lines().collect();
    assert_eq!(
        lines[0], "episode,reset_seed,score,steps,stored_score,same",
        "{shown}"
    );
    for (e, row) in stored.iter().enumerate() {
        let f: Vec<&str> = row.split(',').collect();
        let r: Vec<&str> = lines[1 + e].split(',').collect();
        assert_eq!(
            (r[0], r[2], r[3], r[5]),
            (f[1], f[2], f[3], "true"),
            "{shown}"
        );
    }
    let e = err(&[
        "replay",
        s(&run),
        "--env",
        "gymnax:CartPole-v1",
        "--arch",
        "0HL",
        "--sample",
        "1",
        "--episode",
        "0",
    ]);
    assert!(e.contains("step by step"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// 1 vs 2 threads (and 32 vs 64 networks per call), two shards merged, and
/// a run stopped by Ctrl-C after its first block and resumed with another
/// networks_per_call give the same bytes; a resume whose env.json records
/// another jax version, or with another precision or matmul precision, is
/// refused.
#[test]
fn threads_shards_and_resume_give_the_same_bytes_under_the_same_jax() {
    let Some(py) = python() else { return };
    let dir = temp_dir("jax-bytes");
    let body = manifest(
        &py,
        "gymnax:CartPole-v1",
        "networks_per_call = 32",
        320,
        3,
        true,
    );
    let m = write(&dir, "m.toml", &body);
    let run = |name: &str, extra: &[&str]| {
        let out = dir.join(name);
        let mut args = vec!["run", &m, "--out", s(&out)];
        args.extend_from_slice(extra);
        ok(&args);
        out
    };
    let t1 = run("t1", &["--threads", "1"]);
    // networks_per_call says how, not what: 64 per call, the same bytes
    let m64 = write(
        &dir,
        "m64.toml",
        &body.replace("networks_per_call = 32", "networks_per_call = 64"),
    );
    let t2 = dir.join("t2");
    ok(&["run", &m64, "--out", s(&t2), "--threads", "2"]);
    assert_same(&t1, &t2);

    let s0 = run("s0", &["--shard", "0/2", "--threads", "2"]);
    let s1 = run("s1", &["--shard", "1/2", "--threads", "1"]);
    let merged = dir.join("merged");
    ok(&["merge", s(&s0), s(&s1), "--out", s(&merged)]);
    assert_same(&t1, &merged);

    // stopped by Ctrl-C once its first block is committed, then resumed
    let stopped = dir.join("stopped");
    let mut cmd = rwg_cmd(&["run", &m, "--out", s(&stopped), "--threads", "2"]);
    cmd.env("RWG_COMMIT_LINGER", "0");
    let first = stopped.join(format!("cells/{CARTPOLE}__0HL__nobias/blocks/b0000000.csv"));
    ctrl_c_once(cmd, &first);

    // a copy whose env.json says the blocks were computed under another jax
    let other = dir.join("other-jax");
    let cp = Command::new("cp")
        .args(["-a", s(&stopped), s(&other)])
        .status()
        .unwrap();
    assert!(cp.success());
    let record = other.join(format!("cells/{CARTPOLE}__0HL__nobias/env.json"));
    let text = std::fs::read_to_string(&record).unwrap();
    assert!(text.contains("\"jax\": \"0.10.2\""), "{text}");
    std::fs::write(
        &record,
        text.replace("\"jax\": \"0.10.2\"", "\"jax\": \"0.4.30\""),
    )
    .unwrap();
    let e = err(&["run", &m, "--out", s(&other)]);
    assert!(e.contains("jax: 0.4.30 then, 0.10.2 now"), "{e}");
    assert!(e.contains("env.json"), "{e}");

    // another precision, or matmul precision, is another study
    for (key, value) in [("precision", "float64"), ("matmul_precision", "default")] {
        let other = body.replace(
            "networks_per_call = 32",
            &format!("networks_per_call = 32\n{key} = \"{value}\""),
        );
        let other = write(&dir, "other.toml", &other);
        let e = err(&["run", &other, "--out", s(&stopped)]);
        assert!(e.contains("holds a different study"), "{e}");
        assert!(e.contains(value), "{e}");
    }

    // resumed with 64 networks per call where it started with 32
    ok(&["run", &m64, "--out", s(&stopped), "--threads", "2"]);
    assert_same(&t1, &stopped);
    let _ = std::fs::remove_dir_all(&dir);
}

/// The `jit_program` entries of a compilation cache folder.
fn cached_programs(cache: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(cache)
        .map(|d| {
            d.filter_map(|e| e.ok())
                .map(|e| e.file_name().to_string_lossy().into_owned())
                .filter(|n| n.starts_with("jit_program"))
                .collect()
        })
        .unwrap_or_default();
    v.sort();
    v
}

/// One worker running two (forced) CPU devices gives the bytes of a run on
/// one, and says so in the run's first lines; a second study of the same
/// cell reads its program from the compilation cache: it compiles nothing.
#[test]
fn every_device_gives_one_devices_bytes_and_a_second_study_compiles_nothing() {
    let Some(py) = python() else { return };
    let dir = temp_dir("jax-devices");
    let cache = dir.join("cache");
    let m = write(
        &dir,
        "m.toml",
        &manifest(
            &py,
            "gymnax:CartPole-v1",
            "networks_per_call = 32\ndevice = \"cpu\"",
            160,
            2,
            false,
        ),
    );
    let run = |name: &str, devices: Option<u32>| {
        let out = dir.join(name);
        let mut cmd = rwg_cmd(&["run", &m, "--out", s(&out), "--threads", "1", "--no-report"]);
        cmd.env("RWG_JAX_CACHE", &cache);
        if let Some(n) = devices {
            cmd.env(
                "XLA_FLAGS",
                format!("--xla_force_host_platform_device_count={n}"),
            );
        }
        let res = cmd.output().unwrap();
        let e = String::from_utf8_lossy(&res.stderr).into_owned();
        assert!(res.status.success(), "{name}: {e}");
        (out, e)
    };
    let (one, said) = run("one", None);
    assert!(
        said.contains("gymnax:CartPole-v1: JAX on cpu:0 (cpu, 1 device)"),
        "{said}"
    );
    assert!(said.contains(&format!("cached in {}", s(&cache))), "{said}");
    let compiled = cached_programs(&cache);
    assert!(
        !compiled.is_empty(),
        "nothing cached in {}",
        cache.display()
    );
    let (two, said) = run("two", Some(2));
    assert!(
        said.contains("JAX on cpu:0, cpu:1 (cpu, 2 devices)"),
        "{said}"
    );
    assert_same(&one, &two);
    let before = cached_programs(&cache);
    let (again, _) = run("again", None);
    assert_same(&one, &again);
    assert_eq!(cached_programs(&cache), before, "the second study compiled");
    let _ = std::fs::remove_dir_all(&dir);
}

/// A tiny Brax study runs, with Brax's spaces recorded.
#[test]
fn a_brax_env_runs_a_study() {
    let Some(py) = python() else { return };
    let dir = temp_dir("jax-brax");
    let m = write(
        &dir,
        "m.toml",
        &manifest(
            &py,
            "brax:inverted_pendulum",
            "max_episode_steps = 20\nnetworks_per_call = 32",
            32,
            1,
            false,
        ),
    );
    let run = dir.join("run");
    ok(&["run", &m, "--out", s(&run), "--no-report"]);
    let cell = run.join("cells/brax=inverted_pendulum__0HL__nobias");
    let scores = std::fs::read_to_string(cell.join("scores.csv")).unwrap();
    assert_eq!(scores.lines().count(), 33, "{scores}");
    let record = std::fs::read_to_string(cell.join("env.json")).unwrap();
    assert!(record.contains("\"brax\": \"0.14.2\""), "{record}");
    assert!(record.contains("\"max_episode_steps\": 20"), "{record}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// A `jax:module:callable` env of the user's runs; one whose observation
/// turns NaN stops the run naming the network and episode, keeps the blocks
/// committed before it, and the run resumes once the env is fixed.
/// `dir/m.toml`, a study of `jax:ID` (a slider of `rwg_jax_envs`, seed 5,
/// `samples` x `episodes`, calls of 32 networks) whose episode `episode` of
/// network `sample` observes NaN while `dir/nan-seed` (returned too) holds
/// its reset seed.
fn nan_study(
    py: &str,
    dir: &Path,
    id: &str,
    (sample, episode): (u64, u32),
    (samples, episodes): (u32, u32),
) -> (String, PathBuf) {
    let nan_file = dir.join("nan-seed");
    let seed = rwg_core::sampler::reset_seed(5, id, sample, episode);
    std::fs::write(&nan_file, seed.to_string()).unwrap();
    let entry = format!(
        "kwargs = {{ nan_file = {:?} }}\nnetworks_per_call = 32",
        s(&nan_file)
    );
    let body = manifest(py, &format!("jax:{id}"), &entry, samples, episodes, false);
    (write(dir, "m.toml", &body), nan_file)
}

#[test]
fn a_jax_env_of_ones_own_runs_and_a_nan_observation_stops_it() {
    let Some(py) = python() else { return };
    let dir = temp_dir("jax-custom");
    // network 70's episode 1: in the third call of 32 networks
    let (m, nan_file) = nan_study(&py, &dir, "rwg_jax_envs:make_slider", (70, 1), (128, 2));
    let run = dir.join("run");
    let mut cmd = rwg_cmd(&["run", &m, "--out", s(&run), "--threads", "1", "--no-report"]);
    let out = cmd.env("RWG_COMMIT_LINGER", "0").output().unwrap();
    let e = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{e}");
    assert!(e.contains("sample 70, episode 1"), "{e}");
    assert!(e.contains("observation"), "{e}");
    let blocks = run.join("cells/jax=rwg_jax_envs=make_slider__0HL__nobias/blocks");
    for b in ["b0000000.csv", "b0000001.csv"] {
        assert!(blocks.join(b).is_file(), "{b} not kept: {e}");
    }
    std::fs::remove_file(&nan_file).unwrap();
    ok(&["run", &m, "--out", s(&run), "--threads", "1", "--no-report"]);
    let fresh = dir.join("fresh");
    ok(&[
        "run",
        &m,
        "--out",
        s(&fresh),
        "--threads",
        "2",
        "--no-report",
    ]);
    let cell = "cells/jax=rwg_jax_envs=make_slider__0HL__nobias/scores.csv";
    assert!(std::fs::read(run.join(cell)).unwrap() == std::fs::read(fresh.join(cell)).unwrap());
    let _ = std::fs::remove_dir_all(&dir);
}

/// A `jax:module:callable` env edited between a failed run and its resume
/// is noticed: env.json records a digest of the module's source, and the
/// resume is refused naming the module (no cell mixing networks of two
/// versions); the commands rwg prints (the resume, `rwg top`'s replay,
/// `rwg status`'s) set the PYTHONPATH the module is found through.
#[test]
fn an_edited_jax_module_is_not_resumed_and_printed_commands_find_it() {
    let Some(py) = python() else { return };
    let dir = temp_dir("jax-edited");
    let envs = dir.join("envs");
    std::fs::create_dir_all(&envs).unwrap();
    let module = envs.join("my_slider.py");
    let source = "from rwg_jax_envs import make_slider as make\n";
    std::fs::write(&module, source).unwrap();
    let (m, nan_file) = nan_study(&py, &dir, "my_slider:make", (40, 0), (64, 1));
    let run = dir.join("run");
    let data = std::fs::canonicalize(data_dir()).unwrap();
    let pythonpath = format!("{}:{}", s(&envs), s(&data));
    let rwg = |args: &[&str]| {
        let mut c = rwg_cmd(args);
        c.env("PYTHONPATH", &pythonpath)
            .env("RWG_COMMIT_LINGER", "0");
        c.output().unwrap()
    };
    let args = ["run", &m, "--out", s(&run), "--threads", "1", "--no-report"];
    let first = rwg(&args);
    let e = String::from_utf8_lossy(&first.stderr);
    assert!(!first.status.success() && e.contains("sample 40"), "{e}");
    assert!(
        e.contains(&format!("resume with: PYTHONPATH={pythonpath} rwg run ")),
        "{e}"
    );
    // the module edited, the cause removed: the resume is refused
    std::fs::write(&module, format!("{source}# edited\n")).unwrap();
    std::fs::remove_file(&nan_file).unwrap();
    let second = rwg(&args);
    let e = String::from_utf8_lossy(&second.stderr);
    assert!(!second.status.success(), "{e}");
    assert!(e.contains("the source of module my_slider"), "{e}");
    // as it was: the resume finishes
    std::fs::write(&module, source).unwrap();
    let third = rwg(&args);
    assert!(
        third.status.success(),
        "{}",
        String::from_utf8_lossy(&third.stderr)
    );
    // printed in another shell (no PYTHONPATH), from what env.json records
    let top = ok(&["top", s(&run), "-n", "1"]);
    assert!(
        top.contains(&format!("PYTHONPATH={pythonpath} rwg replay ")),
        "{top}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// SIGTERM or SIGHUP to rwg alone while its JAX workers start or run a
/// chunk: rwg ends by that signal, says so (not that a worker it killed
/// itself "was killed while starting"), and no worker outlives it.
#[cfg(target_os = "linux")]
#[test]
fn jax_workers_end_with_rwg_on_sigterm_and_sighup() {
    use std::os::unix::process::ExitStatusExt;
    use std::time::{Duration, Instant};
    let Some(py) = python() else { return };
    let dir = temp_dir("jax-sigterm");
    let m = write(
        &dir,
        "m.toml",
        &manifest(
            &py,
            "gymnax:CartPole-v1",
            "networks_per_call = 32",
            100_000,
            20,
            true,
        ),
    );
    // (signal, workers to wait for, then seconds): one worker still
    // starting, then both computing chunks
    for (name, sig, workers, wait) in [
        ("TERM", libc::SIGTERM, 1, 0.0),
        ("HUP", libc::SIGHUP, 2, 2.0),
    ] {
        let err_file = dir.join(format!("stderr-{name}"));
        let mut cmd = rwg_cmd(&[
            "run",
            &m,
            "--out",
            s(&dir.join(format!("r{name}"))),
            "--threads",
            "2",
            "-q",
        ]);
        with_default_signals(&mut cmd);
        let mut child = cmd
            .stdout(std::process::Stdio::null())
            .stderr(std::fs::File::create(&err_file).unwrap())
            .spawn()
            .unwrap();
        let t0 = Instant::now();
        let started = loop {
            let w = children(child.id());
            if w.len() >= workers {
                break w;
            }
            assert!(
                t0.elapsed() < Duration::from_secs(120),
                "{name}: no workers started"
            );
            assert!(child.try_wait().unwrap().is_none(), "{name}: rwg ended");
            std::thread::sleep(Duration::from_millis(20));
        };
        std::thread::sleep(Duration::from_secs_f64(wait));
        let started = [started, children(child.id())].concat();
        // SAFETY: signalling the test's own child.
        unsafe {
            libc::kill(child.id() as i32, sig);
        }
        let t0 = Instant::now();
        let status = loop {
            if let Some(s) = child.try_wait().unwrap() {
                break s;
            }
            if t0.elapsed() > Duration::from_secs(40) {
                let _ = child.kill();
                panic!("{name}: rwg did not end");
            }
            std::thread::sleep(Duration::from_millis(20));
        };
        let ended = Instant::now();
        while started.iter().any(|&w| alive(w)) && ended.elapsed() < Duration::from_secs(10) {
            std::thread::sleep(Duration::from_millis(20));
        }
        let late = ended.elapsed();
        let left: Vec<u32> = started.iter().copied().filter(|&w| alive(w)).collect();
        for &w in &left {
            let _ = Command::new("kill")
                .args(["-KILL", &w.to_string()])
                .status();
        }
        let err = std::fs::read_to_string(&err_file).unwrap();
        assert!(left.is_empty(), "{name}: workers {left:?} outlived rwg");
        assert!(
            late < Duration::from_millis(500),
            "{name}: workers outlived rwg by {late:?}"
        );
        assert_eq!(status.signal(), Some(sig), "{name}: {status:?}: {err}");
        assert!(
            err.contains(&format!("error: rwg received SIG{name} (")),
            "{name}: {err}"
        );
        assert!(!err.contains("was killed by signal 9"), "{name}: {err}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}
