//! The bridge against real Gymnasium (needs `RWG_TEST_PYTHON`, a Python with
//! gymnasium 1.4; SKIPPED without it, a failure under `CI=true`).

use rwg_core::policy::Architecture;
use rwg_core::sampler::{run_blocks, BlockResult, CellPlan, SampleError, WeightDist};
use rwg_env::{ActionDtype, Environment};
use rwg_gym::{GymConfig, GymSource};

fn python() -> Option<String> {
    match std::env::var("RWG_TEST_PYTHON") {
        Ok(p) if !p.is_empty() => Some(p),
        _ => {
            let ci = std::env::var("CI").as_deref() == Ok("true")
                || std::env::var("RWG_NO_SKIP").as_deref() == Ok("1");
            assert!(!ci, "set RWG_TEST_PYTHON to a Python with gymnasium 1.4");
            // to the process's stderr, past the test harness's capture (which
            // swallows `eprintln!` of a passing test): the skip shows
            use std::io::Write;
            let _ = writeln!(
                std::io::stderr(),
                "SKIPPED {}: set RWG_TEST_PYTHON to a Python with gymnasium==1.4.0 to run this test",
                std::thread::current().name().unwrap_or("bridge")
            );
            None
        }
    }
}

fn plan(id: &str, hidden: &[usize], bias: bool) -> CellPlan {
    CellPlan {
        seed: 3,
        env_id: id.into(),
        arch: Architecture {
            hidden: hidden.to_vec(),
            bias,
        },
        episodes: 3,
        dist: WeightDist::Normal { std: 1.0 },
        policy: rwg_core::policy::PolicyKind::Network,
        non_finite: Default::default(),
    }
}

fn collect(
    f: impl FnOnce(&mut dyn FnMut(BlockResult) -> Result<(), SampleError>) -> Result<(), SampleError>,
) -> Vec<BlockResult> {
    let mut out = vec![];
    f(&mut |b| {
        out.push(b);
        Ok(())
    })
    .unwrap();
    out
}

#[test]
fn gymnasium_envs_give_the_builtins_results() {
    let Some(py) = python() else { return };
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap();
    for (id, hidden) in [("CartPole-v1", vec![4]), ("Pendulum-v1", vec![])] {
        let mut cfg = GymConfig::new(id);
        cfg.python = py.clone();
        let src = GymSource::open(cfg).unwrap();
        let builtin = rwg_envs::make(id, &Default::default()).unwrap();
        assert_eq!(src.info().spec.obs_dim(), builtin.spec().obs_dim());
        assert_eq!(src.info().spec.action_space, builtin.spec().action_space);
        assert_eq!(
            src.info().spec.max_episode_steps,
            builtin.spec().max_episode_steps
        );
        for bias in [false, true] {
            let p = plan(id, &hidden, bias);
            let blocks = [0..5, 5..21, 21..40];
            let want = pool.install(|| {
                collect(|cb| {
                    run_blocks(
                        &p,
                        &blocks,
                        2,
                        || rwg_envs::make(id, &Default::default()).unwrap(),
                        cb,
                    )
                })
            });
            let got = pool.install(|| collect(|cb| src.run_blocks(&p, &blocks, 2, cb)));
            assert_eq!(got, want, "{id} bias {bias}");
        }
        let _ = ActionDtype::F64;
    }
}
