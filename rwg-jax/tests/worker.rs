//! The JAX worker for real (needs `RWG_PEER_PYTHON`, a Python with jax
//! 0.10.2, gymnax 1.0.1 and brax 0.14.2; SKIPPED without it, a failure
//! under `CI=true` or `RWG_NO_SKIP=1`). The `jax:` envs are
//! `tests/data/rwg_jax_test_envs.py`; `tests/data/replay_check.py` is the
//! replay recipe of a gymnax network, written apart from the worker.
#![expect(
    clippy::single_range_in_vec_init,
    reason = "one block of networks is what is meant"
)]

use rwg_core::policy::Architecture;
use rwg_core::sampler::{BlockResult, CellPlan, WeightDist};
use rwg_jax::{JaxConfig, JaxError, JaxKind, JaxSource, Precision, RunError};
use std::ops::Range;
use std::path::PathBuf;

fn python() -> Option<String> {
    match std::env::var("RWG_PEER_PYTHON") {
        Ok(p) if !p.is_empty() => Some(p),
        _ => {
            let ci = std::env::var("CI").as_deref() == Ok("true")
                || std::env::var("RWG_NO_SKIP").as_deref() == Ok("1");
            assert!(
                !ci,
                "set RWG_PEER_PYTHON to a Python with jax, gymnax and brax"
            );
            // to the process's stderr, past the test harness's capture
            use std::io::Write;
            let _ = writeln!(
                std::io::stderr(),
                "SKIPPED {}: set RWG_PEER_PYTHON to a Python with jax==0.10.2, gymnax==1.0.1 \
                 and brax==0.14.2 to run this test",
                std::thread::current().name().unwrap_or("worker")
            );
            None
        }
    }
}

fn data_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data")
}

/// The worker's float32 sin and cos on a CPU, as a file.
fn trig_module() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("src/jax_trig.py")
}

fn config(py: &str, kind: JaxKind, id: &str) -> JaxConfig {
    // the jax: test envs import from tests/data (the workers inherit it)
    std::env::set_var("PYTHONPATH", data_dir());
    let mut cfg = JaxConfig::new(kind, id);
    cfg.python = py.into();
    cfg.networks_per_call = Some(32);
    // the JAX tests' compilation cache, not the user's
    cfg.compile_cache = Some(std::env::temp_dir().join("rwg-test-jax-cache"));
    cfg
}

fn plan(id: &str, hidden: &[usize], bias: bool, episodes: u32) -> CellPlan {
    CellPlan {
        seed: 3,
        env_id: id.into(),
        arch: Architecture {
            hidden: hidden.to_vec(),
            bias,
        },
        episodes,
        dist: WeightDist::Normal { std: 1.0 },
        policy: rwg_core::policy::PolicyKind::Network,
        non_finite: Default::default(),
    }
}

fn run(
    src: &JaxSource,
    plan: &CellPlan,
    blocks: &[Range<u64>],
    threads: usize,
) -> Result<Vec<BlockResult>, RunError> {
    let mut out = vec![];
    src.run_blocks(plan, blocks, threads, |b| -> Result<(), RunError> {
        out.push(b);
        Ok(())
    })?;
    Ok(out)
}

/// (score bits, steps) of every episode, in block order.
fn bits(blocks: &[BlockResult]) -> Vec<(u64, u32)> {
    blocks
        .iter()
        .flat_map(|b| b.episodes.iter().map(|e| (e.score.to_bits(), e.steps)))
        .collect()
}

fn start_error(cfg: JaxConfig) -> String {
    match JaxSource::open(cfg) {
        Ok(_) => panic!("started"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn cartpole_results_do_not_depend_on_chunks_or_workers() {
    let Some(py) = python() else { return };
    let src = JaxSource::open(config(&py, JaxKind::Gymnax, "CartPole-v1")).unwrap();
    let info = src.info();
    assert_eq!(info.spec.id, "gymnax:CartPole-v1");
    assert_eq!(info.spec.max_episode_steps, Some(500));
    assert_eq!(
        (info.platform.as_str(), info.precision),
        ("cpu", Precision::F32)
    );
    assert!(info.versions.contains_key("gymnax"), "{:?}", info.versions);
    assert_eq!(src.workers_for(3), 3);
    let p = plan("CartPole-v1", &[4, 4], false, 3);
    let whole = run(&src, &p, &[0..40], 1).unwrap();
    assert_eq!(whole.len(), 1);
    assert_eq!(whole[0].episodes.len(), 120);
    assert!(whole[0]
        .episodes
        .iter()
        .all(|e| (1..=500).contains(&e.steps) && e.score == f64::from(e.steps)));
    // the same networks in chunks of other members (3..35, 35..40), two workers
    let split = run(&src, &p, &[3..10, 10..11, 11..40], 2).unwrap();
    let samples: Vec<_> = split.iter().map(|b| b.samples.clone()).collect();
    assert_eq!(samples, [3..10, 10..11, 11..40]);
    assert_eq!(bits(&split), bits(&whole)[3 * 3..]);
}

#[test]
fn a_gymnax_return_is_what_the_replay_recipe_computes() {
    let Some(py) = python() else { return };
    let src = JaxSource::open(config(&py, JaxKind::Gymnax, "CartPole-v1")).unwrap();
    let p = plan("CartPole-v1", &[4], true, 2);
    let got = run(&src, &p, &[0..6], 1).unwrap();
    // the longest episode says the most
    let (i, best) = got[0]
        .episodes
        .iter()
        .enumerate()
        .max_by_key(|(_, e)| e.steps)
        .unwrap();
    let (n, e) = ((i / 2) as u64, (i % 2) as u32);
    let weights = p.policy(&src.info().spec, n).weights().to_vec();
    let seed = rwg_core::sampler::reset_seed(p.seed, &p.env_id, n, e);
    let out = std::process::Command::new(&py)
        .arg(data_dir().join("replay_check.py"))
        .env("RWG_TRIG_MODULE", trig_module())
        .args(["CartPole-v1", "4", "1", &seed.to_string()])
        .args(weights.iter().map(|w| format!("{w:?}")))
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let mut f = text.split_whitespace();
    let ret: f64 = f.next().unwrap().parse().unwrap();
    let len: u32 = f.next().unwrap().parse().unwrap();
    assert_eq!((ret.to_bits(), len), (best.score.to_bits(), best.steps));
}

#[test]
fn pendulum_and_brax_run_continuous_actions() {
    let Some(py) = python() else { return };
    let src = JaxSource::open(config(&py, JaxKind::Gymnax, "Pendulum-v1")).unwrap();
    let p = plan("Pendulum-v1", &[2], false, 2);
    let got = run(&src, &p, &[0..4, 4..5], 1).unwrap();
    assert!(got
        .iter()
        .flat_map(|b| &b.episodes)
        .all(|e| e.steps == 200 && e.score < 0.0));
    // 200 steps of a chaotic system: any difference of a bit would grow
    assert_eq!(bits(&run(&src, &p, &[1..5], 2).unwrap()), bits(&got)[2..]);
    let mut cfg = config(&py, JaxKind::Brax, "inverted_pendulum");
    cfg.max_episode_steps = Some(30);
    let src = JaxSource::open(cfg).unwrap();
    assert_eq!(src.info().spec.max_episode_steps, Some(30));
    assert!(src.info().versions.contains_key("brax"));
    let p = plan("inverted_pendulum", &[], false, 2);
    let a = run(&src, &p, &[0..3], 1).unwrap();
    assert!(a[0].episodes.iter().all(|e| (1..=30).contains(&e.steps)));
    assert_eq!(bits(&run(&src, &p, &[1..3], 1).unwrap()), bits(&a)[2..]);
}

#[test]
fn a_custom_env_runs_in_both_precisions() {
    let Some(py) = python() else { return };
    let p = plan("rwg_jax_test_envs:line", &[3], true, 4);
    let mut results = vec![];
    for precision in [Precision::F32, Precision::F64] {
        let mut cfg = config(&py, JaxKind::Custom, "rwg_jax_test_envs:line");
        cfg.precision = precision;
        let src = JaxSource::open(cfg).unwrap();
        assert_eq!(src.info().precision, precision);
        assert_eq!(src.info().spec.max_episode_steps, Some(50));
        let got = run(&src, &p, &[0..5], 1).unwrap();
        assert!(got[0].episodes.iter().all(|e| (1..=50).contains(&e.steps)));
        results.push(bits(&got));
    }
    // float64 computes other bits (the rewards are not whole numbers)
    assert_ne!(results[0], results[1]);
}

#[test]
fn a_non_finite_value_names_its_network_and_episode() {
    let Some(py) = python() else { return };
    for (what, says) in [("obs", "an observation"), ("reward", "a reward")] {
        let mut cfg = config(&py, JaxKind::Custom, "rwg_jax_test_envs:line");
        cfg.kwargs.insert("nan_at".into(), 3.into());
        cfg.kwargs.insert("what".into(), what.into());
        cfg.kwargs.insert("max_steps".into(), 2000.into());
        let src = JaxSource::open(cfg).unwrap();
        let p = plan("rwg_jax_test_envs:line", &[], false, 2);
        let mut committed = vec![];
        let err = src
            .run_blocks(&p, &[5..7, 7..8], 1, |b| -> Result<(), RunError> {
                committed.push(b);
                Ok(())
            })
            .unwrap_err();
        let RunError::Episode(err) = err else {
            panic!("{err}")
        };
        // episodes shorter than 3 steps end before the NaN: the first
        // episode of 3 steps or more is the one named
        assert!(committed.is_empty());
        assert!(err.sample >= 5 && err.step >= 3, "{err}");
        assert!(err.to_string().contains(says), "{err}");
    }
}

#[test]
fn start_errors_say_what_is_wrong() {
    let Some(py) = python() else { return };
    let e = start_error(config(&py, JaxKind::Gymnax, "CartPole-v9"));
    assert!(e.contains("CartPole-v9") && e.contains("Acrobot-v1"), "{e}");
    let e = start_error(config(&py, JaxKind::Brax, "no_such_robot"));
    assert!(e.contains("inverted_pendulum"), "{e}");
    let e = start_error(config(&py, JaxKind::Custom, "no_such_module_rwg:make"));
    assert!(
        e.contains("cannot import module 'no_such_module_rwg'"),
        "{e}"
    );
    let e = start_error(config(&py, JaxKind::Custom, "rwg_jax_test_envs:dict_obs"));
    assert!(e.contains("Dict space"), "{e}");
    let e = start_error(config(&py, JaxKind::Custom, "rwg_jax_test_envs:no_limit"));
    assert!(e.contains("give max_episode_steps"), "{e}");
    let mut cfg = config(&py, JaxKind::Gymnax, "CartPole-v1");
    cfg.kwargs.insert("gravityy".into(), 9.0.into());
    let e = start_error(cfg);
    assert!(e.contains("gravityy") && e.contains("masscart"), "{e}");
    let mut cfg = config(&py, JaxKind::Gymnax, "CartPole-v1");
    cfg.device = Some("tpu:3".into());
    let err = JaxSource::open(cfg).unwrap_err();
    assert!(
        matches!(&err, JaxError::Worker { error, .. } if error.kind == "device"),
        "{err}"
    );
}

#[test]
fn a_worker_that_dies_in_a_call_names_the_call_and_how_it_ended() {
    let Some(py) = python() else { return };
    let src = JaxSource::open(config(&py, JaxKind::Custom, "rwg_jax_test_envs:dying")).unwrap();
    let p = plan("rwg_jax_test_envs:dying", &[], false, 2);
    let err = run(&src, &p, &[4..6, 6..7], 1).unwrap_err().to_string();
    assert!(err.contains("networks 4 to 6"), "{err}");
    assert!(!err.contains("episode 0, step 0"), "{err}");
    assert!(
        err.contains("exited with status 3 while running a chunk"),
        "{err}"
    );
    // the next run starts a new worker
    let err = run(&src, &p, &[0..1], 1).unwrap_err().to_string();
    assert!(err.contains("networks 0 to 0"), "{err}");
}

#[test]
fn float32_sin_and_cos_are_vectorised_close_to_exact_and_lane_independent() {
    let Some(py) = python() else { return };
    let out = std::process::Command::new(&py)
        .arg(data_dir().join("trig_check.py"))
        .arg(trig_module())
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}
