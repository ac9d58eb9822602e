//! In-process tests of the export shims, the loader's handshake validation
//! and the checker. Plugins are exported with `entry_v1::<P>` and loaded with
//! `load_from_entry`, so no library is built or opened here (the integration
//! tests in `plugins/testing` do that with real cdylibs).

use std::cell::Cell;
use std::ffi::c_char;
use std::path::Path;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::OnceLock;

use crate::check::{check_env, check_plugin_env, CheckStatus};
use crate::loader::{load_from_entry, Plugin, PluginLoadErrorKind};
use rwg_env::env::{discrete_action, Action, EnvError, EnvSpec, Environment, Step};
use rwg_env::plugin::abi::*;
use rwg_env::plugin::export::{entry_v1, ExportedPlugin, PluginBuilder, PluginStatic};
use rwg_env::space::{BoxSpace, Space};

/// A walk on a line: discrete actions 0/1/2 move by -1/0/+1 (times `speed`).
#[derive(Clone)]
struct Walker {
    spec: EnvSpec,
    pos: f64,
    t: f64,
    speed: f64,
    started: bool,
}

impl Walker {
    fn spec(id: &str) -> EnvSpec {
        EnvSpec {
            id: id.into(),
            observation_space: Space::Box(BoxSpace::new(vec![-100.0, 0.0], vec![100.0, 1e9])),
            action_space: Space::Discrete { n: 3 },
            max_episode_steps: Some(10),
            reward_threshold: Some(-1.5),
        }
    }

    fn new(config: &str) -> Result<Walker, String> {
        let speed = match config {
            "" => 1.0,
            c => c
                .strip_prefix("speed=")
                .and_then(|v| v.parse().ok())
                .ok_or_else(|| format!("unknown config '{c}' (expected speed=<number>)"))?,
        };
        Ok(Walker {
            spec: Walker::spec("test/Walker-v0"),
            pos: 0.0,
            t: 0.0,
            speed,
            started: false,
        })
    }
}

impl Environment for Walker {
    fn spec(&self) -> &EnvSpec {
        &self.spec
    }
    fn reset(&mut self, seed: u64, obs: &mut [f64]) -> Result<(), EnvError> {
        self.pos = (seed % 7) as f64 - 3.0;
        self.t = 0.0;
        self.started = true;
        obs.copy_from_slice(&[self.pos, self.t]);
        Ok(())
    }
    fn step(&mut self, action: Action<'_>, obs: &mut [f64]) -> Result<Step, EnvError> {
        if !self.started {
            return Err(EnvError::ResetNeeded);
        }
        let a = discrete_action(action, 3)?;
        self.pos += (a as f64 - 1.0) * self.speed;
        self.t += 1.0;
        obs.copy_from_slice(&[self.pos, self.t]);
        Ok(Step {
            reward: -self.pos.abs(),
            terminated: self.pos.abs() > 5.0,
            truncated: false,
        })
    }
}

/// Panics on its third step.
struct Panicky(Walker);

impl Environment for Panicky {
    fn spec(&self) -> &EnvSpec {
        &self.0.spec
    }
    fn reset(&mut self, seed: u64, obs: &mut [f64]) -> Result<(), EnvError> {
        self.0.reset(seed, obs)
    }
    fn step(&mut self, action: Action<'_>, obs: &mut [f64]) -> Result<Step, EnvError> {
        if self.0.t >= 2.0 {
            panic!("Panicky exploded on purpose");
        }
        self.0.step(action, obs)
    }
}

/// Returns a NaN reward on its second step.
struct NanReward(Walker);

impl Environment for NanReward {
    fn spec(&self) -> &EnvSpec {
        &self.0.spec
    }
    fn reset(&mut self, seed: u64, obs: &mut [f64]) -> Result<(), EnvError> {
        self.0.reset(seed, obs)
    }
    fn step(&mut self, action: Action<'_>, obs: &mut [f64]) -> Result<Step, EnvError> {
        let mut s = self.0.step(action, obs)?;
        if self.0.t >= 2.0 {
            s.reward = f64::NAN;
        }
        Ok(s)
    }
}

/// Adds a process-global counter to its observation: hidden shared state.
struct Leaky(Walker);

static LEAK: AtomicU64 = AtomicU64::new(0);

impl Environment for Leaky {
    fn spec(&self) -> &EnvSpec {
        &self.0.spec
    }
    fn reset(&mut self, seed: u64, obs: &mut [f64]) -> Result<(), EnvError> {
        self.0.reset(seed, obs)
    }
    fn step(&mut self, action: Action<'_>, obs: &mut [f64]) -> Result<Step, EnvError> {
        let s = self.0.step(action, obs)?;
        obs[1] += (LEAK.fetch_add(1, Ordering::Relaxed) % 3) as f64;
        Ok(s)
    }
}

/// A continuous walker: the action is added to the position, clipped to ±1.
struct Glider(Walker);

impl Environment for Glider {
    fn spec(&self) -> &EnvSpec {
        &self.0.spec
    }
    fn reset(&mut self, seed: u64, obs: &mut [f64]) -> Result<(), EnvError> {
        self.0.reset(seed, obs)
    }
    fn step(&mut self, action: Action<'_>, obs: &mut [f64]) -> Result<Step, EnvError> {
        let a = rwg_env::env::continuous_action(action, 1)?;
        self.0.step(Action::Discrete(1), obs)?;
        self.0.pos += a[0].clamp(-1.0, 1.0);
        obs[0] = self.0.pos;
        Ok(Step {
            reward: -self.0.pos.abs(),
            terminated: false,
            truncated: false,
        })
    }
}

fn with_id<E: Environment>(mut w: Walker, id: &str, f: impl FnOnce(Walker) -> E) -> E {
    w.spec.id = id.into();
    f(w)
}

struct TestPlugin;

impl PluginStatic for TestPlugin {
    fn cell() -> &'static OnceLock<ExportedPlugin> {
        static CELL: OnceLock<ExportedPlugin> = OnceLock::new();
        &CELL
    }
    fn build() -> PluginBuilder {
        let glider_spec = EnvSpec {
            action_space: Space::Box(BoxSpace::symmetric(&[1.0])),
            reward_threshold: None,
            max_episode_steps: None,
            ..Walker::spec("test/Glider-v0")
        };
        PluginBuilder::new("test", "1.2.3")
            .env(
                Walker::spec("test/Walker-v0"),
                "walk on a line",
                Walker::new,
            )
            .env(Walker::spec("test/Panicky-v0"), "panics", |c: &str| {
                Walker::new(c).map(|w| with_id(w, "test/Panicky-v0", Panicky))
            })
            .env(
                Walker::spec("test/NanReward-v0"),
                "NaN reward",
                |c: &str| Walker::new(c).map(|w| with_id(w, "test/NanReward-v0", NanReward)),
            )
            .env(Walker::spec("test/Leaky-v0"), "global state", |c: &str| {
                Walker::new(c).map(|w| with_id(w, "test/Leaky-v0", Leaky))
            })
            .env(glider_spec, "continuous", |c: &str| {
                Walker::new(c).map(|w| {
                    let mut g = with_id(w, "test/Glider-v0", Glider);
                    g.0.spec.action_space = Space::Box(BoxSpace::symmetric(&[1.0]));
                    g
                })
            })
    }
}

unsafe extern "C" fn entry_of<P: PluginStatic>(major: u32, minor: u32) -> *const RwgPluginEntry {
    entry_v1::<P>(major, minor)
}

fn test_plugin() -> Plugin {
    unsafe { load_from_entry(Path::new("<test>"), entry_of::<TestPlugin>) }.unwrap()
}

fn walk<E: Environment>(env: &mut E, seed: u64, actions: &[i64]) -> Vec<(Vec<f64>, Step)> {
    let mut obs = vec![0.0; env.spec().obs_dim()];
    env.reset(seed, &mut obs).unwrap();
    let mut out = vec![(
        obs.clone(),
        Step {
            reward: 0.0,
            terminated: false,
            truncated: false,
        },
    )];
    for &a in actions {
        let s = env.step(Action::Discrete(a), &mut obs).unwrap();
        out.push((obs.clone(), s));
    }
    out
}

#[test]
fn exported_plugin_round_trips_spec_and_trajectory() {
    let p = test_plugin();
    assert_eq!(p.id(), "test");
    assert_eq!(p.info().version, "1.2.3");
    assert_eq!(p.info().abi, (ABI_MAJOR, ABI_MINOR));
    let ids: Vec<&str> = p.envs().iter().map(|e| e.id()).collect();
    assert_eq!(
        ids,
        [
            "test/Walker-v0",
            "test/Panicky-v0",
            "test/NanReward-v0",
            "test/Leaky-v0",
            "test/Glider-v0"
        ]
    );
    let ty = p.env("test/Walker-v0").unwrap();
    assert_eq!(ty.spec(), &Walker::spec("test/Walker-v0"));
    assert_eq!(ty.summary(), "walk on a line");
    let glider = p.env("test/Glider-v0").unwrap().spec();
    assert_eq!(glider.reward_threshold, None, "NaN threshold reads as none");
    assert_eq!(glider.max_episode_steps, None, "0 steps reads as no limit");

    let actions = [2, 2, 0, 1, 2, 2, 2, 2, 2, 2, 2, 0];
    let mut direct = rwg_env::TimeLimit::new(Walker::new("").unwrap(), None);
    let mut plugin = ty.make("", None).unwrap();
    let want = walk(&mut direct, 5, &actions);
    let got = walk(&mut plugin, 5, &actions);
    assert_eq!(want, got);
    assert!(got[10].1.truncated, "the host applies the time limit");

    let mut fast = ty.create("speed=2").unwrap();
    assert_eq!(walk(&mut fast, 3, &[2])[1].0, vec![2.0, 1.0]);
}

#[test]
fn bad_config_is_an_error_with_the_plugin_message() {
    let p = test_plugin();
    let e = p
        .env("test/Walker-v0")
        .unwrap()
        .create("speed=fast")
        .unwrap_err();
    let msg = e.to_string();
    assert!(msg.contains("plugin 'test' env 'test/Walker-v0'"), "{msg}");
    assert!(msg.contains("RWG_ERR_INVALID_ARGUMENT"), "{msg}");
    assert!(msg.contains("expected speed=<number>"), "{msg}");
}

#[test]
fn panic_in_step_becomes_an_error_and_poisons_the_instance() {
    let p = test_plugin();
    let mut env = p.env("test/Panicky-v0").unwrap().create("").unwrap();
    let mut obs = [0.0; 2];
    env.reset(1, &mut obs).unwrap();
    env.step(Action::Discrete(1), &mut obs).unwrap();
    env.step(Action::Discrete(1), &mut obs).unwrap();
    let e = env.step(Action::Discrete(1), &mut obs).unwrap_err();
    let msg = e.to_string();
    assert!(msg.contains("RWG_ERR_PANIC"), "{msg}");
    assert!(msg.contains("Panicky exploded on purpose"), "{msg}");
    assert!(msg.contains("test/Panicky-v0"), "{msg}");
    assert!(env.is_poisoned());
    let again = env.reset(1, &mut obs).unwrap_err().to_string();
    assert!(again.contains("poisoned"), "{again}");
    // Other instances are unaffected.
    let mut other = env.try_clone().unwrap();
    other.reset(1, &mut obs).unwrap();
}

#[test]
fn poisoned_instance_is_refused_by_the_shim_itself() {
    // Below the host: call the exported C functions directly.
    let e = unsafe { &*entry_v1::<TestPlugin>(ABI_MAJOR, ABI_MINOR) };
    let vt = unsafe { &*(e.env_vtable.unwrap())(1) };
    let (create, reset, step, last_error, destroy) = (
        vt.create.unwrap(),
        vt.reset.unwrap(),
        vt.step.unwrap(),
        vt.last_error.unwrap(),
        vt.destroy.unwrap(),
    );
    let text = |env| {
        unsafe { std::ffi::CStr::from_ptr(last_error(env)) }
            .to_string_lossy()
            .into_owned()
    };
    unsafe {
        let mut env = std::ptr::null_mut();
        assert_eq!(
            create(1, c"".as_ptr(), &mut env, std::ptr::null_mut(), 0),
            RWG_OK
        );
        let mut obs = [0.0; 2];
        let mut out = RwgStepOut {
            reward: 0.0,
            terminated: 0,
            truncated: 0,
            reserved: [0; 6],
        };
        assert_eq!(reset(env, 1, 3, obs.as_mut_ptr(), 2), RWG_OK);
        assert_eq!(text(env), "");
        assert_eq!(
            step(env, [1.0].as_ptr(), 1, obs.as_mut_ptr(), 2, &mut out),
            RWG_OK
        );
        assert_eq!(
            step(env, [1.0].as_ptr(), 1, obs.as_mut_ptr(), 1, &mut out),
            RWG_ERR_BUFFER_SIZE
        );
        assert!(text(env).contains("obs buffer has length 1"));
        assert_eq!(
            step(env, [1.0].as_ptr(), 1, obs.as_mut_ptr(), 2, &mut out),
            RWG_OK
        );
        assert_eq!(
            step(env, [1.0].as_ptr(), 1, obs.as_mut_ptr(), 2, &mut out),
            RWG_ERR_PANIC
        );
        assert_eq!(text(env), "panic: Panicky exploded on purpose");
        assert_eq!(reset(env, 1, 3, obs.as_mut_ptr(), 2), RWG_ERR_PANIC);
        assert!(
            text(env).contains("poisoned by an earlier panic: Panicky exploded"),
            "{}",
            text(env)
        );
        destroy(env);
        destroy(std::ptr::null_mut());
        let mut buf = [0 as c_char; 64];
        assert_eq!(
            create(99, c"".as_ptr(), &mut env, buf.as_mut_ptr(), 64),
            RWG_ERR_INVALID_ARGUMENT
        );
        assert_eq!(
            std::ffi::CStr::from_ptr(buf.as_ptr()).to_str().unwrap(),
            "create: no environment with index 99"
        );
    }
}

#[test]
fn non_finite_reward_is_an_error_naming_plugin_and_env() {
    let p = test_plugin();
    let mut env = p.env("test/NanReward-v0").unwrap().create("").unwrap();
    let mut obs = [0.0; 2];
    env.reset(1, &mut obs).unwrap();
    env.step(Action::Discrete(1), &mut obs).unwrap();
    let msg = env
        .step(Action::Discrete(1), &mut obs)
        .unwrap_err()
        .to_string();
    assert!(
        msg.contains("plugin 'test' env 'test/NanReward-v0'"),
        "{msg}"
    );
    assert!(msg.contains("non-finite reward"), "{msg}");
}

#[test]
fn invalid_actions_are_refused_by_the_shim() {
    let p = test_plugin();
    let mut env = p.env("test/Walker-v0").unwrap().create("").unwrap();
    let mut obs = [0.0; 2];
    assert_eq!(
        env.step(Action::Discrete(0), &mut obs),
        Err(EnvError::ResetNeeded)
    );
    env.reset(0, &mut obs).unwrap();
    for bad in [&[0.5][..], &[3.0], &[-1.0], &[f64::NAN], &[0.0, 1.0], &[]] {
        match env.step_raw(bad, &mut obs) {
            Err(EnvError::InvalidAction(m)) => {
                assert!(m.contains("RWG_ERR_INVALID_ARGUMENT"), "{m}")
            }
            other => panic!("{bad:?}: {other:?}"),
        }
    }
    assert!(matches!(
        env.step(Action::Continuous(&[1.0]), &mut obs),
        Err(EnvError::InvalidAction(_))
    ));
    env.step(Action::Discrete(2), &mut obs).unwrap();

    let mut g = p.env("test/Glider-v0").unwrap().create("").unwrap();
    g.reset(0, &mut obs).unwrap();
    assert!(g
        .step(Action::Continuous(&[f64::INFINITY]), &mut obs)
        .is_err());
    assert!(
        g.step(Action::Continuous(&[5.0]), &mut obs).is_ok(),
        "clipped"
    );
    assert_eq!(
        g.reset_raw(0, 0, &mut obs),
        Err(EnvError::Unsupported(
            "plugin 'test' env 'test/Glider-v0': reset failed with RWG_ERR_UNSUPPORTED (4): \
             reset without a seed is not supported: pass has_seed = 1"
                .into()
        ))
    );
    let mut short = [0.0; 1];
    assert!(g.reset(0, &mut short).is_err());
}

#[test]
fn instances_work_on_other_threads() {
    let p = test_plugin();
    let ty = p.env("test/Walker-v0").unwrap().clone();
    let mut env = ty.make("", None).unwrap();
    let want = walk(&mut env, 4, &[2, 0, 2]);
    let got = std::thread::spawn(move || walk(&mut env, 4, &[2, 0, 2]))
        .join()
        .unwrap();
    assert_eq!(want, got);
}

// ---- handshake validation with hand-made tables --------------------------

thread_local! {
    static ENTRY: Cell<*const RwgPluginEntry> = const { Cell::new(std::ptr::null()) };
    static DESCS: Cell<&'static [RwgEnvDesc]> = const { Cell::new(&[]) };
}

unsafe extern "C" fn tl_entry(_: u32, _: u32) -> *const RwgPluginEntry {
    ENTRY.with(|e| e.get())
}
unsafe extern "C" fn tl_count() -> u32 {
    DESCS.with(|d| d.get().len() as u32)
}
unsafe extern "C" fn tl_desc(i: u32) -> *const RwgEnvDesc {
    DESCS.with(|d| {
        d.get()
            .get(i as usize)
            .map_or(std::ptr::null(), |d| d as *const _)
    })
}

fn valid_entry() -> (RwgPluginEntry, RwgEnvDesc) {
    let p = unsafe { &*entry_v1::<TestPlugin>(ABI_MAJOR, ABI_MINOR) };
    let d = unsafe { *(p.env_desc.unwrap())(0) };
    (*p, d)
}

/// Loads a copy of the test plugin's entry, edited by `edit_entry`, whose only
/// environments are the given descriptors.
fn load_edited(
    edit_entry: impl FnOnce(&mut RwgPluginEntry),
    descs: Vec<RwgEnvDesc>,
) -> Result<Plugin, PluginLoadErrorKind> {
    let (mut e, _) = valid_entry();
    e.env_count = Some(tl_count);
    e.env_desc = Some(tl_desc);
    edit_entry(&mut e);
    let e: &'static RwgPluginEntry = Box::leak(Box::new(e));
    DESCS.with(|d| d.set(Box::leak(descs.into_boxed_slice())));
    ENTRY.with(|p| p.set(e));
    unsafe { load_from_entry(Path::new("/x/libbad.so"), tl_entry) }.map_err(|e| {
        assert_eq!(e.path, Path::new("/x/libbad.so"));
        assert!(e.to_string().starts_with("plugin /x/libbad.so: "), "{e}");
        e.kind
    })
}

fn load_desc(edit: impl FnOnce(&mut RwgEnvDesc)) -> Result<Plugin, PluginLoadErrorKind> {
    let (_, mut d) = valid_entry();
    edit(&mut d);
    load_edited(|_| {}, vec![d])
}

fn env_reason(r: Result<Plugin, PluginLoadErrorKind>) -> String {
    match r {
        Err(PluginLoadErrorKind::Env { reason, .. }) => reason,
        other => panic!("expected an env error, got {other:?}"),
    }
}

static LOW: [f64; 2] = [1.0, 0.0];
static HIGH: [f64; 2] = [0.0, 1.0];
static NAN2: [f64; 2] = [f64::NAN, 0.0];
static INF2: [f64; 2] = [f64::INFINITY, f64::INFINITY];

#[test]
fn valid_edited_table_loads() {
    let p = load_desc(|_| {}).unwrap();
    assert_eq!(p.envs().len(), 1);
}

#[test]
fn handshake_null_entry_and_wrong_major_and_small_struct() {
    ENTRY.with(|p| p.set(std::ptr::null()));
    let e = unsafe { load_from_entry(Path::new("/x/libnull.so"), tl_entry) }.unwrap_err();
    assert!(
        matches!(e.kind, PluginLoadErrorKind::Declined { host_major: 1, .. }),
        "{e}"
    );
    assert!(e.to_string().contains("returned NULL"), "{e}");

    let e = load_edited(|e| e.abi_major = 2, vec![]).unwrap_err();
    assert_eq!(
        e,
        PluginLoadErrorKind::AbiMajor {
            plugin_major: 2,
            plugin_minor: ABI_MINOR,
            host_major: 1,
            host_minor: ABI_MINOR
        }
    );
    assert!(
        e.to_string()
            .contains(&format!("built for ABI 2.{ABI_MINOR}")),
        "{e}"
    );

    let e = load_edited(|e| e.struct_size = 16, vec![]).unwrap_err();
    assert!(
        matches!(e, PluginLoadErrorKind::StructTooSmall { size: 16, .. }),
        "{e}"
    );

    // A newer minor with a bigger struct is fine.
    let (_, d) = valid_entry();
    assert!(load_edited(|e| e.abi_minor = 7, vec![d]).is_ok());
}

#[test]
fn handshake_tag_names_and_functions() {
    let e = load_edited(|e| e.abi_tag = c"something-else".as_ptr(), vec![]).unwrap_err();
    assert_eq!(
        e,
        PluginLoadErrorKind::AbiTag {
            found: "something-else".into()
        }
    );
    let e = load_edited(|e| e.abi_tag = std::ptr::null(), vec![]).unwrap_err();
    assert!(matches!(e, PluginLoadErrorKind::AbiTag { .. }));
    let e = load_edited(|e| e.plugin_id = c"".as_ptr(), vec![]).unwrap_err();
    assert!(
        matches!(
            e,
            PluginLoadErrorKind::BadString {
                what: "plugin_id",
                ..
            }
        ),
        "{e}"
    );
    let bad_utf8: &'static [u8] = b"caf\xe9\0";
    let e = load_edited(|e| e.plugin_id = bad_utf8.as_ptr().cast::<c_char>(), vec![]).unwrap_err();
    assert!(e.to_string().contains("not valid UTF-8"), "{e}");
    let e = load_edited(|e| e.env_vtable = None, vec![]).unwrap_err();
    assert_eq!(e, PluginLoadErrorKind::Null("env_vtable"));
    let e = load_edited(|_| {}, vec![]).unwrap_err();
    assert_eq!(e, PluginLoadErrorKind::EnvCount(0));
}

unsafe extern "C" fn failing_init(_: *const RwgHost, buf: *mut c_char, len: usize) -> Status {
    // SAFETY: the host passes a buffer valid for `len` bytes (the ABI).
    unsafe { write_c_message(buf, len, "no licence for the simulator") };
    RWG_ERR_INTERNAL
}

#[test]
fn init_failure_carries_the_plugin_message() {
    let e = load_edited(|e| e.init = Some(failing_init), vec![]).unwrap_err();
    assert_eq!(
        e.to_string(),
        "init failed with RWG_ERR_INTERNAL (6): no licence for the simulator"
    );
}

#[test]
fn descriptor_ids_are_validated() {
    assert!(env_reason(load_desc(|d| d.id = c"".as_ptr())).contains("empty"));
    assert!(env_reason(load_desc(|d| d.id = std::ptr::null())).contains("NULL"));
    assert!(env_reason(load_desc(|d| d.id = c"has space-v0".as_ptr())).contains("' '"));
    assert!(env_reason(load_desc(|d| d.id = c"a/b/c-v0".as_ptr())).contains("namespace"));
    let bad_utf8: &'static [u8] = b"x\xff-v0\0";
    assert!(env_reason(load_desc(|d| d.id = bad_utf8.as_ptr().cast())).contains("UTF-8"));
    let (_, d) = valid_entry();
    let e = load_edited(|_| {}, vec![d, d]).unwrap_err();
    assert_eq!(
        e,
        PluginLoadErrorKind::DuplicateId {
            id: "test/Walker-v0".into(),
            first: 0,
            second: 1
        }
    );
}

#[test]
fn descriptor_spaces_and_sizes_are_validated() {
    let r = env_reason(load_desc(|d| d.struct_size = 8));
    assert!(r.contains("rwg_env_desc_t is too small"), "{r}");
    let r = env_reason(load_desc(|d| {
        d.observation_space.low = LOW.as_ptr();
        d.observation_space.high = HIGH.as_ptr();
    }));
    assert!(r.contains("low[0] = 1 > high[0] = 0"), "{r}");
    let r = env_reason(load_desc(|d| d.observation_space.low = NAN2.as_ptr()));
    assert!(r.contains("NaN"), "{r}");
    let r = env_reason(load_desc(|d| d.observation_space.high = std::ptr::null()));
    assert!(r.contains("NULL"), "{r}");
    let r = env_reason(load_desc(|d| d.observation_space.n = 0));
    assert!(r.contains("Box length is 0"), "{r}");
    let r = env_reason(load_desc(|d| d.action_space.n = 0));
    assert!(r.starts_with("action space: Discrete n is 0"), "{r}");
    let r = env_reason(load_desc(|d| d.action_space.kind = 9));
    assert!(r.contains("unknown space kind 9"), "{r}");
    let r = env_reason(load_desc(|d| d.observation_space = d.action_space));
    assert!(r.contains("must be a Box"), "{r}");
    let r = env_reason(load_desc(|d| d.reward_threshold = f64::INFINITY));
    assert!(r.contains("reward_threshold"), "{r}");
    let p = load_desc(|d| {
        d.max_episode_steps = 0;
        d.reward_threshold = f64::NAN;
        d.observation_space.high = INF2.as_ptr();
    });
    let p = p.unwrap();
    assert_eq!(p.envs()[0].spec().max_episode_steps, None);
    assert_eq!(p.envs()[0].spec().reward_threshold, None);
}

unsafe extern "C" fn null_vtable(_: u32) -> *const RwgEnvVtable {
    std::ptr::null()
}

#[test]
fn vtables_are_validated() {
    let (_, d) = valid_entry();
    let r = env_reason(load_edited(|e| e.env_vtable = Some(null_vtable), vec![d]));
    assert!(r.contains("env_vtable returned NULL"), "{r}");
}

// ---- the checker ----------------------------------------------------------

fn statuses(results: &[crate::check::CheckResult]) -> Vec<(String, CheckStatus)> {
    results.iter().map(|r| (r.name.clone(), r.status)).collect()
}

fn failed(results: &[crate::check::CheckResult]) -> Vec<String> {
    results
        .iter()
        .filter(|r| r.status == CheckStatus::Failed)
        .map(|r| r.name.clone())
        .collect()
}

#[test]
fn checker_passes_a_good_env_directly_and_through_the_plugin() {
    let direct = check_env(|| Walker::new(""));
    assert!(failed(&direct).is_empty(), "{direct:#?}");
    let p = test_plugin();
    let res = check_plugin_env(p.env("test/Walker-v0").unwrap(), "");
    assert!(failed(&res).is_empty(), "{res:#?}");
    let names: Vec<String> = statuses(&res).into_iter().map(|(n, _)| n).collect();
    for want in [
        "spaces",
        "step before reset",
        "reset determinism",
        "seed sensitivity",
        "trajectory determinism",
        "threads",
        "truncation",
        "invalid actions",
        "raw discrete actions",
        "unseeded reset",
    ] {
        assert!(names.iter().any(|n| n == want), "missing {want}: {names:?}");
    }
    assert!(res
        .iter()
        .all(|r| r.env.as_deref() == Some("test/Walker-v0")));
    let glider = check_plugin_env(p.env("test/Glider-v0").unwrap(), "");
    assert!(failed(&glider).is_empty(), "{glider:#?}");
}

#[test]
fn checker_reports_panics_nans_and_shared_state() {
    let p = test_plugin();
    let panicky = failed(&check_plugin_env(p.env("test/Panicky-v0").unwrap(), ""));
    assert!(panicky.contains(&"rollout".to_string()), "{panicky:?}");
    let nan = failed(&check_plugin_env(p.env("test/NanReward-v0").unwrap(), ""));
    assert!(nan.contains(&"rollout".to_string()), "{nan:?}");
    let leaky = failed(&check_plugin_env(p.env("test/Leaky-v0").unwrap(), ""));
    assert!(
        leaky.contains(&"independent instances".to_string()),
        "{leaky:?}"
    );
    // Direct Rust panics are caught by the checker itself.
    let direct = failed(&check_env(|| Walker::new("").map(Panicky)));
    assert!(direct.contains(&"rollout".to_string()), "{direct:?}");
}

#[test]
fn checker_flags_accepted_invalid_actions_and_missing_reset_check() {
    /// Accepts anything, even before reset.
    struct Lax(Walker);
    impl Environment for Lax {
        fn spec(&self) -> &EnvSpec {
            &self.0.spec
        }
        fn reset(&mut self, seed: u64, obs: &mut [f64]) -> Result<(), EnvError> {
            self.0.reset(seed, obs)
        }
        fn step(&mut self, _: Action<'_>, obs: &mut [f64]) -> Result<Step, EnvError> {
            obs.copy_from_slice(&[0.0, 0.0]);
            Ok(Step {
                reward: 0.0,
                terminated: false,
                truncated: false,
            })
        }
    }
    let res = check_env(|| Walker::new("").map(Lax));
    let f = failed(&res);
    assert!(f.contains(&"step before reset".to_string()), "{f:?}");
    assert!(f.contains(&"invalid actions".to_string()), "{f:?}");
    let create = check_env(|| Err::<Walker, _>(EnvError::Other("nope".into())));
    assert_eq!(create.len(), 1);
    assert_eq!(create[0].status, CheckStatus::Failed);
}

// The header's "what the reference implementation does" section.
mod batched;
mod contract;
