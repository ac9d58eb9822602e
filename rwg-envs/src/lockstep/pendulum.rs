//! Pendulum-v1 and Pendulum-v0 over `N` lanes: [`crate::pendulum`]'s
//! arithmetic, one `sincos_lanes` per step for the observations (and, in v0,
//! one `sin_lanes` for the gravity term `sin(theta + pi)`).

use super::wide::{step_many_dispatched, wide_step};
use super::{
    check_lens, finish_flags, gather_continuous1, limited_spec, pow2_lanes, Clocks, LockstepEnv,
};
use crate::pendulum::{
    angle_normalize, clip, floored, Pendulum, Version, DT, G, L, M, MAX_SPEED, MAX_TORQUE,
};
use rwg_env::float::{f32r, fmod_rem, pow2_f32, split_divisor, FMOD_FAST_QUOTIENT};
use rwg_env::lanes_math::{sin_lanes, sincos_lanes};
use rwg_env::many::ManyEnv;
use rwg_env::mt19937::{first_outputs_lanes, uniform_res53};
use rwg_env::seeding::{gym_seed_key, Pcg64};
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
        let an = angle_normalize_lanes(&self.th);
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

/// [`angle_normalize`] of every lane, bit for bit, branch-free so that it
/// vectorises: `fmod_pos`'s quotient and its three candidate remainders are
/// computed for every lane and the one its tests pick selected. Lanes
/// beyond `fmod_pos`'s fast range (|θ + π| >= 2π·2^20, inf, NaN) go through
/// [`angle_normalize`] itself.
#[inline(always)]
fn angle_normalize_lanes<const N: usize>(x: &[f64; N]) -> [f64; N] {
    const TWO_PI: f64 = 2.0 * PI;
    let split = split_divisor(TWO_PI);
    let mut out = [0.0; N];
    let mut slow = [false; N];
    for i in 0..N {
        let y = x[i] + PI;
        let ay = y.abs();
        let q = (ay / TWO_PI).trunc();
        let r0 = fmod_rem(ay, q, split);
        let rm = fmod_rem(ay, q - 1.0, split);
        let rp = fmod_rem(ay, q + 1.0, split);
        let r = if r0 < 0.0 {
            rm
        } else if r0 >= TWO_PI {
            rp
        } else {
            r0
        };
        // fmod_pos(y, 2π), then Python's floored `%`.
        let r = floored(if ay < TWO_PI { y } else { r.copysign(y) });
        out[i] = r - PI;
        slow[i] = (ay >= TWO_PI * FMOD_FAST_QUOTIENT) | ay.is_nan();
    }
    for i in 0..N {
        if slow[i] {
            out[i] = angle_normalize(x[i]);
        }
    }
    out
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
            lanes[i] = mask[i] == 1;
        }
        // uniform(low=[-pi, -1], high=[pi, 1]): theta, then theta_dot.
        match self.version {
            Version::V1 => {
                for i in 0..N {
                    if lanes[i] {
                        let mut rng = Pcg64::from_seed(seeds[i]);
                        (self.th[i], self.thdot[i]) =
                            (rng.uniform(-PI, PI), rng.uniform(-1.0, 1.0));
                    }
                }
            }
            Version::V0 => {
                // gym_np_random's RandomState for every lane at once: its
                // first four outputs make the two uniforms.
                let (mut keys, mut two) = ([[0u32; 2]; N], [false; N]);
                for i in 0..N {
                    if lanes[i] {
                        (keys[i], two[i]) = gym_seed_key(seeds[i]);
                    }
                }
                let words: [[u32; 4]; N] = first_outputs_lanes(&keys, &two);
                for i in 0..N {
                    if lanes[i] {
                        let [a, b, c, d] = words[i];
                        self.th[i] = uniform_res53(-PI, PI, a, b);
                        self.thdot[i] = uniform_res53(-1.0, 1.0, c, d);
                    }
                }
            }
        }
        for i in 0..N {
            if lanes[i] {
                self.clocks.reset(i);
            }
        }
        self.write_obs(&lanes, obs);
    }

    step_many_dispatched!();
}

wide_step!(PendulumLanes);

impl<const N: usize> PendulumLanes<N> {
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn angle_normalize_lanes_is_angle_normalize() {
        let two_pi = 2.0 * PI;
        let mut s: u64 = 0x5eed;
        let mut next = || {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            s
        };
        let mut xs: Vec<f64> = vec![
            0.0,
            -0.0,
            PI,
            -PI,
            two_pi,
            -two_pi,
            3.0 * PI,
            -3.0 * PI,
            1e-300,
            -5e-324,
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            1e300,
            two_pi * 1048576.0,
            -two_pi * 1048576.0 - PI,
            two_pi * 1048576.0 - PI,
        ];
        for _ in 0..400_000 {
            let r = next();
            let u = (r >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0;
            xs.push(match r % 4 {
                0 => u * 4.0 * PI,
                1 => u * 200.0 * PI,
                2 => u * 3e6 * two_pi, // partly beyond the fast range
                _ => {
                    // Within a few ulps of an odd multiple of π (θ + π near k·2π).
                    let k = ((next() % 2001) as f64 - 1000.0) * two_pi - PI;
                    f64::from_bits((k.to_bits() as i64 + (next() % 9) as i64 - 4) as u64)
                }
            });
        }
        for chunk in xs.chunks(16) {
            let mut x = [0.0; 16];
            x[..chunk.len()].copy_from_slice(chunk);
            let got = angle_normalize_lanes(&x);
            for (g, v) in got.iter().zip(x) {
                let want = angle_normalize(v);
                assert!(
                    g.to_bits() == want.to_bits() || (g.is_nan() && want.is_nan()),
                    "angle_normalize({v:?}): lanes {g:?}, scalar {want:?}"
                );
            }
        }
    }
}
