//! ABI 1.1's batched calls: the host reads them only within a table's
//! struct_size, the shim's `step_many` refuses malformed calls as a whole and
//! stops at a failing lane, and `PluginBatch` reports what the single path
//! reports.

use super::*;
use crate::loader::{PluginBatch, PluginEnv};
use rwg_env::time_limit::TimeLimit;

unsafe extern "C" fn v1_0_vtable(i: u32) -> *const RwgEnvVtable {
    // SAFETY: the test plugin's entry returns its static entry struct, whose
    // `env_vtable` returns a valid table for every index the host asks for.
    let e = unsafe { &*entry_v1::<TestPlugin>(ABI_MAJOR, ABI_MINOR) };
    // SAFETY: as above.
    let mut vt = unsafe { *(e.env_vtable.unwrap())(i) };
    // A 1.0 table: whatever lies past last_error is not the plugin's.
    vt.struct_size = ENV_VTABLE_SIZE_V1_0;
    assert!(vt.step_many.is_some());
    Box::leak(Box::new(vt))
}

#[test]
fn batched_calls_are_read_only_within_the_vtable_struct_size() {
    let (_, d) = valid_entry();
    let p = load_edited(|_| {}, vec![d]).unwrap();
    assert!(p.envs()[0].has_batched_calls());
    let p = load_edited(|e| e.env_vtable = Some(v1_0_vtable), vec![d]).unwrap();
    assert!(!p.envs()[0].has_batched_calls());
    let mut env = p.envs()[0].make("", None).unwrap();
    let mut obs = [0.0; 2];
    env.reset(3, &mut obs).unwrap();
    env.step(Action::Discrete(2), &mut obs).unwrap();
}

/// Three Walker instances and the raw `step_many`.
struct Lanes {
    vt: &'static RwgEnvVtable,
    envs: Vec<*mut RwgEnv>,
}

impl Lanes {
    fn new() -> Lanes {
        let e = unsafe { &*entry_v1::<TestPlugin>(ABI_MAJOR, ABI_MINOR) };
        let vt = unsafe { &*(e.env_vtable.unwrap())(0) };
        let envs = (0..3)
            .map(|_| {
                let mut env = std::ptr::null_mut();
                let st = unsafe {
                    (vt.create.unwrap())(0, c"".as_ptr(), &mut env, std::ptr::null_mut(), 0)
                };
                assert_eq!(st, RWG_OK);
                env
            })
            .collect();
        Lanes { vt, envs }
    }

    fn reset(&self, obs: &mut [f64]) -> Status {
        let mut failed = usize::MAX;
        unsafe {
            (self.vt.reset_many.unwrap())(
                self.envs.as_ptr(),
                3,
                std::ptr::null(),
                [1, 2, 3].as_ptr(),
                obs.as_mut_ptr(),
                2,
                &mut failed,
            )
        }
    }

    /// (status, failed, rewards) of a step with `mask` (None: NULL) and
    /// `actions`; `obs` NULL if `null_obs`.
    fn step(
        &self,
        mask: Option<&[u8]>,
        actions: &[f64],
        null_obs: bool,
    ) -> (Status, usize, [f64; 3]) {
        let mut obs = [0.0; 6];
        let mut rewards = [f64::NAN; 3];
        let (mut te, mut tr) = ([0u8; 3], [0u8; 3]);
        let mut failed = usize::MAX;
        let st = unsafe {
            (self.vt.step_many.unwrap())(
                self.envs.as_ptr(),
                3,
                mask.map_or(std::ptr::null(), |m| m.as_ptr()),
                actions.as_ptr(),
                1,
                if null_obs {
                    std::ptr::null_mut()
                } else {
                    obs.as_mut_ptr()
                },
                2,
                rewards.as_mut_ptr(),
                te.as_mut_ptr(),
                tr.as_mut_ptr(),
                &mut failed,
            )
        };
        (st, failed, rewards)
    }
}

impl Drop for Lanes {
    fn drop(&mut self) {
        for &e in &self.envs {
            unsafe { (self.vt.destroy.unwrap())(e) };
        }
    }
}

#[test]
fn the_shim_refuses_malformed_batches_and_stops_at_the_failing_lane() {
    let l = Lanes::new();
    let mut obs = [0.0; 6];
    assert_eq!(l.reset(&mut obs), RWG_OK);
    assert_eq!(obs, [-2.0, 0.0, -1.0, 0.0, 0.0, 0.0]);
    // Refused as a whole: a NULL buffer, a mask value other than 0 or 1.
    let (st, failed, r) = l.step(None, &[1.0; 3], true);
    assert_eq!((st, failed), (RWG_ERR_INVALID_ARGUMENT, 3));
    assert!(r.iter().all(|x| x.is_nan()));
    let (st, failed, _) = l.step(Some(&[1, 2, 1]), &[1.0; 3], false);
    assert_eq!((st, failed), (RWG_ERR_INVALID_ARGUMENT, 3));
    // Masked-out lanes are not touched.
    let (st, _, r) = l.step(Some(&[0, 1, 0]), &[1.0; 3], false);
    assert_eq!(st, RWG_OK);
    assert!(r[0].is_nan() && r[1] == -1.0 && r[2].is_nan(), "{r:?}");
    // Lane 1's action is invalid: lane 0 is stepped, lane 2 is not.
    let (st, failed, r) = l.step(None, &[2.0, 7.0, 2.0], false);
    assert_eq!((st, failed), (RWG_ERR_INVALID_ARGUMENT, 1));
    assert!(r[0] == -1.0 && r[1].is_nan() && r[2].is_nan(), "{r:?}");
    let msg = unsafe { std::ffi::CStr::from_ptr((l.vt.last_error.unwrap())(l.envs[1])) };
    assert!(msg.to_str().unwrap().contains("7"), "{msg:?}");
    // Lane 1 holds that message (the checked path's business): the next
    // call steps it and the lanes after it all the same, and clears it.
    let (st, _, r) = l.step(None, &[2.0; 3], false);
    assert_eq!(st, RWG_OK);
    assert!(r.iter().all(|x| x.is_finite()), "{r:?}");
    let msg = unsafe { std::ffi::CStr::from_ptr((l.vt.last_error.unwrap())(l.envs[1])) };
    assert_eq!(msg.to_str().unwrap(), "");
}

#[test]
fn a_batch_reports_a_nan_reward_as_the_single_path_does() {
    let p = test_plugin();
    let ty = p.env("test/NanReward-v0").unwrap();
    let mut single = ty.make("", None).unwrap();
    let mut obs = [0.0; 2];
    single.reset(1, &mut obs).unwrap();
    single.step(Action::Discrete(1), &mut obs).unwrap();
    // Its second step's reward is NaN.
    let want = single.step(Action::Discrete(1), &mut obs).unwrap_err();
    let mut batch = ty.make_batch("", 2, None).unwrap();
    let mut bobs = [0.0; 4];
    batch.reset_many(&[1, 1], &[1, 1], &mut bobs, |f| panic!("{f:?}"));
    let (mut r, mut te, mut tr) = ([0.0; 2], [0u8; 2], [0u8; 2]);
    let mut got = vec![];
    for _ in 0..2 {
        batch.step_many(
            &[1, 1],
            &[1.0, 1.0],
            &mut bobs,
            &mut r,
            &mut te,
            &mut tr,
            |f| got.push((f.lane, f.error)),
        );
    }
    assert_eq!(got, [(0, want.clone()), (1, want)]);
}

#[test]
fn finite_outputs_whose_sum_overflows_pass_the_lane_by_lane_check() {
    // speed=1e308: after a step every lane's position and reward are about
    // ±1e308, finite, but their sums over the buffers are not.
    let p = test_plugin();
    let ty = p.env("test/Walker-v0").unwrap();
    let mut single = ty.make("speed=1e308", None).unwrap();
    let mut sobs = [0.0; 2];
    single.reset(5, &mut sobs).unwrap();
    let want = single.step(Action::Discrete(2), &mut sobs).unwrap();
    let mut batch = ty.make_batch("speed=1e308", 2, None).unwrap();
    let mut obs = [0.0; 4];
    batch.reset_many(&[1, 1], &[5, 5], &mut obs, |f| panic!("{f:?}"));
    let (mut r, mut te, mut tr) = ([0.0; 2], [0u8; 2], [0u8; 2]);
    batch.step_many(
        &[1, 1],
        &[2.0, 2.0],
        &mut obs,
        &mut r,
        &mut te,
        &mut tr,
        |f| panic!("{f:?}"),
    );
    for i in 0..2 {
        assert_eq!(obs[2 * i..2 * i + 2], sobs);
        assert_eq!(
            (r[i], te[i], tr[i]),
            (want.reward, u8::from(want.terminated), 0)
        );
    }
}

#[test]
fn the_time_limit_counts_each_lane_s_own_steps_under_any_mask() {
    // Three lanes stepped under changing masks and reset when their episode
    // ends, each beside a single-call instance given the same calls: the
    // same flags (the limit is 4 steps) and observations at every step.
    let p = test_plugin();
    let ty = p.env("test/Walker-v0").unwrap();
    let mut singles: Vec<_> = (0..3).map(|_| ty.make("", Some(4)).unwrap()).collect();
    let mut batch = ty.make_batch("", 3, Some(4)).unwrap();
    let (mut obs, mut sobs) = ([0.0; 6], [0.0; 6]);
    let mut seed = 0u64;
    let mut reset = |lanes: &[usize],
                     batch: &mut PluginBatch,
                     obs: &mut [f64; 6],
                     sobs: &mut [f64; 6],
                     singles: &mut Vec<TimeLimit<PluginEnv>>| {
        let mut mask = [0u8; 3];
        let mut seeds = [0u64; 3];
        for &i in lanes {
            seed += 1;
            mask[i] = 1;
            seeds[i] = seed;
            singles[i].reset(seed, &mut sobs[2 * i..2 * i + 2]).unwrap();
        }
        batch.reset_many(&mask, &seeds, obs, |f| panic!("{f:?}"));
    };
    reset(&[0, 1, 2], &mut batch, &mut obs, &mut sobs, &mut singles);
    let (mut truncations, mut steps) = (0, 0);
    for k in 0..60u32 {
        // Every lane most of the time, some lanes now and then.
        let mask: [u8; 3] = match k % 7 {
            3 => [1, 0, 1],
            5 => [0, 1, 0],
            6 => [0, 0, 0],
            _ => [1, 1, 1],
        };
        let actions = [1.0, f64::from(k % 3), 1.0];
        let (mut r, mut te, mut tr) = ([0.0; 3], [0u8; 3], [0u8; 3]);
        batch.step_many(&mask, &actions, &mut obs, &mut r, &mut te, &mut tr, |f| {
            panic!("{f:?}")
        });
        let mut ended = vec![];
        for i in (0..3).filter(|&i| mask[i] == 1) {
            let s = singles[i]
                .step(
                    Action::Discrete(actions[i] as i64),
                    &mut sobs[2 * i..2 * i + 2],
                )
                .unwrap();
            assert_eq!(
                (te[i], tr[i]),
                (u8::from(s.terminated), u8::from(s.truncated)),
                "call {k} lane {i}"
            );
            assert_eq!(r[i], s.reward);
            steps += 1;
            if s.terminated || s.truncated {
                truncations += usize::from(s.truncated);
                ended.push(i);
            }
        }
        assert_eq!(obs, sobs, "call {k}");
        if !ended.is_empty() {
            reset(&ended, &mut batch, &mut obs, &mut sobs, &mut singles);
        }
    }
    assert!(truncations >= 10 && steps > 100, "{truncations} {steps}");
}
