//! `rwg bench` end to end: the benchmarks run and report every env /
//! configuration (no timing assertions: the figures depend on the machine).

mod common;
use common::*;

const IDS: [&str; 7] = [
    "CartPole-v0",
    "CartPole-v1",
    "Acrobot-v1",
    "Pendulum-v0",
    "Pendulum-v1",
    "MountainCar-v0",
    "MountainCarContinuous-v0",
];

/// The sampler's configurations: env and hidden-layer column.
const CONFIGS: [(&str, &str); 5] = [
    ("CartPole-v0", "0HL"),
    ("CartPole-v0", "[4,4]"),
    ("Acrobot-v1", "0HL"),
    ("MountainCarContinuous-v0", "[4,4]"),
    ("Pendulum-v1", "[4]"),
];

#[test]
fn bench_envs_reports_every_env() {
    let out = rwg_ok(&["bench", "envs", "--steps", "1000"]);
    for id in IDS {
        let line = out
            .lines()
            .find(|l| l.split_whitespace().next() == Some(id))
            .unwrap_or_else(|| panic!("{id} missing from:\n{out}"));
        assert!(line.contains("1,000"), "{line}");
    }
}

#[test]
fn bench_envs_json_counts_steps_and_filters() {
    let out = rwg_ok(&[
        "bench",
        "envs",
        "--steps",
        "1000",
        "--env",
        "Acrobot-v1",
        "--json",
    ]);
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    let rows = v.as_array().unwrap();
    assert_eq!(rows.len(), 1);
    assert_eq!(rows[0]["env"], "Acrobot-v1");
    assert_eq!(rows[0]["steps"], 1000);
    // 1000 steps of Acrobot's 500-step limit: at least 3 episodes started.
    assert!(rows[0]["episodes"].as_u64().unwrap() >= 3);
    assert!(rows[0]["steps_per_s"].as_f64().unwrap() > 0.0);
}

#[test]
fn bench_sampler_reports_every_config() {
    let out = rwg_ok(&[
        "bench",
        "sampler",
        "--samples",
        "4",
        "--episodes",
        "1",
        "--threads",
        "1",
    ]);
    for (env, hidden) in CONFIGS {
        assert!(
            out.lines().any(|l| {
                let mut w = l.split_whitespace();
                w.next() == Some(env) && w.next() == Some(hidden)
            }),
            "{env} {hidden} missing from:\n{out}"
        );
    }
}

/// `rwg bench sampler` on tiny counts, as JSON.
const SAMPLER_JSON: [&str; 9] = [
    "bench",
    "sampler",
    "--samples",
    "4",
    "--episodes",
    "2",
    "--threads",
    "2",
    "--json",
];

#[test]
fn bench_sampler_json_counts_every_step() {
    let out = rwg_ok(&SAMPLER_JSON);
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    let rows = v.as_array().unwrap();
    assert_eq!(rows.len(), CONFIGS.len());
    for r in rows {
        let steps = r["env_steps"].as_u64().unwrap();
        assert!((8..=8 * 999).contains(&steps), "{r}");
        assert!(
            r.get("ratio_vs_gymnax_raw").is_none(),
            "no copied peer figures: {r}"
        );
        assert_eq!(r["threads"], 2);
        assert!(r["lanes"].as_u64().unwrap() >= 1);
        assert!(r["mean_score"].as_f64().unwrap().is_finite());
    }
    // Pendulum never terminates: every episode lasts its 200-step limit.
    let pendulum = rows.iter().find(|r| r["env"] == "Pendulum-v1").unwrap();
    assert_eq!(pendulum["env_steps"], 4 * 2 * 200);
    // Stepped as `rwg run` steps built-in envs: in lockstep, or one instance
    // per lane with RWG_LOCKSTEP=0; the same episodes either way.
    let out = rwg_env(
        &SAMPLER_JSON,
        &[("RWG_LOCKSTEP", std::ffi::OsStr::new("0"))],
    );
    assert!(out.status.success(), "{out:?}");
    let v0: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    for (r, r0) in rows.iter().zip(v0.as_array().unwrap()) {
        assert_eq!(r["path"], "lockstep", "{r}");
        assert_eq!(r0["path"], "per-lane", "{r0}");
        assert_eq!(r["env_steps"], r0["env_steps"], "{r} {r0}");
        assert_eq!(r["mean_score"], r0["mean_score"], "{r} {r0}");
    }
    // At every SIMD level this CPU has (RWG_SIMD), reported as run: the same
    // episodes and scores.
    for level in rwg_env::simd::Simd::available_levels() {
        let out = rwg_env(
            &SAMPLER_JSON,
            &[("RWG_SIMD", std::ffi::OsStr::new(level.name()))],
        );
        assert!(out.status.success(), "{out:?}");
        let v1: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        for (r, r1) in rows.iter().zip(v1.as_array().unwrap()) {
            assert_eq!(r1["simd"], level.name(), "{r1}");
            assert_eq!(r["env_steps"], r1["env_steps"], "{level}: {r} {r1}");
            assert_eq!(r["mean_score"], r1["mean_score"], "{level}: {r} {r1}");
        }
    }
}

#[test]
fn bench_plugin_compares_builtin_lockstep_single_and_batched_on_the_same_episodes() {
    let lib = classic_control_plugin();
    let out = rwg_ok(&[
        "bench",
        "plugin",
        "--plugin",
        lib.to_str().unwrap(),
        "--env",
        "CartPole-v0",
        "--env",
        "Pendulum-v1",
        "--samples",
        "40",
        "--episodes",
        "2",
        "--rounds",
        "2",
        "--json",
    ]);
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    let rows = v.as_array().unwrap();
    // Two envs x the paper's three architectures; the four variants (the
    // built-in per lane and in lockstep, the plugin's single and batched
    // calls) ran the same episodes (the command fails otherwise).
    assert_eq!(rows.len(), 6, "{out}");
    assert_eq!(rows[0]["env"], "CartPole-v0");
    assert_eq!(rows[5]["env"], "Pendulum-v1");
    assert_eq!(rows[5]["env_steps"], 40 * 2 * 200);
    for r in rows {
        for k in [
            "builtin_ns",
            "single_ns",
            "batched_ns",
            "lockstep_ns",
            "batched_ratio",
            "batched_lockstep_ratio",
        ] {
            assert!(r[k]["median"].as_f64().unwrap() > 0.0, "{k} in {r}");
        }
    }
}

#[test]
fn bench_rejects_unknown_envs() {
    let err = rwg_err(&["bench", "envs", "--steps", "10", "--env", "CartPol-v0"]);
    assert!(err.contains("did you mean 'CartPole-v0'"), "{err}");
    let err = rwg_err(&["bench", "sampler", "--env", "MountainCar-v0"]);
    assert!(err.contains("no benchmark configuration"), "{err}");
}

/// Runs `rwg bench peers ARGS` without the peer's environment variables;
/// requires failure, returns stderr.
fn bench_peers_err(args: &[&str]) -> String {
    let out = std::process::Command::new(rwg_bin())
        .args(["bench", "peers"])
        .args(args)
        .env_remove("RWG_PEER_PYTHON")
        .env_remove("RWG_PEERS_DIR")
        .output()
        .unwrap();
    assert!(
        !out.status.success(),
        "rwg bench peers {args:?} should have failed"
    );
    String::from_utf8(out.stderr).unwrap()
}

#[test]
fn bench_peers_explains_a_missing_peer() {
    let dir = temp_dir("peers-missing");
    let d = dir.to_str().unwrap();
    let err = bench_peers_err(&["--peers", d, "--no-pin"]);
    assert!(err.contains("gymnax_rwg.py not found"), "{err}");
    assert!(err.contains("--peers"), "{err}");
    std::fs::write(dir.join("gymnax_rwg.py"), "").unwrap();
    let venv = dir.join("no-venv");
    let err = bench_peers_err(&["--peers", d, "--venv", venv.to_str().unwrap(), "--no-pin"]);
    assert!(err.contains("pip install"), "{err}");
    assert!(err.contains("gymnax==1.0.1"), "{err}");
    let err = bench_peers_err(&["--env", "MountainCar-v0"]);
    assert!(
        err.contains("no peer workload uses MountainCar-v0"),
        "{err}"
    );
}

/// `--simd` takes levels this CPU has, each once, and says which it lacks;
/// these errors come before the peer is looked for.
#[test]
fn bench_peers_checks_its_simd_levels() {
    let err = bench_peers_err(&["--simd", "avx2,sse4", "--no-pin"]);
    assert!(err.contains("\"sse4\" is not a SIMD level"), "{err}");
    assert!(err.contains("scalar, avx2, avx512"), "{err}");
    let err = bench_peers_err(&["--simd", "scalar,scalar", "--no-pin"]);
    assert!(err.contains("--simd lists scalar twice"), "{err}");
    let err = bench_peers_err(&["--simd", "", "--no-pin"]);
    assert!(err.contains("\"\" is not a SIMD level"), "{err}");
    use rwg_env::simd::Simd;
    let lacking: Vec<&str> = Simd::ALL
        .into_iter()
        .filter(|l| !l.available())
        .map(Simd::name)
        .collect();
    if !lacking.is_empty() {
        let list = format!("scalar,{}", lacking.join(","));
        let err = bench_peers_err(&["--simd", &list, "--no-pin"]);
        assert!(
            err.contains(&format!("this CPU has no {}", lacking.join(", "))),
            "{err}"
        );
    }
    // Levels the CPU has get past --simd, as far as the peer.
    let dir = temp_dir("peers-simd");
    let have: Vec<&str> = Simd::available_levels()
        .into_iter()
        .map(Simd::name)
        .collect();
    let err = bench_peers_err(&[
        "--simd",
        &have.join(","),
        "--peers",
        dir.to_str().unwrap(),
        "--no-pin",
    ]);
    assert!(err.contains("gymnax_rwg.py not found"), "{err}");
}

/// Run from the repository's top folder, `rwg bench peers` finds the peer
/// scripts of benches/peers without --peers: it gets as far as the peer's
/// virtualenv.
#[test]
fn bench_peers_finds_the_repositorys_scripts_by_default() {
    let top = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..");
    for script in ["gymnax_rwg.py", "rwg_common.py", "ref_numpy.py"] {
        assert!(top.join("benches/peers").join(script).is_file(), "{script}");
    }
    let venv = temp_dir("peers-default").join("no-venv");
    let out = std::process::Command::new(rwg_bin())
        .current_dir(&top)
        .args(["bench", "peers", "--no-pin", "--venv"])
        .arg(&venv)
        .env_remove("RWG_PEER_PYTHON")
        .env_remove("RWG_PEERS_DIR")
        .output()
        .unwrap();
    let err = String::from_utf8(out.stderr).unwrap();
    assert!(!out.status.success(), "{err}");
    assert!(!err.contains("not found"), "{err}");
    assert!(err.contains("no peer virtualenv at"), "{err}");
}

/// Smoke test of `rwg bench peers` with the real peer on tiny sample counts:
/// it runs both sides, rwg at every SIMD level this CPU has, parses them and
/// computes the ratios. Needs
/// RWG_PEER_PYTHON (a Python with jax and gymnax, see `rwg bench peers
/// --help`); the peer scripts are the repository's benches/peers (or
/// RWG_PEERS_DIR). `.ci/run` makes that Python, and under CI a skip is a failure.
#[test]
fn bench_peers_measures_both_sides_and_their_ratio() {
    let peers = std::env::var("RWG_PEERS_DIR").map_or_else(
        |_| std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../benches/peers"),
        std::path::PathBuf::from,
    );
    let python = std::env::var("RWG_PEER_PYTHON").ok();
    let Some(python) = python.filter(|_| peers.join("gymnax_rwg.py").exists()) else {
        skip(
            "bench_peers_measures_both_sides_and_their_ratio",
            &format!(
                "set RWG_PEER_PYTHON to a Python with jax and gymnax (rwg bench peers --help) \
                 and have the peer scripts in {} or RWG_PEERS_DIR",
                peers.display()
            ),
        );
        return;
    };
    let work = temp_dir("peers");
    // --peers relative to the working directory, as the README writes it
    // (the peer itself runs in that directory: the path must not be resolved twice).
    let peers = peers.canonicalize().unwrap();
    let (parent, name) = (peers.parent().unwrap(), peers.file_name().unwrap());
    // The interpreter relative to that directory too, as the README's default
    // `--venv target/peers-venv` is: rwg must not look it up from the peer's
    // own working directory.
    let python = relative_to(&python_path(&python), parent);
    assert!(python.is_relative(), "{}", python.display());
    // Every level this CPU has, widest first: the last over the first is
    // the narrowest over the widest.
    let levels: Vec<&str> = rwg_env::simd::Simd::available_levels()
        .into_iter()
        .rev()
        .map(|l| l.name())
        .collect();
    let out = std::process::Command::new(rwg_bin())
        .current_dir(parent)
        .args(["bench", "peers", "--python"])
        .arg(&python)
        .arg("--peers")
        .arg(name)
        .args(["--work-dir", work.to_str().unwrap()])
        .args(["--simd", &levels.join(",")])
        .args([
            "--env",
            "Pendulum-v1",
            "--rwg-samples",
            "6",
            "--peer-samples",
            "4",
            "--episodes",
            "2",
            "--rounds",
            "2",
            "--json",
        ])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "rwg bench peers failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let out = String::from_utf8(out.stdout).unwrap();
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert_eq!(v["setup"]["pinned_cpu"], 0);
    assert_eq!(v["setup"]["simd_levels"], serde_json::json!(levels));
    let rows = v["rows"].as_array().unwrap();
    assert_eq!(rows.len(), 1, "{out}");
    let r = &rows[0];
    assert_eq!(r["env"], "Pendulum-v1");
    let f = |v: &serde_json::Value| -> Vec<f64> {
        v.as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap())
            .collect()
    };
    // Pendulum never terminates: every episode lasts its 200-step limit.
    assert_eq!(
        r["gymnax_raw"]["env_steps"],
        serde_json::json!([1600, 1600])
    );
    let gs = f(&r["gymnax_raw"]["steps_per_cpu_s"]);
    let rwg = r["rwg"].as_array().unwrap();
    assert_eq!(rwg.len(), levels.len(), "{out}");
    for (side, level) in rwg.iter().zip(&levels) {
        assert_eq!(side["simd"], *level, "{out}");
        assert_eq!(side["env_steps"], serde_json::json!([2400, 2400]), "{out}");
        let rs = f(&side["steps_per_cpu_s"]);
        let ratios = f(&side["ratio"]["values"]);
        assert_eq!(ratios.len(), 2);
        for i in 0..2 {
            assert!(rs[i] > 0.0 && gs[i] > 0.0, "{out}");
            assert_eq!(ratios[i], rs[i] / gs[i], "{out}");
        }
        let median = side["ratio"]["median"].as_f64().unwrap();
        assert_eq!(median, (ratios[0] + ratios[1]) / 2.0, "{out}");
        assert_eq!(
            side["ratio"]["min"].as_f64().unwrap(),
            ratios[0].min(ratios[1])
        );
        // The run directory rwg wrote at this level is a real run of the
        // workload, with the scores of every other level.
        let scores = std::fs::read_to_string(work.join(format!(
            "w0-{level}/cells/Pendulum-v1__1HL__nobias/scores.csv"
        )))
        .unwrap();
        assert_eq!(scores.lines().count(), 1 + 6 * 2, "{scores}");
        let first = work.join(format!(
            "w0-{}/cells/Pendulum-v1__1HL__nobias/scores.csv",
            levels[0]
        ));
        assert_eq!(scores, std::fs::read_to_string(first).unwrap(), "{level}");
    }
    let simd_ratio = &r["simd_ratio"];
    if levels.len() == 1 {
        assert!(simd_ratio.is_null(), "{out}");
    } else {
        let (first, last) = (&rwg[0], &rwg[levels.len() - 1]);
        assert_eq!(simd_ratio["level"], last["simd"], "{out}");
        assert_eq!(simd_ratio["over"], first["simd"], "{out}");
        let (a, b) = (f(&last["steps_per_cpu_s"]), f(&first["steps_per_cpu_s"]));
        assert_eq!(
            f(&simd_ratio["values"]),
            [a[0] / b[0], a[1] / b[1]],
            "{out}"
        );
    }
}

/// `--source gymnax` has workloads of gymnax's ids and no SIMD levels; both
/// are checked before the peer is looked for.
#[test]
fn bench_peers_gymnax_source_checks_its_workloads() {
    let err = bench_peers_err(&["--source", "gymnax", "--env", "CartPole-v0", "--no-pin"]);
    assert!(
        err.contains("no peer workload uses CartPole-v0 (--source gymnax)"),
        "{err}"
    );
    assert!(err.contains("CartPole-v1, Acrobot-v1"), "{err}");
    let err = bench_peers_err(&["--source", "gymnax", "--simd", "scalar", "--no-pin"]);
    assert!(err.contains("--simd is for the built-in envs"), "{err}");
    let err = bench_peers_err(&["--source", "jax", "--no-pin"]);
    assert!(err.contains("possible values: builtin, gymnax"), "{err}");
}

/// Smoke test of `rwg bench peers --source gymnax`: rwg runs gymnax's
/// Pendulum-v1 as its `gymnax:` env (its worker on the peer's Python) beside
/// gymnax-raw on tiny counts, against gymnax-raw's whole process, then
/// against its compiled run. Needs RWG_PEER_PYTHON, as the test above.
#[test]
fn bench_peers_gymnax_source_measures_rwgs_jax_source() {
    let test = "bench_peers_gymnax_source_measures_rwgs_jax_source";
    let Some(python) = std::env::var("RWG_PEER_PYTHON")
        .ok()
        .filter(|p| !p.is_empty())
    else {
        skip(test, "set RWG_PEER_PYTHON to a Python with jax and gymnax");
        return;
    };
    let work = temp_dir("peers-gymnax");
    let top = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..");
    let out = std::process::Command::new(rwg_bin())
        .current_dir(&top)
        .args(["bench", "peers", "--source", "gymnax", "--python", &python])
        .args(["--work-dir", work.to_str().unwrap(), "--env", "Pendulum-v1"])
        .args([
            "--whole-samples",
            "6",
            "--compiled-samples",
            "4",
            "--episodes",
            "2",
        ])
        .args(["--rounds", "2", "--json"])
        .env_remove("RWG_PEERS_DIR")
        .env_remove("RWG_PYTHON")
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "rwg bench peers failed: {stderr}");
    let out = String::from_utf8(out.stdout).unwrap();
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert_eq!(v["setup"]["source"], "gymnax", "{out}");
    let rows = v["rows"].as_array().unwrap();
    assert_eq!(rows.len(), 2, "{out}");
    // Pendulum never terminates: every episode lasts its 200-step limit.
    for (r, time, steps) in [(&rows[0], "whole", 2400), (&rows[1], "compiled", 1600)] {
        assert_eq!(r["env"], "gymnax:Pendulum-v1", "{out}");
        assert_eq!(r["peer_time"], time, "{out}");
        assert_eq!(r["rwg"][0]["env_steps"], serde_json::json!([steps, steps]));
        assert_eq!(
            r["gymnax_raw"]["env_steps"],
            serde_json::json!([steps, steps])
        );
        let ratios = r["rwg"][0]["ratio"]["values"].as_array().unwrap();
        assert_eq!(ratios.len(), 2, "{out}");
        for (i, ratio) in ratios.iter().enumerate() {
            let rate = |side: &serde_json::Value| side["steps_per_cpu_s"][i].as_f64().unwrap();
            let (a, b) = (rate(&r["rwg"][0]), rate(&r["gymnax_raw"]));
            assert!(a > 0.0 && b > 0.0, "{out}");
            assert_eq!(ratio.as_f64().unwrap(), a / b, "{out}");
        }
    }
    // The whole process takes more CPU than its compiled run alone (Python,
    // imports, compilation): per step, at these tiny counts, many times more.
    let cpu = |r: &serde_json::Value| r["gymnax_raw"]["cpu_s"][0].as_f64().unwrap();
    assert!(cpu(&rows[0]) > 10.0 * cpu(&rows[1]), "{out}");
    // rwg's side is a real run of gymnax:Pendulum-v1 on the peer's Python.
    let manifest = std::fs::read_to_string(work.join("w0.toml")).unwrap();
    assert!(
        manifest.contains("id = \"gymnax:Pendulum-v1\""),
        "{manifest}"
    );
    assert!(
        manifest.contains(&format!("python = {python:?}")),
        "{manifest}"
    );
    let level = v["setup"]["simd_levels"][0].as_str().unwrap();
    let cells: Vec<_> = std::fs::read_dir(work.join(format!("w0-{level}/cells")))
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    assert_eq!(cells.len(), 1, "{cells:?}");
    let scores = std::fs::read_to_string(cells[0].join("scores.csv")).unwrap();
    assert_eq!(scores.lines().count(), 1 + 6 * 2, "{scores}");
}

/// benches/peers/side_by_side.py, the peers beside `rwg run` in one sitting,
/// on tiny counts: every side runs every round, pinned, and the ratios are
/// rwg's rate over each peer's in the same round. Needs RWG_PEER_PYTHON, as
/// the test above.
#[test]
fn side_by_side_script_pairs_rwg_with_each_peer() {
    let Ok(python) = std::env::var("RWG_PEER_PYTHON") else {
        skip(
            "side_by_side_script_pairs_rwg_with_each_peer",
            "set RWG_PEER_PYTHON to a Python with jax and gymnax (benches/peers/README.md)",
        );
        return;
    };
    let top = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..");
    let work = temp_dir("side-by-side");
    let json = work.join("report.json");
    let out = std::process::Command::new(&python)
        .arg(top.join("benches/peers/side_by_side.py"))
        .arg("--rwg")
        .arg(rwg_bin())
        .args([
            "--peers",
            "ref_numpy,gym_vector,gymnax-raw",
            "--env",
            "Pendulum-v1",
        ])
        .args(["--rwg-samples", "6", "--episodes", "2", "--rounds", "2"])
        .args([
            "--peer-samples",
            "ref_numpy=3",
            "--peer-samples",
            "gym_vector=2",
        ])
        .args(["--peer-samples", "gymnax-raw=4", "--work-dir"])
        .arg(work.join("runs"))
        .arg("--json")
        .arg(&json)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "side_by_side.py failed: {}{stdout}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(stdout.contains("| Pendulum-v1 [4] |"), "{stdout}");
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert_eq!(v["setup"]["pinned_cpu"], 0);
    let rows = v["rows"].as_array().unwrap();
    assert_eq!(rows.len(), 1, "{v}");
    let r = &rows[0];
    let rates = |side: &str| -> Vec<f64> {
        let ms = r["measurements"][side].as_array().unwrap();
        assert_eq!(ms.len(), 2, "{side}: {v}");
        ms.iter()
            .map(|m| m["steps_per_cpu_s"].as_f64().unwrap())
            .collect()
    };
    // Pendulum never terminates: every episode lasts its 200 steps.
    for (side, nets) in [
        ("rwg", 6),
        ("ref_numpy", 3),
        ("gym_vector", 2),
        ("gymnax-raw", 4),
    ] {
        for m in r["measurements"][side].as_array().unwrap() {
            assert_eq!(m["env_steps"], nets * 2 * 200, "{side}: {v}");
        }
    }
    let rwg = rates("rwg");
    for peer in ["ref_numpy", "gym_vector", "gymnax-raw"] {
        let p = rates(peer);
        let ratios: Vec<f64> = rwg.iter().zip(&p).map(|(a, b)| a / b).collect();
        let s = &r["rwg_over"][peer];
        assert_eq!(s["median"].as_f64().unwrap(), (ratios[0] + ratios[1]) / 2.0);
        assert_eq!(s["min"].as_f64().unwrap(), ratios[0].min(ratios[1]));
        assert_eq!(s["max"].as_f64().unwrap(), ratios[0].max(ratios[1]));
    }
    let scores =
        std::fs::read_to_string(work.join("runs/w0-rwg/cells/Pendulum-v1__1HL__nobias/scores.csv"))
            .unwrap();
    assert_eq!(scores.lines().count(), 1 + 6 * 2, "{scores}");
}

#[test]
fn bench_libm_checks_every_range_and_times_both() {
    let out = rwg_ok(&["bench", "libm", "--check", "50000", "--rounds", "1"]);
    assert!(out.starts_with("lanes_math in use: "), "{out}");
    if out.contains("needs an x86-64 CPU with AVX2 and FMA") {
        skip(
            "bench_libm_checks_every_range_and_times_both",
            "no AVX2+FMA on this CPU: the vector code cannot run",
        );
        return;
    }
    // Each set's line: name, arguments, then three zero mismatch counts.
    for (name, args) in [
        ("edges", None),
        ("cartpole", Some("10,000")),
        ("mcc", Some("10,000")),
        ("acrobot", Some("10,000")),
        ("pendulum", Some("10,000")),
        ("log-all", Some("10,000")),
    ] {
        let cells: Vec<&str> = out
            .lines()
            .find(|l| l.split_whitespace().next() == Some(name))
            .unwrap_or_else(|| panic!("{name} missing from:\n{out}"))
            .split_whitespace()
            .collect();
        if let Some(args) = args {
            assert_eq!(cells[1], args, "{name}: {out}");
        }
        assert_eq!(&cells[2..5], &["0", "0", "0"], "{name}: {out}");
    }
    assert!(out.contains("; 0 differing results."), "{out}");
    assert!(!out.contains("MISMATCH"), "{out}");
    // pow(x, 2)'s table, after the sin/cos one: --check's N by default, the
    // port alone and pow2_lanes, two zero counts per set.
    let pow = out
        .split_once("Bits of pow(x, 2)")
        .unwrap_or_else(|| panic!("no pow table in:\n{out}"))
        .1;
    for (name, args) in [
        ("edges", None),
        ("envs", Some("16,666")),
        ("hard", Some("16,666")),
        ("log-all", Some("16,668")),
    ] {
        let cells: Vec<&str> = pow
            .lines()
            .find(|l| l.split_whitespace().next() == Some(name))
            .unwrap_or_else(|| panic!("pow's {name} missing from:\n{out}"))
            .split_whitespace()
            .collect();
        if let Some(args) = args {
            assert_eq!(cells[1], args, "pow {name}: {out}");
        }
        assert_eq!(&cells[2..4], &["0", "0"], "pow {name}: {out}");
    }
    assert_eq!(out.matches("; 0 differing results.").count(), 2, "{out}");
    for name in ["envs", "hard", "log-all"] {
        assert!(
            pow.lines().any(|l| {
                let c: Vec<&str> = l.split_whitespace().collect();
                c.len() == 7 && c[0] == name && c[1].parse::<f64>().is_ok()
            }),
            "pow's {name} timing missing from:\n{out}"
        );
    }
    // The timing table: every range and function, scalar and vector figures.
    for name in ["cartpole", "mcc", "acrobot", "pendulum", "log-all"] {
        for f in ["sin", "cos", "sincos"] {
            assert!(
                out.lines().any(|l| {
                    let c: Vec<&str> = l.split_whitespace().collect();
                    c.len() == 8 && c[0] == name && c[1] == f && c[2].parse::<f64>().is_ok()
                }),
                "{name} {f} timing missing from:\n{out}"
            );
        }
    }
}

/// `python` with its directory canonical and its file name kept (a
/// virtualenv's interpreter is a symlink out of the venv, which must not be
/// followed).
fn python_path(python: &str) -> std::path::PathBuf {
    let p = std::path::Path::new(python);
    let dir = p.parent().unwrap().canonicalize().unwrap();
    dir.join(p.file_name().unwrap())
}

/// `path` relative to the directory `base` (both absolute and canonical but
/// for `path`'s last component), with `..` where it lies outside `base`.
fn relative_to(path: &std::path::Path, base: &std::path::Path) -> std::path::PathBuf {
    let (p, b): (Vec<_>, Vec<_>) = (path.components().collect(), base.components().collect());
    let common = p.iter().zip(&b).take_while(|(x, y)| x == y).count();
    let mut out = std::path::PathBuf::new();
    for _ in common..b.len() {
        out.push("..");
    }
    for c in &p[common..] {
        out.push(c);
    }
    out
}
