//! The environment checks, one function per check, each on fresh instances
//! and the spec. They return a verdict and a message; running them in order
//! and reporting is [`super::check_env_observed`]'s job.

use std::panic::{catch_unwind, AssertUnwindSafe};

use super::report::panic_text;
use super::report::CheckStatus::{self, Failed, Passed, Warned};
use super::trajectory::{
    fmt_vec, in_space, interleaved, sample, solo, trajectory, Fresh, OwnedAction, Rng, Traj,
};
use rwg_env::env::{Action, EnvError, EnvSpec, Environment};
use rwg_env::space::Space;
use rwg_env::time_limit::TimeLimit;

/// A check's verdict and what was found.
pub(super) type Outcome = (CheckStatus, String);

/// An environment check: fresh instances and the spec in, a verdict out.
pub(super) type EnvCheck<E> = fn(Fresh<'_, E>, &EnvSpec) -> Outcome;

/// The checks run after "create" and "spaces" pass, in order, with their
/// names as reported.
pub(super) fn in_order<E: Environment>() -> [(&'static str, EnvCheck<E>); 10] {
    [
        ("step before reset", step_before_reset),
        ("reset", reset),
        ("reset determinism", reset_determinism),
        ("seed sensitivity", seed_sensitivity),
        ("rollout", rollout),
        ("trajectory determinism", trajectory_determinism),
        ("independent instances", independent_instances),
        ("threads", threads),
        ("truncation", truncation),
        ("invalid actions", invalid_actions),
    ]
}

/// Steps compared by the seed-sensitivity check.
pub(super) const SEED_STEPS: usize = 20;
/// Steps per episode in the rollout check.
pub(super) const ROLLOUT_STEPS: usize = 1000;
/// Time limits above this are not run to the end by the truncation check.
pub(super) const MAX_TRUNCATION_RUN: u32 = 100_000;

/// The 'spaces' check: well-formed spaces, finite action bounds, a sane
/// threshold and time limit.
pub(super) fn spaces(spec: &EnvSpec) -> Outcome {
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
        if t == 0.0 {
            // a C descriptor's field left at its zero initialiser says
            // "solved at 0.0", not "no solved score"
            warnings.push(
                "reward_threshold is exactly 0.0, so a mean score of 0 counts as solved; if the \
                 env has no solved score, declare none: NAN in a C descriptor \
                 (`.reward_threshold = NAN`), None in Rust"
                    .to_string(),
            );
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

/// The 'step before reset' check.
pub(super) fn step_before_reset<E: Environment>(fresh: Fresh<'_, E>, spec: &EnvSpec) -> Outcome {
    let dim = spec.obs_dim();
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
}

/// The 'reset' check.
pub(super) fn reset<E: Environment>(fresh: Fresh<'_, E>, spec: &EnvSpec) -> Outcome {
    let dim = spec.obs_dim();
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
}

/// The 'reset determinism' check.
pub(super) fn reset_determinism<E: Environment>(fresh: Fresh<'_, E>, spec: &EnvSpec) -> Outcome {
    let dim = spec.obs_dim();
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
}

/// The 'seed sensitivity' check.
pub(super) fn seed_sensitivity<E: Environment>(fresh: Fresh<'_, E>, _spec: &EnvSpec) -> Outcome {
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
}

/// The 'rollout' check.
pub(super) fn rollout<E: Environment>(fresh: Fresh<'_, E>, spec: &EnvSpec) -> Outcome {
    let dim = spec.obs_dim();
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
}

/// The 'trajectory determinism' check.
pub(super) fn trajectory_determinism<E: Environment>(
    fresh: Fresh<'_, E>,
    _spec: &EnvSpec,
) -> Outcome {
    match (solo(fresh, 11), solo(fresh, 11)) {
        (Ok(a), Ok(b)) if a == b => (
            Passed,
            "the same seed and actions give the same trajectory".into(),
        ),
        (Ok(_), Ok(_)) => (
            Failed,
            "the same seed and actions gave different trajectories on two instances".into(),
        ),
        (Err(m), _) | (_, Err(m)) => (Failed, m),
    }
}

/// The 'independent instances' check.
pub(super) fn independent_instances<E: Environment>(
    fresh: Fresh<'_, E>,
    spec: &EnvSpec,
) -> Outcome {
    // Two instances stepped alternately on one thread: hidden global
    // state shows up as a difference from the solo runs.
    let (want_a, want_b) = match (solo(fresh, 21), solo(fresh, 22)) {
        (Ok(a), Ok(b)) => (a, b),
        (Err(m), _) | (_, Err(m)) => return (Failed, m),
    };
    let (mut a, mut b) = match (fresh(), fresh()) {
        (Ok(a), Ok(b)) => (a, b),
        (Err(m), _) | (_, Err(m)) => return (Failed, m),
    };
    match interleaved(&mut a, &mut b, spec) {
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
}

/// The 'threads' check.
pub(super) fn threads<E: Environment>(fresh: Fresh<'_, E>, _spec: &EnvSpec) -> Outcome {
    let (want_a, want_b) = match (solo(fresh, 31), solo(fresh, 32)) {
        (Ok(a), Ok(b)) => (a, b),
        (Err(m), _) | (_, Err(m)) => return (Failed, m),
    };
    let (got_a, got_b) = std::thread::scope(|s| {
        let ha = s.spawn(|| catch_unwind(AssertUnwindSafe(|| solo(fresh, 31))));
        let hb = s.spawn(|| catch_unwind(AssertUnwindSafe(|| solo(fresh, 32))));
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
}

/// The 'invalid actions' check.
pub(super) fn invalid_actions<E: Environment>(fresh: Fresh<'_, E>, spec: &EnvSpec) -> Outcome {
    let dim = spec.obs_dim();
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
}

/// The 'truncation' check: the host's time limit truncates at the limit.
pub(super) fn truncation<E: Environment>(fresh: Fresh<'_, E>, spec: &EnvSpec) -> Outcome {
    let Some(limit) = spec.max_episode_steps else {
        return (
            Warned,
            "no time limit (max_episode_steps = 0): `rwg run` needs max_episode_steps in \
             the manifest's [[envs]] entry for this env"
                .into(),
        );
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
