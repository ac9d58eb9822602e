//! Test helpers shared by the sampler loops' unit tests (`remote`, `many`).

use rwg_env::{Action, BoxSpace, EnvError, EnvSpec, Environment, Space, Step};

/// A toy env: episodes of 1 + (seed % 7) steps; fails at step 2 of
/// episodes whose seed is a multiple of `fail_every`, and at reset when
/// it is also odd; rewards of `f64::MAX` (finite, but the total of two
/// overflows) in episodes whose seed is 2 more than a multiple of it.
/// With `values` ([`Toy::with_values`]), values that are not finite by
/// `seed % 11`: 3, a `NonFinite` error at step 2; 4, a NaN reward at step
/// 3; 5, infinite observations at step 1 (network outputs NaN or not).
#[derive(Clone)]
pub(crate) struct Toy {
    spec: EnvSpec,
    seed: u64,
    t: u64,
    fail_every: u64,
    values: bool,
}

impl Toy {
    pub(crate) fn new(fail_every: u64, continuous: bool) -> Self {
        Toy {
            spec: EnvSpec {
                id: "Toy-v0".into(),
                observation_space: Space::Box(BoxSpace::symmetric(&[1e9, 1e9])),
                action_space: if continuous {
                    Space::Box(BoxSpace::symmetric(&[2.0]))
                } else {
                    Space::Discrete { n: 3 }
                },
                max_episode_steps: None,
                reward_threshold: None,
            },
            seed: 0,
            t: 0,
            fail_every,
            values: false,
        }
    }

    /// [`Toy::new`] with values that are not finite.
    pub(crate) fn with_values(fail_every: u64, continuous: bool) -> Self {
        Toy {
            values: true,
            ..Toy::new(fail_every, continuous)
        }
    }
}

impl Environment for Toy {
    fn spec(&self) -> &EnvSpec {
        &self.spec
    }
    fn reset(&mut self, seed: u64, obs: &mut [f64]) -> Result<(), EnvError> {
        if seed.is_multiple_of(self.fail_every) && seed % 2 == 1 {
            return Err(EnvError::Other(format!("reset {seed}")));
        }
        self.seed = seed;
        self.t = 0;
        obs[0] = (seed % 1000) as f64 / 1000.0;
        obs[1] = -obs[0];
        Ok(())
    }
    fn step(&mut self, a: Action<'_>, obs: &mut [f64]) -> Result<Step, EnvError> {
        let a = match a {
            Action::Discrete(a) => a as f64,
            Action::Continuous(v) => v[0],
        };
        self.t += 1;
        if self.seed.is_multiple_of(self.fail_every) && self.t == 2 {
            return Err(EnvError::Other(format!("step {}", self.seed)));
        }
        obs[0] = obs[0] * 0.5 + a;
        obs[1] = obs[1] * 0.25 - a;
        let huge = self.seed % self.fail_every == 2;
        let mut reward = if huge { f64::MAX } else { obs[0] - obs[1] };
        match (self.values, self.seed % 11, self.t) {
            (true, 3, 2) => return Err(EnvError::NonFinite("obs[0] = NaN".into())),
            (true, 4, 3) => reward = f64::NAN,
            (true, 5, 1) => (obs[0], obs[1]) = (f64::INFINITY, f64::NEG_INFINITY),
            _ => {}
        }
        Ok(Step {
            reward,
            terminated: self.t > self.seed % 7,
            truncated: false,
        })
    }
}
