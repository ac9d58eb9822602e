//! MountainCarContinuous-v0 over `N` lanes: [`crate::mountain_car_continuous`]'s
//! numpy-2 arithmetic per lane (each lane's precision depends on its own
//! state's and action's kinds), one `cos_lanes` per step for the gravity
//! term `cos(3 * position)`.

use super::{
    check_lens, finish_flags, gather_continuous1, limited_spec, pow2_lanes, Clocks, LockstepEnv,
};
use crate::mountain_car::reset_state;
use crate::mountain_car_continuous::{
    Kind, MountainCarContinuous, Num, GOAL_POSITION, MAX_ACTION, MAX_POSITION, MAX_SPEED,
    MIN_ACTION, MIN_POSITION, POWER,
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
    #[inline]
    fn write_obs(&self, i: usize, obs: &mut [f64]) {
        obs[i * 2] = f32r(self.position[i]);
        obs[i * 2 + 1] = f32r(self.velocity[i]);
    }

    /// Lane `i`'s action and state as numpy-2 scalars.
    #[inline(always)]
    fn operands(&self, i: usize, raw: f64) -> (Num, Num, Num) {
        let a = match self.dtype {
            ActionDtype::F64 => Num::new(raw, Kind::F64),
            ActionDtype::F32 => Num::new(f32r(raw), Kind::F32),
        };
        let kind = if self.state_is_f32[i] {
            Kind::F32
        } else {
            Kind::F64
        };
        (
            a,
            Num::new(self.position[i], kind),
            Num::new(self.velocity[i], kind),
        )
    }
}

/// The scalar step of one lane after `math.cos(3 * position)` (and
/// `sq_a = pow2(a)`, the reward's `math.pow(action[0], 2)`): returns the
/// new `(position, velocity)` (unrounded), whether it terminated, and the
/// reward.
#[inline(always)]
fn after_cos(
    a: Num,
    mut position: Num,
    mut velocity: Num,
    cos_3p: f64,
    sq_a: f64,
) -> (Num, Num, bool, f64) {
    let mut force = a;
    if Num::py(MIN_ACTION).gt(force) {
        force = Num::py(MIN_ACTION);
    }
    if Num::py(MAX_ACTION).lt(force) {
        force = Num::py(MAX_ACTION);
    }
    let gravity = Num::py(0.0025 * cos_3p);
    velocity = velocity + (force * Num::py(POWER) - gravity);
    if velocity.gt(Num::py(MAX_SPEED)) {
        velocity = Num::py(MAX_SPEED);
    }
    if velocity.lt(Num::py(-MAX_SPEED)) {
        velocity = Num::py(-MAX_SPEED);
    }
    position = position + velocity;
    if position.gt(Num::py(MAX_POSITION)) {
        position = Num::py(MAX_POSITION);
    }
    if position.lt(Num::py(MIN_POSITION)) {
        position = Num::py(MIN_POSITION);
    }
    if position.eq(Num::py(MIN_POSITION)) && velocity.x < 0.0 {
        velocity = Num::py(0.0);
    }
    let terminated = position.ge(Num::py(GOAL_POSITION)) && velocity.x >= 0.0;
    let mut reward = if terminated { 100.0 } else { 0.0 };
    reward -= sq_a * 0.1;
    (position, velocity, terminated, reward)
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

    fn step_many(
        &mut self,
        mask: &[u8],
        actions: &[f64],
        obs: &mut [f64],
        rewards: &mut [f64],
        terminated: &mut [u8],
        truncated: &mut [u8],
        on_fail: &mut dyn FnMut(usize, EnvError),
    ) {
        check_lens(N, mask, obs, 2);
        let mut raw = [0.0; N];
        let live = gather_continuous1(&self.clocks, mask, actions, &mut raw, on_fail);
        // 3 * position, in the lane's precision.
        let mut three_p = [0.0; N];
        for i in 0..N {
            let (_, position, _) = self.operands(i, raw[i]);
            three_p[i] = (Num::py(3.0) * position).x;
        }
        let mut cos_3p = [0.0; N];
        cos_lanes(&three_p, &mut cos_3p);
        // math.pow(action[0], 2) of the action as the env sees it.
        let mut a_val = [0.0; N];
        for i in 0..N {
            a_val[i] = self.operands(i, raw[i]).0.x;
        }
        let mut sq_a = [0.0; N];
        pow2_lanes(&a_val, &mut sq_a);
        let mut term = [false; N];
        for i in 0..N {
            if !live[i] {
                continue;
            }
            let (a, position, velocity) = self.operands(i, raw[i]);
            let (p, v, t, r) = after_cos(a, position, velocity, cos_3p[i], sq_a[i]);
            // self.state = np.array([position, velocity], dtype=np.float32)
            self.position[i] = f32r(p.x);
            self.velocity[i] = f32r(v.x);
            self.state_is_f32[i] = true;
            term[i] = t;
            rewards[i] = r;
            self.write_obs(i, obs);
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
