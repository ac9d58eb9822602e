//! The JAX examples for real: `examples/jax-replay.py` recomputes episodes of
//! a study of `gymnax:` and `jax:` envs (the env of `examples/jax-env/`) in
//! JAX alone, bit for bit with the run's `scores.csv`, from the run
//! directory and from `rwg replay --export-weights`; and a replay under
//! another precision than the run's is seen to differ.
//!
//! Needs `RWG_PEER_PYTHON` (a Python with jax and gymnax); without it each
//! test prints `SKIPPED` (and fails under `CI=true` or `RWG_NO_SKIP=1`).

mod common;
use common::*;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// The JAX Python (`RWG_PEER_PYTHON`), or `None` after a visible skip.
fn python(test: &str) -> Option<String> {
    match std::env::var("RWG_PEER_PYTHON") {
        Ok(p) if !p.is_empty() => Some(p),
        _ => {
            skip(test, "set RWG_PEER_PYTHON to a Python with jax and gymnax");
            None
        }
    }
}

/// `jax-replay.py ARGS` with the example env importable and rwg's binary.
fn replay(py: &str, args: &[&str]) -> Output {
    Command::new(py)
        .arg(repo().join("examples/jax-replay.py"))
        .args(args)
        .arg("--rwg")
        .arg(rwg_bin())
        .env("PYTHONPATH", repo().join("examples/jax-env"))
        .env("RWG_JAX_CACHE", cache())
        .env_remove("XLA_FLAGS")
        .output()
        .unwrap()
}

/// The compilation cache of the JAX tests (as `tests/jax_common.rs`'s).
fn cache() -> PathBuf {
    std::env::temp_dir().join("rwg-test-jax-cache")
}

/// A study of four JAX envs: gymnax's CartPole-v1 (float32, discrete),
/// MountainCarContinuous-v0 (float32, a cos a step: rwg's own on a CPU; a
/// return that sums every step's action, so a bit of any cos shows),
/// Pendulum-v1 (float64, a box, 32 networks per call: the replay runs the
/// network alone all the same) and the point mass of examples/jax-env (a
/// box, with kwargs and a time limit of its own).
fn run_study(py: &str, dir: &Path) -> PathBuf {
    let manifest = dir.join("m.toml");
    std::fs::write(
        &manifest,
        format!(
            "seed = 4\nsamples = 40\nepisodes = 3\nbias = [true]\n\
             [[architectures]]\nname = \"2HL\"\nhidden = [4, 4]\n\
             [[envs]]\nid = \"gymnax:CartPole-v1\"\npython = {py:?}\n\
             [[envs]]\nid = \"gymnax:MountainCarContinuous-v0\"\npython = {py:?}\n\
             [[envs]]\nid = \"gymnax:Pendulum-v1\"\npython = {py:?}\n\
             precision = \"float64\"\nnetworks_per_call = 32\n\
             [[envs]]\nid = \"jax:point_mass:make_env\"\npython = {py:?}\n\
             kwargs = {{ dt = 0.1 }}\nmax_episode_steps = 60\n"
        ),
    )
    .unwrap();
    let out = dir.join("run");
    let st = Command::new(rwg_bin())
        .arg("run")
        .arg(&manifest)
        .args(["--threads", "2", "--no-report", "--out"])
        .arg(&out)
        .env("PYTHONPATH", repo().join("examples/jax-env"))
        .env("RWG_JAX_CACHE", cache())
        .env_remove("RWG_PYTHON")
        .env_remove("XLA_FLAGS")
        .output()
        .unwrap();
    assert!(
        st.status.success(),
        "rwg run failed: {}",
        String::from_utf8_lossy(&st.stderr)
    );
    out
}

/// The stored (score, steps) of `sample`'s `episode` in the cell of `env`.
fn stored(run: &Path, env: &str, sample: u64, episode: u32) -> (f64, u32) {
    for cell in std::fs::read_dir(run.join("cells")).unwrap() {
        let cell = cell.unwrap().path();
        let meta: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(cell.join("cell.json")).unwrap())
                .unwrap();
        if meta["env"] != env {
            continue;
        }
        let scores = std::fs::read_to_string(cell.join("scores.csv")).unwrap();
        let row = scores
            .lines()
            .find(|l| l.starts_with(&format!("{sample},{episode},")))
            .unwrap();
        let f: Vec<&str> = row.split(',').collect();
        return (f[2].parse().unwrap(), f[3].parse().unwrap());
    }
    panic!("no cell of {env} in {}", run.display())
}

/// `return R length L ...` -> (R, L).
fn printed(out: &Output) -> (f64, u32) {
    let text = String::from_utf8_lossy(&out.stdout);
    let w: Vec<&str> = text.split_whitespace().collect();
    assert_eq!((w[0], w[2]), ("return", "length"), "{text}");
    (w[1].parse().unwrap(), w[3].parse().unwrap())
}

#[test]
fn jax_replay_recomputes_scores_bit_for_bit() {
    let Some(py) = python("jax_replay_recomputes_scores_bit_for_bit") else {
        return;
    };
    let dir = temp_dir("jax-replay");
    let run = run_study(&py, &dir);
    let run_s = run.to_str().unwrap();
    // Pendulum's episodes all end at its time limit: its cells ran the plain
    // loop, which the script's lanes reproduce bit for bit all the same
    for (cell, want) in [
        ("gymnax=Pendulum-v1__2HL__bias", "plain"),
        ("gymnax=CartPole-v1__2HL__bias", "lanes"),
    ] {
        let env = std::fs::read_to_string(run.join("cells").join(cell).join("env.json")).unwrap();
        let env: serde_json::Value = serde_json::from_str(&env).unwrap();
        assert_eq!(env["jax"]["episode_loop"]["loop"], want, "{cell}: {env}");
    }
    // From the run directory: the script compares with scores.csv itself.
    for (env, sample, episode) in [
        ("gymnax:CartPole-v1", 37, 2),
        // an episode whose return XLA's own sin and cos would change
        ("gymnax:MountainCarContinuous-v0", 2, 0),
        ("gymnax:Pendulum-v1", 5, 1),
        ("jax:point_mass:make_env", 33, 0),
    ] {
        let (s, e) = (sample.to_string(), episode.to_string());
        let out = replay(
            &py,
            &[
                run_s,
                "--env",
                env,
                "--arch",
                "2HL",
                "--sample",
                &s,
                "--episode",
                &e,
            ],
        );
        let text = String::from_utf8_lossy(&out.stdout);
        assert!(
            out.status.success() && text.contains(": the same"),
            "{env} {sample}/{episode}: {text}\n{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let (ret, len) = printed(&out);
        assert_eq!((ret.to_bits(), len), {
            let (r, l) = stored(&run, env, sample, episode);
            (r.to_bits(), l)
        });
    }
    // From exported weights, with the run's settings given as options; then
    // the same network in float32 instead of the run's float64 differs.
    let net = dir.join("net.json");
    let st = Command::new(rwg_bin())
        .args([
            "replay",
            run_s,
            "--env",
            "gymnax:Pendulum-v1",
            "--arch",
            "2HL",
        ])
        .args(["--sample", "5", "--export-weights", net.to_str().unwrap()])
        .env("PYTHONPATH", repo().join("examples/jax-env"))
        .env("RWG_JAX_CACHE", cache())
        .output()
        .unwrap();
    assert!(
        st.status.success(),
        "{}",
        String::from_utf8_lossy(&st.stderr)
    );
    let want = stored(&run, "gymnax:Pendulum-v1", 5, 2);
    let net_s = net.to_str().unwrap();
    let args = ["--weights", net_s, "--episode", "2", "--lanes", "512"];
    let got = printed(&replay(
        &py,
        &[&args[..], &["--precision", "float64"]].concat(),
    ));
    assert_eq!((got.0.to_bits(), got.1), (want.0.to_bits(), want.1));
    let f32 = printed(&replay(
        &py,
        &[&args[..], &["--precision", "float32"]].concat(),
    ));
    assert_ne!(
        f32.0.to_bits(),
        want.0.to_bits(),
        "float32 gave the float64 bits"
    );
}

/// The key recipe of docs/jax.md ("Keys and policy"), run as printed in
/// float32 mode (JAX's default, without x64) and in float64 mode, gives the
/// key data rwg uses, `[r >> 32, r & 0xFFFFFFFF]`, for reset seeds whose
/// upper word is not 0 (and one of 2^63 or more).
#[test]
fn the_documented_key_recipe_gives_rwg_s_key_in_both_modes() {
    let Some(py) = python("the_documented_key_recipe_gives_rwg_s_key_in_both_modes") else {
        return;
    };
    let page = std::fs::read_to_string(repo().join("docs/jax.md")).unwrap();
    let recipe = page
        .lines()
        .map(str::trim)
        .find(|l| l.starts_with("key = "))
        .expect("docs/jax.md gives the key as `key = ...`");
    let seeds = [1_099_511_627_781u64, 17_368_565_813_789_276_978, u64::MAX];
    let want: Vec<String> = seeds
        .iter()
        .map(|r| format!("[{}, {}]", r >> 32, r & 0xFFFF_FFFF))
        .collect();
    for x64 in ["False", "True"] {
        let script = format!(
            "import jax, jax.numpy as jnp\n\
             jax.config.update('jax_enable_x64', {x64})\n\
             for r in {seeds:?}:\n    {recipe}\n    \
             print([int(w) for w in jax.random.key_data(key)])\n"
        );
        let out = Command::new(&py)
            .args(["-c", &script])
            .env("JAX_PLATFORMS", "cpu")
            .output()
            .unwrap();
        let printed = String::from_utf8_lossy(&out.stdout);
        assert!(
            out.status.success(),
            "x64 {x64}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        assert_eq!(printed.lines().collect::<Vec<_>>(), want, "x64 {x64}");
    }
}
