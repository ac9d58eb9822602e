//! JAX envs refused or described, end to end with the real `rwg` binary:
//! bad JAX entries are refused at their manifest line, `rwg envs` describes
//! a JAX env, `rwg rollout` and `rwg check` refuse one saying what works,
//! `rwg slurm` checks one without the device its shards will have, an env
//! that computes other sizes than its spaces declare is named with both, and
//! a compiled call that fails as a whole names its networks, not an episode.
//!
//! Needs `RWG_PEER_PYTHON` (see `cli_jax.rs`) except for the refusals that
//! start no Python.

mod common;
mod jax_common;
use common::*;
use jax_common::*;

/// Bad JAX entries are refused at their manifest line, saying why.
#[test]
fn bad_jax_entries_are_refused_at_their_line() {
    let Some(py) = python() else { return };
    let dir = temp_dir("jax-errors");
    let cases: [(&str, &str, &str, &[&str]); 6] = [
        (
            "gymnax:CartPole-v9",
            "",
            ":8:",
            &["CartPole-v9", "CartPole-v1", "Acrobot-v1"],
        ),
        (
            "gymnax:CartPole-v1",
            "precision = \"float16\"",
            ":10:",
            &["precision", "float32", "float64"],
        ),
        (
            "gymnax:CartPole-v1",
            "networks_per_call = 33",
            ":10:",
            &["networks_per_call", "multiple of 32"],
        ),
        (
            "gymnax:CartPole-v1",
            "device = \"gpu\"",
            ":10:",
            &["device", "gpu", "cpu"],
        ),
        (
            "gymnax:CartPole-v1",
            "plugin = \"x.so\"",
            ":10:",
            &["plugin", "JAX"],
        ),
        (
            "CartPole-v1",
            "precision = \"float64\"",
            ":10:",
            &["precision", "JAX"],
        ),
    ];
    for (id, entry, line, says) in cases {
        let body = manifest(&py, id, entry, 32, 1, false);
        let body = if id.contains(':') {
            body
        } else {
            body.replace(&format!("python = {py:?}\n"), "")
        };
        // (the built-in id's entry has no python line: its key sits a line up)
        let line = if id.contains(':') { line } else { ":9:" };
        let m = write(&dir, "m.toml", &body);
        let e = err(&["run", &m, "--out", s(&dir.join("r")), "--no-report"]);
        assert!(e.contains(&format!("m.toml{line}")), "{id} {entry}: {e}");
        for w in says {
            assert!(e.contains(w), "{id} {entry}: {w:?} missing in {e}");
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// An env whose observations or rewards have other sizes than it declares
/// is refused before anything runs, naming both sizes (not XLA's
/// "dot_general requires contracting dimensions"); one that raises is one
/// error line naming the file its traceback is kept in; a worker that dies
/// in a call is named by the call's networks, with no episode or step of it
/// blamed.
#[test]
fn wrong_sizes_and_failed_calls_are_told_as_they_are() {
    let Some(py) = python() else { return };
    let dir = temp_dir("jax-sizes");
    for (kwargs, says) in [
        (
            "declared = 3",
            "the env's reset returns an observation of 2 values (shape (2,)) where its \
             observation space declares 3 (shape (3,))",
        ),
        (
            "reward_values = 4",
            "the env's reward has shape (4,): rwg sums one reward (a scalar) per step",
        ),
    ] {
        let entry = format!("kwargs = {{ {kwargs} }}");
        let body = manifest(
            &py,
            "jax:rwg_jax_envs:make_wrong_size",
            &entry,
            32,
            1,
            false,
        );
        let m = write(&dir, "m.toml", &body);
        let run = dir.join("r");
        let e = err(&["run", &m, "--out", s(&run), "--no-report"]);
        assert!(e.contains(says), "{kwargs}: {e}");
        assert!(e.contains("m.toml:8:"), "{kwargs}: {e}");
        assert!(!e.contains("dot_general"), "{kwargs}: {e}");
        assert!(!run.exists(), "{kwargs}: nothing may be created");
    }
    // an env that raises: one error line; the traceback in the file it names
    let body = manifest(&py, "jax:rwg_jax_envs:make_raising", "", 32, 1, false);
    let m = write(&dir, "m.toml", &body);
    let e = err(&["run", &m, "--out", s(&dir.join("r")), "--no-report"]);
    assert!(
        e.contains(
            "tracing the env's reset and a first step raised RuntimeError: a deliberate \
                    failure in step"
        ),
        "{e}"
    );
    assert_eq!(e.lines().count(), 1, "{e}");
    assert!(e.contains("; the Python traceback is in "), "{e}");
    let all = with_details(&e);
    assert!(all.contains("Traceback (most recent call last)"), "{all}");
    let entry = "networks_per_call = 32";
    let body = manifest(&py, "jax:rwg_jax_envs:make_dying", entry, 64, 1, false);
    let m = write(&dir, "m.toml", &body);
    let d = dir.join("d");
    let e = err(&["run", &m, "--out", s(&d), "--threads", "1", "--no-report"]);
    assert!(
        e.contains(
            "rwg_jax_envs:make_dying: the compiled call of networks 0 to 31 (32 \
                    networks, every episode) failed: the JAX worker exited with status 3"
        ),
        "{e}"
    );
    assert!(!e.contains("episode 0, step 0"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// Action spaces rwg cannot drive and gymnax kwargs of the wrong type are
/// refused in one line saying what is wrong: a space at the id's line, a
/// kwarg at the kwargs line (not a bare TypeError, a protocol error, or a
/// kwarg silently cast).
#[test]
fn odd_action_spaces_and_kwargs_of_the_wrong_type_say_what_is_wrong() {
    let Some(py) = python() else { return };
    let dir = temp_dir("jax-odd-spaces");
    let custom = "jax:rwg_jax_envs:make_actions";
    let cases: [(&str, &str, &str, &[&str]); 7] = [
        (
            custom,
            "multi",
            ":8:",
            &["2 discrete choices", "MultiDiscrete"],
        ),
        (custom, "none", ":8:", &["n = 0", "a whole n of 1 or more"]),
        (
            custom,
            "half",
            ":8:",
            &["n = 2.5", "a whole n of 1 or more"],
        ),
        (
            custom,
            "misfit",
            ":8:",
            &["bounds of shape (2,)", "shape (3,)"],
        ),
        (
            "gymnax:CartPole-v1",
            "gravity = \"heavy\"",
            ":10:",
            &["gravity = 'heavy' is a str", "a number (its default: 9.8"],
        ),
        (
            "gymnax:CartPole-v1",
            "gravity = true",
            ":10:",
            &["gravity = True is a bool", "a number"],
        ),
        (
            "gymnax:CartPole-v1",
            "max_steps_in_episode = 2.5",
            ":10:",
            &[
                "max_steps_in_episode = 2.5",
                "a whole number (its default: 500",
            ],
        ),
    ];
    for (id, arg, line, says) in cases {
        let kwargs = if id == custom {
            format!("kind = \"{arg}\"")
        } else {
            arg.to_string()
        };
        let entry = format!("kwargs = {{ {kwargs} }}");
        let m = write(&dir, "m.toml", &manifest(&py, id, &entry, 32, 1, false));
        let e = err(&["run", &m, "--out", s(&dir.join("r")), "--no-report"]);
        assert!(e.contains(&format!("m.toml{line}")), "{arg}: {e}");
        for w in says {
            assert!(e.contains(w), "{arg}: {w:?} missing in {e}");
        }
        assert_eq!(e.lines().count(), 1, "{arg}: {e}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// `rwg envs gymnax:CartPole-v1` describes the env: spaces, time limit,
/// versions, device.
#[test]
fn envs_describes_a_gymnax_env() {
    let Some(py) = python() else { return };
    let shown = ok(&["envs", "gymnax:CartPole-v1", "--python", &py]);
    for w in [
        "gymnax:CartPole-v1",
        "Discrete(2)",
        "500",
        "jax 0.10.2",
        "gymnax 1.0.1",
        "cpu",
    ] {
        assert!(shown.contains(w), "{w:?} missing in {shown}");
    }
    let json = ok(&["envs", "gymnax:CartPole-v1", "--python", &py, "--json"]);
    let v: serde_json::Value = serde_json::from_str(&json).unwrap();
    assert_eq!(v[0]["max_episode_steps"], 500, "{json}");
    assert_eq!(v[0]["jax"]["platform"], "cpu", "{json}");
}

/// Commands that step an env one call at a time refuse a JAX env, saying
/// what works for one (no Python is started).
#[test]
fn rollout_and_check_refuse_jax_envs_naming_what_works() {
    for (cmd, id) in [("rollout", "gymnax:CartPole-v1"), ("check", "brax:ant")] {
        let e = err(&[cmd, id]);
        assert!(e.contains(&format!("'{id}' is a JAX env")), "{e}");
        assert!(e.contains(&format!("rwg envs {id}")), "{e}");
    }
}

/// `action_dtype` on a JAX env is refused at its line whatever its value
/// (float64, the default elsewhere, too: the page says it is refused), and
/// no Python is started to say so.
#[test]
fn action_dtype_is_refused_on_jax_envs_even_the_default() {
    let dir = temp_dir("jax-action-dtype");
    for dtype in ["float64", "float32"] {
        let body = manifest(
            "/nonexistent/python3",
            "gymnax:CartPole-v1",
            &format!("action_dtype = \"{dtype}\""),
            32,
            1,
            false,
        );
        let m = write(&dir, "m.toml", &body);
        let e = err(&["run", &m, "--out", s(&dir.join("r")), "--no-report"]);
        assert!(
            e.starts_with(&format!(
                "error: {m}:10:16: envs[0].action_dtype: 'gymnax:CartPole-v1' is a JAX \
                 environment, which takes no `action_dtype`"
            )),
            "{dtype}: {e}"
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// `rwg slurm` on a machine without the device a JAX env names (a login
/// node without GPUs) checks the env on JAX's default device and keeps the
/// manifest's device for the shards.
#[test]
fn slurm_checks_a_jax_env_without_the_device_the_shards_will_have() {
    let Some(py) = python() else { return };
    let dir = temp_dir("jax-slurm");
    let m = write(
        &dir,
        "m.toml",
        &manifest(&py, "gymnax:CartPole-v1", "device = \"gpu\"", 64, 1, false),
    );
    let study = dir.join("study");
    ok(&[
        "slurm",
        &m,
        "--shards",
        "2",
        "--out",
        s(&study),
        "--dry-run",
    ]);
    let resolved = std::fs::read_to_string(study.join("slurm/manifest.toml")).unwrap();
    assert!(resolved.contains("device = \"gpu\""), "{resolved}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// `--isolate` (every plugin env isolated) leaves a JAX env, which takes no
/// `isolate`, as it is: the resolved manifests of `rwg run` and `rwg slurm`
/// read back, and a run resumes from its own manifest.toml.
#[test]
fn isolate_leaves_jax_envs_alone() {
    let Some(py) = python() else { return };
    let dir = temp_dir("jax-isolate");
    let m = write(
        &dir,
        "m.toml",
        &manifest(
            &py,
            "gymnax:CartPole-v1",
            "networks_per_call = 32",
            32,
            1,
            false,
        ),
    );
    let run = dir.join("run");
    ok(&["run", &m, "--out", s(&run), "--isolate", "--no-report"]);
    let own = run.join("manifest.toml");
    let resolved = std::fs::read_to_string(&own).unwrap();
    assert!(!resolved.contains("isolate"), "{resolved}");
    // nor an action_dtype, which a JAX env refuses
    assert!(!resolved.contains("action_dtype"), "{resolved}");
    ok(&["run", s(&own), "--out", s(&run), "--no-report"]);
    let study = dir.join("study");
    ok(&[
        "slurm",
        &m,
        "--shards",
        "2",
        "--out",
        s(&study),
        "--isolate",
        "--dry-run",
    ]);
    let shards = std::fs::read_to_string(study.join("slurm/manifest.toml")).unwrap();
    assert!(!shards.contains("isolate"), "{shards}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// `non_finite = "end"` on a JAX env: an episode ends at its first value
/// that is not finite (a NaN observation from step 1 of one episode; physics
/// that blow up in float32 and float64), flagged in scores.csv and counted,
/// with the same bytes whatever the threads.
#[test]
fn with_end_a_jax_episode_ends_at_its_first_value_not_finite() {
    let Some(py) = python() else { return };
    let dir = temp_dir("jax-non-finite");
    let nan_file = dir.join("nan-seed");
    let seed = rwg_core::sampler::reset_seed(5, "rwg_jax_envs:make_slider", 40, 1);
    std::fs::write(&nan_file, seed.to_string()).unwrap();
    let entry = format!(
        "kwargs = {{ nan_file = {:?} }}\nnetworks_per_call = 32\nnon_finite = \"end\"",
        s(&nan_file)
    );
    let m = write(
        &dir,
        "nan.toml",
        &manifest(&py, "jax:rwg_jax_envs:make_slider", &entry, 64, 2, false),
    );
    let run = dir.join("nan");
    ok(&["run", &m, "--out", s(&run), "--no-report"]);
    let cell = run.join("cells/jax=rwg_jax_envs=make_slider__0HL__nobias");
    let scores = std::fs::read_to_string(cell.join("scores.csv")).unwrap();
    let flagged: Vec<&str> = scores.lines().filter(|l| l.ends_with(",1")).collect();
    // network 40's episode 1 observes NaN at step 1: it ends there, its
    // reward left out
    assert_eq!(flagged, ["40,1,0.0,1,1"], "{scores}");
    let json = std::fs::read_to_string(cell.join("cell.json")).unwrap();
    assert!(json.contains("\"non_finite_episodes\": 1"), "{json}");
    // physics that blow up: float32 overflows, float64 leaves ±1e100 (the
    // threads compared in float32)
    for (precision, threads) in [("float32", &["1", "2"][..]), ("float64", &["2"])] {
        let runs: Vec<_> = threads
            .iter()
            .map(|threads| {
                let entry = format!(
                    "kwargs = {{ blowup = 10.0 }}\nprecision = \"{precision}\"\n\
                     networks_per_call = 32\nnon_finite = \"end\""
                );
                let name = format!("{precision}-{threads}");
                let m = write(
                    &dir,
                    &format!("{name}.toml"),
                    &manifest(&py, "jax:rwg_jax_envs:make_slider", &entry, 64, 2, false),
                );
                let out = dir.join(&name);
                ok(&[
                    "run",
                    &m,
                    "--out",
                    s(&out),
                    "--threads",
                    threads,
                    "--no-report",
                ]);
                let cell = out.join("cells/jax=rwg_jax_envs=make_slider__0HL__nobias");
                std::fs::read_to_string(cell.join("scores.csv")).unwrap()
            })
            .collect();
        let rows: Vec<&str> = runs[0].lines().skip(1).collect();
        assert!(
            rows.iter().all(|l| l.ends_with(",1")),
            "{precision}: {}",
            runs[0]
        );
        assert!(
            rows.iter().all(|l| !l.ends_with(",60,1")),
            "{precision}: {}",
            runs[0]
        );
        assert_eq!(
            runs[0],
            runs[runs.len() - 1],
            "{precision}: the threads change it"
        );
    }
    ok(&["verify", s(&run)]);
    let _ = std::fs::remove_dir_all(&dir);
}
