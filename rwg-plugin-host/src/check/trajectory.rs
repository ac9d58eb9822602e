//! What the checks drive environments with: a deterministic action source,
//! recorded trajectories, and small helpers.

use rwg_env::env::{Action, EnvError, EnvSpec, Environment};
use rwg_env::space::Space;

/// Makes a fresh instance of the environment under test (errors as text).
/// Shared by threads in the `threads` check.
pub(super) type Fresh<'a, E> = &'a (dyn Fn() -> Result<E, String> + Sync);

/// Mixed into a seed to seed the action sequence of a trajectory.
pub(super) const ACTION_SALT: u64 = 0x5eed_0fac_710a_5eed;

/// Steps per trajectory in the determinism checks.
pub(super) const TRAJ_STEPS: usize = 300;
/// SplitMix64: the checker's deterministic action source.
pub(super) struct Rng(pub(super) u64);

impl Rng {
    /// The next 64 random bits.
    pub(super) fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }
    /// A uniform number in [0, 1).
    pub(super) fn unit(&mut self) -> f64 {
        (self.next() >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// An owned action sampled from a space.
pub(super) enum OwnedAction {
    /// A discrete action (may be out of range on purpose).
    Discrete(i64),
    /// A continuous action (may be malformed on purpose).
    Continuous(Vec<f64>),
}

impl OwnedAction {
    /// Borrowed as an [`Action`].
    pub(super) fn as_action(&self) -> Action<'_> {
        match self {
            OwnedAction::Discrete(a) => Action::Discrete(*a),
            OwnedAction::Continuous(v) => Action::Continuous(v),
        }
    }
}

/// A random action of `space` (box bounds clipped to ±1e3).
pub(super) fn sample(space: &Space, rng: &mut Rng) -> OwnedAction {
    match space {
        Space::Discrete { n } => OwnedAction::Discrete((rng.next() % (*n as u64).max(1)) as i64),
        Space::Box(b) => OwnedAction::Continuous(
            b.low
                .iter()
                .zip(&b.high)
                .map(|(&lo, &hi)| {
                    let (lo, hi) = (lo.max(-1e3), hi.min(1e3));
                    lo + (hi - lo) * rng.unit()
                })
                .collect(),
        ),
    }
}

/// `[x, y, ...]` with numpy's float formatting.
pub(super) fn fmt_vec(v: &[f64]) -> String {
    let parts: Vec<String> = v.iter().map(|x| rwg_env::float::fmt_f64(*x)).collect();
    format!("[{}]", parts.join(", "))
}

/// Whether an observation lies in `space`.
pub(super) fn in_space(space: &Space, obs: &[f64]) -> bool {
    match space {
        Space::Box(b) => b.contains(obs),
        Space::Discrete { n } => obs.len() == 1 && obs[0] >= 0.0 && obs[0] < *n as f64,
    }
}

/// A recorded trajectory: the bits of every observation, reward and flag.
#[derive(Debug, PartialEq)]
pub(super) struct Traj(Vec<u64>);

/// Runs `seed` with the checker's action sequence for `action_seed`.
pub(super) fn trajectory<E: Environment>(
    env: &mut E,
    seed: u64,
    action_seed: u64,
    steps: usize,
) -> Result<Traj, EnvError> {
    let spec = env.spec().clone();
    let mut obs = vec![0.0; spec.obs_dim()];
    let mut rec = Vec::new();
    let mut rng = Rng(action_seed ^ ACTION_SALT);
    env.reset(seed, &mut obs)?;
    rec.extend(obs.iter().map(|x| x.to_bits()));
    for _ in 0..steps {
        let a = sample(&spec.action_space, &mut rng);
        let s = env.step(a.as_action(), &mut obs)?;
        rec.extend(obs.iter().map(|x| x.to_bits()));
        rec.push(s.reward.to_bits());
        rec.push(u64::from(s.terminated) | u64::from(s.truncated) << 1);
        if s.terminated || s.truncated {
            break;
        }
    }
    Ok(Traj(rec))
}

/// Two instances stepped alternately on one thread (seeds 21 and 22).
pub(super) fn interleaved<E: Environment>(
    a: &mut E,
    b: &mut E,
    spec: &EnvSpec,
) -> Result<(Traj, Traj), EnvError> {
    let dim = spec.obs_dim();
    let envs = [a, b];
    let seeds = [21u64, 22];
    let mut obs = [vec![0.0; dim], vec![0.0; dim]];
    let mut rec = [Vec::new(), Vec::new()];
    let mut rng = seeds.map(|s| Rng(s ^ ACTION_SALT));
    let mut done = [false, false];
    for i in 0..2 {
        envs[i].reset(seeds[i], &mut obs[i])?;
        rec[i].extend(obs[i].iter().map(|x| x.to_bits()));
    }
    for _ in 0..TRAJ_STEPS {
        for i in 0..2 {
            if done[i] {
                continue;
            }
            let act = sample(&spec.action_space, &mut rng[i]);
            let s = envs[i].step(act.as_action(), &mut obs[i])?;
            rec[i].extend(obs[i].iter().map(|x| x.to_bits()));
            rec[i].push(s.reward.to_bits());
            rec[i].push(u64::from(s.terminated) | u64::from(s.truncated) << 1);
            done[i] = s.terminated || s.truncated;
        }
        if done[0] && done[1] {
            break;
        }
    }
    let [ra, rb] = rec;
    Ok((Traj(ra), Traj(rb)))
}

/// One instance's trajectory for `seed` (actions seeded by `seed` too).
pub(super) fn solo<E: Environment>(fresh: Fresh<'_, E>, seed: u64) -> Result<Traj, String> {
    let mut env = fresh()?;
    trajectory(&mut env, seed, seed, TRAJ_STEPS).map_err(|e| format!("seed {seed}: {e}"))
}
