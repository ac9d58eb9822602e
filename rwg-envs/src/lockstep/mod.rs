//! The built-in envs stepped in lockstep over `N` lanes (structure of
//! arrays): one [`ManyEnv::step_many`] call computes a step of every lane.
//!
//! Each env here is its scalar twin (`crate::pendulum` etc.) with only the
//! layout changed: every state variable is an array over lanes, the
//! arithmetic runs in plain loops over lanes in the scalar code's order of
//! operations (Rust neither contracts nor reorders `f64` operations, so a
//! vectorised loop gives the scalar bits), each libm use is one
//! [`rwg_env::lanes_math`] call for all lanes, and the branchy helpers
//! (`pow2`, `fmod_pos`, the f32 casts) run per lane as in the scalar env.
//! The time limit and the reset-before-step check are Gymnasium's
//! `TimeLimit` / `OrderEnforcing` per lane (`Clocks`), and actions are
//! checked with the scalar envs' own functions, so a lane gives the
//! observations, rewards, flags and errors of a `TimeLimit`-wrapped scalar
//! env bit for bit (`tests/lockstep.rs`).
//!
//! Lanes outside the mask are never written: a step may compute them (their
//! results are dropped), but their state, observation and flags stay.

// Loops over lanes index several arrays by the lane: the layout this module
// is about.
#![expect(
    clippy::needless_range_loop,
    reason = "lane loops index several arrays by the lane"
)]

use crate::EnvOptions;
use rwg_env::env::{continuous_action, discrete_action};
use rwg_env::{Action, EnvError, EnvSpec, Environment};

pub use rwg_env::many::ManyEnv;

pub mod acrobot;
pub mod cartpole;
pub mod mountain_car;
pub mod mountain_car_continuous;
pub mod pendulum;
mod wide;

/// A lockstep env whose lanes' states can be read (as the scalar env's
/// [`Environment::state`]), for tests and diagnostics.
pub trait LockstepEnv: ManyEnv {
    /// Length of one lane's state vector.
    fn state_len(&self) -> usize;

    /// Writes lane `lane`'s state (Gymnasium's `env.unwrapped.state`) to `out`.
    fn lane_state(&self, lane: usize, out: &mut [f64]);
}

/// The spec of `env` under a time limit override, as [`rwg_env::TimeLimit`]
/// makes it.
pub(crate) fn limited_spec(env: &impl Environment, max_episode_steps: Option<u32>) -> EnvSpec {
    let mut spec = env.spec().clone();
    if max_episode_steps.is_some() {
        spec.max_episode_steps = max_episode_steps;
    }
    spec
}

/// Gymnasium's `TimeLimit` (and `OrderEnforcing`) for each of `N` lanes:
/// what [`rwg_env::TimeLimit`] does for one env.
#[derive(Debug, Clone)]
pub(crate) struct Clocks<const N: usize> {
    max_steps: u32,
    elapsed: [u32; N],
    has_reset: [bool; N],
}

impl<const N: usize> Clocks<N> {
    /// Clocks for the time limit of `spec` (none: never truncated).
    pub(crate) fn new(spec: &EnvSpec) -> Self {
        Clocks {
            max_steps: spec.max_episode_steps.unwrap_or(u32::MAX),
            elapsed: [0; N],
            has_reset: [false; N],
        }
    }

    /// Lane `i` started an episode.
    #[inline]
    pub(crate) fn reset(&mut self, i: usize) {
        self.elapsed[i] = 0;
        self.has_reset[i] = true;
    }

    /// Counts a step of lane `i`; whether the time limit truncates it.
    #[inline]
    pub(crate) fn tick(&mut self, i: usize) -> bool {
        self.elapsed[i] = self.elapsed[i].saturating_add(1);
        self.elapsed[i] >= self.max_steps
    }

    /// Lane `i` may step (it was reset), or the scalar env's error.
    #[inline]
    fn ready(&self, i: usize) -> Result<(), EnvError> {
        if self.has_reset[i] {
            Ok(())
        } else {
            Err(EnvError::ResetNeeded)
        }
    }
}

/// A lane's discrete action: the integral double the [`ManyEnv`] contract
/// carries, as the `i64` the sampler hands a scalar env.
#[inline]
fn discrete_of(v: f64) -> Result<i64, EnvError> {
    let i = v as i64;
    if i as f64 == v {
        Ok(i)
    } else {
        Err(EnvError::InvalidAction(format!(
            "{v} is not an integral discrete action"
        )))
    }
}

/// The lanes of a step that run: masked, reset, with a valid action of a
/// `Discrete(n)` space (written to `out`). The others' errors go to
/// `on_fail` in lane order, with the scalar env's texts (the reset check
/// first, as `TimeLimit` does it before the env sees the action).
#[inline(always)]
pub(crate) fn gather_discrete<const N: usize>(
    clocks: &Clocks<N>,
    mask: &[u8],
    actions: &[f64],
    n: usize,
    out: &mut [usize; N],
    on_fail: &mut dyn FnMut(usize, EnvError),
) -> [bool; N] {
    let mut live = [false; N];
    for i in 0..N {
        if mask[i] != 1 {
            continue;
        }
        let a = clocks
            .ready(i)
            .and_then(|()| discrete_of(actions[i]))
            .and_then(|a| discrete_action(Action::Discrete(a), n));
        match a {
            Ok(a) => {
                out[i] = a;
                live[i] = true;
            }
            Err(e) => on_fail(i, e),
        }
    }
    live
}

/// [`gather_discrete`] for a one-dimensional Box action space: lane `i`'s
/// action is `actions[i]`.
#[inline]
pub(crate) fn gather_continuous1<const N: usize>(
    clocks: &Clocks<N>,
    mask: &[u8],
    actions: &[f64],
    out: &mut [f64; N],
    on_fail: &mut dyn FnMut(usize, EnvError),
) -> [bool; N] {
    let mut live = [false; N];
    for i in 0..N {
        if mask[i] != 1 {
            continue;
        }
        let a = clocks
            .ready(i)
            .and_then(|()| continuous_action(Action::Continuous(&actions[i..i + 1]), 1));
        match a {
            Ok(a) => {
                out[i] = a[0];
                live[i] = true;
            }
            Err(e) => on_fail(i, e),
        }
    }
    live
}

/// Writes the flags of the lanes that ran: `terminated[i]` as given and
/// `truncated[i]` by the lane's clock.
#[inline(always)]
pub(crate) fn finish_flags<const N: usize>(
    clocks: &mut Clocks<N>,
    live: &[bool; N],
    term: &[bool; N],
    terminated: &mut [u8],
    truncated: &mut [u8],
) {
    for i in 0..N {
        if live[i] {
            terminated[i] = u8::from(term[i]);
            truncated[i] = u8::from(clocks.tick(i));
        }
    }
}

/// A step's per-lane buffers as arrays of `N` lanes, each length checked
/// once (a wrong one is a caller's bug, as in [`check_lens`]), so that the
/// step bodies' lane loops index them without a bounds check per lane.
/// Inlined into the sampler, the built-in envs' buffers are the worker's
/// arrays and the checks vanish; in a plugin's vector env they are slices of
/// the host's buffers, whose lengths are known at run time only (without
/// this, its copy of CartPole's step ran about 120 more instructions per
/// call than the built-in's). Every lockstep env has one action value per
/// lane (a `Discrete` space or a one-dimensional `Box`).
#[inline(always)]
#[expect(
    clippy::type_complexity,
    reason = "the five per-lane buffers as arrays of the lane count"
)]
pub(crate) fn lane_arrays<'a, const N: usize>(
    mask: &'a [u8],
    actions: &'a [f64],
    rewards: &'a mut [f64],
    terminated: &'a mut [u8],
    truncated: &'a mut [u8],
) -> (
    &'a [u8; N],
    &'a [f64; N],
    &'a mut [f64; N],
    &'a mut [u8; N],
    &'a mut [u8; N],
) {
    (
        lanes(mask, "mask"),
        lanes(actions, "actions"),
        lanes_mut(rewards, "rewards"),
        lanes_mut(terminated, "terminated flags"),
        lanes_mut(truncated, "truncated flags"),
    )
}

/// `values` as an array of `N` lanes; a wrong length panics naming `what`.
#[inline(always)]
fn lanes<'a, T, const N: usize>(values: &'a [T], what: &str) -> &'a [T; N] {
    values
        .try_into()
        .unwrap_or_else(|_| panic!("{what} of {N} lanes, not {}", values.len()))
}

/// [`lanes`] for a buffer the step writes.
#[inline(always)]
fn lanes_mut<'a, T, const N: usize>(values: &'a mut [T], what: &str) -> &'a mut [T; N] {
    let len = values.len();
    values
        .try_into()
        .unwrap_or_else(|_| panic!("{what} of {N} lanes, not {len}"))
}

/// Checks the buffer lengths of a call over `n` lanes (a wrong length is a
/// caller's bug, as in the plugin host).
#[inline]
pub(crate) fn check_lens(n: usize, mask: &[u8], obs: &[f64], obs_dim: usize) {
    assert_eq!(mask.len(), n, "mask of {n} lanes");
    assert_eq!(obs.len(), n * obs_dim, "observations of {n} lanes");
}

/// `out[i] = pow2(x[i])` ([`rwg_env::float::pow2`], Python's `x**2`) for
/// every lane: [`rwg_env::lanes_math::pow2_lanes`] (the fast path's test
/// four lanes at a time, the vector port of glibc's `pow` for the squares it
/// leaves, about 4 %), so the bits are `pow2`'s.
#[inline(always)]
pub(crate) fn pow2_lanes<const N: usize>(x: &[f64; N], out: &mut [f64; N]) {
    rwg_env::lanes_math::pow2_lanes(x, out);
}

/// Receives a concrete lockstep environment type from
/// [`crate::visit_lockstep`].
pub trait LockstepVisitor {
    /// What the visitor returns.
    type Output;
    /// Called with the lockstep env (its time limit applied per lane).
    fn visit<M: LockstepEnv + Clone + Send + Sync + 'static>(self, env: M) -> Self::Output;
}

/// Builds the lockstep version of the built-in env `id` over `N` lanes
/// (with `opts`' action dtype and time limit) and hands it to `v`; gives `v`
/// back when `id` has no lockstep version (or is not built in), so the
/// caller can fall back to [`crate::visit`].
pub fn visit_lockstep<const N: usize, V: LockstepVisitor>(
    id: &str,
    opts: &EnvOptions,
    v: V,
) -> Result<V::Output, V> {
    let limit = opts.max_episode_steps;
    let dtype = opts.action_dtype;
    Ok(match id {
        "CartPole-v0" => v.visit(cartpole::CartPoleLanes::<N>::v0(limit)),
        "CartPole-v1" => v.visit(cartpole::CartPoleLanes::<N>::v1(limit)),
        "Acrobot-v1" => v.visit(acrobot::AcrobotLanes::<N>::new(limit)),
        "Pendulum-v0" => v.visit(pendulum::PendulumLanes::<N>::v0(dtype, limit)),
        "Pendulum-v1" => v.visit(pendulum::PendulumLanes::<N>::v1(dtype, limit)),
        "MountainCar-v0" => v.visit(mountain_car::MountainCarLanes::<N>::new(limit)),
        "MountainCarContinuous-v0" => {
            v.visit(mountain_car_continuous::MountainCarContinuousLanes::<N>::new(dtype, limit))
        }
        _ => return Err(v),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pow2_lanes_gives_pow2_bits() {
        use rwg_env::float::pow2;
        let mut s: u64 = 0x9e37_79b9_7f4a_7c15;
        let mut xs = vec![
            0.0,
            -0.0,
            1e-300,
            1e-200,
            1e-150,
            1e150,
            1e160,
            8.673617379884035e-19, // 2^-60: the port's ends
            4294967296.0,
            -4294967296.0,
            4294967297.0,
            8.6e-19,
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::MIN_POSITIVE,
            5e-324,
            f64::MAX,
            0.6800728488750654,
        ];
        for _ in 0..400_000 {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            // Magnitudes 2^-80 .. 2^80, both signs.
            let m = f64::from_bits((s >> 12) | 0x3ff0_0000_0000_0000) - 1.0;
            let e = ((s >> 4) % 161) as i32 - 80;
            let sign = if s & 1 == 0 { 1.0 } else { -1.0 };
            xs.push(sign * (1.0 + m) * 2f64.powi(e));
        }
        for chunk in xs.chunks(16) {
            let mut x = [0.0; 16];
            x[..chunk.len()].copy_from_slice(chunk);
            let mut out = [0.0; 16];
            pow2_lanes(&x, &mut out);
            for (a, b) in x.iter().zip(out) {
                assert_eq!(b.to_bits(), pow2(*a).to_bits(), "pow2({a:e})");
            }
        }
    }

    #[test]
    fn discrete_actions_must_be_integral() {
        assert_eq!(discrete_of(2.0), Ok(2));
        assert_eq!(discrete_of(-0.0), Ok(0));
        assert_eq!(discrete_of(-1.0), Ok(-1));
        assert!(discrete_of(0.5).is_err());
        assert!(discrete_of(f64::NAN).is_err());
        assert!(discrete_of(1e300).is_err());
    }

    #[test]
    fn gather_reports_in_lane_order_with_scalar_texts() {
        let mut clocks = Clocks::<4>::new(
            &crate::make("CartPole-v0", &Default::default())
                .unwrap()
                .spec()
                .clone(),
        );
        clocks.reset(0);
        clocks.reset(1);
        clocks.reset(3);
        let mut errs = Vec::new();
        let mut out = [0usize; 4];
        let live = gather_discrete(
            &clocks,
            &[1, 1, 1, 0],
            &[1.0, 5.0, 0.0, 1.0],
            2,
            &mut out,
            &mut |i, e| errs.push((i, e.to_string())),
        );
        assert_eq!(live, [true, false, false, false]);
        assert_eq!(out[0], 1);
        assert_eq!(
            errs,
            vec![
                (
                    1,
                    "invalid action: 5 is outside the action space Discrete(2) (valid: 0..=1)"
                        .to_string()
                ),
                (2, "step called before reset".to_string()),
            ]
        );
    }

    #[test]
    fn clocks_truncate_at_the_limit() {
        let mut spec = crate::make("CartPole-v0", &Default::default())
            .unwrap()
            .spec()
            .clone();
        spec.max_episode_steps = Some(2);
        let mut c = Clocks::<1>::new(&spec);
        c.reset(0);
        assert!(!c.tick(0));
        assert!(c.tick(0));
        assert!(c.tick(0));
        c.reset(0);
        assert!(!c.tick(0));
    }

    #[test]
    fn a_step_names_the_buffer_of_the_wrong_length() {
        use crate::lockstep::cartpole::CartPoleLanes;
        let mut env = CartPoleLanes::<4>::v0(None);
        let (mut obs, mut te, mut tr) = ([0.0; 16], [0u8; 4], [0u8; 4]);
        let mut on_fail = |_: usize, _: EnvError| {};
        let mut step = |rewards: &mut [f64], actions: &[f64]| {
            std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                env.step_many(
                    &[0; 4],
                    actions,
                    &mut obs,
                    rewards,
                    &mut te,
                    &mut tr,
                    &mut on_fail,
                )
            }))
            .map_err(|p| p.downcast_ref::<String>().cloned().unwrap_or_default())
        };
        assert_eq!(
            step(&mut [0.0; 3], &[0.0; 4]),
            Err("rewards of 4 lanes, not 3".to_string())
        );
        assert_eq!(
            step(&mut [0.0; 4], &[0.0; 8]),
            Err("actions of 4 lanes, not 8".to_string())
        );
        assert_eq!(step(&mut [0.0; 4], &[0.0; 4]), Ok(()));
    }
}
