//! MountainCar-v0 over `N` lanes: [`crate::mountain_car`]'s float64 step in
//! loops over lanes, one `cos_lanes` per step for `cos(3 * position)`.

use super::wide::{step_many_dispatched, wide_step};
use super::{check_lens, finish_flags, gather_discrete, limited_spec, Clocks, LockstepEnv};
use crate::mountain_car::{
    reset_state, MountainCar, FORCE, GOAL_POSITION, GOAL_VELOCITY, GRAVITY, MAX_POSITION,
    MAX_SPEED, MIN_POSITION,
};
use rwg_env::float::f32r;
use rwg_env::lanes_math::cos_lanes;
use rwg_env::many::ManyEnv;
use rwg_env::{EnvError, EnvSpec};

/// `N` mountain cars (three discrete pushes) stepped together.
#[derive(Debug, Clone)]
pub struct MountainCarLanes<const N: usize> {
    spec: EnvSpec,
    position: [f64; N],
    velocity: [f64; N],
    clocks: Clocks<N>,
}

impl<const N: usize> MountainCarLanes<N> {
    /// Lanes of [`MountainCar::new`], `max_episode_steps` overriding the
    /// registered 200.
    pub fn new(max_episode_steps: Option<u32>) -> Self {
        let spec = limited_spec(&MountainCar::new(), max_episode_steps);
        MountainCarLanes {
            clocks: Clocks::new(&spec),
            spec,
            position: [0.0; N],
            velocity: [0.0; N],
        }
    }

    /// Lane `i`'s observation: its state as float32.
    #[inline(always)]
    fn write_obs(&self, i: usize, obs: &mut [f64]) {
        obs[i * 2] = f32r(self.position[i]);
        obs[i * 2 + 1] = f32r(self.velocity[i]);
    }
}

impl<const N: usize> ManyEnv for MountainCarLanes<N> {
    fn spec(&self) -> &EnvSpec {
        &self.spec
    }

    fn lanes(&self) -> usize {
        N
    }

    fn reset_many(
        &mut self,
        mask: &[u8],
        seeds: &[u64],
        obs: &mut [f64],
        _on_fail: &mut dyn FnMut(usize, EnvError),
    ) {
        check_lens(N, mask, obs, 2);
        for i in 0..N {
            if mask[i] == 1 {
                [self.position[i], self.velocity[i]] = reset_state(seeds[i]);
                self.clocks.reset(i);
                self.write_obs(i, obs);
            }
        }
    }

    step_many_dispatched!();
}

wide_step!(MountainCarLanes);

impl<const N: usize> MountainCarLanes<N> {
    /// The step of every lane ([`ManyEnv::step_many`]).
    #[inline(always)]
    #[expect(
        clippy::too_many_arguments,
        reason = "`ManyEnv::step_many`'s buffers, one argument each"
    )]
    fn step_body(
        &mut self,
        mask: &[u8; N],
        actions: &[f64; N],
        obs: &mut [f64],
        rewards: &mut [f64; N],
        terminated: &mut [u8; N],
        truncated: &mut [u8; N],
        on_fail: &mut dyn FnMut(usize, EnvError),
    ) {
        check_lens(N, mask, obs, 2);
        let mut a = [0usize; N];
        let live = gather_discrete(&self.clocks, mask, actions, 3, &mut a, on_fail);
        let mut three_p = [0.0; N];
        for i in 0..N {
            three_p[i] = 3.0 * self.position[i];
        }
        let mut c = [0.0; N];
        cos_lanes(&three_p, &mut c);
        let (mut pos, mut vel, mut term) = ([0.0; N], [0.0; N], [false; N]);
        for i in 0..N {
            let mut velocity = self.velocity[i];
            velocity += (a[i] as f64 - 1.0) * FORCE + c[i] * (-GRAVITY);
            velocity = velocity.clamp(-MAX_SPEED, MAX_SPEED);
            let mut position = self.position[i] + velocity;
            position = position.clamp(MIN_POSITION, MAX_POSITION);
            // `&`, not `&&`: no branch, so the loop vectorises.
            if (position == MIN_POSITION) & (velocity < 0.0) {
                velocity = 0.0;
            }
            term[i] = (position >= GOAL_POSITION) & (velocity >= GOAL_VELOCITY);
            pos[i] = position;
            vel[i] = velocity;
        }
        for i in 0..N {
            if live[i] {
                self.position[i] = pos[i];
                self.velocity[i] = vel[i];
                rewards[i] = -1.0;
                self.write_obs(i, obs);
            }
        }
        finish_flags(&mut self.clocks, &live, &term, terminated, truncated);
    }
}

impl<const N: usize> LockstepEnv for MountainCarLanes<N> {
    fn state_len(&self) -> usize {
        2
    }

    fn lane_state(&self, lane: usize, out: &mut [f64]) {
        out.copy_from_slice(&[self.position[lane], self.velocity[lane]]);
    }
}
