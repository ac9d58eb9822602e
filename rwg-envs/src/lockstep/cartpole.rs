//! CartPole-v0 / CartPole-v1 over `N` lanes: [`crate::cartpole`]'s Euler
//! step in loops over lanes, one `sincos_lanes` per step for the pole angle.

use super::wide::{step_many_dispatched, wide_step};
use super::{check_lens, finish_flags, gather_discrete, limited_spec, Clocks, LockstepEnv};
use crate::cartpole::{
    theta_threshold, CartPole, FORCE_MAG, GRAVITY, LENGTH, MASSCART, MASSPOLE, TAU, X_THRESHOLD,
};
use rwg_env::float::f32r;
use rwg_env::lanes_math::sincos_lanes;
use rwg_env::many::ManyEnv;
use rwg_env::seeding::Pcg64;
use rwg_env::{EnvError, EnvSpec};

/// `N` cart-poles stepped together.
#[derive(Debug, Clone)]
pub struct CartPoleLanes<const N: usize> {
    spec: EnvSpec,
    x: [f64; N],
    x_dot: [f64; N],
    theta: [f64; N],
    theta_dot: [f64; N],
    /// Gymnasium's `steps_beyond_terminated` per lane.
    terminated_before: [bool; N],
    clocks: Clocks<N>,
}

impl<const N: usize> CartPoleLanes<N> {
    /// CartPole-v0 lanes ([`CartPole::v0`]), `max_episode_steps` overriding
    /// the registered limit.
    pub fn v0(max_episode_steps: Option<u32>) -> Self {
        Self::of(CartPole::v0(), max_episode_steps)
    }

    /// CartPole-v1 lanes ([`CartPole::v1`]).
    pub fn v1(max_episode_steps: Option<u32>) -> Self {
        Self::of(CartPole::v1(), max_episode_steps)
    }

    fn of(env: CartPole, limit: Option<u32>) -> Self {
        let spec = limited_spec(&env, limit);
        CartPoleLanes {
            clocks: Clocks::new(&spec),
            spec,
            x: [0.0; N],
            x_dot: [0.0; N],
            theta: [0.0; N],
            theta_dot: [0.0; N],
            terminated_before: [false; N],
        }
    }

    /// Lane `i`'s observation: its state as float32.
    #[inline(always)]
    fn write_obs(&self, i: usize, obs: &mut [f64]) {
        let o = &mut obs[i * 4..i * 4 + 4];
        o[0] = f32r(self.x[i]);
        o[1] = f32r(self.x_dot[i]);
        o[2] = f32r(self.theta[i]);
        o[3] = f32r(self.theta_dot[i]);
    }
}

impl<const N: usize> ManyEnv for CartPoleLanes<N> {
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
        check_lens(N, mask, obs, 4);
        for i in 0..N {
            if mask[i] != 1 {
                continue;
            }
            let mut rng = Pcg64::from_seed(seeds[i]);
            self.x[i] = rng.uniform(-0.05, 0.05);
            self.x_dot[i] = rng.uniform(-0.05, 0.05);
            self.theta[i] = rng.uniform(-0.05, 0.05);
            self.theta_dot[i] = rng.uniform(-0.05, 0.05);
            self.terminated_before[i] = false;
            self.clocks.reset(i);
            self.write_obs(i, obs);
        }
    }

    step_many_dispatched!();
}

wide_step!(CartPoleLanes);

impl<const N: usize> CartPoleLanes<N> {
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
        check_lens(N, mask, obs, 4);
        let mut a = [0usize; N];
        let live = gather_discrete(&self.clocks, mask, actions, 2, &mut a, on_fail);
        let (mut sintheta, mut costheta) = ([0.0; N], [0.0; N]);
        sincos_lanes(&self.theta, &mut sintheta, &mut costheta);
        let total_mass = MASSPOLE + MASSCART;
        let polemass_length = MASSPOLE * LENGTH;
        let th = theta_threshold();
        let mut new = [[0.0; N]; 4];
        let mut term = [false; N];
        for i in 0..N {
            let force = if a[i] == 1 { FORCE_MAG } else { -FORCE_MAG };
            let (costheta, sintheta) = (costheta[i], sintheta[i]);
            let theta_dot = self.theta_dot[i];
            let temp = (force + polemass_length * (theta_dot * theta_dot) * sintheta) / total_mass;
            let thetaacc = (GRAVITY * sintheta - costheta * temp)
                / (LENGTH * (4.0 / 3.0 - MASSPOLE * (costheta * costheta) / total_mass));
            let xacc = temp - polemass_length * thetaacc * costheta / total_mass;
            let x = self.x[i] + TAU * self.x_dot[i];
            let theta = self.theta[i] + TAU * theta_dot;
            new[0][i] = x;
            new[1][i] = self.x_dot[i] + TAU * xacc;
            new[2][i] = theta;
            new[3][i] = theta_dot + TAU * thetaacc;
            // Strict comparisons: a NaN state does not terminate (as the
            // scalar env).
            #[expect(
                clippy::manual_range_contains,
                reason = "a range's `contains` is true for NaN, Gymnasium's comparisons are not"
            )]
            // `|`, not `||`: no branch, so the loop vectorises.
            let t = (x < -X_THRESHOLD) | (x > X_THRESHOLD) | (theta < -th) | (theta > th);
            term[i] = t;
        }
        for i in 0..N {
            if !live[i] {
                continue;
            }
            self.x[i] = new[0][i];
            self.x_dot[i] = new[1][i];
            self.theta[i] = new[2][i];
            self.theta_dot[i] = new[3][i];
            rewards[i] = if !term[i] {
                1.0
            } else if !self.terminated_before[i] {
                self.terminated_before[i] = true;
                1.0
            } else {
                0.0
            };
            self.write_obs(i, obs);
        }
        finish_flags(&mut self.clocks, &live, &term, terminated, truncated);
    }
}

impl<const N: usize> LockstepEnv for CartPoleLanes<N> {
    fn state_len(&self) -> usize {
        4
    }

    fn lane_state(&self, lane: usize, out: &mut [f64]) {
        out.copy_from_slice(&[
            self.x[lane],
            self.x_dot[lane],
            self.theta[lane],
            self.theta_dot[lane],
        ]);
    }
}
