//! MountainCarContinuous-v0 over `N` lanes: [`crate::mountain_car_continuous`]'s
//! numpy-2 arithmetic per lane (each lane's precision depends on its own
//! state's and action's kinds), one `cos_lanes` per step for the gravity
//! term `cos(3 * position)`.

use super::wide::{step_many_dispatched, wide_step};
use super::{
    check_lens, finish_flags, gather_continuous1, limited_spec, pow2_lanes, Clocks, LockstepEnv,
};
use crate::mountain_car::reset_state;
use crate::mountain_car_continuous::{
    MountainCarContinuous, GOAL_POSITION, MAX_ACTION, MAX_POSITION, MAX_SPEED, MIN_ACTION,
    MIN_POSITION, POWER,
};
use rwg_env::float::f32r;
use rwg_env::lanes_math::cos_lanes;
use rwg_env::many::ManyEnv;
use rwg_env::{ActionDtype, EnvError, EnvSpec};

/// `N` continuous mountain cars stepped together.
#[derive(Debug, Clone)]
pub struct MountainCarContinuousLanes<const N: usize> {
    spec: EnvSpec,
    dtype: ActionDtype,
    position: [f64; N],
    velocity: [f64; N],
    /// Per lane: the state is the float32 array a step stores (false right
    /// after reset, Gymnasium's float64 array).
    state_is_f32: [bool; N],
    clocks: Clocks<N>,
}

impl<const N: usize> MountainCarContinuousLanes<N> {
    /// Lanes of [`MountainCarContinuous::new`]`(dtype)` with the time limit
    /// `max_episode_steps` (`None`: the registered 999).
    pub fn new(dtype: ActionDtype, max_episode_steps: Option<u32>) -> Self {
        let spec = limited_spec(&MountainCarContinuous::new(dtype), max_episode_steps);
        MountainCarContinuousLanes {
            clocks: Clocks::new(&spec),
            spec,
            dtype,
            position: [0.0; N],
            velocity: [0.0; N],
            state_is_f32: [false; N],
        }
    }

    /// The observation of lane `i`: its state as float32.
    #[inline(always)]
    fn write_obs(&self, i: usize, obs: &mut [f64]) {
        obs[i * 2] = f32r(self.position[i]);
        obs[i * 2 + 1] = f32r(self.velocity[i]);
    }
}

/// `x + y` in float32 (both rounded to f32 first, as numpy does for a
/// float32 operation) or in float64.
#[inline(always)]
fn add(f32_op: bool, x: f64, y: f64) -> f64 {
    let x32 = (x as f32 + y as f32) as f64;
    let x64 = x + y;
    if f32_op {
        x32
    } else {
        x64
    }
}

/// `x > y` compared in float32 or in float64.
#[inline(always)]
fn gt(f32_op: bool, x: f64, y: f64) -> bool {
    let c32 = x as f32 > y as f32;
    let c64 = x > y;
    if f32_op {
        c32
    } else {
        c64
    }
}

impl<const N: usize> ManyEnv for MountainCarContinuousLanes<N> {
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
                self.state_is_f32[i] = false;
                self.clocks.reset(i);
                self.write_obs(i, obs);
            }
        }
    }

    step_many_dispatched!();
}

wide_step!(MountainCarContinuousLanes);

impl<const N: usize> MountainCarContinuousLanes<N> {
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
        let mut raw = [0.0; N];
        let live = gather_continuous1(&self.clocks, mask, actions, &mut raw, on_fail);
        // The scalar step's numpy-2 kinds (see `crate::mountain_car_continuous`)
        // as booleans per lane, both precisions computed and one selected,
        // so the loops have no branches and vectorise (the booleans combine
        // with `&` and `|`: a short-circuit `&&` or `||` made LLVM keep the
        // main loop scalar and branchy). The action's kind is
        // the dtype's (a float32 action is f32-representable, so comparing
        // it with the exact bounds ±1 gives the same answer in either
        // precision); the state is float32 after a step, float64 after reset.
        let a32 = self.dtype == ActionDtype::F32;
        let mut a = [0.0; N];
        let mut three_p = [0.0; N];
        for i in 0..N {
            a[i] = if a32 { f32r(raw[i]) } else { raw[i] };
            // 3 * position, in the state's precision.
            let p = self.position[i];
            let p32 = (3.0f32 * p as f32) as f64;
            three_p[i] = if self.state_is_f32[i] { p32 } else { 3.0 * p };
        }
        let mut cos_3p = [0.0; N];
        cos_lanes(&three_p, &mut cos_3p);
        // math.pow(action[0], 2), the raw action as the env sees it.
        let mut sq_a = [0.0; N];
        pow2_lanes(&a, &mut sq_a);
        let (mut new_p, mut new_v, mut term, mut reward) =
            ([0.0; N], [0.0; N], [false; N], [0.0; N]);
        for i in 0..N {
            let s32 = self.state_is_f32[i];
            // force = min(max(a, -1.0), 1.0); a clipped force is a Python float.
            let lo = MIN_ACTION > a[i];
            let force = if lo { MIN_ACTION } else { a[i] };
            let hi = MAX_ACTION < force;
            let force = if hi { MAX_ACTION } else { force };
            let force_py = lo | hi;
            // force * power: float32 only for an unclipped float32 action.
            let fp_f32 = a32 & !force_py;
            let fp32 = (force as f32 * POWER as f32) as f64;
            let fp = if fp_f32 { fp32 } else { force * POWER };
            // ... - 0.0025 * math.cos(3 * position) (a Python float).
            let gravity = 0.0025 * cos_3p[i];
            let t32 = (fp as f32 - gravity as f32) as f64;
            let t = if fp_f32 { t32 } else { fp - gravity };
            // velocity += t: float32 unless either side is np.float64.
            let v_f32 = s32 & (a32 | force_py);
            let v = add(v_f32, self.velocity[i], t);
            let v_hi = gt(v_f32, v, MAX_SPEED);
            let v_lo = !v_hi & gt(v_f32, -MAX_SPEED, v);
            let v_py = v_hi | v_lo;
            let v = if v_hi {
                MAX_SPEED
            } else if v_lo {
                -MAX_SPEED
            } else {
                v
            };
            // position += velocity.
            let p_f32 = s32 & (v_f32 | v_py);
            let p = add(p_f32, self.position[i], v);
            let p_hi = gt(p_f32, p, MAX_POSITION);
            let p_lo = !p_hi & gt(p_f32, MIN_POSITION, p);
            let p_py = p_hi | p_lo;
            let p = if p_hi {
                MAX_POSITION
            } else if p_lo {
                MIN_POSITION
            } else {
                p
            };
            // A Python float position compares in float64.
            let pos_f32 = p_f32 & !p_py;
            let at_min32 = p as f32 == MIN_POSITION as f32;
            let at_min = if pos_f32 { at_min32 } else { p == MIN_POSITION };
            let v = if at_min & (v < 0.0) { 0.0 } else { v };
            let goal32 = p as f32 >= GOAL_POSITION as f32;
            let goal = if pos_f32 { goal32 } else { p >= GOAL_POSITION };
            let t = goal & (v >= 0.0);
            term[i] = t;
            reward[i] = if t { 100.0 } else { 0.0 } - sq_a[i] * 0.1;
            new_p[i] = f32r(p);
            new_v[i] = f32r(v);
        }
        for i in 0..N {
            if live[i] {
                // self.state = np.array([position, velocity], dtype=np.float32)
                self.position[i] = new_p[i];
                self.velocity[i] = new_v[i];
                self.state_is_f32[i] = true;
                rewards[i] = reward[i];
                self.write_obs(i, obs);
            }
        }
        finish_flags(&mut self.clocks, &live, &term, terminated, truncated);
    }
}

impl<const N: usize> LockstepEnv for MountainCarContinuousLanes<N> {
    fn state_len(&self) -> usize {
        2
    }

    fn lane_state(&self, lane: usize, out: &mut [f64]) {
        out.copy_from_slice(&[self.position[lane], self.velocity[lane]]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rwg_env::{Action, Environment};

    /// The f32 neighbours of `x` (as f64) and `x` itself, rounded or not.
    fn around(x: f64) -> Vec<f64> {
        let f = x as f32;
        vec![x, f as f64, f.next_up() as f64, f.next_down() as f64]
    }

    /// States and actions at every bound of the step (the clips of force,
    /// speed and position, the left wall, the goal), in both state kinds and
    /// both action dtypes, stepped by the scalar env and a lane: same bits.
    /// Each lane starts where the scalar env is set (by the fields: a float32
    /// state arises only from a step).
    #[test]
    fn corner_states_match_the_scalar_env() {
        let mut positions = Vec::new();
        for b in [MIN_POSITION, GOAL_POSITION, MAX_POSITION] {
            for d in [0.0, 0.07, -0.07, 0.0699, -0.0699, 1e-3, -1e-3] {
                positions.extend(around(b + d));
            }
        }
        positions.push(-0.5);
        let mut velocities = Vec::new();
        for b in [MAX_SPEED, -MAX_SPEED, 0.0, 0.0015, -0.0015, 0.0685, -0.0685] {
            velocities.extend(around(b));
        }
        let mut actions = Vec::new();
        for b in [MAX_ACTION, MIN_ACTION, 0.5, 0.0] {
            actions.extend(around(b));
        }
        actions.extend([f64::NAN, f64::INFINITY, f64::NEG_INFINITY, 3.0, -1e200]);
        let mut cases = Vec::new();
        for dtype in [ActionDtype::F64, ActionDtype::F32] {
            for &p in &positions {
                for &v in &velocities {
                    for s32 in [false, true] {
                        let (p, v) = if s32 { (f32r(p), f32r(v)) } else { (p, v) };
                        for &a in &actions {
                            cases.push((dtype, p, v, s32, a));
                        }
                    }
                }
            }
        }
        // States from which a float32 step lands exactly on f32(-1.2)
        // without the clip (the left wall's float32 comparison): found by
        // fixed-point iteration p0 = f32(-1.2) - v_new(p0).
        let step_from = |dtype, p, v, a| {
            let mut e = MountainCarContinuous::new(dtype);
            e.state = [p, v];
            e.state_is_f32 = true;
            let mut o = [0.0; 2];
            e.step(Action::Continuous(&[a]), &mut o).unwrap();
            e.state
        };
        let mut at_wall = 0;
        for dtype in [ActionDtype::F64, ActionDtype::F32] {
            for k in 1..400 {
                let v0 = f32r(-(k as f64) * 1.7e-4);
                for a in [-1.0, -0.3, 0.0, 0.4, 1.0] {
                    let mut p0 = f32r(MIN_POSITION - v0);
                    for _ in 0..4 {
                        let [_, v1] = step_from(dtype, p0, v0, a);
                        if v1 == 0.0 {
                            break;
                        }
                        p0 = ((MIN_POSITION as f32) - v1 as f32) as f64;
                    }
                    // Walk up to the highest start that still ends at the
                    // wall: its sum lands on f32(-1.2) without the clip.
                    let wall = [f32r(MIN_POSITION), 0.0];
                    let mut q = p0 as f32;
                    if step_from(dtype, q as f64, v0, a) == wall {
                        at_wall += 1;
                        for _ in 0..2000 {
                            if step_from(dtype, q.next_up() as f64, v0, a) != wall {
                                break;
                            }
                            q = q.next_up();
                        }
                    }
                    for x in [q.next_down(), q, q.next_up()] {
                        cases.push((dtype, x as f64, v0, true, a));
                    }
                }
            }
        }
        assert!(at_wall > 10, "only {at_wall} states land on the wall");
        let mut steps = 0;
        for (dtype, p, v, s32, a) in cases {
            let mut lanes = MountainCarContinuousLanes::<1>::new(dtype, None);
            let mut scalar = MountainCarContinuous::new(dtype);
            scalar.state = [p, v];
            scalar.state_is_f32 = s32;
            let mut want_obs = [0.0; 2];
            let want = scalar
                .step(Action::Continuous(&[a]), &mut want_obs)
                .unwrap();
            lanes.position[0] = p;
            lanes.velocity[0] = v;
            lanes.state_is_f32[0] = s32;
            lanes.clocks.reset(0);
            let (mut obs, mut r, mut t, mut tr) = ([0.0; 2], [0.0], [0u8], [0u8]);
            lanes.step_many(
                &[1],
                &[a],
                &mut obs,
                &mut r,
                &mut t,
                &mut tr,
                &mut |_, e| panic!("{e}"),
            );
            let what = format!("{dtype:?} p {p:e} v {v:e} f32 {s32} a {a:e}");
            assert_eq!(
                obs.map(f64::to_bits),
                want_obs.map(f64::to_bits),
                "{what}: obs"
            );
            assert_eq!(
                [lanes.position[0], lanes.velocity[0]].map(f64::to_bits),
                scalar.state.map(f64::to_bits),
                "{what}: state"
            );
            assert_eq!(r[0].to_bits(), want.reward.to_bits(), "{what}: reward");
            assert_eq!(t[0] == 1, want.terminated, "{what}: terminated");
            steps += 1;
        }
        assert!(steps > 10_000);
    }
}
