//! The reference plugin's vector env through the raw C ABI (ABI 1.2): what
//! the header promises where the host never goes — calls refused as a
//! whole, a lane's own failure beside lanes that step, the statuses and
//! messages of each lane, a partial last chunk (20 lanes: 16 + 4).

use std::ffi::{c_char, CStr};
use std::sync::OnceLock;

use rwg_env::plugin::abi::*;
use rwg_env::plugin::export::{entry_v1, ExportedPlugin, PluginBuilder, PluginStatic};

struct Reference;

impl PluginStatic for Reference {
    fn cell() -> &'static OnceLock<ExportedPlugin> {
        static CELL: OnceLock<ExportedPlugin> = OnceLock::new();
        &CELL
    }
    fn build() -> PluginBuilder {
        rwg_plugin_classic_control::plugin()
    }
}

const N: usize = 20;
const D: usize = 4;

/// CartPole-v0's table (index 0) and a vector env of [`N`] lanes.
fn cartpole() -> (&'static RwgEnvVtable, *mut RwgVecEnv) {
    let e = unsafe { &*entry_v1::<Reference>(ABI_MAJOR, ABI_MINOR) };
    let desc = unsafe { &*(e.env_desc.unwrap())(0) };
    assert_eq!(
        unsafe { CStr::from_ptr(desc.id) }.to_str().unwrap(),
        "classic_control/CartPole-v0"
    );
    let vt = unsafe { &*(e.env_vtable.unwrap())(0) };
    assert_eq!(vt.struct_size, ENV_VTABLE_SIZE_V1_2);
    let mut vec = std::ptr::null_mut();
    let st =
        unsafe { (vt.vec_create.unwrap())(0, c"".as_ptr(), N, &mut vec, std::ptr::null_mut(), 0) };
    assert_eq!(st, RWG_OK);
    (vt, vec)
}

fn message(vt: &RwgEnvVtable, vec: *const RwgVecEnv, lane: usize) -> String {
    let p: *const c_char = unsafe { (vt.vec_last_error.unwrap())(vec, lane) };
    unsafe { CStr::from_ptr(p) }.to_string_lossy().into_owned()
}

struct Buffers {
    actions: Vec<f64>,
    obs: Vec<f64>,
    rewards: Vec<f64>,
    terminated: Vec<u8>,
    truncated: Vec<u8>,
    status: Vec<Status>,
}

impl Buffers {
    fn new() -> Buffers {
        Buffers {
            actions: vec![1.0; N],
            obs: vec![0.0; N * D],
            rewards: vec![0.0; N],
            terminated: vec![0; N],
            truncated: vec![0; N],
            status: vec![-1; N],
        }
    }

    fn step(
        &mut self,
        vt: &RwgEnvVtable,
        vec: *mut RwgVecEnv,
        mask: *const u8,
        obs_len: usize,
    ) -> Status {
        unsafe {
            (vt.vec_step.unwrap())(
                vec,
                mask,
                self.actions.as_ptr(),
                1,
                self.obs.as_mut_ptr(),
                obs_len,
                self.rewards.as_mut_ptr(),
                self.terminated.as_mut_ptr(),
                self.truncated.as_mut_ptr(),
                self.status.as_mut_ptr(),
            )
        }
    }

    fn reset(&mut self, vt: &RwgEnvVtable, vec: *mut RwgVecEnv, mask: *const u8) -> Status {
        let seeds: Vec<u64> = (0..N as u64).collect();
        unsafe {
            (vt.vec_reset.unwrap())(
                vec,
                mask,
                seeds.as_ptr(),
                self.obs.as_mut_ptr(),
                D,
                self.status.as_mut_ptr(),
            )
        }
    }
}

#[test]
fn calls_refused_as_a_whole_give_every_lane_their_status_and_touch_nothing() {
    let (vt, vec) = cartpole();
    let mut b = Buffers::new();
    assert_eq!(b.reset(vt, vec, std::ptr::null()), RWG_OK);
    let before = b.obs.clone();
    // A mask value other than 0 or 1.
    let mut mask = [1u8; N];
    mask[17] = 2;
    assert_eq!(b.step(vt, vec, mask.as_ptr(), D), RWG_ERR_INVALID_ARGUMENT);
    assert!(b.status.iter().all(|&s| s == RWG_ERR_INVALID_ARGUMENT));
    assert!(
        message(vt, vec, N).contains("mask"),
        "{}",
        message(vt, vec, N)
    );
    // A wrong observation length.
    assert_eq!(b.step(vt, vec, std::ptr::null(), 3), RWG_ERR_BUFFER_SIZE);
    assert!(b.status.iter().all(|&s| s == RWG_ERR_BUFFER_SIZE));
    assert!(message(vt, vec, 0).contains("obs_len is 3"));
    // A NULL buffer.
    let st = unsafe {
        (vt.vec_step.unwrap())(
            vec,
            std::ptr::null(),
            b.actions.as_ptr(),
            1,
            std::ptr::null_mut(),
            D,
            b.rewards.as_mut_ptr(),
            b.terminated.as_mut_ptr(),
            b.truncated.as_mut_ptr(),
            b.status.as_mut_ptr(),
        )
    };
    assert_eq!(st, RWG_ERR_INVALID_ARGUMENT);
    assert_eq!(b.obs, before, "a refused call stepped a lane");
    // The vector env still works, and the messages are gone.
    assert_eq!(b.step(vt, vec, std::ptr::null(), D), RWG_OK);
    assert_eq!(message(vt, vec, 0), "");
    assert_eq!(message(vt, vec, N), "");
    unsafe { (vt.vec_destroy.unwrap())(vec) };
}

#[test]
fn a_failing_lane_fails_alone_with_its_status_and_message() {
    let (vt, vec) = cartpole();
    let mut b = Buffers::new();
    // Lanes 3 and 18 are not reset: stepping them is RWG_ERR_RESET_NEEDED.
    let mut mask = [1u8; N];
    mask[3] = 0;
    mask[18] = 0;
    assert_eq!(b.reset(vt, vec, mask.as_ptr()), RWG_OK);
    b.actions[17] = 0.5; // not an integral action, in the partial chunk
    b.rewards[5] = 1234.5; // a lane left out of the step keeps its slot
    let mut step_mask = [1u8; N];
    step_mask[5] = 0;
    let st = b.step(vt, vec, step_mask.as_ptr(), D);
    assert_eq!(st, RWG_ERR_RESET_NEEDED, "the lowest failing lane's status");
    for i in 0..N {
        let want = match i {
            3 | 18 => RWG_ERR_RESET_NEEDED,
            17 => RWG_ERR_INVALID_ARGUMENT,
            _ => RWG_OK,
        };
        assert_eq!(b.status[i], want, "lane {i}");
        assert_eq!(message(vt, vec, i).is_empty(), want == RWG_OK, "lane {i}");
        if want == RWG_OK && i != 5 {
            assert_eq!((b.rewards[i], b.terminated[i], b.truncated[i]), (1.0, 0, 0));
        }
    }
    assert_eq!(b.rewards[5], 1234.5);
    assert!(
        message(vt, vec, 17).contains("0.5"),
        "{}",
        message(vt, vec, 17)
    );
    unsafe { (vt.vec_destroy.unwrap())(vec) };
}

#[test]
fn vec_create_refuses_no_lanes_and_a_bad_config() {
    let e = unsafe { &*entry_v1::<Reference>(ABI_MAJOR, ABI_MINOR) };
    let vt = unsafe { &*(e.env_vtable.unwrap())(0) };
    let mut buf = [0 as c_char; 200];
    let mut vec = std::ptr::null_mut();
    let create = |config: &CStr, lanes: usize, vec: &mut *mut RwgVecEnv, buf: &mut [c_char]| unsafe {
        (vt.vec_create.unwrap())(0, config.as_ptr(), lanes, vec, buf.as_mut_ptr(), buf.len())
    };
    assert_eq!(create(c"", 0, &mut vec, &mut buf), RWG_ERR_INVALID_ARGUMENT);
    let text = |buf: &[c_char]| {
        unsafe { CStr::from_ptr(buf.as_ptr()) }
            .to_string_lossy()
            .into_owned()
    };
    assert!(text(&buf).contains("at least one lane"), "{}", text(&buf));
    assert_eq!(
        create(c"speed=9", 4, &mut vec, &mut buf),
        RWG_ERR_INVALID_ARGUMENT
    );
    assert!(
        text(&buf).contains("unknown config item 'speed=9'"),
        "{}",
        text(&buf)
    );
    assert!(vec.is_null());
    // NULL-safe destroy and last_error.
    unsafe { (vt.vec_destroy.unwrap())(std::ptr::null_mut()) };
    assert_eq!(message(vt, std::ptr::null(), 0), "");
}
