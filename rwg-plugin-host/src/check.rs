//! Conformance checks for environments and plugins, after Gymnasium's
//! `utils/env_checker.py`: the library behind `rwg check`.
//!
//! [`check_env`] works on any [`Environment`] given a constructor;
//! [`check_plugin_env`] adds the checks only the raw ABI can express, and
//! [`check_plugin`] loads a file and checks every environment in it.
//!
//! The checks run in this process. A plugin that crashes (a segfault, an
//! abort) takes the process with it, so `rwg check` should run
//! [`check_plugin_env`] in a child process per environment. Panics of Rust
//! environments checked through [`check_env`] are caught and reported.
//!
//! Results are [`CheckStatus::Passed`], [`CheckStatus::Warned`] (legal but
//! suspicious, as Gymnasium's checker warns) or [`CheckStatus::Failed`] (the
//! contract is broken).

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::loader::{check_env_id, load_plugin, PluginEnvType};
use rwg_env::env::{Action, EnvError, EnvSpec, Environment};
use rwg_env::space::Space;
use rwg_env::time_limit::TimeLimit;

/// The verdict of one check.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum CheckStatus {
    /// The check passed.
    Passed,
    /// Allowed, but probably not what the author wants.
    Warned,
    /// The environment breaks the contract.
    Failed,
}

/// One check's outcome.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CheckResult {
    /// The environment id, or `None` for a check of the plugin file itself.
    pub env: Option<String>,
    /// The check's name, e.g. `"reset determinism"`.
    pub name: String,
    /// The verdict.
    pub status: CheckStatus,
    /// What was found.
    pub message: String,
}

impl std::fmt::Display for CheckResult {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let s = match self.status {
            CheckStatus::Passed => "ok",
            CheckStatus::Warned => "WARN",
            CheckStatus::Failed => "FAIL",
        };
        match &self.env {
            Some(e) => write!(f, "[{s}] {e}: {}: {}", self.name, self.message),
            None => write!(f, "[{s}] {}: {}", self.name, self.message),
        }
    }
}

/// Mixed into a seed to seed the action sequence of a trajectory.
const ACTION_SALT: u64 = 0x5eed_0fac_710a_5eed;

/// Steps per trajectory in the determinism checks.
const TRAJ_STEPS: usize = 300;
/// Steps compared by the seed-sensitivity check.
const SEED_STEPS: usize = 20;
/// Steps per episode in the rollout check.
const ROLLOUT_STEPS: usize = 1000;
/// Time limits above this are not run to the end by the truncation check.
const MAX_TRUNCATION_RUN: u32 = 100_000;

/// The progress of the checks, reported as they run by the `*_observed`
/// functions. A host that runs the checks in a child process streams these,
/// so that when the plugin crashes the child it knows which check did it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum CheckEvent<'a> {
    /// A check is about to run (`env` is `None` before the first instance
    /// of a [`check_env`] run exists).
    Started {
        /// The environment id, if known yet.
        env: Option<&'a str>,
        /// The check's name.
        name: &'a str,
    },
    /// A check finished with this result.
    Finished(&'a CheckResult),
}

struct Report<'o> {
    env: Option<String>,
    results: Vec<CheckResult>,
    observe: &'o mut dyn FnMut(CheckEvent<'_>),
}

impl<'o> Report<'o> {
    fn new(env: Option<String>, observe: &'o mut dyn FnMut(CheckEvent<'_>)) -> Self {
        Report {
            env,
            results: Vec::new(),
            observe,
        }
    }

    fn start(&mut self, name: &str) {
        (self.observe)(CheckEvent::Started {
            env: self.env.as_deref(),
            name,
        });
    }

    fn add(&mut self, name: &str, status: CheckStatus, message: impl Into<String>) {
        self.results.push(CheckResult {
            env: self.env.clone(),
            name: name.to_string(),
            status,
            message: message.into(),
        });
        (self.observe)(CheckEvent::Finished(
            self.results.last().expect("just pushed"),
        ));
    }

    /// Runs a check, turning a panic into a failure.
    fn run(&mut self, name: &str, f: impl FnOnce() -> (CheckStatus, String)) {
        self.start(name);
        let (status, msg) = match catch_unwind(AssertUnwindSafe(f)) {
            Ok(r) => r,
            Err(p) => (
                CheckStatus::Failed,
                format!("panicked: {}", panic_text(&*p)),
            ),
        };
        self.add(name, status, msg);
    }
}

fn panic_text(p: &(dyn std::any::Any + Send)) -> String {
    p.downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| p.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "non-string panic payload".into())
}

use CheckStatus::{Failed, Passed, Warned};

/// SplitMix64: the checker's deterministic action source.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }
    fn unit(&mut self) -> f64 {
        (self.next() >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// An owned action sampled from a space.
enum OwnedAction {
    Discrete(i64),
    Continuous(Vec<f64>),
}

impl OwnedAction {
    fn as_action(&self) -> Action<'_> {
        match self {
            OwnedAction::Discrete(a) => Action::Discrete(*a),
            OwnedAction::Continuous(v) => Action::Continuous(v),
        }
    }
}

fn sample(space: &Space, rng: &mut Rng) -> OwnedAction {
    match space {
        Space::Discrete { n } => OwnedAction::Discrete((rng.next() % (*n as u64).max(1)) as i64),
        Space::Box(b) => OwnedAction::Continuous(
            b.low
                .iter()
                .zip(&b.high)
                .map(|(&lo, &hi)| {
                    let (lo, hi) = (lo.max(-1e3), hi.min(1e3));
                    lo + (hi - lo) * rng.unit()
                })
                .collect(),
        ),
    }
}

fn fmt_vec(v: &[f64]) -> String {
    let parts: Vec<String> = v.iter().map(|x| rwg_env::float::fmt_f64(*x)).collect();
    format!("[{}]", parts.join(", "))
}

fn check_spaces(spec: &EnvSpec) -> (CheckStatus, String) {
    let mut warnings = Vec::new();
    let check_box = |what: &str, s: &Space, warn_inf: bool, warnings: &mut Vec<String>| match s {
        Space::Discrete { n } if *n == 0 => Err(format!("{what} is Discrete(0)")),
        Space::Discrete { .. } => Ok(()),
        Space::Box(b) => {
            if b.dim() == 0 {
                return Err(format!("{what} is an empty Box"));
            }
            if b.low.len() != b.high.len() {
                return Err(format!("{what}: low and high have different lengths"));
            }
            for i in 0..b.dim() {
                let (lo, hi) = (b.low[i], b.high[i]);
                if lo.is_nan() || hi.is_nan() || lo > hi {
                    return Err(format!("{what}: bound {i} is [{lo}, {hi}]"));
                }
                if warn_inf && (lo.is_infinite() || hi.is_infinite()) {
                    warnings.push(format!(
                        "{what}: bound {i} is infinite ([{lo}, {hi}]); random policies \
                             need finite action bounds"
                    ));
                }
            }
            Ok(())
        }
    };
    if !matches!(spec.observation_space, Space::Box(_)) {
        return (Failed, "the observation space must be a Box".into());
    }
    if let Err(e) = check_box(
        "observation space",
        &spec.observation_space,
        false,
        &mut warnings,
    )
    .and_then(|_| check_box("action space", &spec.action_space, true, &mut warnings))
    {
        return (Failed, e);
    }
    if let Some(t) = spec.reward_threshold {
        if !t.is_finite() {
            return (Failed, format!("reward_threshold is {t}"));
        }
    }
    if spec.max_episode_steps == Some(0) {
        return (Failed, "max_episode_steps is Some(0)".into());
    }
    let text = format!(
        "observation {}, action {}",
        spec.observation_space.describe(),
        spec.action_space.describe()
    );
    if warnings.is_empty() {
        (Passed, text)
    } else {
        (Warned, warnings.join("; "))
    }
}

fn in_space(space: &Space, obs: &[f64]) -> bool {
    match space {
        Space::Box(b) => b.contains(obs),
        Space::Discrete { n } => obs.len() == 1 && obs[0] >= 0.0 && obs[0] < *n as f64,
    }
}

/// A recorded trajectory: the bits of every observation, reward and flag.
#[derive(Debug, PartialEq)]
struct Traj(Vec<u64>);

/// Runs `seed` with the checker's action sequence for `action_seed`.
fn trajectory<E: Environment>(
    env: &mut E,
    seed: u64,
    action_seed: u64,
    steps: usize,
) -> Result<Traj, EnvError> {
    let spec = env.spec().clone();
    let mut obs = vec![0.0; spec.obs_dim()];
    let mut rec = Vec::new();
    let mut rng = Rng(action_seed ^ ACTION_SALT);
    env.reset(seed, &mut obs)?;
    rec.extend(obs.iter().map(|x| x.to_bits()));
    for _ in 0..steps {
        let a = sample(&spec.action_space, &mut rng);
        let s = env.step(a.as_action(), &mut obs)?;
        rec.extend(obs.iter().map(|x| x.to_bits()));
        rec.push(s.reward.to_bits());
        rec.push(u64::from(s.terminated) | u64::from(s.truncated) << 1);
        if s.terminated || s.truncated {
            break;
        }
    }
    Ok(Traj(rec))
}

/// Runs the environment checks on instances built by `make`.
///
/// `make` must build a fresh instance each call, without a time limit or
/// with one (the truncation check applies the spec's limit itself). It is
/// called from several threads.
pub fn check_env<E, Er, F>(make: F) -> Vec<CheckResult>
where
    E: Environment,
    Er: std::fmt::Display,
    F: Fn() -> Result<E, Er> + Sync,
{
    check_env_observed(make, &mut |_| {})
}

/// [`check_env`], reporting every check to `observe` as it starts and ends.
pub fn check_env_observed<E, Er, F>(
    make: F,
    observe: &mut dyn FnMut(CheckEvent<'_>),
) -> Vec<CheckResult>
where
    E: Environment,
    Er: std::fmt::Display,
    F: Fn() -> Result<E, Er> + Sync,
{
    let mut r = Report::new(None, observe);
    r.start("create");
    let first = match catch_unwind(AssertUnwindSafe(&make)) {
        Ok(Ok(e)) => e,
        Ok(Err(e)) => {
            r.add("create", Failed, format!("cannot create an instance: {e}"));
            return r.results;
        }
        Err(p) => {
            r.add("create", Failed, format!("panicked: {}", panic_text(&*p)));
            return r.results;
        }
    };
    let spec = first.spec().clone();
    drop(first);
    r.env = Some(spec.id.clone());
    r.add("create", Passed, "an instance was created");
    r.run("spaces", || check_spaces(&spec));
    if r.results.last().map(|c| c.status) == Some(Failed) {
        return r.results;
    }
    let dim = spec.obs_dim();
    let fresh = || make().map_err(|e| format!("cannot create an instance: {e}"));

    r.run("step before reset", || {
        let mut env = match fresh() {
            Ok(e) => e,
            Err(m) => return (Failed, m),
        };
        let mut obs = vec![0.0; dim];
        let a = sample(&spec.action_space, &mut Rng(1));
        match env.step(a.as_action(), &mut obs) {
            Err(EnvError::ResetNeeded) => (Passed, "refused with reset-needed".into()),
            Err(e) => (Warned, format!("refused, but not as reset-needed: {e}")),
            Ok(_) => (Failed, "a step before the first reset was accepted".into()),
        }
    });

    r.run("reset", || {
        let mut env = match fresh() {
            Ok(e) => e,
            Err(m) => return (Failed, m),
        };
        let mut obs = vec![0.0; dim];
        if let Err(e) = env.reset(0, &mut obs) {
            return (Failed, format!("reset(seed=0) failed: {e}"));
        }
        if obs.iter().any(|x| !x.is_finite()) {
            return (Failed, format!("non-finite observation {}", fmt_vec(&obs)));
        }
        if !in_space(&spec.observation_space, &obs) {
            return (
                Warned,
                format!(
                    "observation {} is outside the observation space",
                    fmt_vec(&obs)
                ),
            );
        }
        (Passed, format!("reset(seed=0) gives {}", fmt_vec(&obs)))
    });

    r.run("reset determinism", || {
        let (mut a, mut b) = match (fresh(), fresh()) {
            (Ok(a), Ok(b)) => (a, b),
            (Err(m), _) | (_, Err(m)) => return (Failed, m),
        };
        let mut o1 = vec![0.0; dim];
        let mut o2 = vec![0.0; dim];
        let mut o3 = vec![0.0; dim];
        let res = a
            .reset(42, &mut o1)
            .and_then(|_| a.reset(7, &mut o3))
            .and_then(|_| a.reset(42, &mut o3))
            .and_then(|_| b.reset(42, &mut o2));
        if let Err(e) = res {
            return (Failed, format!("reset failed: {e}"));
        }
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        if bits(&o1) != bits(&o3) {
            (
                Failed,
                format!(
                    "reset(seed=42) twice on one instance: {} then {}",
                    fmt_vec(&o1),
                    fmt_vec(&o3)
                ),
            )
        } else if bits(&o1) != bits(&o2) {
            (
                Failed,
                format!(
                    "reset(seed=42) on two instances: {} and {}",
                    fmt_vec(&o1),
                    fmt_vec(&o2)
                ),
            )
        } else {
            (Passed, "the same seed gives the same observation".into())
        }
    });

    r.run("seed sensitivity", || {
        // The same actions under different seeds: the first observation or
        // anything in the first steps should differ.
        let mut env = match fresh() {
            Ok(e) => e,
            Err(m) => return (Failed, m),
        };
        let first = match trajectory(&mut env, 0, 0, SEED_STEPS) {
            Ok(t) => t,
            Err(e) => return (Failed, format!("seed 0: {e}")),
        };
        for seed in 1..8u64 {
            match trajectory(&mut env, seed, 0, SEED_STEPS) {
                Ok(t) if t != first => {
                    return (
                        Passed,
                        format!("seeds 0 and {seed} give different episodes"),
                    )
                }
                Ok(_) => {}
                Err(e) => return (Failed, format!("seed {seed}: {e}")),
            }
        }
        (
            Warned,
            format!(
                "seeds 0..8 give the same first {SEED_STEPS} steps for the same actions: \
                 is the seed used?"
            ),
        )
    });

    r.run("rollout", || {
        let mut env = match fresh() {
            Ok(e) => e,
            Err(m) => return (Failed, m),
        };
        let mut obs = vec![0.0; dim];
        let mut rng = Rng(3);
        let mut steps = 0usize;
        let mut outside: Option<String> = None;
        for seed in [1u64, 2, 3] {
            if let Err(e) = env.reset(seed, &mut obs) {
                return (Failed, format!("reset(seed={seed}) failed: {e}"));
            }
            for t in 0..ROLLOUT_STEPS {
                let a = sample(&spec.action_space, &mut rng);
                let s = match env.step(a.as_action(), &mut obs) {
                    Ok(s) => s,
                    Err(e) => return (Failed, format!("seed {seed}, step {t}: {e}")),
                };
                steps += 1;
                if !s.reward.is_finite() {
                    return (
                        Failed,
                        format!("seed {seed}, step {t}: reward {}", s.reward),
                    );
                }
                if obs.iter().any(|x| !x.is_finite()) {
                    return (
                        Failed,
                        format!("seed {seed}, step {t}: observation {}", fmt_vec(&obs)),
                    );
                }
                if outside.is_none() && !in_space(&spec.observation_space, &obs) {
                    outside = Some(format!(
                        "seed {seed}, step {t}: observation {} is outside the observation space",
                        fmt_vec(&obs)
                    ));
                }
                if s.terminated || s.truncated {
                    break;
                }
            }
        }
        match outside {
            Some(m) => (Warned, m),
            None => (
                Passed,
                format!("{steps} random steps: finite rewards, observations in the space"),
            ),
        }
    });

    let solo = |seed: u64| -> Result<Traj, String> {
        let mut env = fresh()?;
        trajectory(&mut env, seed, seed, TRAJ_STEPS).map_err(|e| format!("seed {seed}: {e}"))
    };

    r.run("trajectory determinism", || match (solo(11), solo(11)) {
        (Ok(a), Ok(b)) if a == b => (
            Passed,
            "the same seed and actions give the same trajectory".into(),
        ),
        (Ok(_), Ok(_)) => (
            Failed,
            "the same seed and actions gave different trajectories on two instances".into(),
        ),
        (Err(m), _) | (_, Err(m)) => (Failed, m),
    });

    r.run("independent instances", || {
        // Two instances stepped alternately on one thread: hidden global
        // state shows up as a difference from the solo runs.
        let (want_a, want_b) = match (solo(21), solo(22)) {
            (Ok(a), Ok(b)) => (a, b),
            (Err(m), _) | (_, Err(m)) => return (Failed, m),
        };
        let (mut a, mut b) = match (fresh(), fresh()) {
            (Ok(a), Ok(b)) => (a, b),
            (Err(m), _) | (_, Err(m)) => return (Failed, m),
        };
        match interleaved(&mut a, &mut b, &spec) {
            Ok((ta, tb)) if ta == want_a && tb == want_b => {
                (Passed, "interleaved instances match their solo runs".into())
            }
            Ok(_) => (
                Failed,
                "two instances stepped alternately differ from solo runs: \
                 the env keeps hidden shared state"
                    .into(),
            ),
            Err(e) => (Failed, e.to_string()),
        }
    });

    r.run("threads", || {
        let (want_a, want_b) = match (solo(31), solo(32)) {
            (Ok(a), Ok(b)) => (a, b),
            (Err(m), _) | (_, Err(m)) => return (Failed, m),
        };
        let (got_a, got_b) = std::thread::scope(|s| {
            let ha = s.spawn(|| catch_unwind(AssertUnwindSafe(|| solo(31))));
            let hb = s.spawn(|| catch_unwind(AssertUnwindSafe(|| solo(32))));
            (ha.join(), hb.join())
        });
        let flat = |r: std::thread::Result<std::thread::Result<Result<Traj, String>>>| match r {
            Ok(Ok(t)) => t,
            Ok(Err(p)) | Err(p) => Err(format!("panicked: {}", panic_text(&*p))),
        };
        match (flat(got_a), flat(got_b)) {
            (Ok(a), Ok(b)) if a == want_a && b == want_b => (
                Passed,
                "two instances on two threads match their solo runs".into(),
            ),
            (Ok(_), Ok(_)) => (
                Failed,
                "instances run on two threads differ from solo runs: \
                 the env depends on threads or shared state"
                    .into(),
            ),
            (Err(m), _) | (_, Err(m)) => (Failed, m),
        }
    });

    r.run("truncation", || check_truncation(&fresh, &spec));

    r.run("invalid actions", || {
        let mut env = match fresh() {
            Ok(e) => e,
            Err(m) => return (Failed, m),
        };
        let mut obs = vec![0.0; dim];
        let mut accepted = Vec::new();
        let mut tried = 0;
        let bad: Vec<(String, OwnedAction)> = match &spec.action_space {
            Space::Discrete { n } => vec![
                ("-1".into(), OwnedAction::Discrete(-1)),
                (n.to_string(), OwnedAction::Discrete(*n as i64)),
            ],
            Space::Box(b) => vec![
                (
                    "NaN".into(),
                    OwnedAction::Continuous(vec![f64::NAN; b.dim()]),
                ),
                (
                    "infinity".into(),
                    OwnedAction::Continuous(vec![f64::INFINITY; b.dim()]),
                ),
                (
                    format!("{} values", b.dim() + 1),
                    OwnedAction::Continuous(vec![0.0; b.dim() + 1]),
                ),
            ],
        };
        for (what, a) in &bad {
            if let Err(e) = env.reset(5, &mut obs) {
                return (Failed, format!("reset failed: {e}"));
            }
            tried += 1;
            if env.step(a.as_action(), &mut obs).is_ok() {
                accepted.push(what.clone());
            }
        }
        // An env that was handed a bad action must still work after reset.
        let good = sample(&spec.action_space, &mut Rng(9));
        if let Err(e) = env
            .reset(5, &mut obs)
            .and_then(|_| env.step(good.as_action(), &mut obs))
        {
            return (Failed, format!("unusable after invalid actions: {e}"));
        }
        if !accepted.is_empty() {
            return (
                Failed,
                format!("invalid actions were accepted: {}", accepted.join(", ")),
            );
        }
        if let Space::Box(b) = &spec.action_space {
            let big: Vec<f64> = b
                .high
                .iter()
                .map(|h| {
                    if h.is_finite() {
                        h + 1.0 + h.abs()
                    } else {
                        1e6
                    }
                })
                .collect();
            if let Err(e) = env.reset(5, &mut obs) {
                return (Failed, format!("reset failed: {e}"));
            }
            match env.step(Action::Continuous(&big), &mut obs) {
                Ok(_) if obs.iter().any(|x| !x.is_finite()) => {
                    return (
                        Failed,
                        format!(
                            "an action above the bounds gave the observation {}",
                            fmt_vec(&obs)
                        ),
                    )
                }
                Ok(_) | Err(EnvError::InvalidAction(_)) => {}
                Err(e) => {
                    return (Failed, format!("an action above the bounds gave: {e}"));
                }
            }
        }
        (
            Passed,
            format!("{tried} invalid actions refused with an error"),
        )
    });

    r.results
}

fn interleaved<E: Environment>(
    a: &mut E,
    b: &mut E,
    spec: &EnvSpec,
) -> Result<(Traj, Traj), EnvError> {
    let dim = spec.obs_dim();
    let envs = [a, b];
    let seeds = [21u64, 22];
    let mut obs = [vec![0.0; dim], vec![0.0; dim]];
    let mut rec = [Vec::new(), Vec::new()];
    let mut rng = seeds.map(|s| Rng(s ^ ACTION_SALT));
    let mut done = [false, false];
    for i in 0..2 {
        envs[i].reset(seeds[i], &mut obs[i])?;
        rec[i].extend(obs[i].iter().map(|x| x.to_bits()));
    }
    for _ in 0..TRAJ_STEPS {
        for i in 0..2 {
            if done[i] {
                continue;
            }
            let act = sample(&spec.action_space, &mut rng[i]);
            let s = envs[i].step(act.as_action(), &mut obs[i])?;
            rec[i].extend(obs[i].iter().map(|x| x.to_bits()));
            rec[i].push(s.reward.to_bits());
            rec[i].push(u64::from(s.terminated) | u64::from(s.truncated) << 1);
            done[i] = s.terminated || s.truncated;
        }
        if done[0] && done[1] {
            break;
        }
    }
    let [ra, rb] = rec;
    Ok((Traj(ra), Traj(rb)))
}

fn check_truncation<E: Environment>(
    fresh: &dyn Fn() -> Result<E, String>,
    spec: &EnvSpec,
) -> (CheckStatus, String) {
    let Some(limit) = spec.max_episode_steps else {
        return (Passed, "no time limit".into());
    };
    if limit > MAX_TRUNCATION_RUN {
        return (
            Warned,
            format!("time limit {limit} is too long to run; not checked"),
        );
    }
    let mut rng = Rng(77);
    let mut obs = vec![0.0; spec.obs_dim()];
    let mut early_truncation = None;
    for seed in 0..5u64 {
        let inner = match fresh() {
            Ok(e) => e,
            Err(m) => return (Failed, m),
        };
        let mut env = TimeLimit::new(inner, Some(limit));
        if let Err(e) = env.reset(seed, &mut obs) {
            return (Failed, format!("reset failed: {e}"));
        }
        for t in 1..=limit {
            let a = sample(&spec.action_space, &mut rng);
            let s = match env.step(a.as_action(), &mut obs) {
                Ok(s) => s,
                Err(e) => return (Failed, format!("seed {seed}, step {t}: {e}")),
            };
            if s.truncated && t < limit && early_truncation.is_none() {
                early_truncation = Some(t);
            }
            if s.terminated || s.truncated {
                if t == limit && !s.truncated {
                    return (Failed, format!("step {limit} is not truncated"));
                }
                break;
            }
            if t == limit {
                return (Failed, format!("step {limit} is not truncated"));
            }
        }
        if let Some(t) = early_truncation {
            return (
                Warned,
                format!(
                    "the env truncated at step {t} on its own, before the limit {limit}; \
                     the host applies the time limit"
                ),
            );
        }
        if env.elapsed() == limit {
            return (Passed, format!("truncated at step {limit}"));
        }
    }
    (
        Passed,
        format!("5 episodes terminated before the time limit {limit}; truncation not reached"),
    )
}

/// [`check_env`] on a plugin environment plus the checks that need the raw
/// ABI: id style, non-integral and wrongly sized discrete actions, and reset
/// without a seed. Instances are created with `config`.
pub fn check_plugin_env(ty: &PluginEnvType, config: &str) -> Vec<CheckResult> {
    check_plugin_env_observed(ty, config, &mut |_| {})
}

/// [`check_plugin_env`], reporting every check to `observe` as it starts and
/// ends (what `rwg check`'s child process streams to its parent).
pub fn check_plugin_env_observed(
    ty: &PluginEnvType,
    config: &str,
    observe: &mut dyn FnMut(CheckEvent<'_>),
) -> Vec<CheckResult> {
    // The id is known before any instance exists: name it in every result.
    let mut results = check_env_observed(|| ty.create(config), &mut |ev| match ev {
        CheckEvent::Started { name, .. } => observe(CheckEvent::Started {
            env: Some(ty.id()),
            name,
        }),
        CheckEvent::Finished(r) if r.env.is_none() => observe(CheckEvent::Finished(&CheckResult {
            env: Some(ty.id().to_string()),
            ..r.clone()
        })),
        ev => observe(ev),
    });
    for r in &mut results {
        r.env.get_or_insert_with(|| ty.id().to_string());
    }
    let mut r = Report::new(Some(ty.id().to_string()), observe);
    let id = ty.id();
    r.run("id", || {
        if let Err(e) = check_env_id(id) {
            return (Failed, e);
        }
        let name = id.rsplit('/').next().unwrap_or(id);
        let versioned = name.rsplit_once("-v").is_some_and(|(n, v)| {
            !n.is_empty() && !v.is_empty() && v.bytes().all(|b| b.is_ascii_digit())
        });
        match (id.contains('/'), versioned) {
            (true, true) => (Passed, "namespaced and versioned".into()),
            (false, _) => (
                Warned,
                "not namespaced: plugin ids should look like namespace/Name-v0".into(),
            ),
            (_, false) => (Warned, "no version suffix: ids should end in -vN".into()),
        }
    });
    let dim = ty.spec().obs_dim();
    if let Space::Discrete { .. } = ty.spec().action_space {
        r.run("raw discrete actions", || {
            let mut env = match ty.create(config) {
                Ok(e) => e,
                Err(e) => return (Failed, e.to_string()),
            };
            let mut obs = vec![0.0; dim];
            let mut accepted = Vec::new();
            for (what, a) in [
                ("0.5", &[0.5][..]),
                ("NaN", &[f64::NAN][..]),
                ("two values", &[0.0, 0.0][..]),
                ("no value", &[][..]),
            ] {
                if let Err(e) = env.reset(5, &mut obs) {
                    return (Failed, format!("reset failed: {e}"));
                }
                if env.step_raw(a, &mut obs).is_ok() {
                    accepted.push(what);
                }
            }
            if accepted.is_empty() {
                (Passed, "malformed discrete actions refused".into())
            } else {
                (
                    Failed,
                    format!(
                        "malformed discrete actions accepted: {}",
                        accepted.join(", ")
                    ),
                )
            }
        });
    }
    r.run("unseeded reset", || {
        let mut env = match ty.create(config) {
            Ok(e) => e,
            Err(e) => return (Failed, e.to_string()),
        };
        let mut obs = vec![0.0; dim];
        match env.reset_raw(0, 0, &mut obs) {
            Ok(()) => (Passed, "reset without a seed works".into()),
            Err(EnvError::Unsupported(_)) => (
                Passed,
                "reset without a seed is refused as unsupported (allowed)".into(),
            ),
            Err(e) => (Warned, format!("reset without a seed: {e}")),
        }
    });
    results.extend(r.results);
    results
}

/// Loads the plugin file and checks every environment in it with config `""`.
/// A file that does not load gives one failed `"load"` result with the reason.
/// Runs in this process: a crashing plugin crashes it (see the module docs).
pub fn check_plugin(path: &Path) -> Vec<CheckResult> {
    let mut quiet = |_: CheckEvent<'_>| {};
    let mut r = Report::new(None, &mut quiet);
    r.start("load");
    let plugin = match load_plugin(path) {
        Ok(p) => p,
        Err(e) => {
            r.add("load", Failed, e.to_string());
            return r.results;
        }
    };
    let info = plugin.info();
    r.add(
        "load",
        Passed,
        format!(
            "plugin '{}' {} (ABI {}.{}), {} environment(s)",
            info.id,
            info.version,
            info.abi.0,
            info.abi.1,
            plugin.envs().len()
        ),
    );
    for ty in plugin.envs() {
        r.results.extend(check_plugin_env(ty, ""));
    }
    r.results
}
