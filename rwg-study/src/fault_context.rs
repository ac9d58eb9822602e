//! What each thread is calling in a plugin environment, for fault reports.
//!
//! A plugin env runs in the runner's process: if it crashes, aborts, calls
//! `exit()` or hangs, the program running the study (the `rwg` binary
//! installs the handlers) needs to say where. The runner wraps every plugin
//! env in [`Watched`], which records each call (`create`, `reset`, `step`)
//! with its network, episode and step in a per-thread [`CallCtx`]: a few
//! relaxed atomic stores per call, nothing next to the call itself. The
//! records are readable from a signal handler on the same thread
//! ([`this_thread`]: no allocation, no lock) and from a watchdog thread
//! ([`all_threads`]). [`cell_label`] names the cell being run.

use rwg_env::{Action, EnvError, EnvSpec, Environment, Step};
use std::cell::Cell;
use std::sync::atomic::{AtomicPtr, AtomicU64, AtomicU8, Ordering::*};
use std::sync::Mutex;

/// What a thread is calling in a plugin.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u8)]
pub enum Phase {
    /// Not in a plugin call.
    Idle = 0,
    /// `create`.
    Create = 1,
    /// `reset`.
    Reset = 2,
    /// `step`.
    Step = 3,
    /// ABI 1.1's `reset_many` (a batched reset; the snapshot's `episode` is
    /// the number of lanes, `step` the thread's count of batched calls).
    ResetMany = 4,
    /// ABI 1.1's `step_many` (a batched step; fields as for `ResetMany`).
    StepMany = 5,
    /// ABI 1.2's `vec_reset` (a vector env's reset; fields as for
    /// `ResetMany`).
    VecReset = 6,
    /// ABI 1.2's `vec_step` (a vector env's step; fields as for
    /// `ResetMany`).
    VecStep = 7,
}

/// One thread's plugin call in progress. Written only by its thread.
#[repr(align(64))]
#[derive(Default)]
pub struct CallCtx {
    sample: AtomicU64,
    episode: AtomicU64,
    step: AtomicU64,
    phase: AtomicU8,
}

/// A copy of a [`CallCtx`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CallSnapshot {
    /// What the thread is calling.
    pub phase: Phase,
    /// The network (sample index) of the episode (reset and step).
    pub sample: u64,
    /// The episode of the network (reset and step).
    pub episode: u64,
    /// The step of the episode, 1-based (step only; for create, the
    /// number of the create call).
    pub step: u64,
}

impl CallSnapshot {
    /// What identifies the call within a cell: (sample, episode, step) is
    /// different for every call the sampler makes (resets have step 0), so
    /// a watchdog that sees the same key twice sees the same call.
    pub fn key(&self) -> (Phase, u64, u64, u64) {
        (self.phase, self.sample, self.episode, self.step)
    }
}

impl CallCtx {
    #[inline(always)]
    fn enter(&self, phase: Phase, sample: u64, episode: u64, step: u64) {
        self.sample.store(sample, Relaxed);
        self.episode.store(episode, Relaxed);
        self.step.store(step, Relaxed);
        self.phase.store(phase as u8, Release);
    }

    #[inline(always)]
    fn leave(&self) {
        self.phase.store(Phase::Idle as u8, Release);
    }

    /// The call in progress (async-signal-safe: loads only).
    pub fn snapshot(&self) -> CallSnapshot {
        let phase = match self.phase.load(Acquire) {
            1 => Phase::Create,
            2 => Phase::Reset,
            3 => Phase::Step,
            4 => Phase::ResetMany,
            5 => Phase::StepMany,
            6 => Phase::VecReset,
            7 => Phase::VecStep,
            _ => Phase::Idle,
        };
        CallSnapshot {
            phase,
            sample: self.sample.load(Relaxed),
            episode: self.episode.load(Relaxed),
            step: self.step.load(Relaxed),
        }
    }
}

thread_local! {
    static CTX: Cell<Option<&'static CallCtx>> = const { Cell::new(None) };
}

/// Every thread's context (leaked: worker threads live as long as a run).
static REGISTRY: Mutex<Vec<&'static CallCtx>> = Mutex::new(Vec::new());

/// This thread's context, registered on first use.
#[inline(always)]
fn ctx() -> &'static CallCtx {
    match CTX.with(|c| c.get()) {
        Some(x) => x,
        None => register(),
    }
}

/// Registers this thread's context (once per thread).
#[cold]
#[inline(never)]
fn register() -> &'static CallCtx {
    let x: &'static CallCtx = Box::leak(Box::default());
    REGISTRY.lock().unwrap_or_else(|e| e.into_inner()).push(x);
    CTX.with(|c| c.set(Some(x)));
    x
}

/// The calling thread's plugin call, if it ever made one (for a signal or
/// `atexit` handler on that thread: no allocation, no lock).
pub fn this_thread() -> Option<CallSnapshot> {
    CTX.try_with(|c| c.get())
        .ok()
        .flatten()
        .map(|c| c.snapshot())
}

/// Every thread's plugin call (for a watchdog thread).
pub fn all_threads() -> Vec<&'static CallCtx> {
    REGISTRY.lock().unwrap_or_else(|e| e.into_inner()).clone()
}

/// The cell being run, set by the runner (leaked when replaced: one per cell).
static CELL: AtomicPtr<Box<[u8]>> = AtomicPtr::new(std::ptr::null_mut());

/// Names the cell being run: `plugin 'p' (file), env 'id', cell DIR`.
pub fn set_cell_label(label: String) {
    let b = Box::into_raw(Box::new(label.into_bytes().into_boxed_slice()));
    CELL.store(b, SeqCst);
}

/// The label set by [`set_cell_label`] (`""` before any; async-signal-safe).
pub fn cell_label() -> &'static [u8] {
    let p = CELL.load(SeqCst);
    if p.is_null() {
        b""
    } else {
        // SAFETY: set from a leaked box, never freed.
        unsafe { &*p }
    }
}

/// Runs `make`, recorded as a `create` call.
pub fn recorded_create<T>(make: impl FnOnce() -> T) -> T {
    // Numbered, so that consecutive creates are different calls.
    static CREATES: AtomicU64 = AtomicU64::new(0);
    let n = CREATES.fetch_add(1, Relaxed);
    let c = ctx();
    c.enter(Phase::Create, u64::MAX, u64::MAX, n);
    let r = make();
    c.leave();
    r
}

thread_local! {
    /// The number of batched calls this thread has made (their key).
    static BATCHED_CALLS: Cell<u64> = const { Cell::new(0) };
}

/// Runs `call`, recorded as a call on many lanes (`phase` is
/// [`Phase::ResetMany`], [`Phase::StepMany`], [`Phase::VecReset`] or
/// [`Phase::VecStep`]) on `lanes` lanes. The plugin cannot say which of
/// the lanes it is working on, so a fault report names the batch, not the
/// network and step.
#[inline]
pub fn recorded_batch<R>(phase: Phase, lanes: usize, call: impl FnOnce() -> R) -> R {
    let n = BATCHED_CALLS.with(|k| {
        let n = k.get() + 1;
        k.set(n);
        n
    });
    let c = ctx();
    c.enter(phase, u64::MAX, lanes as u64, n);
    let r = call();
    c.leave();
    r
}

/// A plugin environment whose calls are recorded (see the module docs).
pub struct Watched<E> {
    inner: E,
    sample: u64,
    episode: u64,
    steps: u64,
}

impl<E> Watched<E> {
    /// Creates the env with `make`, recorded as a `create` call.
    pub fn create(make: impl FnOnce() -> E) -> Self {
        let inner = recorded_create(make);
        Watched {
            inner,
            sample: u64::MAX,
            episode: u64::MAX,
            steps: 0,
        }
    }
}

impl<E: Environment> Environment for Watched<E> {
    fn spec(&self) -> &EnvSpec {
        self.inner.spec()
    }

    fn reset(&mut self, seed: u64, obs: &mut [f64]) -> Result<(), EnvError> {
        let (sample, episode) = rwg_core::sampler::starting_episode();
        (self.sample, self.episode, self.steps) = (sample, episode.into(), 0);
        let c = ctx();
        c.enter(Phase::Reset, self.sample, self.episode, 0);
        let r = self.inner.reset(seed, obs);
        c.leave();
        r
    }

    #[inline(always)]
    fn step(&mut self, action: Action<'_>, obs: &mut [f64]) -> Result<Step, EnvError> {
        self.steps += 1;
        let c = ctx();
        c.enter(Phase::Step, self.sample, self.episode, self.steps);
        let r = self.inner.step(action, obs);
        c.leave();
        r
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rwg_env::{BoxSpace, Space};

    /// Records the context it sees inside each call.
    struct Probe {
        spec: EnvSpec,
        seen: Vec<CallSnapshot>,
    }

    impl Environment for Probe {
        fn spec(&self) -> &EnvSpec {
            &self.spec
        }
        fn reset(&mut self, _seed: u64, _obs: &mut [f64]) -> Result<(), EnvError> {
            self.seen.push(this_thread().unwrap());
            Ok(())
        }
        fn step(&mut self, _a: Action<'_>, _obs: &mut [f64]) -> Result<Step, EnvError> {
            self.seen.push(this_thread().unwrap());
            Ok(Step {
                reward: 0.0,
                terminated: false,
                truncated: false,
            })
        }
    }

    #[test]
    fn calls_are_recorded_with_network_episode_and_step() {
        let spec = EnvSpec {
            id: "t/Probe-v0".into(),
            observation_space: Space::Box(BoxSpace::new(vec![0.0], vec![1.0])),
            action_space: Space::Discrete { n: 2 },
            max_episode_steps: Some(3),
            reward_threshold: None,
        };
        let mut env = Watched::create(|| Probe { spec, seen: vec![] });
        let mut obs = [0.0];
        env.reset(1, &mut obs).unwrap();
        env.step(Action::Discrete(0), &mut obs).unwrap();
        env.step(Action::Discrete(0), &mut obs).unwrap();
        let phases: Vec<(Phase, u64)> = env.inner.seen.iter().map(|s| (s.phase, s.step)).collect();
        assert_eq!(
            phases,
            [(Phase::Reset, 0), (Phase::Step, 1), (Phase::Step, 2)]
        );
        let keys: Vec<_> = env.inner.seen.iter().map(|s| s.key()).collect();
        assert!(keys.windows(2).all(|w| w[1] != w[0]), "{keys:?}");
        assert_eq!(this_thread().unwrap().phase, Phase::Idle);
        set_cell_label("env 't/Probe-v0', cell x".into());
        assert_eq!(cell_label(), b"env 't/Probe-v0', cell x");
    }
}
