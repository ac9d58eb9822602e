//! CartPole-v0 / CartPole-v1 (Gymnasium's `CartPoleEnv`, Euler integrator).
//!
//! A pole is hinged on a cart that moves along a frictionless track; push
//! the cart left or right to keep the pole upright.
//!
//! - **Action space**: `Discrete(2)`: 0 pushes the cart left, 1 right, with
//!   a force of 10 N.
//! - **Observation space**: `Box(4)`, float32: cart position [-4.8, 4.8],
//!   cart velocity unbounded (±float32's largest), pole angle [-0.418,
//!   0.418] rad (±24°), pole angular velocity unbounded.
//! - **Rewards**: +1 for every step, the terminating one included (Gymnasium's
//!   default, `sutton_barto_reward=False`); 0 for steps after termination.
//! - **Starting state**: all four values uniform in [-0.05, 0.05).
//! - **Episode end**: terminated when the pole angle leaves ±12° (±0.2095
//!   rad) or the cart position leaves ±2.4; truncated at 200 steps (v0) or
//!   500 (v1).
//! - **Versions**: v0 and v1 share the dynamics; only the time limit
//!   (200 / 500) and the reward threshold (195 / 475) differ.
//! - **Source**: Gymnasium 1.4's `gymnasium/envs/classic_control/cartpole.py`
//!   (after Barto, Sutton and Anderson, 1983; Gymnasium is MIT-licensed:
//!   THIRD-PARTY-NOTICES). The golden trajectories `tests/data/CartPole-v*.json`,
//!   recorded from Gymnasium, are replayed bit for bit by
//!   `rwg-envs/tests/golden.rs`.

use rwg_env::env::discrete_action;
use rwg_env::float::{f32r, sin_cos};
use rwg_env::seeding::Pcg64;
use rwg_env::{Action, BoxSpace, EnvError, EnvSpec, Environment, Space, Step};

pub(crate) const GRAVITY: f64 = 9.8;
pub(crate) const MASSCART: f64 = 1.0;
pub(crate) const MASSPOLE: f64 = 0.1;
pub(crate) const LENGTH: f64 = 0.5; // half the pole's length
pub(crate) const FORCE_MAG: f64 = 10.0;
pub(crate) const TAU: f64 = 0.02;
pub(crate) const X_THRESHOLD: f64 = 2.4;

/// 12 degrees in radians, computed as Gymnasium does: `12 * 2 * pi / 360`.
#[inline]
pub(crate) fn theta_threshold() -> f64 {
    12.0 * 2.0 * std::f64::consts::PI / 360.0
}

/// The cart-pole balancing task.
#[derive(Debug, Clone)]
pub struct CartPole {
    spec: EnvSpec,
    /// `[x, x_dot, theta, theta_dot]`.
    state: [f64; 4],
    /// Gymnasium's `steps_beyond_terminated`: reward 0 after the terminal step.
    terminated_before: bool,
}

impl CartPole {
    /// CartPole-v0 (time limit 200, solved at 195).
    pub fn v0() -> Self {
        Self::with_spec("CartPole-v0", 200, 195.0)
    }

    /// CartPole-v1 (time limit 500, solved at 475).
    pub fn v1() -> Self {
        Self::with_spec("CartPole-v1", 500, 475.0)
    }

    fn with_spec(id: &str, max_steps: u32, threshold: f64) -> Self {
        let th = theta_threshold();
        let high = [
            X_THRESHOLD * 2.0,
            f32::MAX as f64,
            th * 2.0,
            f32::MAX as f64,
        ];
        let high: Vec<f64> = high.iter().map(|&h| f32r(h)).collect();
        let spec = EnvSpec {
            id: id.into(),
            observation_space: Space::Box(BoxSpace::symmetric(&high)),
            action_space: Space::Discrete { n: 2 },
            max_episode_steps: Some(max_steps),
            reward_threshold: Some(threshold),
        };
        CartPole {
            spec,
            state: [0.0; 4],
            terminated_before: false,
        }
    }

    #[inline]
    fn write_obs(&self, obs: &mut [f64]) {
        for (o, s) in obs.iter_mut().zip(self.state) {
            *o = f32r(s);
        }
    }
}

impl Environment for CartPole {
    fn spec(&self) -> &EnvSpec {
        &self.spec
    }

    fn reset(&mut self, seed: u64, obs: &mut [f64]) -> Result<(), EnvError> {
        let mut rng = Pcg64::from_seed(seed);
        for s in &mut self.state {
            *s = rng.uniform(-0.05, 0.05);
        }
        self.terminated_before = false;
        self.write_obs(obs);
        Ok(())
    }

    #[inline]
    fn step(&mut self, action: Action<'_>, obs: &mut [f64]) -> Result<Step, EnvError> {
        let a = discrete_action(action, 2)?;
        let [x, x_dot, theta, theta_dot] = self.state;
        let force = if a == 1 { FORCE_MAG } else { -FORCE_MAG };
        let (sintheta, costheta) = sin_cos(theta);
        let total_mass = MASSPOLE + MASSCART;
        let polemass_length = MASSPOLE * LENGTH;

        let temp = (force + polemass_length * (theta_dot * theta_dot) * sintheta) / total_mass;
        let thetaacc = (GRAVITY * sintheta - costheta * temp)
            / (LENGTH * (4.0 / 3.0 - MASSPOLE * (costheta * costheta) / total_mass));
        let xacc = temp - polemass_length * thetaacc * costheta / total_mass;

        self.state = [
            x + TAU * x_dot,
            x_dot + TAU * xacc,
            theta + TAU * theta_dot,
            theta_dot + TAU * thetaacc,
        ];
        let [x, _, theta, _] = self.state;
        let th = theta_threshold();
        // Gymnasium's strict comparisons, written out: a NaN state does not
        // terminate, as in Python (a range `contains` would say it does).
        #[expect(
            clippy::manual_range_contains,
            reason = "a range's `contains` is true for NaN, Gymnasium's comparisons are not"
        )]
        let terminated = x < -X_THRESHOLD || x > X_THRESHOLD || theta < -th || theta > th;

        let reward = if !terminated {
            1.0
        } else if !self.terminated_before {
            self.terminated_before = true;
            1.0
        } else {
            0.0
        };
        self.write_obs(obs);
        Ok(Step {
            reward,
            terminated,
            truncated: false,
        })
    }

    array_state!(4, |env, obs| {
        env.terminated_before = false;
        env.write_obs(obs);
    });
}
