//! ABI 1.2's vector env through the host's `PluginVecEnv`: the C example
//! (built against today's header and against the 1.1 header), failures in
//! one lane, masks, the host's time limit, and the Rust export's panic
//! catching and lane naming (the broken plugin's vector envs).

mod common;

use common::{c_out_dir, compile_c, compile_c_against, rust_plugin};
use rwg_env::EnvError;
use rwg_plugin_host::{load_plugin, LaneFailure, PluginVecEnv};
use rwg_testing_plugins::Fault;

const CHAIN: &str = "examples/plugin-c/chain.c";

#[test]
fn a_plugin_built_against_the_1_1_header_has_no_vector_env_and_runs_alike() {
    let dir = c_out_dir("vec-v1_1");
    let old = load_plugin(compile_c_against(
        CHAIN,
        "tests/data/abi-v1.1",
        &dir,
        "chain11",
        &[],
    ))
    .unwrap();
    let new = load_plugin(compile_c(CHAIN, &dir, "chain12", &[])).unwrap();
    assert_eq!(old.info().abi, (1, 1));
    assert_eq!(new.info().abi, (1, 2));
    let (t11, t12) = (&old.envs()[0], &new.envs()[0]);
    assert!(t11.has_batched_calls() && !t11.has_vec_env());
    assert!(t12.has_batched_calls() && t12.has_vec_env());
    assert!(matches!(
        t11.make_vec("", 2, None),
        Err(EnvError::Unsupported(_))
    ));
    // Same episodes through 1.1's batched calls and 1.2's vector env, on
    // lanes that start and stop at different times.
    let mut batch = t11.make_batch("", 3, None).unwrap();
    let mut vec = t12.make_vec("", 3, None).unwrap();
    let (mut bobs, mut vobs) = ([0.0; 6], [0.0; 6]);
    let seeds = [5, 42, 9];
    batch.reset_many(&[1, 1, 0], &seeds, &mut bobs, |f| panic!("{f:?}"));
    vec.reset_many(&[1, 1, 0], &seeds, &mut vobs, |f| panic!("{f:?}"));
    assert_eq!(bobs, vobs);
    let (mut br, mut bte, mut btr) = ([0.0; 3], [0u8; 3], [0u8; 3]);
    let (mut vr, mut vte, mut vtr) = ([0.0; 3], [0u8; 3], [0u8; 3]);
    let mut mask = [1u8, 1, 0];
    for k in 0..150 {
        if k == 10 {
            batch.reset_many(&[0, 0, 1], &seeds, &mut bobs, |f| panic!("{f:?}"));
            vec.reset_many(&[0, 0, 1], &seeds, &mut vobs, |f| panic!("{f:?}"));
            mask[2] = 1;
        }
        let actions = [1.0, f64::from(k % 3 != 0), 1.0];
        batch.step_many(
            &mask,
            &actions,
            &mut bobs,
            &mut br,
            &mut bte,
            &mut btr,
            |f| panic!("{f:?}"),
        );
        vec.step_many(
            &mask,
            &actions,
            &mut vobs,
            &mut vr,
            &mut vte,
            &mut vtr,
            |f| panic!("{f:?}"),
        );
        assert_eq!(bobs.map(f64::to_bits), vobs.map(f64::to_bits), "step {k}");
        for i in 0..3 {
            if mask[i] == 1 {
                assert_eq!(
                    (br[i].to_bits(), bte[i], btr[i]),
                    (vr[i].to_bits(), vte[i], vtr[i]),
                    "step {k} lane {i}"
                );
                if vte[i] == 1 || vtr[i] == 1 {
                    mask[i] = 0;
                }
            }
        }
        if mask == [0, 0, 0] {
            return;
        }
    }
    panic!("the episodes did not end within the time limit");
}

#[test]
fn a_failing_lane_of_a_vector_env_is_reported_and_the_others_are_stepped() {
    let dir = c_out_dir("vec-fail");
    let p = load_plugin(compile_c(CHAIN, &dir, "chain", &[])).unwrap();
    let ty = &p.envs()[0];
    let mut vec = ty.make_vec("length=3", 4, Some(2)).unwrap();
    let mut obs = [0.0; 8];
    let (mut r, mut te, mut tr) = ([0.0; 4], [0u8; 4], [0u8; 4]);
    // Lane 3 is never reset: refused by the host like TimeLimit does.
    vec.reset_many(&[1, 1, 1, 0], &[1, 2, 3, 0], &mut obs, |f| panic!("{f:?}"));
    let mut failures: Vec<LaneFailure> = vec![];
    // Lane 1's action is invalid: lanes 0 and 2 are stepped all the same.
    vec.step_many(
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
        msg.contains("plugin 'c_example' env 'c_example/Chain-v0': step failed with RWG_ERR_INVALID_ARGUMENT (1): the action must be 0 (left) or 1 (right)"),
        "{msg}"
    );
    assert!(matches!(failures[1].error, EnvError::InvalidAction(_)));
    assert!(r[0].is_finite() && r[2].is_finite());
    // The host's time limit (2 steps here) truncates lane 0's second step.
    vec.step_many(
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

fn broken(fault: Fault, lanes: usize) -> PluginVecEnv {
    let p = load_plugin(rust_plugin("rwg_testing_plugins", "rwg-testing-plugins")).unwrap();
    let ty = p.env(fault.id()).unwrap();
    assert!(ty.has_vec_env());
    ty.make_vec("", lanes, None).unwrap()
}

/// Steps every lane of `vec` with action 1 `steps` times; the failures as
/// (step, lane, text).
fn step_all(vec: &mut PluginVecEnv, steps: usize) -> Vec<(usize, usize, String)> {
    let n = vec.len();
    let mut obs = vec![0.0; n];
    vec.reset_many(&vec![1; n], &vec![0; n], &mut obs, |f| panic!("{f:?}"));
    let (mut r, mut te, mut tr) = (vec![0.0; n], vec![0u8; n], vec![0u8; n]);
    let mut failed = vec![];
    for k in 1..=steps {
        vec.step_many(
            &vec![1; n],
            &vec![1.0; n],
            &mut obs,
            &mut r,
            &mut te,
            &mut tr,
            |f| failed.push((k, f.lane, f.error.to_string())),
        );
    }
    failed
}

#[test]
fn a_panic_in_a_vector_env_is_caught_and_poisons_it_whole() {
    // 6 lanes: a chunk of 4 and a partial one of 2 (EachLane::WIDTH is 4).
    let mut vec = broken(Fault::PanicInStep, 6);
    let failed = step_all(&mut vec, 4);
    // Step 3 panics in lane 0; the catch fails every lane, and step 4 finds
    // the vector env poisoned.
    let at: Vec<(usize, usize)> = failed.iter().map(|f| (f.0, f.1)).collect();
    let expected: Vec<(usize, usize)> = (3..=4).flat_map(|k| (0..6).map(move |i| (k, i))).collect();
    assert_eq!(at, expected, "{failed:?}");
    assert!(
        failed[0].2.contains(
            "plugin 'broken' env 'broken/PanicInStep-v0': step failed with RWG_ERR_PANIC (5): panic: broken/PanicInStep-v0 panics on step 3"
        ),
        "{failed:?}"
    );
    assert!(
        failed[6]
            .2
            .contains("the vector env is poisoned by an earlier panic"),
        "{failed:?}"
    );
    assert!(vec.is_poisoned());
}

#[test]
fn non_finite_outputs_of_a_vector_env_fail_their_lanes() {
    let failed = step_all(&mut broken(Fault::NanObservation, 5), 2);
    assert_eq!(failed.len(), 5, "{failed:?}");
    assert_eq!((failed[4].0, failed[4].1), (2, 4));
    assert!(
        failed[4].2.contains(
            "env 'broken/NaNObservation-v0': step returned a non-finite observation: obs[0] = NaN"
        ),
        "{failed:?}"
    );
    let failed = step_all(&mut broken(Fault::NanReward, 3), 2);
    assert_eq!(failed.len(), 3, "{failed:?}");
    assert!(
        failed[1]
            .2
            .contains("env 'broken/NaNReward-v0': step returned a non-finite reward: NaN"),
        "{failed:?}"
    );
}

#[test]
fn the_c_example_refuses_malformed_vector_calls_as_a_whole_and_fails_lanes_alone() {
    use rwg_env::plugin::abi::*;
    use std::ffi::{c_char, CStr};
    let dir = c_out_dir("vec-raw");
    let path = compile_c(CHAIN, &dir, "chainraw", &[]);
    // SAFETY: the C example, built above; its entry has the ABI's signature.
    let lib = unsafe { libloading::Library::new(&path) }.unwrap();
    let entry: libloading::Symbol<EntryFn> = unsafe { lib.get(ENTRY_SYMBOL) }.unwrap();
    let e = unsafe { &*entry(ABI_MAJOR, ABI_MINOR) };
    let vt = unsafe { &*(e.env_vtable.unwrap())(0) };
    let msg = |vec: *const RwgVecEnv, lane: usize| {
        let p: *const c_char = unsafe { (vt.vec_last_error.unwrap())(vec, lane) };
        unsafe { CStr::from_ptr(p) }.to_string_lossy().into_owned()
    };
    let mut vec = std::ptr::null_mut();
    let st = unsafe {
        (vt.vec_create.unwrap())(
            0,
            c"length=4".as_ptr(),
            3,
            &mut vec,
            std::ptr::null_mut(),
            0,
        )
    };
    assert_eq!(st, RWG_OK);
    let (mut obs, mut r, mut te, mut tr) = ([0.0; 6], [0.0; 3], [0u8; 3], [0u8; 3]);
    let mut status = [-1; 3];
    let st = unsafe {
        (vt.vec_reset.unwrap())(
            vec,
            std::ptr::null(),
            [1, 2, 3].as_ptr(),
            obs.as_mut_ptr(),
            2,
            status.as_mut_ptr(),
        )
    };
    assert_eq!(st, RWG_OK);
    let before = obs;
    let mut step =
        |mask: &[u8; 3], actions: &[f64; 3], obs_len: usize, status: &mut [Status; 3]| unsafe {
            (vt.vec_step.unwrap())(
                vec,
                mask.as_ptr(),
                actions.as_ptr(),
                1,
                obs.as_mut_ptr(),
                obs_len,
                r.as_mut_ptr(),
                te.as_mut_ptr(),
                tr.as_mut_ptr(),
                status.as_mut_ptr(),
            )
        };
    // Refused as a whole: every lane gets the status and the message.
    assert_eq!(
        step(&[1, 2, 1], &[1.0; 3], 2, &mut status),
        RWG_ERR_INVALID_ARGUMENT
    );
    assert_eq!(status, [RWG_ERR_INVALID_ARGUMENT; 3]);
    for lane in 0..=3 {
        assert!(
            msg(vec, lane).contains("mask value"),
            "lane {lane}: {}",
            msg(vec, lane)
        );
    }
    assert_eq!(
        step(&[1, 1, 1], &[1.0; 3], 3, &mut status),
        RWG_ERR_BUFFER_SIZE
    );
    assert_eq!(status, [RWG_ERR_BUFFER_SIZE; 3]);
    // A lane that fails alone: the others step.
    let mut status = [-1; 3];
    assert_eq!(
        step(&[1, 1, 0], &[1.0, 0.5, 1.0], 2, &mut status),
        RWG_ERR_INVALID_ARGUMENT
    );
    assert_eq!(status, [RWG_OK, RWG_ERR_INVALID_ARGUMENT, RWG_OK]);
    assert!(
        msg(vec, 1).contains("must be 0 (left) or 1 (right)"),
        "{}",
        msg(vec, 1)
    );
    assert_eq!((msg(vec, 0), msg(vec, 2)), (String::new(), String::new()));
    assert!(obs[0] != before[0] || obs[1] != before[1], "lane 0 stepped");
    assert_eq!(obs[4..], before[4..], "lane 2 (masked out) untouched");
    unsafe { (vt.vec_destroy.unwrap())(vec) };
}
