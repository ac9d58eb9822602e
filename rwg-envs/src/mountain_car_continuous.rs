//! MountainCarContinuous-v0 (Gymnasium's `Continuous_MountainCarEnv`).
//!
//! MountainCar with a continuous force: reach the flag on the right hill,
//! spending as little force as possible.
//!
//! - **Action space**: `Box(1)`: the force, in [-1, 1] (clipped to it; the
//!   cost uses the unclipped value).
//! - **Observation space**: `Box(2)`, float32: position [-1.2, 0.6], velocity
//!   [-0.07, 0.07].
//! - **Rewards**: `−0.1·a²` for every step (the raw action `a`), plus 100 on
//!   the step that reaches the goal.
//! - **Starting state**: position uniform in [-0.6, -0.4), velocity 0.
//! - **Episode end**: terminated when the position reaches 0.45 with a
//!   non-negative velocity; truncated at 999 steps. Reward threshold 90.
//! - **Versions**: v0 is the only one.
//! - **Source**: Gymnasium 1.4's
//!   `gymnasium/envs/classic_control/continuous_mountain_car.py` (Gymnasium
//!   is MIT-licensed: THIRD-PARTY-NOTICES). The golden trajectories
//!   `tests/data/MountainCarContinuous-v0.json`, recorded from Gymnasium,
//!   are replayed bit for bit by `rwg-envs/tests/golden.rs`.
//!
//! Gymnasium 1.4 stores the state as a float32 array after every step, and
//! under numpy 2 (NEP 50) the precision of each operation in `step` depends
//! on the *kind* of its operands: a Python float is "weak" and adopts the
//! other operand's precision, `np.float32 ⊕ np.float32` stays float32 and
//! anything with an `np.float64` becomes float64. This module follows those
//! rules literally with the small `Num` value type, which reproduces
//! Gymnasium bit for bit (`tests/data/MountainCarContinuous-v0.json` holds
//! trajectories with float32 and float64 actions).
//!
//! Kinds at the start of a step:
//! - the state `p`, `v` is float64 right after `reset` / `set_state` and
//!   float32 after any step;
//! - the action element is `np.float64` ([`ActionDtype::F64`]) or
//!   `np.float32` ([`ActionDtype::F32`], the action is rounded to f32 first);
//! - a clipped action (`min(max(a, -1.0), 1.0)` returning a bound) is the
//!   Python float ±1.0.
//!
//! Non-finite actions: a NaN action passes the clip unchanged (every
//! comparison with NaN is false, as in Python), so the state becomes NaN, the
//! reward is NaN and the episode does not terminate; later steps stay NaN.
//! Python does the same without an error. An action whose square overflows
//! (|a| > ~1.3e154 in the float64 path) makes Python's `math.pow` raise
//! `OverflowError`; here the reward is simply −inf. ±inf gives force ±1 and
//! reward −inf, as in Python.

use rwg_env::env::continuous_action;
use rwg_env::float::{f32r, pow2};
use rwg_env::{Action, ActionDtype, BoxSpace, EnvError, EnvSpec, Environment, Space, Step};

use crate::mountain_car::{observation_box, reset_state};

pub(crate) const MIN_ACTION: f64 = -1.0;
pub(crate) const MAX_ACTION: f64 = 1.0;
pub(crate) const MIN_POSITION: f64 = -1.2;
pub(crate) const MAX_POSITION: f64 = 0.6;
pub(crate) const MAX_SPEED: f64 = 0.07;
pub(crate) const GOAL_POSITION: f64 = 0.45;
pub(crate) const POWER: f64 = 0.0015;

/// The numpy-2 kind of a scalar.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Kind {
    /// A Python float: float64 value, adopts the other operand's precision.
    Py,
    /// `np.float64`.
    F64,
    /// `np.float32`.
    F32,
}

impl Kind {
    /// NEP 50: py ⊕ py → py; anything ⊕ f64 → f64; f32 ⊕ f32 or py → f32.
    #[inline(always)]
    fn promote(self, other: Kind) -> Kind {
        match (self, other) {
            (Kind::Py, Kind::Py) => Kind::Py,
            (Kind::F64, _) | (_, Kind::F64) => Kind::F64,
            _ => Kind::F32,
        }
    }
}

/// A scalar with its numpy-2 kind. The value is held as `f64`; a `F32` value
/// is always f32-representable.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Num {
    pub(crate) x: f64,
    pub(crate) kind: Kind,
}

impl Num {
    #[inline(always)]
    pub(crate) const fn py(x: f64) -> Num {
        Num { x, kind: Kind::Py }
    }

    #[inline(always)]
    pub(crate) const fn new(x: f64, kind: Kind) -> Num {
        Num { x, kind }
    }

    /// Applies a binary arithmetic op in the promoted precision: float32
    /// operands (a Python float is rounded to f32 first) give a float32 result.
    #[inline(always)]
    fn arith(self, o: Num, op64: fn(f64, f64) -> f64, op32: fn(f32, f32) -> f32) -> Num {
        match self.kind.promote(o.kind) {
            Kind::F32 => Num::new(op32(self.x as f32, o.x as f32) as f64, Kind::F32),
            k => Num::new(op64(self.x, o.x), k),
        }
    }

    /// Compares in the promoted precision (`np.float32` vs a Python float
    /// compares in float32).
    #[inline(always)]
    fn cmp(self, o: Num, op64: fn(&f64, &f64) -> bool, op32: fn(&f32, &f32) -> bool) -> bool {
        match self.kind.promote(o.kind) {
            Kind::F32 => op32(&(self.x as f32), &(o.x as f32)),
            _ => op64(&self.x, &o.x),
        }
    }

    #[inline(always)]
    pub(crate) fn gt(self, o: Num) -> bool {
        self.cmp(o, f64::gt, f32::gt)
    }

    #[inline(always)]
    pub(crate) fn lt(self, o: Num) -> bool {
        self.cmp(o, f64::lt, f32::lt)
    }

    #[inline(always)]
    pub(crate) fn ge(self, o: Num) -> bool {
        self.cmp(o, f64::ge, f32::ge)
    }

    #[inline(always)]
    pub(crate) fn eq(self, o: Num) -> bool {
        self.cmp(o, f64::eq, f32::eq)
    }
}

impl std::ops::Add for Num {
    type Output = Num;
    #[inline(always)]
    fn add(self, o: Num) -> Num {
        self.arith(o, |a, b| a + b, |a, b| a + b)
    }
}

impl std::ops::Sub for Num {
    type Output = Num;
    #[inline(always)]
    fn sub(self, o: Num) -> Num {
        self.arith(o, |a, b| a - b, |a, b| a - b)
    }
}

impl std::ops::Mul for Num {
    type Output = Num;
    #[inline(always)]
    fn mul(self, o: Num) -> Num {
        self.arith(o, |a, b| a * b, |a, b| a * b)
    }
}

/// The continuous mountain car: drive up the right hill with a force in
/// [−1, 1].
///
/// Reward per step: 100 on reaching position 0.45 with non-negative velocity
/// (which terminates the episode), minus 0.1·a² for the raw, unclipped action
/// a. The observation is the float32 state `[position, velocity]`.
#[derive(Debug, Clone)]
pub struct MountainCarContinuous {
    spec: EnvSpec,
    dtype: ActionDtype,
    /// `[position, velocity]`; f32-representable when `state_is_f32`.
    pub(crate) state: [f64; 2],
    /// False right after reset / `set_state` (Gymnasium's float64 reset
    /// array), true after any step (the float32 array `step` stores).
    pub(crate) state_is_f32: bool,
}

impl MountainCarContinuous {
    /// MountainCarContinuous-v0 (time limit 999, solved at 90) receiving
    /// actions of numpy dtype `dtype`.
    pub fn new(dtype: ActionDtype) -> Self {
        MountainCarContinuous {
            spec: EnvSpec {
                id: "MountainCarContinuous-v0".into(),
                observation_space: Space::Box(observation_box()),
                action_space: Space::Box(BoxSpace::new(vec![MIN_ACTION], vec![MAX_ACTION])),
                max_episode_steps: Some(999),
                reward_threshold: Some(90.0),
            },
            dtype,
            state: [0.0; 2],
            state_is_f32: false,
        }
    }

    /// The action dtype this instance emulates.
    pub fn action_dtype(&self) -> ActionDtype {
        self.dtype
    }

    /// Observation: the state as float32 (after a step it already is).
    #[inline]
    fn write_obs(&self, obs: &mut [f64]) {
        for (o, s) in obs.iter_mut().zip(self.state) {
            *o = f32r(s);
        }
    }
}

impl Environment for MountainCarContinuous {
    fn spec(&self) -> &EnvSpec {
        &self.spec
    }

    fn reset(&mut self, seed: u64, obs: &mut [f64]) -> Result<(), EnvError> {
        self.state = reset_state(seed);
        self.state_is_f32 = false;
        self.write_obs(obs);
        Ok(())
    }

    #[inline]
    fn step(&mut self, action: Action<'_>, obs: &mut [f64]) -> Result<Step, EnvError> {
        let raw = continuous_action(action, 1)?[0];
        // action[0]: an np.float32 or np.float64 scalar.
        let a = match self.dtype {
            ActionDtype::F64 => Num::new(raw, Kind::F64),
            ActionDtype::F32 => Num::new(f32r(raw), Kind::F32),
        };
        let state_kind = if self.state_is_f32 {
            Kind::F32
        } else {
            Kind::F64
        };
        let mut position = Num::new(self.state[0], state_kind);
        let mut velocity = Num::new(self.state[1], state_kind);

        // force = min(max(action[0], min_action), max_action): Python's max/min
        // return the first argument unless the bound compares greater/less.
        let mut force = a;
        if Num::py(MIN_ACTION).gt(force) {
            force = Num::py(MIN_ACTION);
        }
        if Num::py(MAX_ACTION).lt(force) {
            force = Num::py(MAX_ACTION);
        }

        // velocity += force * power - 0.0025 * math.cos(3 * position)
        let three_p = Num::py(3.0) * position;
        let gravity = Num::py(0.0025 * three_p.x.cos()); // math.cos: a Python float
        velocity = velocity + (force * Num::py(POWER) - gravity);
        if velocity.gt(Num::py(MAX_SPEED)) {
            velocity = Num::py(MAX_SPEED);
        }
        if velocity.lt(Num::py(-MAX_SPEED)) {
            velocity = Num::py(-MAX_SPEED);
        }
        position = position + velocity;
        if position.gt(Num::py(MAX_POSITION)) {
            position = Num::py(MAX_POSITION);
        }
        if position.lt(Num::py(MIN_POSITION)) {
            position = Num::py(MIN_POSITION);
        }
        // `velocity < 0` and `velocity >= goal_velocity` compare with the
        // integer 0, which is exact in any precision.
        if position.eq(Num::py(MIN_POSITION)) && velocity.x < 0.0 {
            velocity = Num::py(0.0);
        }

        let terminated = position.ge(Num::py(GOAL_POSITION)) && velocity.x >= 0.0;
        // reward = (100.0 if terminated else 0) - math.pow(action[0], 2) * 0.1,
        // with the raw, unclipped action.
        let mut reward = if terminated { 100.0 } else { 0.0 };
        reward -= pow2(a.x) * 0.1;

        // self.state = np.array([position, velocity], dtype=np.float32)
        self.state = [f32r(position.x), f32r(velocity.x)];
        self.state_is_f32 = true;
        self.write_obs(obs);
        Ok(Step {
            reward,
            terminated,
            truncated: false,
        })
    }

    // set_state starts from `state` as a reset would: the state is taken as
    // float64 (Gymnasium's reset array), whatever its values.
    array_state!(2, |env, obs| {
        env.state_is_f32 = false;
        env.write_obs(obs);
    });
}

#[cfg(test)]
mod tests {
    use super::*;
    use ActionDtype::{F32, F64};

    /// An env whose state is `[p, v]` of the given kind: float32 (as after a
    /// step; the values must be f32-representable) or float64 (as after reset).
    fn env_at(dtype: ActionDtype, p: f64, v: f64, f32_state: bool) -> MountainCarContinuous {
        let mut e = MountainCarContinuous::new(dtype);
        let mut obs = [0.0; 2];
        e.set_state(&[p, v], &mut obs).unwrap();
        if f32_state {
            assert_eq!([f32r(p), f32r(v)], [p, v], "not a float32 state");
            e.state_is_f32 = true;
        }
        e
    }

    /// One step from `[p, v]`; returns the new state and the step.
    fn step_at(dtype: ActionDtype, p: f64, v: f64, f32_state: bool, a: f64) -> ([f64; 2], Step) {
        let mut e = env_at(dtype, p, v, f32_state);
        let mut obs = [0.0; 2];
        let s = e.step(Action::Continuous(&[a]), &mut obs).unwrap();
        let mut st = [0.0; 2];
        e.state(&mut st).unwrap();
        assert!(
            st.iter().zip(obs).all(|(a, b)| a.to_bits() == b.to_bits()),
            "the observation is the float32 state"
        );
        (st, s)
    }

    // Expected values below come from `mcc_step`, a literal Python reference
    // of Gymnasium's step under NEP 50 (checked against
    // `tests/data/MountainCarContinuous-v0.json`), with the action rounded
    // to f32 first for the float32 dtype.

    /// f32(-0.52), f32(0.012): a float32 state as after a step.
    const P: f64 = -0.5199999809265137;
    const V: f64 = 0.012000000104308128;

    #[test]
    fn reward_uses_the_unclipped_action() {
        for dtype in [F64, F32] {
            let (st, s) = step_at(dtype, P, V, true, 5.0);
            assert_eq!(st, [-0.5065269470214844, 0.013473009690642357]);
            assert_eq!(s.reward, -2.5);
            assert!(!s.terminated);
            let (st, s) = step_at(dtype, P, V, true, -5.0);
            assert_eq!(st, [-0.5095269680023193, 0.010473009198904037]);
            assert_eq!(s.reward, -2.5);
        }
    }

    #[test]
    fn clipped_action_is_a_python_float() {
        // -5.0 clips to the Python float -1.0: the increment is a Python float
        // and `v + increment` is float32. An in-range np.float64 -1.0 makes it
        // float64, which rounds differently.
        let (st, _) = step_at(F64, P, V, true, -5.0);
        assert_eq!(st, [-0.5095269680023193, 0.010473009198904037]);
        let (st, s) = step_at(F64, P, V, true, -1.0);
        assert_eq!(st, [-0.5095269680023193, 0.010473010130226612]);
        assert_eq!(s.reward, -0.1);
        let (st, _) = step_at(F32, P, V, true, -1.0);
        assert_eq!(st, [-0.5095269680023193, 0.010473009198904037]);
    }

    #[test]
    fn f64_path_takes_any_f64_action() {
        let a = -0.7543673950140615; // not float32-representable
        let (st, s) = step_at(F64, P, V, true, a);
        assert_eq!(st, [-0.5091585516929626, 0.010841459035873413]);
        assert_eq!(s.reward, -0.05690701666603011);
        // The float32 dtype rounds the action first.
        let (st, s) = step_at(F32, P, V, true, a);
        assert_eq!(st, [-0.5091584920883179, 0.010841459035873413]);
        assert_eq!(s.reward, -0.05690701909849771);
    }

    #[test]
    fn first_step_after_reset_is_float64() {
        let p = -0.5234567891234567;
        let (st, s) = step_at(F64, p, 0.0, false, 0.3);
        assert_eq!(st, [-0.523007869720459, 0.0004489351122174412]);
        assert_eq!(s.reward, -0.009);
        let (st, s) = step_at(F32, p, 0.0, false, 0.3);
        assert_eq!(st, [-0.523007869720459, 0.0004489351122174412]);
        assert_eq!(s.reward, -0.009000000715255752);
        for dtype in [F64, F32] {
            let (st, s) = step_at(dtype, p, 0.0, false, 7.0);
            assert_eq!(st, [-0.5219578742980957, 0.0014989350456744432]);
            assert_eq!(s.reward, -4.9);
        }
    }

    #[test]
    fn speed_clip_gives_a_python_float_and_position_stays_float32() {
        // v is clipped to the Python float -0.07; p + v is then float32, a tie
        // that float64 arithmetic would round to -0.05392179265618324.
        let (p, v) = (0.016078205779194832, -0.06800000369548798);
        for (dtype, a, reward) in [(F32, -1.0, -0.1), (F64, -2.0, -0.4), (F64, -1.0, -0.1)] {
            let (st, s) = step_at(dtype, p, v, true, a);
            assert_eq!(
                st,
                [-0.05392179638147354, -0.07000000029802322],
                "{dtype:?} {a}"
            );
            assert_eq!(s.reward, reward);
        }
    }

    #[test]
    fn left_wall_stops_the_car() {
        // f32(-1.17), f32(-0.05)
        let (p, v) = (-1.1699999570846558, -0.05000000074505806);
        let (st, s) = step_at(F32, p, v, true, -1.0);
        assert_eq!(st, [-1.2000000476837158, 0.0]);
        assert_eq!(s.reward, -0.1);
        let (st, _) = step_at(F64, p, v, true, -0.5);
        assert_eq!(st, [-1.2000000476837158, 0.0]);
        // p + v lands exactly on f32(-1.2): equal to -1.2 in float32.
        let (st, _) = step_at(F32, -1.1907716989517212, -0.009999999776482582, true, -1.0);
        assert_eq!(st, [-1.2000000476837158, 0.0]);
        // Float64 path: p + v = -1.1999999995671493 > -1.2 is not at the wall,
        // although the stored float32 position is f32(-1.2).
        let (st, _) = step_at(F64, -1.1915193796157837, -0.009999933652579784, true, -0.5);
        assert_eq!(st, [-1.2000000476837158, -0.008480619639158249]);
    }

    #[test]
    fn goal_is_compared_in_the_state_precision() {
        // float32 state: p' == f32(0.45) >= 0.45 in float32.
        let (p, v) = (0.41926974058151245, 0.029999999329447746);
        for dtype in [F32, F64] {
            let (st, s) = step_at(dtype, p, v, true, 2.0);
            assert_eq!(st, [0.44999998807907104, 0.030730243772268295]);
            assert!(s.terminated);
            assert_eq!(s.reward, 99.6);
            // The same values as a float64 reset state: not yet at the goal.
            let (st, s) = step_at(dtype, p, v, false, 2.0);
            assert_eq!(st, [0.44999998807907104, 0.030730243772268295]);
            assert!(!s.terminated);
            assert_eq!(s.reward, -0.4);
        }
        // np.float64 action: p' = 0.44999998987343015 in float64 (< 0.45), so
        // no termination although the stored position is f32(0.45); the
        // float32 action compares in float32 and terminates.
        let (p, v) = (0.4200144112110138, 0.03000001795589924);
        let (st, s) = step_at(F64, p, v, true, 0.5);
        assert_eq!(st, [0.44999998807907104, 0.0299855787307024]);
        assert!(!s.terminated);
        assert_eq!(s.reward, -0.025);
        let (st, s) = step_at(F32, p, v, true, 0.5);
        assert_eq!(st, [0.44999998807907104, 0.0299855787307024]);
        assert!(s.terminated);
        assert_eq!(s.reward, 99.975);
    }

    #[test]
    fn invalid_action_length_is_refused() {
        let mut e = env_at(F64, P, V, true);
        let mut obs = [0.0; 2];
        assert!(e.step(Action::Continuous(&[]), &mut obs).is_err());
        assert!(e.step(Action::Continuous(&[0.1, 0.2]), &mut obs).is_err());
        assert!(e.step(Action::Discrete(1), &mut obs).is_err());
        // The state is untouched.
        let mut st = [0.0; 2];
        e.state(&mut st).unwrap();
        assert_eq!(st, [P, V]);
    }

    #[test]
    fn nan_action_gives_nan_state_and_reward_without_panicking() {
        for dtype in [F64, F32] {
            let mut e = env_at(dtype, P, V, true);
            let mut obs = [0.0; 2];
            let s = e.step(Action::Continuous(&[f64::NAN]), &mut obs).unwrap();
            assert!(obs.iter().all(|o| o.is_nan()));
            assert!(s.reward.is_nan());
            assert!(!s.terminated);
            let s = e.step(Action::Continuous(&[0.0]), &mut obs).unwrap();
            assert!(obs.iter().all(|o| o.is_nan()));
            assert_eq!(s.reward, 0.0);
            assert!(!s.terminated);
        }
    }

    #[test]
    fn huge_and_infinite_actions_clip_and_cost_infinity() {
        for a in [1e200, f64::INFINITY] {
            let (st, s) = step_at(F64, P, V, true, a);
            assert_eq!(st, [-0.5065269470214844, 0.013473009690642357]);
            assert_eq!(s.reward, f64::NEG_INFINITY);
        }
    }

    #[test]
    fn spec_and_reset() {
        let mut e = MountainCarContinuous::new(F32);
        assert_eq!(e.action_dtype(), F32);
        assert_eq!(e.spec().max_episode_steps, Some(999));
        assert_eq!(e.spec().reward_threshold, Some(90.0));
        let mut obs = [0.0; 2];
        e.reset(0, &mut obs).unwrap();
        let mut st = [0.0; 2];
        e.state(&mut st).unwrap();
        // tests/data/MountainCarContinuous-v0.json, seed 0
        assert_eq!(st, [-0.4726076625357092, 0.0]);
        assert_eq!(obs, [-0.47260767221450806, 0.0]);
        assert!(!e.state_is_f32);
    }
}
