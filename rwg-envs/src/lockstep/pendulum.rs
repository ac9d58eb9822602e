//! Pendulum-v1 and Pendulum-v0 over `N` lanes: [`crate::pendulum`]'s
//! arithmetic, one `sincos_lanes` per step for the observations (and, in v0,
//! one `sin_lanes` for the gravity term `sin(theta + pi)`).

use super::wide::{step_many_dispatched, wide_step};
use super::{
    check_lens, finish_flags, gather_continuous1, limited_spec, pow2_lanes, Clocks, LockstepEnv,
};
use crate::pendulum::{
    angle_normalize, clip, Pendulum, Version, DT, G, L, M, MAX_SPEED, MAX_TORQUE,
};
use rwg_env::float::{f32r, pow2_f32};
use rwg_env::lanes_math::{sin_lanes, sincos_lanes};
use rwg_env::many::ManyEnv;
use rwg_env::seeding::{gym_np_random, Pcg64};
use rwg_env::{ActionDtype, EnvError, EnvSpec};
use std::f64::consts::PI;

/// `N` pendulums (v0 or v1) stepped together.
#[derive(Debug, Clone)]
pub struct PendulumLanes<const N: usize> {
    spec: EnvSpec,
    version: Version,
    dtype: ActionDtype,
    th: [f64; N],
    thdot: [f64; N],
    /// `sin(theta)` of each lane's state (its observation's), which v1's
    /// next step uses, as the scalar env keeps it.
    sin_th: [f64; N],
    clocks: Clocks<N>,
}

impl<const N: usize> PendulumLanes<N> {
    /// Pendulum-v1 lanes ([`Pendulum::v1`]) with the time limit
    /// `max_episode_steps` (`None`: the registered 200).
    pub fn v1(dtype: ActionDtype, max_episode_steps: Option<u32>) -> Self {
        Self::of(Pendulum::v1(dtype), Version::V1, dtype, max_episode_steps)
    }

    /// Pendulum-v0 lanes ([`Pendulum::v0`]).
    pub fn v0(dtype: ActionDtype, max_episode_steps: Option<u32>) -> Self {
        Self::of(Pendulum::v0(dtype), Version::V0, dtype, max_episode_steps)
    }

    fn of(env: Pendulum, version: Version, dtype: ActionDtype, limit: Option<u32>) -> Self {
        let spec = limited_spec(&env, limit);
        PendulumLanes {
            clocks: Clocks::new(&spec),
            spec,
            version,
            dtype,
            th: [0.0; N],
            thdot: [0.0; N],
            sin_th: [0.0; N],
        }
    }

    /// Writes the observations `[cos th, sin th, thdot]` of the lanes in
    /// `lanes` (float32 in v1) and keeps their `sin th`.
    #[inline(always)]
    fn write_obs(&mut self, lanes: &[bool; N], obs: &mut [f64]) {
        let (mut s, mut c) = ([0.0; N], [0.0; N]);
        sincos_lanes(&self.th, &mut s, &mut c);
        for i in 0..N {
            if !lanes[i] {
                continue;
            }
            self.sin_th[i] = s[i];
            let o = [c[i], s[i], self.thdot[i]];
            let dst = &mut obs[i * 3..i * 3 + 3];
            match self.version {
                Version::V1 => {
                    for (d, v) in dst.iter_mut().zip(o) {
                        *d = f32r(v);
                    }
                }
                Version::V0 => dst.copy_from_slice(&o),
            }
        }
    }

    /// `pow2(angle_normalize(th))` and `pow2(thdot)` of every lane: the
    /// first two terms of both versions' cost.
    #[inline(always)]
    fn state_squares(&self) -> ([f64; N], [f64; N]) {
        let mut an = [0.0; N];
        for i in 0..N {
            an[i] = angle_normalize(self.th[i]);
        }
        let (mut sq_th, mut sq_thdot) = ([0.0; N], [0.0; N]);
        pow2_lanes(&an, &mut sq_th);
        pow2_lanes(&self.thdot, &mut sq_thdot);
        (sq_th, sq_thdot)
    }

    /// Gymnasium 1.4's step for every lane: new `(th, thdot)` and costs.
    #[inline(always)]
    fn transition_v1(&self, a: &[f64; N], new: &mut ([f64; N], [f64; N]), costs: &mut [f64; N]) {
        let (mut torque_term, mut u_cost) = ([0.0; N], [0.0; N]);
        match self.dtype {
            ActionDtype::F64 => {
                let mut u = [0.0; N];
                for i in 0..N {
                    u[i] = clip(a[i], -MAX_TORQUE, MAX_TORQUE);
                    torque_term[i] = 3.0 / (M * L * L) * u[i];
                }
                let mut sq_u = [0.0; N];
                pow2_lanes(&u, &mut sq_u);
                for i in 0..N {
                    u_cost[i] = 0.001 * sq_u[i];
                }
            }
            ActionDtype::F32 => {
                for i in 0..N {
                    let u = (a[i] as f32).clamp(-MAX_TORQUE as f32, MAX_TORQUE as f32);
                    let three = (3.0 / (M * L * L)) as f32;
                    torque_term[i] = (three * u) as f64;
                    u_cost[i] = (0.001f32 * pow2_f32(u)) as f64;
                }
            }
        }
        let (sq_th, sq_thdot) = self.state_squares();
        for i in 0..N {
            costs[i] = sq_th[i] + 0.1 * sq_thdot[i] + u_cost[i];
        }
        let (newth, newthdot) = new;
        for i in 0..N {
            let d = self.thdot[i] + (3.0 * G / (2.0 * L) * self.sin_th[i] + torque_term[i]) * DT;
            let d = clip(d, -MAX_SPEED, MAX_SPEED);
            newthdot[i] = d;
            newth[i] = self.th[i] + d * DT;
        }
    }

    /// gym 0.17.2's step for every lane: new `(th, thdot)` and costs.
    #[inline(always)]
    fn transition_v0(&self, a: &[f64; N], new: &mut ([f64; N], [f64; N]), costs: &mut [f64; N]) {
        let mut u = [0.0; N];
        for i in 0..N {
            let a = match self.dtype {
                ActionDtype::F64 => a[i],
                ActionDtype::F32 => f32r(a[i]),
            };
            u[i] = clip(a, -MAX_TORQUE, MAX_TORQUE);
        }
        let (sq_th, sq_thdot) = self.state_squares();
        let mut sq_u = [0.0; N];
        pow2_lanes(&u, &mut sq_u);
        for i in 0..N {
            costs[i] = sq_th[i] + 0.1 * sq_thdot[i] + 0.001 * sq_u[i];
        }
        let mut arg = [0.0; N];
        for i in 0..N {
            arg[i] = self.th[i] + PI;
        }
        let mut s = [0.0; N];
        sin_lanes(&arg, &mut s);
        let (newth, newthdot) = new;
        for i in 0..N {
            let d = self.thdot[i] + (-3.0 * G / (2.0 * L) * s[i] + 3.0 / (M * L * L) * u[i]) * DT;
            newth[i] = self.th[i] + d * DT;
            newthdot[i] = clip(d, -MAX_SPEED, MAX_SPEED);
        }
    }
}

impl<const N: usize> ManyEnv for PendulumLanes<N> {
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
        check_lens(N, mask, obs, 3);
        let mut lanes = [false; N];
        for i in 0..N {
            if mask[i] != 1 {
                continue;
            }
            lanes[i] = true;
            // uniform(low=[-pi, -1], high=[pi, 1]): theta, then theta_dot.
            (self.th[i], self.thdot[i]) = match self.version {
                Version::V1 => {
                    let mut rng = Pcg64::from_seed(seeds[i]);
                    (rng.uniform(-PI, PI), rng.uniform(-1.0, 1.0))
                }
                Version::V0 => {
                    let mut rng = gym_np_random(seeds[i]);
                    (rng.uniform(-PI, PI), rng.uniform(-1.0, 1.0))
                }
            };
            self.clocks.reset(i);
        }
        self.write_obs(&lanes, obs);
    }

    step_many_dispatched!();
}

wide_step!(PendulumLanes);

impl<const N: usize> PendulumLanes<N> {
    /// The step of every lane ([`ManyEnv::step_many`]).
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn step_body(
        &mut self,
        mask: &[u8],
        actions: &[f64],
        obs: &mut [f64],
        rewards: &mut [f64],
        terminated: &mut [u8],
        truncated: &mut [u8],
        on_fail: &mut dyn FnMut(usize, EnvError),
    ) {
        check_lens(N, mask, obs, 3);
        let mut a = [0.0; N];
        let live = gather_continuous1(&self.clocks, mask, actions, &mut a, on_fail);
        let mut new = ([0.0; N], [0.0; N]);
        let mut costs = [0.0; N];
        match self.version {
            Version::V1 => self.transition_v1(&a, &mut new, &mut costs),
            Version::V0 => self.transition_v0(&a, &mut new, &mut costs),
        }
        for i in 0..N {
            if live[i] {
                self.th[i] = new.0[i];
                self.thdot[i] = new.1[i];
                rewards[i] = -costs[i];
            }
        }
        self.write_obs(&live, obs);
        finish_flags(&mut self.clocks, &live, &[false; N], terminated, truncated);
    }
}

impl<const N: usize> LockstepEnv for PendulumLanes<N> {
    fn state_len(&self) -> usize {
        2
    }

    fn lane_state(&self, lane: usize, out: &mut [f64]) {
        out.copy_from_slice(&[self.th[lane], self.thdot[lane]]);
    }
}
