//! Acrobot-v1 over `N` lanes: [`crate::acrobot`]'s RK4 step with every
//! stage computed for all lanes at once. Each stage's `sin θ2, cos θ2` is
//! one `sincos_lanes` (the first stage reuses the observation's), its
//! `cos(θ1 + θ2 − π/2)` and `cos(θ1 − π/2)` one `cos_lanes` each; the
//! `x**2` terms are `pow2`'s bits through `pow2_lanes`, so the loops of
//! plain arithmetic around them vectorise.

use super::wide::{step_many_dispatched, wide_step};
use super::{
    check_lens, finish_flags, gather_discrete, limited_spec, pow2_lanes, Clocks, LockstepEnv,
};
use crate::acrobot::{
    bound, wrap, Acrobot, AVAIL_TORQUE, DT, G, LINK_COM_POS_1, LINK_COM_POS_2, LINK_LENGTH_1,
    LINK_MASS_1, LINK_MASS_2, LINK_MOI_1, LINK_MOI_2, MAX_VEL_1, MAX_VEL_2,
};
use rwg_env::float::f32r;
use rwg_env::lanes_math::{cos_lanes, sincos_lanes};
use rwg_env::many::ManyEnv;
use rwg_env::seeding::Pcg64;
use rwg_env::{EnvError, EnvSpec};
use std::f64::consts::PI;

/// `[θ1, θ2, θ̇1, θ̇2]` of every lane (or their time derivatives).
#[derive(Debug, Clone, Copy)]
struct Y<const N: usize> {
    t1: [f64; N],
    t2: [f64; N],
    d1: [f64; N],
    d2: [f64; N],
}

impl<const N: usize> Y<N> {
    const ZERO: Self = Y {
        t1: [0.0; N],
        t2: [0.0; N],
        d1: [0.0; N],
        d2: [0.0; N],
    };

    /// `y + h·k`, element-wise (the scalar `axpy`; the torque component is
    /// `a + h·0 = a` and is not stored).
    #[inline(always)]
    fn axpy(&self, h: f64, k: &Y<N>) -> Y<N> {
        let mut out = Y::ZERO;
        for i in 0..N {
            out.t1[i] = self.t1[i] + h * k.t1[i];
            out.t2[i] = self.t2[i] + h * k.t2[i];
            out.d1[i] = self.d1[i] + h * k.d1[i];
            out.d2[i] = self.d2[i] + h * k.d2[i];
        }
        out
    }
}

/// [`dsdt_body`] as one out-of-line function, compiled for the SIMD level
/// the step bodies are ([`rwg_env::simd::level`]: AVX-512, AVX2 or the
/// baseline; the same bits at each).
///
/// Inlined, the four RK4 stages made the 16-lane step 55 KB of machine code,
/// more than the 32 KB instruction cache, fetched again from L2 on every
/// step; out of line, the stages share one 11 KB copy. Whole `rwg run` of
/// Acrobot-v1 0HL (3000 x 20, one pinned core): 0.90x the CPU time (0.77-1.03,
/// 9 pairs).
#[inline(always)]
fn dsdt<const N: usize>(y: &Y<N>, a: &[f64; N], sin_t2: &[f64; N], cos_t2: &[f64; N]) -> Y<N> {
    #[cfg(target_arch = "x86_64")]
    match rwg_env::simd::level() {
        // SAFETY: `level` names only a level the CPU has.
        rwg_env::simd::Simd::Avx512 => return unsafe { dsdt_avx512(y, a, sin_t2, cos_t2) },
        // SAFETY: as above.
        rwg_env::simd::Simd::Avx2 => return unsafe { dsdt_avx2(y, a, sin_t2, cos_t2) },
        rwg_env::simd::Simd::Scalar => {}
    }
    dsdt_base(y, a, sin_t2, cos_t2)
}

/// [`dsdt_body`] for the target's baseline.
#[inline(never)]
fn dsdt_base<const N: usize>(y: &Y<N>, a: &[f64; N], sin_t2: &[f64; N], cos_t2: &[f64; N]) -> Y<N> {
    dsdt_body(y, a, sin_t2, cos_t2)
}

/// [`dsdt_body`] compiled for AVX2; callable only on a CPU with AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline(never)]
unsafe fn dsdt_avx2<const N: usize>(
    y: &Y<N>,
    a: &[f64; N],
    sin_t2: &[f64; N],
    cos_t2: &[f64; N],
) -> Y<N> {
    dsdt_body(y, a, sin_t2, cos_t2)
}

/// [`dsdt_body`] compiled for AVX-512F/DQ/VL; callable only on a CPU with
/// them.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512dq,avx512vl")]
#[inline(never)]
unsafe fn dsdt_avx512<const N: usize>(
    y: &Y<N>,
    a: &[f64; N],
    sin_t2: &[f64; N],
    cos_t2: &[f64; N],
) -> Y<N> {
    dsdt_body(y, a, sin_t2, cos_t2)
}

/// The scalar `dsdt_with` for every lane, given `sin θ2, cos θ2` of `y`.
#[inline(always)]
fn dsdt_body<const N: usize>(y: &Y<N>, a: &[f64; N], sin_t2: &[f64; N], cos_t2: &[f64; N]) -> Y<N> {
    const M1: f64 = LINK_MASS_1;
    const M2: f64 = LINK_MASS_2;
    const L1: f64 = LINK_LENGTH_1;
    const LC1: f64 = LINK_COM_POS_1;
    const LC2: f64 = LINK_COM_POS_2;
    const I1: f64 = LINK_MOI_1;
    const I2: f64 = LINK_MOI_2;
    const LC1_SQ: f64 = LC1 * LC1;
    const LC2_SQ: f64 = LC2 * LC2;
    const L1_SQ: f64 = L1 * L1;

    // cos(θ1 + θ2 − π/2) and cos(θ1 − π/2), literally.
    let (mut arg2, mut arg1) = ([0.0; N], [0.0; N]);
    for i in 0..N {
        arg2[i] = y.t1[i] + y.t2[i] - PI / 2.0;
        arg1[i] = y.t1[i] - PI / 2.0;
    }
    let (mut cos2, mut cos1) = ([0.0; N], [0.0; N]);
    cos_lanes(&arg2, &mut cos2);
    cos_lanes(&arg1, &mut cos1);

    let (mut d1, mut d2) = ([0.0; N], [0.0; N]);
    for i in 0..N {
        d1[i] = M1 * LC1_SQ + M2 * (L1_SQ + LC2_SQ + 2.0 * L1 * LC2 * cos_t2[i]) + I1 + I2;
        d2[i] = M2 * (LC2_SQ + L1 * LC2 * cos_t2[i]) + I2;
    }
    // Python's x**2: libm pow's bits (`pow2`).
    let (mut sq_d1, mut sq_d2, mut sq_dd2) = ([0.0; N], [0.0; N], [0.0; N]);
    pow2_lanes(&y.d1, &mut sq_d1);
    pow2_lanes(&y.d2, &mut sq_d2);
    pow2_lanes(&d2, &mut sq_dd2);
    let mut out = Y::ZERO;
    for i in 0..N {
        let (dtheta1, dtheta2, sin_t2) = (y.d1[i], y.d2[i], sin_t2[i]);
        let phi2 = M2 * LC2 * G * cos2[i];
        let phi1 = -M2 * L1 * LC2 * sq_d2[i] * sin_t2
            - 2.0 * M2 * L1 * LC2 * dtheta2 * dtheta1 * sin_t2
            + (M1 * LC1 + M2 * L1) * G * cos1[i]
            + phi2;
        let ddtheta2 = (a[i] + d2[i] / d1[i] * phi1 - M2 * L1 * LC2 * sq_d1[i] * sin_t2 - phi2)
            / (M2 * LC2_SQ + I2 - sq_dd2[i] / d1[i]);
        let ddtheta1 = -(d2[i] * ddtheta2 + phi1) / d1[i];
        out.t1[i] = dtheta1;
        out.t2[i] = dtheta2;
        out.d1[i] = ddtheta1;
        out.d2[i] = ddtheta2;
    }
    out
}

/// [`dsdt`] with `sin θ2, cos θ2` of `y` computed here.
#[inline(always)]
fn dsdt_sc<const N: usize>(y: &Y<N>, a: &[f64; N]) -> Y<N> {
    let (mut s, mut c) = ([0.0; N], [0.0; N]);
    sincos_lanes(&y.t2, &mut s, &mut c);
    dsdt(y, a, &s, &c)
}

/// `N` acrobots stepped together.
#[derive(Debug, Clone)]
pub struct AcrobotLanes<const N: usize> {
    spec: EnvSpec,
    state: Y<N>,
    /// `sin θ2`, `cos θ2` of each lane's state (its observation's), which
    /// the next step's first RK4 stage uses.
    sin_t2: [f64; N],
    cos_t2: [f64; N],
    clocks: Clocks<N>,
}

impl<const N: usize> AcrobotLanes<N> {
    /// Lanes of [`Acrobot::new`], `max_episode_steps` overriding the
    /// registered 500.
    pub fn new(max_episode_steps: Option<u32>) -> Self {
        let spec = limited_spec(&Acrobot::new(), max_episode_steps);
        AcrobotLanes {
            clocks: Clocks::new(&spec),
            spec,
            state: Y::ZERO,
            sin_t2: [0.0; N],
            cos_t2: [1.0; N],
        }
    }

    /// Writes the observations `f32([cos θ1, sin θ1, cos θ2, sin θ2, θ̇1, θ̇2])`
    /// of the lanes in `lanes`, keeps their `sin θ2, cos θ2`, and returns
    /// every lane's `cos θ1`.
    #[inline(always)]
    fn write_obs(&mut self, lanes: &[bool; N], obs: &mut [f64]) -> [f64; N] {
        let (mut s1, mut c1, mut s2, mut c2) = ([0.0; N], [0.0; N], [0.0; N], [0.0; N]);
        sincos_lanes(&self.state.t1, &mut s1, &mut c1);
        sincos_lanes(&self.state.t2, &mut s2, &mut c2);
        for i in 0..N {
            if !lanes[i] {
                continue;
            }
            self.sin_t2[i] = s2[i];
            self.cos_t2[i] = c2[i];
            let o = [
                c1[i],
                s1[i],
                c2[i],
                s2[i],
                self.state.d1[i],
                self.state.d2[i],
            ];
            for (d, v) in obs[i * 6..i * 6 + 6].iter_mut().zip(o) {
                *d = f32r(v);
            }
        }
        c1
    }
}

impl<const N: usize> ManyEnv for AcrobotLanes<N> {
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
        check_lens(N, mask, obs, 6);
        let mut lanes = [false; N];
        for i in 0..N {
            if mask[i] != 1 {
                continue;
            }
            lanes[i] = true;
            // Four U[-0.1, 0.1) draws, as float32.
            let mut rng = Pcg64::from_seed(seeds[i]);
            let s = &mut self.state;
            for v in [&mut s.t1[i], &mut s.t2[i], &mut s.d1[i], &mut s.d2[i]] {
                *v = f32r(rng.uniform(-0.1, 0.1));
            }
            self.clocks.reset(i);
        }
        self.write_obs(&lanes, obs);
    }

    step_many_dispatched!();
}

wide_step!(AcrobotLanes);

impl<const N: usize> AcrobotLanes<N> {
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
        check_lens(N, mask, obs, 6);
        let mut act = [0usize; N];
        let live = gather_discrete(&self.clocks, mask, actions, 3, &mut act, on_fail);
        let mut a = [0.0; N];
        for i in 0..N {
            a[i] = AVAIL_TORQUE[act[i]];
        }
        // One RK4 step over [0, DT] (the scalar `rk4`).
        let y0 = self.state;
        let dt2 = DT / 2.0;
        let k1 = dsdt(&y0, &a, &self.sin_t2, &self.cos_t2);
        let k2 = dsdt_sc(&y0.axpy(dt2, &k1), &a);
        let k3 = dsdt_sc(&y0.axpy(dt2, &k2), &a);
        let k4 = dsdt_sc(&y0.axpy(DT, &k3), &a);
        let h = DT / 6.0;
        let mut ns = Y::<N>::ZERO;
        for i in 0..N {
            ns.t1[i] = y0.t1[i] + h * (((k1.t1[i] + 2.0 * k2.t1[i]) + 2.0 * k3.t1[i]) + k4.t1[i]);
            ns.t2[i] = y0.t2[i] + h * (((k1.t2[i] + 2.0 * k2.t2[i]) + 2.0 * k3.t2[i]) + k4.t2[i]);
            ns.d1[i] = y0.d1[i] + h * (((k1.d1[i] + 2.0 * k2.d1[i]) + 2.0 * k3.d1[i]) + k4.d1[i]);
            ns.d2[i] = y0.d2[i] + h * (((k1.d2[i] + 2.0 * k2.d2[i]) + 2.0 * k3.d2[i]) + k4.d2[i]);
        }
        // Wrapping loops only for the lanes that step.
        for i in 0..N {
            if live[i] {
                self.state.t1[i] = wrap(ns.t1[i]);
                self.state.t2[i] = wrap(ns.t2[i]);
                self.state.d1[i] = bound(ns.d1[i], -MAX_VEL_1, MAX_VEL_1);
                self.state.d2[i] = bound(ns.d2[i], -MAX_VEL_2, MAX_VEL_2);
            }
        }
        let cos_t1 = self.write_obs(&live, obs);
        let mut arg = [0.0; N];
        for i in 0..N {
            arg[i] = self.state.t2[i] + self.state.t1[i];
        }
        let mut cos_12 = [0.0; N];
        cos_lanes(&arg, &mut cos_12);
        let mut term = [false; N];
        for i in 0..N {
            // `−cos θ1 − cos(θ2 + θ1) > 1.0`, strict.
            term[i] = -cos_t1[i] - cos_12[i] > 1.0;
            if live[i] {
                rewards[i] = if term[i] { 0.0 } else { -1.0 };
            }
        }
        finish_flags(&mut self.clocks, &live, &term, terminated, truncated);
    }
}

impl<const N: usize> LockstepEnv for AcrobotLanes<N> {
    fn state_len(&self) -> usize {
        4
    }

    fn lane_state(&self, lane: usize, out: &mut [f64]) {
        let s = &self.state;
        out.copy_from_slice(&[s.t1[lane], s.t2[lane], s.d1[lane], s.d2[lane]]);
    }
}
