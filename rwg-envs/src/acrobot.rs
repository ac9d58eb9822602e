//! Acrobot-v1 (Gymnasium's `AcrobotEnv`, "book" dynamics, one RK4 step per action).
//!
//! Two links hang from a fixed pivot; only the joint between them is actuated.
//! Swing the tip of the lower link above a given height.
//!
//! - **Action space**: `Discrete(3)`: torque −1, 0 or +1 on the joint between
//!   the links.
//! - **Observation space**: `Box(6)`, float32: `cos θ1, sin θ1, cos θ2,
//!   sin θ2` in [-1, 1], `θ̇1` in [-4π, 4π], `θ̇2` in [-9π, 9π] (θ1 the first
//!   link's angle from hanging down, θ2 the second's relative to the first).
//! - **Rewards**: −1 for every step that does not terminate, 0 for the one
//!   that does.
//! - **Starting state**: θ1, θ2, θ̇1, θ̇2 each uniform in [-0.1, 0.1).
//! - **Episode end**: terminated once the tip rises more than one link length
//!   above the pivot, `−cos θ1 − cos(θ2 + θ1) > 1`; truncated at 500 steps.
//!   Reward threshold −100.
//! - **Versions**: v1 is the only one (Gymnasium's; gym's v1 has the same
//!   dynamics).
//! - **Source**: Gymnasium 1.4's `gymnasium/envs/classic_control/acrobot.py`
//!   (Gymnasium is MIT-licensed; that file keeps RLPy's header: Copyright
//!   2013 RLPy, BSD 3-Clause, by Christoph Dann: THIRD-PARTY-NOTICES). The
//!   golden trajectories `tests/data/Acrobot-v1.json`, recorded from
//!   Gymnasium, are replayed bit for bit by `rwg-envs/tests/golden.rs`.
//!
//! Every formula is written in Gymnasium's source order, because bit-exactness
//! needs the same association of every float64 operation:
//! - `cos(θ1 − π/2)` and `cos(θ1 + θ2 − π/2)` are evaluated literally, not as
//!   `sin`;
//! - `(m1·lc1 + m2·l1)·g` is `1.5 · 9.8 = 14.700000000000001`;
//! - Python's `x**2` on θ̇1, θ̇2 and d2 is libm `pow(x, 2.0)` ([`pow2`]);
//! - the angles are wrapped by *repeated* ±2π and the velocities clamped only
//!   after the RK4 step, with Python's `min(max(x, lo), hi)`.

use rwg_env::env::discrete_action;
use rwg_env::float::{f32r, pow2, sin, sin_cos};
use rwg_env::seeding::Pcg64;
use rwg_env::{Action, BoxSpace, EnvError, EnvSpec, Environment, Space, Step};
use std::f64::consts::PI;

/// Time step of one action (one RK4 step over `[0, DT]`).
pub(crate) const DT: f64 = 0.2;
/// Length of link 1.
pub(crate) const LINK_LENGTH_1: f64 = 1.0;
/// Mass of link 1.
pub(crate) const LINK_MASS_1: f64 = 1.0;
/// Mass of link 2.
pub(crate) const LINK_MASS_2: f64 = 1.0;
/// Position of the centre of mass of link 1.
pub(crate) const LINK_COM_POS_1: f64 = 0.5;
/// Position of the centre of mass of link 2.
pub(crate) const LINK_COM_POS_2: f64 = 0.5;
/// Moment of inertia of link 1.
pub(crate) const LINK_MOI_1: f64 = 1.0;
/// Moment of inertia of link 2.
pub(crate) const LINK_MOI_2: f64 = 1.0;
/// Gravity.
pub(crate) const G: f64 = 9.8;
/// Bound of θ̇1: `4 · π`.
pub(crate) const MAX_VEL_1: f64 = 4.0 * PI;
/// Bound of θ̇2: `9 · π`.
pub(crate) const MAX_VEL_2: f64 = 9.0 * PI;
/// Torque of actions 0, 1, 2.
pub(crate) const AVAIL_TORQUE: [f64; 3] = [-1.0, 0.0, 1.0];

/// Beyond this magnitude an angle is reduced with a floored remainder instead
/// of Gymnasium's repeated ±2π loop, which would need more than ~10⁵
/// iterations (or never end, for ±∞ or |x| ≳ 7·10¹⁶). Dynamics started from a
/// sane state never get near it: the velocities are clamped every step.
const WRAP_LOOP_MAX: f64 = 1.0e6;

/// The two-link underactuated pendulum swing-up task.
#[derive(Debug, Clone)]
pub struct Acrobot {
    spec: EnvSpec,
    /// `[θ1, θ2, θ̇1, θ̇2]`.
    state: [f64; 4],
    /// `(sin θ2, cos θ2)` of the current state: computed for the observation
    /// and needed again by the first RK4 stage of the next step.
    sin_cos_t2: (f64, f64),
}

impl Default for Acrobot {
    fn default() -> Self {
        Self::new()
    }
}

impl Acrobot {
    /// Acrobot-v1 (time limit 500, solved at −100).
    pub fn new() -> Self {
        let high = [1.0, 1.0, 1.0, 1.0, MAX_VEL_1, MAX_VEL_2].map(f32r);
        let spec = EnvSpec {
            id: "Acrobot-v1".into(),
            observation_space: Space::Box(BoxSpace::symmetric(&high)),
            action_space: Space::Discrete { n: 3 },
            max_episode_steps: Some(500),
            reward_threshold: Some(-100.0),
        };
        Acrobot {
            spec,
            state: [0.0; 4],
            sin_cos_t2: (0.0, 1.0),
        }
    }

    /// Writes `f32` of `[cos θ1, sin θ1, cos θ2, sin θ2, θ̇1, θ̇2]` for the
    /// current state, given `cos θ1` (which the caller already has).
    #[inline(always)]
    fn write_obs(&mut self, cos_t1: f64, obs: &mut [f64]) {
        let [t1, t2, dt1, dt2] = self.state;
        self.sin_cos_t2 = sin_cos(t2);
        let (sin_t2, cos_t2) = self.sin_cos_t2;
        let out = [cos_t1, sin(t1), cos_t2, sin_t2, dt1, dt2];
        for (o, v) in obs.iter_mut().zip(out) {
            *o = f32r(v);
        }
    }
}

/// The time derivative of `y = [θ1, θ2, θ̇1, θ̇2, τ]` (Gymnasium's `_dsdt`):
/// `[θ̇1, θ̇2, θ̈1, θ̈2, 0]`, every operation in source order.
#[inline(always)]
fn dsdt(y: &[f64; 5]) -> [f64; 5] {
    // sin θ2 and cos θ2 each occur several times; evaluate them once.
    dsdt_with(y, sin_cos(y[1]))
}

/// [`dsdt`] given `(sin θ2, cos θ2)` of `y`.
#[inline(always)]
fn dsdt_with(y: &[f64; 5], (sin_t2, cos_t2): (f64, f64)) -> [f64; 5] {
    const M1: f64 = LINK_MASS_1;
    const M2: f64 = LINK_MASS_2;
    const L1: f64 = LINK_LENGTH_1;
    const LC1: f64 = LINK_COM_POS_1;
    const LC2: f64 = LINK_COM_POS_2;
    const I1: f64 = LINK_MOI_1;
    const I2: f64 = LINK_MOI_2;
    // Squares of constants are exact, so `lc1**2` etc. equal these products.
    const LC1_SQ: f64 = LC1 * LC1;
    const LC2_SQ: f64 = LC2 * LC2;
    const L1_SQ: f64 = L1 * L1;
    let [theta1, theta2, dtheta1, dtheta2, a] = *y;

    // d1 = m1·lc1² + m2·(l1² + lc2² + 2·l1·lc2·cos θ2) + I1 + I2
    let d1 = M1 * LC1_SQ + M2 * (L1_SQ + LC2_SQ + 2.0 * L1 * LC2 * cos_t2) + I1 + I2;
    // d2 = m2·(lc2² + l1·lc2·cos θ2) + I2
    let d2 = M2 * (LC2_SQ + L1 * LC2 * cos_t2) + I2;
    // φ2 = m2·lc2·g·cos(θ1 + θ2 − π/2)
    let phi2 = M2 * LC2 * G * (theta1 + theta2 - PI / 2.0).cos();
    // φ1 = −m2·l1·lc2·θ̇2²·sin θ2 − 2·m2·l1·lc2·θ̇2·θ̇1·sin θ2
    //      + (m1·lc1 + m2·l1)·g·cos(θ1 − π/2) + φ2
    let phi1 = -M2 * L1 * LC2 * pow2(dtheta2) * sin_t2
        - 2.0 * M2 * L1 * LC2 * dtheta2 * dtheta1 * sin_t2
        + (M1 * LC1 + M2 * L1) * G * (theta1 - PI / 2.0).cos()
        + phi2;
    // θ̈2 = (τ + d2/d1·φ1 − m2·l1·lc2·θ̇1²·sin θ2 − φ2) / (m2·lc2² + I2 − d2²/d1)
    let ddtheta2 = (a + d2 / d1 * phi1 - M2 * L1 * LC2 * pow2(dtheta1) * sin_t2 - phi2)
        / (M2 * LC2_SQ + I2 - pow2(d2) / d1);
    // θ̈1 = −(d2·θ̈2 + φ1) / d1
    let ddtheta1 = -(d2 * ddtheta2 + phi1) / d1;
    [dtheta1, dtheta2, ddtheta1, ddtheta2, 0.0]
}

/// `y + h·k`, element-wise.
#[inline(always)]
fn axpy(y: &[f64; 5], h: f64, k: &[f64; 5]) -> [f64; 5] {
    std::array::from_fn(|i| y[i] + h * k[i])
}

/// One classical RK4 step of [`dsdt`] over `[0, DT]` (Gymnasium's `rk4` with
/// `t = [0, dt]`), given `(sin θ2, cos θ2)` of `y0`.
#[inline(always)]
fn rk4(y0: &[f64; 5], sin_cos_t2: (f64, f64)) -> [f64; 5] {
    let dt2 = DT / 2.0;
    let k1 = dsdt_with(y0, sin_cos_t2);
    let k2 = dsdt(&axpy(y0, dt2, &k1));
    let k3 = dsdt(&axpy(y0, dt2, &k2));
    let k4 = dsdt(&axpy(y0, DT, &k3));
    // `dt / 6.0` is computed first, then `y0 + h·(((k1 + 2·k2) + 2·k3) + k4)`.
    let h = DT / 6.0;
    std::array::from_fn(|i| y0[i] + h * (((k1[i] + 2.0 * k2[i]) + 2.0 * k3[i]) + k4[i]))
}

/// Gymnasium's `wrap(x, −π, π)`: repeated subtraction / addition of 2π (not a
/// modulo; exactly ±π stays). Magnitudes beyond [`WRAP_LOOP_MAX`] (and ±∞) are
/// reduced with a floored remainder instead, where Gymnasium would loop for
/// very long or forever.
#[inline(always)]
pub(crate) fn wrap(mut x: f64) -> f64 {
    if x.abs() > WRAP_LOOP_MAX {
        return (x + PI).rem_euclid(2.0 * PI) - PI;
    }
    while x > PI {
        x -= 2.0 * PI;
    }
    while x < -PI {
        x += 2.0 * PI;
    }
    x
}

/// Python's `min(max(x, lo), hi)`: like a clamp, but a NaN passes through
/// (Python keeps the first argument unless a later one compares greater/less).
#[inline(always)]
pub(crate) fn bound(x: f64, lo: f64, hi: f64) -> f64 {
    let m = if lo > x { lo } else { x };
    if hi < m {
        hi
    } else {
        m
    }
}

impl Environment for Acrobot {
    fn spec(&self) -> &EnvSpec {
        &self.spec
    }

    /// Four U[−0.1, 0.1) draws, cast to `f32` (Gymnasium's reset state is a
    /// float32 array).
    fn reset(&mut self, seed: u64, obs: &mut [f64]) -> Result<(), EnvError> {
        let mut rng = Pcg64::from_seed(seed);
        for s in &mut self.state {
            *s = f32r(rng.uniform(-0.1, 0.1));
        }
        self.write_obs(self.state[0].cos(), obs);
        Ok(())
    }

    #[inline]
    fn step(&mut self, action: Action<'_>, obs: &mut [f64]) -> Result<Step, EnvError> {
        let a = discrete_action(action, 3)?;
        let [t1, t2, dt1, dt2] = self.state;
        // sin/cos of θ2 were computed for the current state's observation.
        let ns = rk4(&[t1, t2, dt1, dt2, AVAIL_TORQUE[a]], self.sin_cos_t2);
        self.state = [
            wrap(ns[0]),
            wrap(ns[1]),
            bound(ns[2], -MAX_VEL_1, MAX_VEL_1),
            bound(ns[3], -MAX_VEL_2, MAX_VEL_2),
        ];
        let [t1, t2, _, _] = self.state;
        let cos_t1 = t1.cos();
        // `−cos θ1 − cos(θ2 + θ1) > 1.0`, strict.
        let terminated = -cos_t1 - (t2 + t1).cos() > 1.0;
        self.write_obs(cos_t1, obs);
        Ok(Step {
            reward: if terminated { 0.0 } else { -1.0 },
            terminated,
            truncated: false,
        })
    }

    array_state!(4, |env, obs| {
        env.write_obs(env.state[0].cos(), obs);
    });
}

#[cfg(test)]
mod tests {
    use super::*;

    /// At this angle glibc's `sincos` gives a sine one ulp below `sin`'s;
    /// Gymnasium (numpy's `sin`, libm's) gives `sin`'s, which the dynamics
    /// then use in float64.
    #[test]
    fn sin_theta2_is_libm_sin_not_sincos() {
        let t2 = f64::from_bits(0x3ffad1fb54442d18);
        let mut env = Acrobot::new();
        let mut obs = [0.0; 6];
        env.set_state(&[0.1, t2, 0.0, 0.0], &mut obs).unwrap();
        assert_eq!(env.sin_cos_t2.0.to_bits(), t2.sin().to_bits());
        assert_eq!(env.sin_cos_t2.1.to_bits(), t2.cos().to_bits());
        if cfg!(all(
            target_os = "linux",
            target_env = "gnu",
            target_arch = "x86_64"
        )) {
            assert_eq!(env.sin_cos_t2.0.to_bits(), 0x3fefd27acee550dc);
        }
    }

    /// Starts from `state`, applies `action`, returns the new state and step.
    fn step_from(state: [f64; 4], action: i64) -> ([f64; 4], Step) {
        let mut env = Acrobot::new();
        let mut obs = [0.0; 6];
        env.set_state(&state, &mut obs).unwrap();
        let s = env.step(Action::Discrete(action), &mut obs).unwrap();
        let mut out = [0.0; 4];
        env.state(&mut out).unwrap();
        (out, s)
    }

    fn assert_bits(ours: [f64; 4], expected: [f64; 4]) {
        for (a, b) in ours.iter().zip(expected) {
            assert_eq!(a.to_bits(), b.to_bits(), "{ours:?} != {expected:?}");
        }
    }

    // Expected values come from the pure-Python reference
    // (`acrobot_step` of the script that checked the golden trajectories of
    // `tests/data/` against Gymnasium), which is bit-exact with Gymnasium 1.4.

    #[test]
    fn velocities_are_clamped_after_the_step() {
        // Both velocities leave their bounds, upwards and downwards.
        let (s, r) = step_from([0.0, 0.0, 20.0, -40.0], 1);
        assert_bits(
            s,
            [
                -1.1107822510384695,
                1.7194039945148774,
                12.566370614359172,
                -28.274333882308138,
            ],
        );
        assert_eq!(s[2], MAX_VEL_1);
        assert_eq!(s[3], -MAX_VEL_2);
        assert_eq!((r.reward, r.terminated), (-1.0, false));

        let (s, r) = step_from([0.3, -0.2, -30.0, 50.0], 0);
        assert_bits(
            s,
            [
                -3.0292201864633483,
                0.5747351643613641,
                -12.566370614359172,
                28.274333882308138,
            ],
        );
        assert_eq!(s[2], -MAX_VEL_1);
        assert_eq!(s[3], MAX_VEL_2);
        assert_eq!((r.reward, r.terminated), (0.0, true));
    }

    #[test]
    fn angles_are_wrapped_into_minus_pi_pi() {
        // θ1 crosses +π and θ2 crosses −π during the step.
        let (s, _) = step_from([3.1, -3.1, 5.0, -5.0], 2);
        assert_bits(
            s,
            [
                -2.1620677095268555,
                2.128337016545381,
                5.368389021692291,
                -6.010080252199447,
            ],
        );
        // The mirror image: θ1 crosses −π, θ2 crosses +π.
        let (s, _) = step_from([-3.1, 3.1, -5.0, 5.0], 0);
        assert_bits(
            s,
            [
                2.1620677095268555,
                -2.128337016545381,
                -5.368389021692291,
                6.010080252199447,
            ],
        );
    }

    #[test]
    fn wrap_is_repeated_subtraction() {
        // Exactly ±π stays.
        assert_eq!(wrap(PI), PI);
        assert_eq!(wrap(-PI), -PI);
        // Several turns, one 2π at a time (not a modulo).
        let mut x = 7.5 * PI;
        while x > PI {
            x -= 2.0 * PI;
        }
        assert_eq!(wrap(7.5 * PI).to_bits(), x.to_bits());
        let w = wrap(-5.2 * PI);
        assert!((-PI..=PI).contains(&w));
        // Huge and non-finite angles terminate instead of looping forever.
        assert!((-PI..=PI).contains(&wrap(1e300)));
        assert!(wrap(f64::INFINITY).is_nan());
        assert!(wrap(f64::NAN).is_nan());
    }

    #[test]
    fn bound_is_pythons_min_max() {
        assert_eq!(bound(5.0, -1.0, 1.0), 1.0);
        assert_eq!(bound(-5.0, -1.0, 1.0), -1.0);
        assert_eq!(bound(0.5, -1.0, 1.0), 0.5);
        assert!(bound(f64::NAN, -1.0, 1.0).is_nan());
    }

    #[test]
    fn observation_of_a_state() {
        let mut env = Acrobot::new();
        let mut obs = [0.0; 6];
        env.set_state(&[0.5, -1.0, 30.0, -30.0], &mut obs).unwrap();
        let expected = [
            0.5f64.cos(),
            0.5f64.sin(),
            (-1.0f64).cos(),
            (-1.0f64).sin(),
            30.0,
            -30.0,
        ]
        .map(f32r);
        assert_eq!(obs, expected);
    }

    #[test]
    fn reset_state_is_float32_and_small() {
        let mut env = Acrobot::new();
        let mut obs = [0.0; 6];
        env.reset(42, &mut obs).unwrap();
        let mut s = [0.0; 4];
        env.state(&mut s).unwrap();
        for v in s {
            assert_eq!(f32r(v), v);
            assert!((-0.1..0.1).contains(&v));
        }
        let Space::Box(b) = &env.spec().observation_space else {
            panic!("observation space is not a box");
        };
        assert!(b.contains(&obs));
        assert_eq!(b.high[4], f32r(4.0 * PI));
        assert_eq!(b.high[5], f32r(9.0 * PI));
    }

    #[test]
    fn invalid_actions_are_errors() {
        let mut env = Acrobot::new();
        let mut obs = [0.0; 6];
        env.reset(0, &mut obs).unwrap();
        for a in [3, -1] {
            assert!(matches!(
                env.step(Action::Discrete(a), &mut obs),
                Err(EnvError::InvalidAction(_))
            ));
        }
        assert!(matches!(
            env.step(Action::Continuous(&[1.0]), &mut obs),
            Err(EnvError::InvalidAction(_))
        ));
    }

    #[test]
    fn wrong_state_length_is_an_error() {
        let mut env = Acrobot::new();
        let mut obs = [0.0; 6];
        assert_eq!(
            env.set_state(&[0.0; 3], &mut obs),
            Err(EnvError::StateLength {
                expected: 4,
                got: 3
            })
        );
        assert_eq!(
            env.set_state(&[0.0; 5], &mut obs),
            Err(EnvError::StateLength {
                expected: 4,
                got: 5
            })
        );
    }

    #[test]
    fn spec_matches_gymnasium() {
        let env = Acrobot::new();
        let spec = env.spec();
        assert_eq!(spec.id, "Acrobot-v1");
        assert_eq!(spec.obs_dim(), 6);
        assert_eq!(spec.action_space, Space::Discrete { n: 3 });
        assert_eq!(spec.max_episode_steps, Some(500));
        assert_eq!(spec.reward_threshold, Some(-100.0));
    }
}
