//! ABI 1.1's batched calls through the host's `PluginBatch`: the C example
//! (built against today's header and against the 1.0 header) and the Rust
//! shim, failures in one lane, masks and the host's time limit.

mod common;

use common::{c_out_dir, compile_c, compile_c_against, rust_plugin};
use rwg_env::{EnvError, Environment};
use rwg_plugin_host::{load_plugin, LaneFailure};

const CHAIN: &str = "examples/plugin-c/chain.c";

#[test]
fn a_plugin_built_against_the_1_0_header_has_no_batched_calls_and_runs_alike() {
    let dir = c_out_dir("batched-v1_0");
    let old = load_plugin(compile_c_against(
        CHAIN,
        "tests/data/abi-v1.0",
        &dir,
        "chain10",
        &[],
    ))
    .unwrap();
    let new = load_plugin(compile_c(CHAIN, &dir, "chain11", &[])).unwrap();
    assert_eq!(old.info().abi, (1, 0));
    assert_eq!(new.info().abi, (1, 2));
    let (t10, t11) = (&old.envs()[0], &new.envs()[0]);
    assert!(!t10.has_batched_calls());
    assert!(t11.has_batched_calls());
    assert!(matches!(
        t10.make_batch("", 2, None),
        Err(EnvError::Unsupported(_))
    ));
    // Same episodes through 1.0's single calls and 1.1's batched calls.
    let mut single = t10.make("", None).unwrap();
    let mut batch = t11.make_batch("", 3, None).unwrap();
    let mut obs = [0.0; 2];
    let mut bobs = [0.0; 6];
    single.reset(42, &mut obs).unwrap();
    batch.reset_many(&[0, 1, 0], &[0, 42, 0], &mut bobs, |f| panic!("{f:?}"));
    assert_eq!(obs, bobs[2..4]);
    let (mut r, mut te, mut tr) = ([0.0; 3], [0u8; 3], [0u8; 3]);
    for k in 0..100 {
        let a = (k % 3 != 0) as i64;
        let s = single.step(rwg_env::Action::Discrete(a), &mut obs).unwrap();
        let actions = [0.0, a as f64, 0.0];
        batch.step_many(
            &[0, 1, 0],
            &actions,
            &mut bobs,
            &mut r,
            &mut te,
            &mut tr,
            |f| panic!("{f:?}"),
        );
        assert_eq!(obs, bobs[2..4], "step {k}");
        assert_eq!(
            (s.reward.to_bits(), s.terminated, s.truncated),
            (r[1].to_bits(), te[1] == 1, tr[1] == 1),
            "step {k}"
        );
        if s.terminated || s.truncated {
            break;
        }
    }
}

#[test]
fn a_failing_lane_is_reported_and_the_other_lanes_are_stepped() {
    let dir = c_out_dir("batched-fail");
    let p = load_plugin(compile_c(CHAIN, &dir, "chain", &[])).unwrap();
    let ty = &p.envs()[0];
    let mut batch = ty.make_batch("length=3", 4, Some(2)).unwrap();
    let mut obs = [0.0; 8];
    let (mut r, mut te, mut tr) = ([0.0; 4], [0u8; 4], [0u8; 4]);
    // Lane 3 is never reset: refused by the host like TimeLimit does.
    batch.reset_many(&[1, 1, 1, 0], &[1, 2, 3, 0], &mut obs, |f| panic!("{f:?}"));
    let mut failures: Vec<LaneFailure> = vec![];
    // Lane 1's action is invalid: lanes 0 and 2 are stepped all the same.
    batch.step_many(
        &[1, 1, 1, 1],
        &[1.0, 0.5, 1.0, 1.0],
        &mut obs,
        &mut r,
        &mut te,
        &mut tr,
        |f| failures.push(f),
    );
    assert_eq!(failures.len(), 2, "{failures:?}");
    assert_eq!(failures[0].lane, 3);
    assert_eq!(failures[0].error, EnvError::ResetNeeded);
    assert_eq!(failures[1].lane, 1);
    let msg = failures[1].error.to_string();
    assert!(
        msg.contains("step failed with RWG_ERR_INVALID_ARGUMENT (1): the action must be 0 (left) or 1 (right)"),
        "{msg}"
    );
    assert!(matches!(failures[1].error, EnvError::InvalidAction(_)));
    assert!(r[0].is_finite() && r[2].is_finite());
    // The host's time limit (2 steps here) truncates the second step.
    batch.step_many(
        &[1, 0, 0, 0],
        &[0.0; 4],
        &mut obs,
        &mut r,
        &mut te,
        &mut tr,
        |f| panic!("{f:?}"),
    );
    assert_eq!(tr[0], 1);
}

#[test]
fn rust_plugins_export_batched_calls_that_catch_panics_per_lane() {
    let p = load_plugin(rust_plugin("rwg_testing_plugins", "rwg-testing-plugins")).unwrap();
    let ty = p.env("broken/PanicInStep-v0").unwrap();
    assert!(ty.has_batched_calls());
    let d = ty.spec().obs_dim();
    let mut batch = ty.make_batch("", 2, None).unwrap();
    let mut obs = vec![0.0; 2 * d];
    batch.reset_many(&[1, 1], &[1, 2], &mut obs, |f| panic!("{f:?}"));
    let a = batch.action_len();
    let (mut r, mut te, mut tr) = ([0.0; 2], [0u8; 2], [0u8; 2]);
    let mut failed = vec![];
    // It panics on its 3rd step: in both lanes, each caught and reported.
    for k in 1..=3 {
        batch.step_many(
            &[1, 1],
            &vec![0.0; 2 * a],
            &mut obs,
            &mut r,
            &mut te,
            &mut tr,
            |f| failed.push((k, f.lane, f.error.to_string())),
        );
    }
    let lanes: Vec<(i32, usize)> = failed.iter().map(|f| (f.0, f.1)).collect();
    assert_eq!(lanes, [(3, 0), (3, 1)], "{failed:?}");
    assert!(failed[0].2.contains("RWG_ERR_PANIC"), "{failed:?}");
    assert!(batch.lane(0).is_poisoned() && batch.lane(1).is_poisoned());
}
