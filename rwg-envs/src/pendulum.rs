//! Pendulum-v1 (Gymnasium 1.4's `PendulumEnv`) and Pendulum-v0 (gym 0.17.2's).
//!
//! Swing a pendulum up from a random position and hold it upright.
//!
//! - **Action space**: `Box(1)`: the torque, in [-2, 2] (clipped to it).
//! - **Observation space**: `Box(3)`: `cos θ, sin θ` in [-1, 1] and `θ̇` in
//!   [-8, 8], with θ = 0 upright; float32 in v1, float64 in v0.
//! - **Rewards**: `−(θ² + 0.1·θ̇² + 0.001·torque²)` with θ normalised to
//!   [-π, π]: from about −16.27 up to 0 (upright, still, no torque).
//! - **Starting state**: θ uniform in [-π, π), θ̇ uniform in [-1, 1).
//! - **Episode end**: never terminated; truncated at 200 steps. No reward
//!   threshold.
//! - **Source**: Gymnasium 1.4's `gymnasium/envs/classic_control/pendulum.py`
//!   (v1) and gym 0.17.2's `gym/envs/classic_control/pendulum.py` (v0), both
//!   MIT-licensed (THIRD-PARTY-NOTICES). The golden trajectories
//!   `tests/data/Pendulum-v1.json` (recorded from Gymnasium) and
//!   `tests/data/Pendulum-v0.json` (from a port of gym 0.17.2 checked against
//!   it) are replayed bit for bit by `rwg-envs/tests/golden.rs`.
//!
//! The state is `[theta, theta_dot]`; theta is never wrapped. The two
//! versions differ:
//!
//! - **v1** clips the new speed to [-8, 8] *before* integrating theta with it,
//!   writes float32 observations and, given a float32 action array, computes
//!   the two action terms in float32 (numpy 2's promotion rules).
//! - **v0** integrates theta with the *unclipped* new speed and clips
//!   afterwards, writes the gravity term as `-15 sin(theta + pi)`, returns
//!   float64 observations, does all arithmetic in float64, and seeds its reset
//!   with gym 0.17.2's SHA-512 + MT19937 scheme.

use rwg_env::env::continuous_action;
use rwg_env::float::{f32r, fmod_pos, pow2, pow2_f32, sin_cos};
use rwg_env::seeding::{gym_np_random, Pcg64};
use rwg_env::{Action, ActionDtype, BoxSpace, EnvError, EnvSpec, Environment, Space, Step};
use std::f64::consts::PI;

pub(crate) const MAX_SPEED: f64 = 8.0;
pub(crate) const MAX_TORQUE: f64 = 2.0;
pub(crate) const DT: f64 = 0.05;
pub(crate) const G: f64 = 10.0;
pub(crate) const M: f64 = 1.0;
pub(crate) const L: f64 = 1.0;

/// `((x + pi) mod 2pi) - pi` with Python's floored modulo (the remainder has
/// the sign of 2pi, so it lies in [0, 2pi)).
#[inline]
pub fn angle_normalize(x: f64) -> f64 {
    // `%`, computed exactly but faster than the library's fmod.
    floored(fmod_pos(x + PI, 2.0 * PI)) - PI
}

/// Python's floored `x % 2pi` from C's `fmod(x, 2pi)` remainder `r`: the
/// sign of 2pi, and +0.0 for a zero remainder.
#[inline(always)]
pub(crate) fn floored(r: f64) -> f64 {
    if r < 0.0 {
        r + 2.0 * PI
    } else if r == 0.0 {
        0.0
    } else {
        r
    }
}

/// `np.clip(x, lo, hi)`: NaN stays NaN.
#[inline(always)]
pub(crate) fn clip(x: f64, lo: f64, hi: f64) -> f64 {
    x.clamp(lo, hi)
}

/// Which implementation the env follows.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Version {
    /// gym 0.17.2's `Pendulum-v0`.
    V0,
    /// Gymnasium 1.4's `Pendulum-v1`.
    V1,
}

/// The inverted-pendulum swing-up task, version 0 or 1.
#[derive(Debug, Clone)]
pub struct Pendulum {
    spec: EnvSpec,
    version: Version,
    dtype: ActionDtype,
    /// `[theta, theta_dot]`.
    state: [f64; 2],
    /// `sin(theta)` of the current state: the observation's value, which
    /// v1's next step needs again (glibc's `sin`, whether computed alone or
    /// with `cos` by `sincos`, gives the same bits).
    sin_th: f64,
}

impl Pendulum {
    /// Pendulum-v1 as in Gymnasium 1.4, with actions handed to `step()` as a
    /// numpy array of `dtype`.
    ///
    /// - [`ActionDtype::F64`]: Gymnasium's float64-action path for any `f64`
    ///   (all arithmetic in float64, `u**2` = libm `pow`).
    /// - [`ActionDtype::F32`]: the action is rounded to f32 (as
    ///   `np.array([a], dtype=np.float32)` does), and `3.0*u` and
    ///   `0.001*(u**2)` are computed in float32, with `u**2` = libm `powf`.
    ///
    /// `reset(seed)` equals Gymnasium's `env.reset(seed=seed)`.
    pub fn v1(dtype: ActionDtype) -> Self {
        Self::with_version(Version::V1, "Pendulum-v1", dtype)
    }

    /// Pendulum-v0 as in gym 0.17.2 (under numpy 1.x: float64 throughout).
    ///
    /// With [`ActionDtype::F32`] the action is rounded to f32 first, as a
    /// float32 action array would be; the arithmetic is float64 either way.
    ///
    /// `reset(seed)` equals gym 0.17.2's `env.seed(seed); env.reset()`
    /// (SHA-512-hashed seed, MT19937 `RandomState`, `uniform`), bit for bit.
    pub fn v0(dtype: ActionDtype) -> Self {
        Self::with_version(Version::V0, "Pendulum-v0", dtype)
    }

    fn with_version(version: Version, id: &str, dtype: ActionDtype) -> Self {
        let spec = EnvSpec {
            id: id.into(),
            observation_space: Space::Box(BoxSpace::symmetric(&[1.0, 1.0, MAX_SPEED])),
            action_space: Space::Box(BoxSpace::symmetric(&[MAX_TORQUE])),
            max_episode_steps: Some(200),
            reward_threshold: None,
        };
        Pendulum {
            spec,
            version,
            dtype,
            state: [0.0; 2],
            sin_th: 0.0,
        }
    }

    /// The action dtype this env reproduces.
    pub fn action_dtype(&self) -> ActionDtype {
        self.dtype
    }

    /// `[cos theta, sin theta, theta_dot]`: cast to float32 in v1, float64 in v0.
    #[inline]
    fn write_obs(&mut self, obs: &mut [f64]) {
        let [th, thdot] = self.state;
        let (sin_th, cos_th) = sin_cos(th);
        self.sin_th = sin_th;
        let o = [cos_th, sin_th, thdot];
        for (dst, v) in obs.iter_mut().zip(o) {
            *dst = match self.version {
                Version::V1 => f32r(v),
                Version::V0 => v,
            };
        }
    }

    /// Gymnasium 1.4's step: returns the new state and the cost.
    #[inline]
    fn transition_v1(&self, a: f64) -> ([f64; 2], f64) {
        let [th, thdot] = self.state;
        // The two action terms, 3/(m l^2) * u and 0.001 * u^2.
        let (torque_term, u_cost) = match self.dtype {
            ActionDtype::F64 => {
                let u = clip(a, -MAX_TORQUE, MAX_TORQUE);
                (3.0 / (M * L * L) * u, 0.001 * pow2(u))
            }
            ActionDtype::F32 => {
                // u is an np.float32 scalar; numpy 2 computes `Python float *
                // u` in float32 (the float rounded to f32 first).
                let u = (a as f32).clamp(-MAX_TORQUE as f32, MAX_TORQUE as f32);
                let three = (3.0 / (M * L * L)) as f32;
                ((three * u) as f64, (0.001f32 * pow2_f32(u)) as f64)
            }
        };
        let costs = pow2(angle_normalize(th)) + 0.1 * pow2(thdot) + u_cost;
        // sin(th), computed for the observation of this state.
        let newthdot = thdot + (3.0 * G / (2.0 * L) * self.sin_th + torque_term) * DT;
        let newthdot = clip(newthdot, -MAX_SPEED, MAX_SPEED);
        let newth = th + newthdot * DT;
        ([newth, newthdot], costs)
    }

    /// gym 0.17.2's step: returns the new state and the cost.
    #[inline]
    fn transition_v0(&self, a: f64) -> ([f64; 2], f64) {
        let [th, thdot] = self.state;
        let a = match self.dtype {
            ActionDtype::F64 => a,
            ActionDtype::F32 => f32r(a),
        };
        let u = clip(a, -MAX_TORQUE, MAX_TORQUE);
        let costs = pow2(angle_normalize(th)) + 0.1 * pow2(thdot) + 0.001 * pow2(u);
        let newthdot =
            thdot + (-3.0 * G / (2.0 * L) * (th + PI).sin() + 3.0 / (M * L * L) * u) * DT;
        let newth = th + newthdot * DT;
        let newthdot = clip(newthdot, -MAX_SPEED, MAX_SPEED);
        ([newth, newthdot], costs)
    }
}

impl Environment for Pendulum {
    fn spec(&self) -> &EnvSpec {
        &self.spec
    }

    fn reset(&mut self, seed: u64, obs: &mut [f64]) -> Result<(), EnvError> {
        // uniform(low=[-pi, -1], high=[pi, 1]): theta, then theta_dot.
        self.state = match self.version {
            Version::V1 => {
                let mut rng = Pcg64::from_seed(seed);
                [rng.uniform(-PI, PI), rng.uniform(-1.0, 1.0)]
            }
            Version::V0 => {
                let mut rng = gym_np_random(seed);
                [rng.uniform(-PI, PI), rng.uniform(-1.0, 1.0)]
            }
        };
        self.write_obs(obs);
        Ok(())
    }

    #[inline]
    fn step(&mut self, action: Action<'_>, obs: &mut [f64]) -> Result<Step, EnvError> {
        let a = continuous_action(action, 1)?[0];
        let (state, costs) = match self.version {
            Version::V1 => self.transition_v1(a),
            Version::V0 => self.transition_v0(a),
        };
        self.state = state;
        self.write_obs(obs);
        Ok(Step {
            reward: -costs,
            terminated: false,
            truncated: false,
        })
    }

    array_state!(2, |env, obs| {
        env.write_obs(obs);
    });
}

#[cfg(test)]
mod tests {
    use super::*;
    use rwg_env::float::pow2_libm;

    /// At this angle glibc's `sincos` gives a sine one ulp below `sin`'s;
    /// Gymnasium (numpy's `sin`, libm's) gives `sin`'s: 0x3fefd27acee550dc.
    #[test]
    fn observation_sine_is_libm_sin_not_sincos() {
        let th = f64::from_bits(0x3ffad1fb54442d18);
        let mut env = Pendulum::v0(ActionDtype::F32);
        let mut obs = [0.0; 3];
        env.set_state(&[th, 0.0], &mut obs).unwrap();
        assert_eq!(obs[1].to_bits(), th.sin().to_bits());
        if cfg!(all(
            target_os = "linux",
            target_env = "gnu",
            target_arch = "x86_64"
        )) {
            assert_eq!(obs[1].to_bits(), 0x3fefd27acee550dc);
        }
    }

    fn from_state(mut env: Pendulum, state: [f64; 2]) -> Pendulum {
        let mut obs = [0.0; 3];
        env.set_state(&state, &mut obs).unwrap();
        env
    }

    fn step(env: &mut Pendulum, a: f64) -> ([f64; 2], [f64; 3], f64) {
        let mut obs = [0.0; 3];
        let s = env.step(Action::Continuous(&[a]), &mut obs).unwrap();
        assert!(!s.terminated && !s.truncated);
        (env.state, obs, s.reward)
    }

    // Values from Python: ((x + math.pi) % (2 * math.pi)) - math.pi
    #[test]
    fn angle_normalize_is_floored() {
        let cases = [
            (-10.0, 2.5663706143591725),
            (10.0, -2.5663706143591725),
            (-PI, -PI),
            (PI, -PI),
            (3.5, -2.7831853071795862),
            (-3.5, 2.7831853071795862),
            (-1e-300, 0.0),
            (100.25, -0.28096491487337616),
        ];
        for (x, want) in cases {
            assert_eq!(angle_normalize(x).to_bits(), want.to_bits(), "x = {x}");
        }
    }

    /// theta = pi/2 (gravity pushes with 15), speed 7.9 and torque +2: the
    /// new speed 7.9 + (15 + 6) * 0.05 = 8.95 exceeds the limit.
    #[test]
    fn speed_clip_order_v1_vs_v0() {
        let th = PI / 2.0;
        let start = [th, 7.9];

        let mut v1 = from_state(Pendulum::v1(ActionDtype::F64), start);
        let ([newth, newthdot], obs, _) = step(&mut v1, 2.0);
        assert_eq!(newthdot, 8.0);
        assert_eq!(newth, th + 8.0 * DT); // integrated with the clipped speed
        assert_eq!(obs[2], 8.0);

        let mut v0 = from_state(Pendulum::v0(ActionDtype::F64), start);
        let unclipped = 7.9 + (-15.0 * (th + PI).sin() + 3.0 * 2.0) * DT;
        assert!(unclipped > 8.5);
        let ([newth, newthdot], obs, _) = step(&mut v0, 2.0);
        assert_eq!(newthdot, 8.0);
        assert_eq!(newth, th + unclipped * DT); // integrated before clipping
        assert_eq!(obs, [newth.cos(), newth.sin(), 8.0]); // float64 obs

        // The same on the negative side.
        let mut v1 = from_state(Pendulum::v1(ActionDtype::F32), [-th, -7.9]);
        let ([newth, newthdot], _, _) = step(&mut v1, -5.0);
        assert_eq!(newthdot, -8.0);
        assert_eq!(newth, -th - 8.0 * DT);
    }

    #[test]
    fn actions_are_clipped_to_the_torque_bound() {
        for make in [Pendulum::v0, Pendulum::v1] {
            for dtype in [ActionDtype::F64, ActionDtype::F32] {
                for (a, bound) in [
                    (5.0, 2.0),
                    (-2.0001, -2.0),
                    (1e300, 2.0),
                    (f64::NEG_INFINITY, -2.0),
                ] {
                    let start = [0.3, -0.2];
                    let mut e1 = from_state(make(dtype), start);
                    let mut e2 = from_state(make(dtype), start);
                    let r1 = step(&mut e1, a);
                    let r2 = step(&mut e2, bound);
                    assert_eq!(r1, r2, "{} {dtype:?} a = {a}", e1.spec.id);
                }
            }
        }
        // The cost uses the clipped action: at the origin it is 0.001 * 2^2.
        let mut e = from_state(Pendulum::v1(ActionDtype::F64), [0.0, 0.0]);
        assert_eq!(step(&mut e, 5.0).2, -(0.001 * 4.0));
    }

    #[test]
    fn nan_action_propagates_like_np_clip() {
        for env in [
            Pendulum::v1(ActionDtype::F64),
            Pendulum::v1(ActionDtype::F32),
            Pendulum::v0(ActionDtype::F64),
        ] {
            let mut e = from_state(env, [0.1, 0.2]);
            let (s, obs, r) = step(&mut e, f64::NAN);
            assert!(s.iter().all(|x| x.is_nan()));
            assert!(obs.iter().all(|x| x.is_nan()));
            assert!(r.is_nan());
        }
    }

    /// A float64 action that is not f32-representable, where glibc's
    /// pow(u, 2.0) differs from u*u (Python: u**2 != u*u).
    #[test]
    fn float64_action_uses_pow_and_is_not_rounded() {
        let u = 0.6800728488750654;
        assert_ne!(pow2_libm(u), u * u);
        assert_ne!(0.001 * pow2_libm(u), 0.001 * (u * u));
        for make in [Pendulum::v0, Pendulum::v1] {
            let mut e = from_state(make(ActionDtype::F64), [0.0, 0.0]);
            let ([newth, newthdot], _, r) = step(&mut e, u);
            // cost = (0 + 0.1 * 0) + 0.001 * u**2
            assert_eq!(r, -(0.001 * pow2_libm(u)), "{}", e.spec.id);
            let gravity = match e.version {
                Version::V1 => 15.0 * 0.0f64.sin(),
                Version::V0 => -15.0 * PI.sin(),
            };
            assert_eq!(newthdot, (gravity + 3.0 * u) * DT);
            assert_eq!(newth, newthdot * DT);
        }
    }

    /// A float32 action for v1: u = f32(a), 3u and 0.001 u^2 in float32 with
    /// libm powf. 1.184326171875 is a value where powf(u, 2) != f32(u*u).
    #[test]
    fn float32_action_v1_uses_float32_products() {
        for a in [1.184326171875, 0.6800728488750654] {
            let u = a as f32;
            let mut e = from_state(Pendulum::v1(ActionDtype::F32), [0.0, 0.0]);
            let ([_, newthdot], _, r) = step(&mut e, a);
            let cost = (0.001f32 * u.powf(std::hint::black_box(2.0))) as f64;
            assert_eq!(r, -cost);
            assert_eq!(newthdot, (15.0 * 0.0f64.sin() + (3.0 * u) as f64) * DT);
            // It differs from the float64 path.
            let mut e64 = from_state(Pendulum::v1(ActionDtype::F64), [0.0, 0.0]);
            assert_ne!(step(&mut e64, u as f64).2, r);
        }
        // v0 only rounds the action.
        let a = 0.6800728488750654;
        let mut e = from_state(Pendulum::v0(ActionDtype::F32), [0.0, 0.0]);
        let (_, _, r) = step(&mut e, a);
        assert_eq!(r, -(0.001 * pow2(f32r(a))));
    }

    #[test]
    fn wrong_actions_are_rejected() {
        for make in [Pendulum::v0, Pendulum::v1] {
            let mut e = from_state(make(ActionDtype::F64), [0.0, 0.0]);
            let mut obs = [0.0; 3];
            for action in [
                Action::Continuous(&[]),
                Action::Continuous(&[0.0, 1.0]),
                Action::Discrete(1),
            ] {
                assert!(matches!(
                    e.step(action, &mut obs),
                    Err(EnvError::InvalidAction(_))
                ));
            }
            assert_eq!(e.state, [0.0, 0.0]);
        }
    }

    #[test]
    fn specs() {
        let v1 = Pendulum::v1(ActionDtype::F32);
        assert_eq!(v1.spec().id, "Pendulum-v1");
        assert_eq!(v1.spec().obs_dim(), 3);
        assert_eq!(v1.spec().max_episode_steps, Some(200));
        assert_eq!(v1.spec().reward_threshold, None);
        assert_eq!(
            v1.spec().action_space,
            Space::Box(BoxSpace::new(vec![-2.0], vec![2.0]))
        );
        let v0 = Pendulum::v0(ActionDtype::F64);
        assert_eq!(v0.spec().id, "Pendulum-v0");
        assert_eq!(v0.spec().observation_space, v1.spec().observation_space);
    }

    // gym 0.17.2: env.seed(0); env.reset() -> state (golden Pendulum-v0.json);
    // Gymnasium: env.reset(seed=0) (golden Pendulum-v1.json).
    #[test]
    fn seeded_resets() {
        let mut obs = [0.0; 3];
        let mut v0 = Pendulum::v0(ActionDtype::F32);
        v0.reset(0, &mut obs).unwrap();
        assert_eq!(v0.state, [-2.8000383468574164, 0.9307818744846408]);
        assert_eq!(
            obs,
            [
                (-2.8000383468574164f64).cos(),
                (-2.8000383468574164f64).sin(),
                0.9307818744846408
            ]
        );
        let mut v1 = Pendulum::v1(ActionDtype::F32);
        v1.reset(0, &mut obs).unwrap();
        assert!(obs.iter().all(|&o| f32r(o) == o));
    }
}
