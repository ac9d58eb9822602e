//! The statements of `rwg_plugin.h`'s section "What the reference
//! implementation does where the rules above leave a choice", one test each.

use super::*;

/// The Walker's raw C functions (index 0 of the test plugin).
struct Raw {
    vt: &'static RwgEnvVtable,
    env: *mut RwgEnv,
}

impl Raw {
    fn new() -> Raw {
        let e = unsafe { &*entry_v1::<TestPlugin>(ABI_MAJOR, ABI_MINOR) };
        let vt = unsafe { &*(e.env_vtable.unwrap())(0) };
        let mut env = std::ptr::null_mut();
        let st =
            unsafe { (vt.create.unwrap())(0, c"".as_ptr(), &mut env, std::ptr::null_mut(), 0) };
        assert_eq!(st, RWG_OK);
        Raw { vt, env }
    }
    fn reset(&mut self, has_seed: u8, seed: u64, obs: &mut [f64]) -> Status {
        unsafe { (self.vt.reset.unwrap())(self.env, has_seed, seed, obs.as_mut_ptr(), obs.len()) }
    }
    fn step(&mut self, a: f64, obs: &mut [f64]) -> (Status, RwgStepOut) {
        let mut out = RwgStepOut {
            reward: 0.0,
            terminated: 0,
            truncated: 0,
            reserved: [0; 6],
        };
        let st = unsafe {
            (self.vt.step.unwrap())(self.env, &a, 1, obs.as_mut_ptr(), obs.len(), &mut out)
        };
        (st, out)
    }
}

impl Drop for Raw {
    fn drop(&mut self) {
        unsafe { (self.vt.destroy.unwrap())(self.env) }
    }
}

#[test]
fn the_first_applicable_error_wins_in_the_documented_order() {
    let mut w = Raw::new();
    let (mut obs, mut short) = ([0.0; 2], [0.0; 1]);
    // Before the first reset: an invalid action beats reset-needed, and a
    // wrong obs_len beats it too.
    assert_eq!(w.step(0.5, &mut obs).0, RWG_ERR_INVALID_ARGUMENT);
    assert_eq!(w.step(1.0, &mut short).0, RWG_ERR_BUFFER_SIZE);
    assert_eq!(w.step(1.0, &mut obs).0, RWG_ERR_RESET_NEEDED);
    // An invalid action beats a wrong obs_len.
    assert_eq!(w.step(0.5, &mut short).0, RWG_ERR_INVALID_ARGUMENT);
    // In reset, has_seed is checked before obs_len.
    assert_eq!(w.reset(0, 1, &mut short), RWG_ERR_UNSUPPORTED);
    assert_eq!(w.reset(2, 1, &mut short), RWG_ERR_INVALID_ARGUMENT);
    assert_eq!(w.reset(1, 1, &mut short), RWG_ERR_BUFFER_SIZE);
}

#[test]
fn a_refused_call_leaves_the_instance_as_it_was() {
    let (mut a, mut b) = (Raw::new(), Raw::new());
    let mut obs_a = [0.0; 2];
    let mut obs_b = [0.0; 2];
    assert_eq!(a.reset(1, 3, &mut obs_a), RWG_OK);
    assert_eq!(b.reset(1, 3, &mut obs_b), RWG_OK);
    assert_eq!(a.step(2.0, &mut obs_a).0, RWG_OK);
    // Refused calls on `a` only: a bad action, a bad buffer, a bad has_seed.
    assert_eq!(a.step(7.0, &mut obs_a).0, RWG_ERR_INVALID_ARGUMENT);
    assert_eq!(a.step(2.0, &mut [0.0; 3]).0, RWG_ERR_BUFFER_SIZE);
    assert_eq!(a.reset(5, 9, &mut obs_a), RWG_ERR_INVALID_ARGUMENT);
    assert_eq!(a.reset(0, 9, &mut obs_a), RWG_ERR_UNSUPPORTED);
    assert_eq!(b.step(2.0, &mut obs_b).0, RWG_OK);
    for act in [0.0, 2.0, 2.0] {
        let (sa, oa) = a.step(act, &mut obs_a);
        let (sb, ob) = b.step(act, &mut obs_b);
        assert_eq!((sa, sb), (RWG_OK, RWG_OK));
        assert_eq!(oa.reward.to_bits(), ob.reward.to_bits());
        assert_eq!(obs_a, obs_b);
    }
}

#[test]
fn the_shim_passes_a_step_after_termination_to_the_env() {
    let mut w = Raw::new();
    let mut obs = [0.0; 2];
    assert_eq!(w.reset(1, 6, &mut obs), RWG_OK); // pos = 6 % 7 - 3 = 3
    let mut terminated = false;
    for _ in 0..3 {
        let (st, out) = w.step(2.0, &mut obs);
        assert_eq!(st, RWG_OK);
        terminated = out.terminated == 1;
    }
    assert!(terminated, "pos 6 > 5 terminates");
    let (st, out) = w.step(2.0, &mut obs);
    assert_eq!((st, out.terminated), (RWG_OK, 1));
    assert_eq!(obs[0], 7.0);
}

#[test]
fn observations_outside_a_finite_box_are_used_and_check_warns() {
    let p = test_plugin();
    let ty = p.env("test/Walker-v0").unwrap();
    // Walker's observation space is [-100, 100] x [0, 1e9].
    let mut env = ty.create("speed=200").unwrap();
    let mut obs = [0.0; 2];
    env.reset(3, &mut obs).unwrap();
    env.step(Action::Discrete(2), &mut obs).unwrap();
    assert_eq!(obs[0], 200.0, "outside the box, used as it is");
    let rollout = check_plugin_env(ty, "speed=200")
        .into_iter()
        .find(|r| r.name == "rollout")
        .unwrap();
    assert_eq!(rollout.status, CheckStatus::Warned, "{}", rollout.message);
    assert!(rollout.message.contains("outside the observation space"));
}

/// Writes nothing into `obs` on step.
struct Lazy(Walker);

impl Environment for Lazy {
    fn spec(&self) -> &EnvSpec {
        &self.0.spec
    }
    fn reset(&mut self, seed: u64, obs: &mut [f64]) -> Result<(), EnvError> {
        self.0.reset(seed, obs)
    }
    fn step(&mut self, action: Action<'_>, _obs: &mut [f64]) -> Result<Step, EnvError> {
        let mut scratch = [0.0; 2];
        self.0.step(action, &mut scratch)
    }
}

struct LazyPlugin;

impl PluginStatic for LazyPlugin {
    fn cell() -> &'static OnceLock<ExportedPlugin> {
        static CELL: OnceLock<ExportedPlugin> = OnceLock::new();
        &CELL
    }
    fn build() -> PluginBuilder {
        PluginBuilder::new("lazy", "1").env(
            Walker::spec("lazy/Lazy-v0"),
            "leaves obs unwritten",
            |c: &str| Walker::new(c).map(|w| with_id(w, "lazy/Lazy-v0", Lazy)),
        )
    }
}

#[test]
fn an_unwritten_observation_is_a_non_finite_observation_error() {
    let p = unsafe { load_from_entry(Path::new("<lazy>"), entry_of::<LazyPlugin>) }.unwrap();
    let mut env = p.env("lazy/Lazy-v0").unwrap().create("").unwrap();
    let mut obs = [1.0, 2.0];
    env.reset(3, &mut obs).unwrap();
    let e = env.step(Action::Discrete(1), &mut obs).unwrap_err();
    assert!(
        e.to_string()
            .contains("step returned a non-finite observation: obs[0] = NaN"),
        "{e}"
    );
}

#[test]
fn the_host_passes_has_seed_1_and_the_shim_refuses_other_values() {
    let p = test_plugin();
    let mut env = p.env("test/Walker-v0").unwrap().create("").unwrap();
    let mut obs = [0.0; 2];
    let e = env.reset_raw(2, 0, &mut obs).unwrap_err().to_string();
    assert!(
        e.contains("RWG_ERR_INVALID_ARGUMENT") && e.contains("has_seed is 2"),
        "{e}"
    );
    let e = env.reset_raw(0, 0, &mut obs).unwrap_err();
    assert!(matches!(e, EnvError::Unsupported(_)), "{e}");
    env.reset(4, &mut obs).unwrap(); // Environment::reset: has_seed = 1
    let unseeded = check_plugin_env(p.env("test/Walker-v0").unwrap(), "")
        .into_iter()
        .find(|r| r.name == "unseeded reset")
        .unwrap();
    assert_eq!(unseeded.status, CheckStatus::Passed, "{}", unseeded.message);
}

unsafe extern "C" fn bigger_vtable(i: u32) -> *const RwgEnvVtable {
    // SAFETY: the test plugin's entry returns its static entry struct, whose
    // `env_vtable` returns a valid table for every index the host asks for.
    let e = unsafe { &*entry_v1::<TestPlugin>(ABI_MAJOR, ABI_MINOR) };
    // SAFETY: as above.
    let mut vt = unsafe { *(e.env_vtable.unwrap())(i) };
    vt.struct_size += 64;
    Box::leak(Box::new(vt))
}

#[test]
fn structs_from_a_newer_header_are_read_up_to_what_the_host_knows() {
    let (e, d) = valid_entry();
    let bigger_desc = RwgEnvDesc {
        struct_size: ENV_DESC_SIZE_V1_0 + 64,
        ..d
    };
    let p = load_edited(
        |e| {
            e.struct_size += 64;
            e.abi_minor = 3;
            e.env_vtable = Some(bigger_vtable);
        },
        vec![bigger_desc],
    )
    .unwrap();
    assert_eq!(p.envs()[0].id(), "test/Walker-v0");
    let mut env = p.envs()[0].create("").unwrap();
    let mut obs = [0.0; 2];
    env.reset(1, &mut obs).unwrap();
    env.step(Action::Discrete(2), &mut obs).unwrap();
    // Smaller than 1.0's: refused, naming the struct and both sizes.
    let r = env_reason(load_desc(|d| d.struct_size = 8));
    assert!(
        r.contains(&format!(
            "rwg_env_desc_t is too small: struct_size is 8, ABI 1.0 needs at least {ENV_DESC_SIZE_V1_0}"
        )),
        "{r}"
    );
    // The shim's side: a bigger rwg_host_t is fine, a smaller one is refused.
    let init = e.init.unwrap();
    let host = |size| RwgHost {
        struct_size: size,
        abi_major: ABI_MAJOR,
        abi_minor: 9,
        reserved: 0,
        name: c"rwg".as_ptr(),
        version: c"9".as_ptr(),
    };
    let mut buf = [0 as c_char; 128];
    assert_eq!(
        unsafe { init(&host(HOST_SIZE_V1_0 + 32), buf.as_mut_ptr(), buf.len()) },
        RWG_OK
    );
    assert_eq!(
        unsafe { init(&host(8), buf.as_mut_ptr(), buf.len()) },
        RWG_ERR_INVALID_ARGUMENT
    );
    let msg = unsafe { std::ffi::CStr::from_ptr(buf.as_ptr()) };
    assert_eq!(msg.to_str().unwrap(), "init: incompatible host table");
}

#[test]
fn no_time_limit_is_a_check_warning_that_names_what_run_needs() {
    let p = test_plugin();
    // Glider has max_episode_steps 0 (none).
    let ty = p.env("test/Glider-v0").unwrap();
    assert_eq!(ty.spec().max_episode_steps, None);
    let r = check_plugin_env(ty, "")
        .into_iter()
        .find(|r| r.name == "truncation")
        .unwrap();
    assert_eq!(r.status, CheckStatus::Warned);
    assert!(
        r.message.contains("`rwg run` needs max_episode_steps"),
        "{}",
        r.message
    );
}
