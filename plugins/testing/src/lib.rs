//! Deliberately broken environments, exported as one plugin
//! (`librwg_testing_plugins.so`) for the loader's and `rwg check`'s tests.
//! Do not use them for anything else.
//!
//! | id | what goes wrong |
//! |----|-----------------|
//! | `broken/PanicInStep-v0` | panics on the 3rd step (caught by the export shim) |
//! | `broken/NaNObservation-v0` | a NaN observation on the 2nd step |
//! | `broken/NaNReward-v0` | a NaN reward on the 2nd step |
//! | `broken/HiddenGlobalState-v0` | observations depend on a process-global counter |
//! | `broken/SegfaultInStep-v0` | **segfaults** on the first step: kills the process that steps it |
//! | `broken/HangInStep-v0` | **never returns** from the first step (for `rwg check --timeout`) |
//! | `broken/ExitInReset-v0` | calls `exit(0)` in the process's 3rd reset (config `at_reset=N`: the N-th) |
//! | `broken/AbortInStep-v0` | calls `abort()` on step 5 of its 2nd episode |
//! | `broken/PrintInReset-v0` | works, but prints a line to stdout on every reset |
//! | `broken/HugeReward-v0` | rewards of 1e308: each finite, an episode's sum overflows to inf |
//!
//! Every one also has ABI 1.2's vector env ([`EachLane`]: its lanes are
//! instances stepped one after another), which misbehaves the same way, so
//! the tests see each fault through the single calls, the batched calls
//! (`RWG_PLUGIN_VEC=0`) and the vector env (`rwg run`'s default).
//!
//! Broken handshakes (wrong ABI version, bad descriptors, ...) are C
//! variants of `c/handshake.c`, compiled by the tests.

use std::sync::atomic::{AtomicU64, Ordering};

use rwg_env::env::discrete_action;
use rwg_env::many::ManyEnv;
use rwg_env::plugin::PluginBuilder;
use rwg_env::{Action, BoxSpace, EnvError, EnvSpec, Environment, Space, Step};

/// How an environment misbehaves.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Fault {
    /// Panics on the 3rd step.
    PanicInStep,
    /// NaN observation on the 2nd step.
    NanObservation,
    /// NaN reward on the 2nd step.
    NanReward,
    /// Adds a process-global counter to the observation.
    HiddenGlobalState,
    /// Writes to an unmapped address on the first step.
    SegfaultInStep,
    /// Never returns from the first step.
    HangInStep,
    /// Calls `exit(0)` in the process's 3rd reset of such envs (config
    /// `at_reset=N`: the N-th), counted over all instances.
    ExitInReset,
    /// Calls `abort()` on step 5 of its 2nd episode.
    AbortInStep,
    /// Prints `broken/PrintInReset-v0 says hello on stdout` on every reset.
    PrintInReset,
    /// Rewards of 1e308: each finite, an episode's sum overflows to inf.
    HugeReward,
}

impl Fault {
    /// Every fault, in export order.
    pub const ALL: [Fault; 10] = [
        Fault::PanicInStep,
        Fault::NanObservation,
        Fault::NanReward,
        Fault::HiddenGlobalState,
        Fault::SegfaultInStep,
        Fault::HangInStep,
        Fault::ExitInReset,
        Fault::AbortInStep,
        Fault::PrintInReset,
        Fault::HugeReward,
    ];

    /// The exported id.
    pub fn id(self) -> &'static str {
        match self {
            Fault::PanicInStep => "broken/PanicInStep-v0",
            Fault::NanObservation => "broken/NaNObservation-v0",
            Fault::NanReward => "broken/NaNReward-v0",
            Fault::HiddenGlobalState => "broken/HiddenGlobalState-v0",
            Fault::SegfaultInStep => "broken/SegfaultInStep-v0",
            Fault::HangInStep => "broken/HangInStep-v0",
            Fault::ExitInReset => "broken/ExitInReset-v0",
            Fault::AbortInStep => "broken/AbortInStep-v0",
            Fault::PrintInReset => "broken/PrintInReset-v0",
            Fault::HugeReward => "broken/HugeReward-v0",
        }
    }
}

static GLOBAL: AtomicU64 = AtomicU64::new(0);
/// Resets of `ExitInReset` envs in this process.
static RESETS: AtomicU64 = AtomicU64::new(0);

/// A counter (obs = steps taken, reward 1, ends after 50 steps) with a fault.
#[derive(Debug, Clone)]
pub struct Broken {
    spec: EnvSpec,
    fault: Fault,
    t: u32,
    started: bool,
    /// Resets so far.
    resets: u32,
    /// `ExitInReset`: the process-wide reset that exits.
    exit_at: u64,
}

impl Broken {
    /// The spec of `fault`'s environment.
    pub fn spec(fault: Fault) -> EnvSpec {
        EnvSpec {
            id: fault.id().into(),
            observation_space: Space::Box(BoxSpace::new(vec![0.0], vec![1e6])),
            action_space: Space::Discrete { n: 2 },
            max_episode_steps: Some(20),
            reward_threshold: None,
        }
    }

    /// A new instance.
    pub fn new(fault: Fault) -> Broken {
        Broken {
            spec: Broken::spec(fault),
            fault,
            t: 0,
            started: false,
            resets: 0,
            exit_at: 3,
        }
    }

    /// A new instance with a config: `""`, or `at_reset=N` for `ExitInReset`.
    pub fn with_config(fault: Fault, config: &str) -> Result<Broken, String> {
        let mut b = Broken::new(fault);
        if let Some(n) = config.strip_prefix("at_reset=") {
            b.exit_at = n
                .parse()
                .map_err(|_| format!("at_reset: '{n}' is not a count"))?;
        } else if !config.is_empty() {
            return Err(format!("unknown config '{config}' (expected at_reset=N)"));
        }
        Ok(b)
    }
}

impl Environment for Broken {
    fn spec(&self) -> &EnvSpec {
        &self.spec
    }

    fn reset(&mut self, seed: u64, obs: &mut [f64]) -> Result<(), EnvError> {
        self.t = 0;
        self.started = true;
        self.resets += 1;
        match self.fault {
            // Like a C plugin that gives up with exit() from deep inside.
            Fault::ExitInReset if RESETS.fetch_add(1, Ordering::SeqCst) + 1 == self.exit_at => {
                std::process::exit(0)
            }
            Fault::PrintInReset => println!("{} says hello on stdout", self.fault.id()),
            _ => {}
        }
        obs[0] = (seed % 3) as f64;
        Ok(())
    }

    fn step(&mut self, action: Action<'_>, obs: &mut [f64]) -> Result<Step, EnvError> {
        if !self.started {
            return Err(EnvError::ResetNeeded);
        }
        discrete_action(action, 2)?;
        self.t += 1;
        obs[0] = self.t as f64;
        let mut reward = 1.0;
        match self.fault {
            Fault::PanicInStep if self.t >= 3 => panic!("broken/PanicInStep-v0 panics on step 3"),
            Fault::NanObservation if self.t >= 2 => obs[0] = f64::NAN,
            Fault::NanReward if self.t >= 2 => reward = f64::NAN,
            Fault::HugeReward => reward = 1e308,
            Fault::HiddenGlobalState => {
                obs[0] += (GLOBAL.fetch_add(1, Ordering::Relaxed) % 2) as f64;
            }
            Fault::SegfaultInStep => {
                // A real segfault, as from a C plugin following a bad pointer:
                // address 16 is never mapped (the zero page).
                // SAFETY: none; this is the point of the environment.
                unsafe { std::ptr::write_volatile(16 as *mut u8, 1) };
            }
            Fault::AbortInStep if self.resets == 2 && self.t == 5 => std::process::abort(),
            Fault::HangInStep => loop {
                // Like a plugin stuck in an endless loop or a deadlock.
                std::thread::sleep(std::time::Duration::from_secs(1));
            },
            _ => {}
        }
        Ok(Step {
            reward,
            terminated: self.t >= 50,
            truncated: false,
        })
    }
}

/// A vector env's chunk of [`EachLane::WIDTH`] lanes: [`Broken`]
/// instances stepped one after another, so a lane misbehaves as the
/// single instance does.
pub struct EachLane {
    envs: Vec<Broken>,
}

impl EachLane {
    /// Lanes per chunk (a vector env of more lanes has several chunks).
    pub const WIDTH: usize = 4;

    /// [`Self::WIDTH`] instances of `fault`'s env with `config`.
    pub fn with_config(fault: Fault, config: &str) -> Result<EachLane, String> {
        let envs = (0..Self::WIDTH)
            .map(|_| Broken::with_config(fault, config))
            .collect::<Result<_, _>>()?;
        Ok(EachLane { envs })
    }
}

impl ManyEnv for EachLane {
    fn spec(&self) -> &EnvSpec {
        &self.envs[0].spec
    }

    fn lanes(&self) -> usize {
        self.envs.len()
    }

    fn reset_many(
        &mut self,
        mask: &[u8],
        seeds: &[u64],
        obs: &mut [f64],
        on_fail: &mut dyn FnMut(usize, EnvError),
    ) {
        for (i, env) in self.envs.iter_mut().enumerate() {
            if mask[i] == 1 {
                if let Err(e) = env.reset(seeds[i], &mut obs[i..i + 1]) {
                    on_fail(i, e);
                }
            }
        }
    }

    fn step_many(
        &mut self,
        mask: &[u8],
        actions: &[f64],
        obs: &mut [f64],
        rewards: &mut [f64],
        terminated: &mut [u8],
        truncated: &mut [u8],
        on_fail: &mut dyn FnMut(usize, EnvError),
    ) {
        for (i, env) in self.envs.iter_mut().enumerate() {
            if mask[i] != 1 {
                continue;
            }
            let a = actions[i];
            let action = if a.fract() == 0.0 && (0.0..2.0).contains(&a) {
                Action::Discrete(a as i64)
            } else {
                on_fail(i, EnvError::InvalidAction(format!("{a} is not 0 or 1")));
                continue;
            };
            match env.step(action, &mut obs[i..i + 1]) {
                Ok(s) => {
                    rewards[i] = s.reward;
                    terminated[i] = u8::from(s.terminated);
                    truncated[i] = u8::from(s.truncated);
                }
                Err(e) => on_fail(i, e),
            }
        }
    }
}

/// The plugin: one environment per [`Fault`], each with a vector env.
pub fn plugin() -> PluginBuilder {
    let mut b = PluginBuilder::new("broken", env!("CARGO_PKG_VERSION"));
    for fault in Fault::ALL {
        b = b
            .env(
                Broken::spec(fault),
                "deliberately broken",
                move |config: &str| Broken::with_config(fault, config),
            )
            .vec_env(move |config: &str| EachLane::with_config(fault, config));
    }
    b
}

rwg_env::export_plugin!(plugin());
