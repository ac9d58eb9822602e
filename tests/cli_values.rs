//! Values are checked where they enter rwg, end to end with the real `rwg`
//! binary: an episode's total reward beyond ±1e100 (plugin through every
//! path, Gymnasium), Gymnasium observations that are complex, strings or
//! of no values, the pre-0.26 Gym API, registered reward thresholds that are
//! not finite, and manifest `kwargs` with nan/inf or a datetime. What can be
//! refused before the run is refused before the run directory is created.
//!
//! The Gymnasium tests need `RWG_TEST_PYTHON` (see `cli_gym_bridge_faults.rs`).

mod common;
mod gym_bridge_common;
use common::*;
use gym_bridge_common::*;
use std::path::Path;

const HEAD: &str = "samples = 40\nepisodes = 2\n[[architectures]]\nname = \"0HL\"\nhidden = []\n";

fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

/// A manifest of one Gymnasium env entry `env` (the lines after `[[envs]]`).
fn gym_manifest(dir: &Path, name: &str, env: &str) -> String {
    write(dir, name, &format!("{HEAD}[[envs]]\n{env}"))
}

/// `rwg run` of `m` into `dir/out` with the test Python; requires failure
/// and that nothing was created; returns stderr.
fn refused_before_run(py: &str, m: &str, dir: &Path, out: &str) -> String {
    let run = dir.join(out);
    let err = run_err(
        rwg_cmd(py, &["run", m, "--out", run.to_str().unwrap()])
            .output()
            .unwrap(),
    );
    assert!(!run.exists(), "{out}: a run directory was created:\n{err}");
    assert!(!err.contains("internal error"), "{err}");
    err
}

#[test]
fn a_return_beyond_the_bound_fails_the_episode_at_its_step_on_every_plugin_path() {
    let dir = temp_dir("values-plugin-sum");
    let m = write(
        &dir,
        "m.toml",
        &format!(
            "{HEAD}[[envs]]\nid = \"broken/HugeReward-v0\"\nplugin = \"{}\"\n",
            broken_plugin().display()
        ),
    );
    let vars: [(&str, &[(&str, &str)]); 3] = [
        ("single", &[("RWG_PLUGIN_BATCH", "0")]),
        ("batched", &[("RWG_PLUGIN_VEC", "0")]),
        ("vector", &[]),
    ];
    for (path, env) in vars {
        let out = dir.join(path);
        let env: Vec<(&str, &std::ffi::OsStr)> =
            env.iter().map(|(k, v)| (*k, v.as_ref())).collect();
        let res = rwg_env(
            &["run", &m, "--out", out.to_str().unwrap(), "--no-report"],
            &env,
        );
        let err = text(&res.stderr);
        assert!(!res.status.success(), "{path}: {err}");
        // 1e308 per step: the return leaves ±1e100 at step 1, found there
        assert!(
            err.contains("broken/HugeReward-v0: sample 0, episode 0, step 1: "),
            "{path}: {err}"
        );
        assert!(
            err.contains("the episode's total reward is 1e308, beyond ±1e100"),
            "{path}: {err}"
        );
        assert!(err.contains("scale the rewards"), "{path}: {err}");
        let scores = out.join("cells/broken+HugeReward-v0__0HL__nobias/scores.csv");
        assert!(!scores.exists(), "{path}: scores.csv written");
    }
    // isolated in worker processes: the batched sampler's sum
    let iso = write(
        &dir,
        "iso.toml",
        &format!(
            "{HEAD}[[envs]]\nid = \"broken/HugeReward-v0\"\nplugin = \"{}\"\nisolate = true\n",
            broken_plugin().display()
        ),
    );
    let out = dir.join("isolated");
    let err = rwg_err(&["run", &iso, "--out", out.to_str().unwrap(), "--no-report"]);
    assert!(
        err.contains("sample 0, episode 0, step 1: the episode's total reward is 1e308, beyond"),
        "{err}"
    );
}

/// Finite episode totals too large for the statistics (1e308: two of them
/// overflow a mean, one squared a variance) are refused where they enter,
/// naming the env, network, episode and value, on every plugin path; before,
/// the run exited 0 with infinite means and `rwg top` refused its own
/// `samples.csv`.
#[test]
fn a_finite_total_beyond_what_the_statistics_hold_is_refused_where_it_enters() {
    let dir = temp_dir("values-plugin-huge-total");
    let env = format!(
        "{HEAD}[[envs]]\nid = \"broken/HugeReward-v0\"\nplugin = \"{}\"\nmax_episode_steps = 1\n",
        broken_plugin().display()
    );
    for (path, isolate) in [("in-process", ""), ("isolated", "isolate = true\n")] {
        let m = write(&dir, &format!("{path}.toml"), &format!("{env}{isolate}"));
        let out = dir.join(path);
        let err = rwg_err(&["run", &m, "--out", out.to_str().unwrap(), "--no-report"]);
        assert!(
            err.contains(
                "broken/HugeReward-v0: sample 0, episode 0, step 1: the episode's total \
                 reward is 1e308, beyond"
            ),
            "{path}: {err}"
        );
        assert!(err.contains("1e100"), "{path}: {err}");
        assert!(err.contains("scale the rewards"), "{path}: {err}");
        let cell = out.join("cells/broken+HugeReward-v0__0HL__nobias");
        assert!(
            !cell.join("samples.csv").exists(),
            "{path}: samples.csv written"
        );
    }
}

#[test]
fn gymnasium_a_return_beyond_the_bound_fails_the_episode_at_its_step() {
    let Some(py) = python() else { return };
    let dir = temp_dir("values-gym-sum");
    let m = gym_manifest(
        &dir,
        "m.toml",
        "id = \"gymnasium:rwg_test_envs:Odd-v0\"\nkwargs = { mode = \"huge_reward\" }\n",
    );
    let out = dir.join("run");
    let err = run_err(
        rwg_cmd(&py, &["run", &m, "--out", out.to_str().unwrap()])
            .output()
            .unwrap(),
    );
    assert!(
        err.contains(
            "rwg_test_envs:Odd-v0: sample 0, episode 0, step 1: the episode's total reward is 1e308, \
             beyond ±1e100"
        ),
        "{err}"
    );
    assert!(!out
        .join("cells/gymnasium=rwg_test_envs=Odd-v0__0HL__nobias/scores.csv")
        .exists());
}

/// With `non_finite = "end"`, a Gymnasium env's infinite reward (step 3 of
/// every episode) is taken by the start-up probe, and ends each episode
/// there, flagged, with the rewards of steps 1 and 2.
#[test]
fn gymnasium_with_end_an_infinite_reward_ends_the_episode_flagged() {
    let Some(py) = python() else { return };
    let dir = temp_dir("values-gym-end");
    let m = gym_manifest(
        &dir,
        "m.toml",
        "id = \"gymnasium:rwg_test_envs:Odd-v0\"\nkwargs = { mode = \"inf_reward\" }\n\
         non_finite = \"end\"\n",
    );
    let out = dir.join("run");
    run_ok(
        &py,
        &["run", &m, "--out", out.to_str().unwrap(), "--no-report"],
    );
    let cell = out.join("cells/gymnasium=rwg_test_envs=Odd-v0__0HL__nobias");
    let scores = text(&read(cell.join("scores.csv")));
    let mut lines = scores.lines();
    assert_eq!(lines.next(), Some("sample,episode,score,steps,non_finite"));
    assert!(lines.all(|l| l.ends_with(",2.0,3,1")), "{scores}");
    assert!(text(&read(cell.join("cell.json"))).contains("\"non_finite_episodes\": 80"));
}

#[test]
fn gymnasium_bad_observations_and_the_old_api_are_refused_before_the_run() {
    let Some(py) = python() else { return };
    let dir = temp_dir("values-gym-obs");
    let cases: [(&str, &[&str]); 10] = [
        (
            "complex_obs",
            &["complex128", "imaginary part", "ObservationWrapper"],
        ),
        ("str_obs", &["dtype <U", "real numbers"]),
        (
            "str_reward",
            &["step() returned the reward '1.5' (str)", "TransformReward"],
        ),
        ("box0", &["has no values", "at least one"]),
        (
            "nan_reset",
            &[
                "reset(seed=20200509) returned a non-finite observation: value 0 of 3 is nan",
                "finite numbers only",
            ],
        ),
        (
            "inf_reward",
            &[
                "step() returned a non-finite observation or reward",
                "reward inf",
            ],
        ),
        (
            "term_array",
            &[
                "terminated and truncated must be booleans",
                "array([False, False])",
            ],
        ),
        ("box0_action", &["action space Box", "has no values"]),
        (
            "old_reset",
            &["reset() must return (observation, info)", "0.26"],
        ),
        (
            "old_step",
            &[
                "the env's step() returned what Gymnasium cannot unpack",
                "(expected 5, got 4)",
                "step() must return (observation, reward, terminated, truncated, info)",
            ],
        ),
    ];
    for (mode, says) in cases {
        let m = gym_manifest(
            &dir,
            &format!("{mode}.toml"),
            &format!("id = \"gymnasium:rwg_test_envs:Odd-v0\"\nkwargs = {{ mode = \"{mode}\" }}\n"),
        );
        let err = refused_before_run(&py, &m, &dir, mode);
        assert!(err.contains(&format!("{mode}.toml:7:")), "{mode}: {err}");
        assert!(err.contains("rwg_test_envs:Odd-v0"), "{mode}: {err}");
        for s in says {
            assert!(err.contains(s), "{mode}: {s:?} missing in:\n{err}");
        }
        assert!(!err.contains("Traceback"), "{mode}: {err}");
    }
    // accepted: a plain list, an integer Box
    for mode in ["obs_list", "int_obs"] {
        let m = gym_manifest(
            &dir,
            &format!("{mode}.toml"),
            &format!("id = \"gymnasium:rwg_test_envs:Odd-v0\"\nkwargs = {{ mode = \"{mode}\" }}\n"),
        );
        let out = dir.join(mode);
        run_ok(
            &py,
            &["run", &m, "--out", out.to_str().unwrap(), "--no-report"],
        );
    }
}

#[test]
fn gymnasium_a_complex_observation_mid_run_fails_its_episode() {
    let Some(py) = python() else { return };
    let dir = temp_dir("values-gym-complex");
    let at_seed = rwg_core::sampler::reset_seed(0, "rwg_test_envs:Faulty-v0", 3, 1);
    let m = gym_manifest(
        &dir,
        "m.toml",
        &format!(
            "id = \"gymnasium:rwg_test_envs:Faulty-v0\"\nkwargs = {{ mode = \"complex\", \
             at_seed = \"{at_seed}\", at_step = 4 }}\n"
        ),
    );
    let out = dir.join("run");
    // (one thread: one worker process)
    let err = run_err(
        rwg_cmd(
            &py,
            &["run", &m, "--out", out.to_str().unwrap(), "--threads", "1"],
        )
        .output()
        .unwrap(),
    );
    assert!(
        err.contains(
            "rwg_test_envs:Faulty-v0: sample 3, episode 1, step 4: step() returned an \
             observation with complex values; rwg takes real numbers only"
        ),
        "{err}"
    );
}

#[test]
fn gymnasium_non_finite_reward_thresholds_need_solved() {
    let Some(py) = python() else { return };
    let dir = temp_dir("values-gym-threshold");
    for (id, shown) in [("NanThreshold-v0", "nan"), ("InfThreshold-v0", "inf")] {
        let m = gym_manifest(
            &dir,
            "m.toml",
            &format!("id = \"gymnasium:rwg_test_envs:{id}\"\n"),
        );
        let err = refused_before_run(&py, &m, &dir, "r");
        assert!(err.contains("m.toml:7:6"), "{id}: {err}");
        assert!(
            err.contains(&format!("registers reward_threshold = {shown}")),
            "{id}: {err}"
        );
        assert!(err.contains("set `solved = ...`"), "{id}: {err}");
        assert!(!err.contains("Traceback"), "{id}: {err}");
        // the manifest's solved score stands in for it
        let m = gym_manifest(
            &dir,
            "s.toml",
            &format!("id = \"gymnasium:rwg_test_envs:{id}\"\nsolved = 30\n"),
        );
        let out = dir.join(format!("ok-{id}"));
        run_ok(
            &py,
            &["run", &m, "--out", out.to_str().unwrap(), "--no-report"],
        );
        let meta = std::fs::read_to_string(out.join("run.json")).unwrap();
        assert!(meta.contains("\"solved\": 30.0"), "{id}: {meta}");
    }
}

#[test]
fn gymnasium_a_registered_time_limit_beyond_rwgs_is_named() {
    let Some(py) = python() else { return };
    let dir = temp_dir("values-gym-limit");
    let m = gym_manifest(
        &dir,
        "m.toml",
        "id = \"gymnasium:rwg_test_envs:HugeLimit-v0\"\n",
    );
    let err = refused_before_run(&py, &m, &dir, "r");
    assert!(
        err.contains("m.toml:7:6: envs[0]: gymnasium:rwg_test_envs:HugeLimit-v0: the env's spec registers max_episode_steps = 1099511627776"),
        "{err}"
    );
    assert!(
        err.contains("set max_episode_steps in the manifest"),
        "{err}"
    );
    // the manifest's limit replaces it
    let m = gym_manifest(
        &dir,
        "s.toml",
        "id = \"gymnasium:rwg_test_envs:HugeLimit-v0\"\nmax_episode_steps = 30\n",
    );
    let out = dir.join("ok");
    run_ok(
        &py,
        &["run", &m, "--out", out.to_str().unwrap(), "--no-report"],
    );
}

#[test]
fn gymnasium_kwargs_pass_nan_and_inf_as_floats_and_refuse_datetimes() {
    let Some(py) = python() else { return };
    let dir = temp_dir("values-gym-kwargs");
    let got = dir.join("got.txt");
    let m = gym_manifest(
        &dir,
        "m.toml",
        &format!(
            "id = \"gymnasium:rwg_test_envs:Kwargs-v0\"\nkwargs = {{ out = \"{}\", a = nan, \
             b = inf, c = -inf, l = [1.0, -nan], t = {{ x = +inf, y = 2 }}, \
             e = {{ \"$rwg\" = \"nan\" }} }}\n",
            got.display()
        ),
    );
    let out = dir.join("run");
    run_ok(
        &py,
        &["run", &m, "--out", out.to_str().unwrap(), "--no-report"],
    );
    // a NaN is the same NaN: the finished run verifies, and the same command
    // (or the run's own manifest) finds it complete, not another study
    run_ok(&py, &["verify", out.to_str().unwrap()]);
    let own = out.join("manifest.toml");
    for manifest in [m.as_str(), own.to_str().unwrap()] {
        let again = run_ok(
            &py,
            &[
                "run",
                manifest,
                "--out",
                out.to_str().unwrap(),
                "--no-report",
            ],
        );
        assert!(again.contains("complete; nothing to do"), "{again}");
    }
    assert_eq!(
        std::fs::read_to_string(&got).unwrap(),
        format!(
            "{{'a': nan, 'b': inf, 'c': -inf, 'e': {{'$rwg': 'nan'}}, 'l': [1.0, nan], \
             't': {{'x': inf, 'y': 2}}}}"
        )
    );
    // an exported network's kwargs, decoded by rwg_net.gym_kwargs, are the same
    let w = dir.join("w.json");
    run_ok(
        &py,
        &[
            "replay",
            out.to_str().unwrap(),
            "--env",
            "gymnasium:rwg_test_envs:Kwargs-v0",
            "--arch",
            "0HL",
            "--sample",
            "0",
            "--export-weights",
            w.to_str().unwrap(),
        ],
    );
    let decoded = std::process::Command::new(&py)
        .arg("-c")
        .arg(
            "import json, sys, rwg_net; k = rwg_net.gym_kwargs(json.load(open(sys.argv[1]))); \
             del k['out']; print(repr(dict(sorted(k.items()))), end='')",
        )
        .arg(&w)
        .env("PYTHONPATH", python_dir())
        .output()
        .unwrap();
    assert_eq!(
        String::from_utf8_lossy(&decoded.stdout),
        "{'a': nan, 'b': inf, 'c': -inf, 'e': {'$rwg': 'nan'}, 'l': [1.0, nan], \
         't': {'x': inf, 'y': 2}}",
        "{}",
        String::from_utf8_lossy(&decoded.stderr)
    );
    // a datetime: refused at its line, the key named
    let m = write(
        &dir,
        "d.toml",
        &format!(
            "{HEAD}[[envs]]\nid = \"gymnasium:rwg_test_envs:Kwargs-v0\"\n\n[envs.kwargs]\n\
             out = \"{}\"\nwhen = 1979-05-27T07:32:00Z\n",
            got.display()
        ),
    );
    let err = refused_before_run(&py, &m, &dir, "d");
    assert!(err.contains("d.toml:11:"), "{err}");
    assert!(err.contains("envs[0].kwargs.when"), "{err}");
    assert!(err.contains("datetime"), "{err}");
    let m = gym_manifest(
        &dir,
        "n.toml",
        &format!(
            "id = \"gymnasium:rwg_test_envs:Kwargs-v0\"\nkwargs = {{ out = \"{}\", w = \
             {{ at = [07:32:00] }} }}\n",
            got.display()
        ),
    );
    let err = refused_before_run(&py, &m, &dir, "n");
    assert!(err.contains("n.toml:8:"), "{err}");
    assert!(err.contains("envs[0].kwargs.w.at[0]"), "{err}");
}

/// A weight scale whose draws can overflow is refused at its manifest line,
/// saying what is accepted; a network whose output overflows (weights times
/// observations beyond a 64-bit float) fails its episode, naming the scale,
/// instead of acting on infinities or NaN (the run ended 0, or blamed the
/// env's rewards).
#[test]
fn weights_and_network_outputs_must_be_finite() {
    let dir = temp_dir("values-weights");
    let body = |scale: &str, dist: &str| {
        format!(
            "samples = 40\nepisodes = 2\n[weights]\ndistribution = \"{dist}\"\nscale = {scale}\n\
             [[architectures]]\nname = \"0HL\"\nhidden = []\n[[envs]]\nid = \"Acrobot-v1\"\n"
        )
    };
    for (scale, dist, max) in [("1e308", "normal", "1e307"), ("9e307", "uniform", "8e307")] {
        let m = write(&dir, &format!("{dist}.toml"), &body(scale, dist));
        let out = dir.join(dist);
        let err = rwg_err(&["run", &m, "--out", out.to_str().unwrap()]);
        assert!(
            err.contains(&format!("{dist}.toml:5:9: weights.scale: ")),
            "{err}"
        );
        assert!(
            err.contains(&format!("must be above 0 and at most {max}")),
            "{err}"
        );
        assert!(!out.exists(), "{dist}: a run directory was created");
    }
    // finite weights, but Acrobot's angular velocities (up to 9 pi) times
    // them overflow to infinity
    let m = write(&dir, "big.toml", &body("1e307", "normal"));
    let out = dir.join("big");
    let err = rwg_err(&["run", &m, "--out", out.to_str().unwrap(), "--no-report"]);
    assert!(err.contains("Acrobot-v1: sample "), "{err}");
    assert!(err.contains("the network's output is inf"), "{err}");
    assert!(err.contains("[weights] scale = 1e307"), "{err}");
    assert!(!err.contains("reward"), "{err}");
    assert!(!out
        .join("cells/Acrobot-v1__0HL__nobias/scores.csv")
        .exists());
}
