//! MountainCar-v0 (Gymnasium's `MountainCarEnv`, three discrete actions).
//!
//! A car sits in a valley between two hills, too weak to drive straight up
//! the right one: rock back and forth to reach the flag on its top.
//!
//! - **Action space**: `Discrete(3)`: accelerate left, do not accelerate,
//!   accelerate right.
//! - **Observation space**: `Box(2)`, float32: position [-1.2, 0.6], velocity
//!   [-0.07, 0.07].
//! - **Rewards**: −1 for every step.
//! - **Starting state**: position uniform in [-0.6, -0.4), velocity 0.
//! - **Episode end**: terminated when the position reaches 0.5 with a
//!   non-negative velocity; truncated at 200 steps. Reward threshold −110.
//! - **Versions**: v0 is the only one.
//! - **Source**: Gymnasium 1.4's
//!   `gymnasium/envs/classic_control/mountain_car.py` (after Moore, 1990;
//!   Gymnasium is MIT-licensed: THIRD-PARTY-NOTICES). The golden
//!   trajectories `tests/data/MountainCar-v0.json`, recorded from Gymnasium,
//!   are replayed bit for bit by `rwg-envs/tests/golden.rs`.
//!
//! The state is float64 throughout (Gymnasium keeps a tuple of numpy float64
//! scalars), so numpy 2's promotion rules change nothing here; only the
//! observation is cast to float32.

use rwg_env::env::discrete_action;
use rwg_env::float::f32r;
use rwg_env::seeding::Pcg64;
use rwg_env::{Action, BoxSpace, EnvError, EnvSpec, Environment, Space, Step};

pub(crate) const MIN_POSITION: f64 = -1.2;
pub(crate) const MAX_POSITION: f64 = 0.6;
pub(crate) const MAX_SPEED: f64 = 0.07;
pub(crate) const GOAL_POSITION: f64 = 0.5;
pub(crate) const GOAL_VELOCITY: f64 = 0.0;
pub(crate) const FORCE: f64 = 0.001;
pub(crate) const GRAVITY: f64 = 0.0025;

/// Drive an under-powered car up the right hill by rocking it back and forth.
///
/// Actions: 0 = push left, 1 = no push, 2 = push right. Reward −1 on every
/// step; the episode terminates when the car reaches position 0.5 with a
/// non-negative velocity.
#[derive(Debug, Clone)]
pub struct MountainCar {
    spec: EnvSpec,
    /// `[position, velocity]`.
    state: [f64; 2],
}

impl MountainCar {
    /// MountainCar-v0 (time limit 200, solved at −110).
    pub fn new() -> Self {
        MountainCar {
            spec: EnvSpec {
                id: "MountainCar-v0".into(),
                observation_space: Space::Box(observation_box()),
                action_space: Space::Discrete { n: 3 },
                max_episode_steps: Some(200),
                reward_threshold: Some(-110.0),
            },
            state: [0.0; 2],
        }
    }

    #[inline]
    fn write_obs(&self, obs: &mut [f64]) {
        for (o, s) in obs.iter_mut().zip(self.state) {
            *o = f32r(s);
        }
    }
}

impl Default for MountainCar {
    fn default() -> Self {
        Self::new()
    }
}

/// The observation box of both mountain-car envs: `[-1.2, 0.6] × [-0.07, 0.07]`
/// as float32 bounds.
pub(crate) fn observation_box() -> BoxSpace {
    BoxSpace::new(
        vec![f32r(MIN_POSITION), f32r(-MAX_SPEED)],
        vec![f32r(MAX_POSITION), f32r(MAX_SPEED)],
    )
}

/// The reset state of both mountain-car envs: `[U[-0.6, -0.4), 0]`.
pub(crate) fn reset_state(seed: u64) -> [f64; 2] {
    let mut rng = Pcg64::from_seed(seed);
    [rng.uniform(-0.6, -0.4), 0.0]
}

impl Environment for MountainCar {
    fn spec(&self) -> &EnvSpec {
        &self.spec
    }

    fn reset(&mut self, seed: u64, obs: &mut [f64]) -> Result<(), EnvError> {
        self.state = reset_state(seed);
        self.write_obs(obs);
        Ok(())
    }

    #[inline]
    fn step(&mut self, action: Action<'_>, obs: &mut [f64]) -> Result<Step, EnvError> {
        let a = discrete_action(action, 3)?;
        let [mut position, mut velocity] = self.state;

        // `velocity += (action - 1) * force + cos(3 * position) * (-gravity)`:
        // the increment is computed first, then added.
        velocity += (a as f64 - 1.0) * FORCE + (3.0 * position).cos() * (-GRAVITY);
        velocity = velocity.clamp(-MAX_SPEED, MAX_SPEED);
        position += velocity;
        position = position.clamp(MIN_POSITION, MAX_POSITION);
        if position == MIN_POSITION && velocity < 0.0 {
            velocity = 0.0;
        }

        let terminated = position >= GOAL_POSITION && velocity >= GOAL_VELOCITY;
        self.state = [position, velocity];
        self.write_obs(obs);
        Ok(Step {
            reward: -1.0,
            terminated,
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

    fn step_from(state: [f64; 2], a: i64) -> ([f64; 2], [f64; 2], Step) {
        let mut env = MountainCar::new();
        let mut obs = [0.0; 2];
        env.set_state(&state, &mut obs).unwrap();
        let s = env.step(Action::Discrete(a), &mut obs).unwrap();
        let mut st = [0.0; 2];
        env.state(&mut st).unwrap();
        (st, obs, s)
    }

    // Expected values below come from `mountaincar_step` in
    // the bit-exact Python reference that checked `tests/data/`'s golden
    // trajectories against Gymnasium.

    #[test]
    fn speed_is_clipped_to_plus_minus_0_07() {
        let (st, obs, s) = step_from([-0.5, 0.0695], 2);
        assert_eq!(st, [-0.43, 0.07]);
        assert_eq!(obs, [-0.4300000071525574, 0.07000000029802322]);
        assert!(!s.terminated);
        let (st, obs, _) = step_from([-0.5, -0.0695], 0);
        assert_eq!(st, [-0.5700000000000001, -0.07]);
        assert_eq!(obs, [-0.5699999928474426, -0.07000000029802322]);
    }

    #[test]
    fn left_wall_stops_the_car() {
        let (st, obs, s) = step_from([-1.17, -0.05], 0);
        assert_eq!(st, [-1.2, 0.0]);
        assert_eq!(obs, [-1.2000000476837158, 0.0]);
        assert_eq!(s.reward, -1.0);
        assert!(!s.terminated);
        // Moving right near the wall: no clipping.
        let (st, _, _) = step_from([-1.19, 0.001], 0);
        assert_eq!(st, [-1.187725928681605, 0.002274071318394861]);
    }

    #[test]
    fn right_bound_clips_position_only() {
        let (st, obs, s) = step_from([0.59, 0.05], 2);
        assert_eq!(st, [0.6, 0.05149472203652278]);
        assert_eq!(obs, [0.6000000238418579, 0.051494721323251724]);
        assert!(s.terminated);
    }

    #[test]
    fn terminates_at_the_goal_with_non_negative_velocity() {
        let (st, _, s) = step_from([0.49, 0.02], 2);
        assert_eq!(st, [0.5107484356665326, 0.020748435666532672]);
        assert!(s.terminated);
        assert_eq!(s.reward, -1.0);
        // Past the goal but moving left: not terminated.
        let (st, _, s) = step_from([0.55, -0.001], 0);
        assert_eq!(st, [0.5481978022220169, -0.0018021977779831648]);
        assert!(!s.terminated);
    }

    #[test]
    fn increment_is_summed_before_it_is_added() {
        // (v + force) + gravity would give 0.050052034768657085 here.
        let (st, _, _) = step_from([-0.9581443605976778, 0.04864072317121258], 0);
        assert_eq!(st, [-0.9080923258290208, 0.05005203476865709]);
    }

    #[test]
    fn invalid_actions_are_refused() {
        let mut env = MountainCar::new();
        let mut obs = [0.0; 2];
        env.reset(0, &mut obs).unwrap();
        assert!(env.step(Action::Discrete(3), &mut obs).is_err());
        assert!(env.step(Action::Discrete(-1), &mut obs).is_err());
        assert!(env.step(Action::Continuous(&[1.0]), &mut obs).is_err());
    }
}
