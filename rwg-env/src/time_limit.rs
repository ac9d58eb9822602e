//! Gymnasium's `TimeLimit` wrapper (which here also enforces reset-before-step,
//! like Gymnasium's `OrderEnforcing`).

use crate::env::{Action, EnvError, EnvSpec, Environment, Step};

/// Truncates episodes after `max_episode_steps` steps, as Gymnasium's
/// `TimeLimit` does: `reset` zeroes the step count, every step increments it,
/// and `truncated` is set on the step where the count reaches the limit,
/// independently of `terminated` (both may be true). A step before the first
/// reset is refused with [`EnvError::ResetNeeded`], as `OrderEnforcing` does.
#[derive(Debug, Clone)]
pub struct TimeLimit<E> {
    inner: E,
    spec: EnvSpec,
    max_steps: u32,
    elapsed: u32,
    has_reset: bool,
}

impl<E: Environment> TimeLimit<E> {
    /// Wraps `inner`; `max_episode_steps = None` uses the inner spec's limit
    /// (no limit at all if it has none). `Some(u32::MAX)` is no limit either:
    /// the step count saturates there.
    pub fn new(inner: E, max_episode_steps: Option<u32>) -> Self {
        let mut spec = inner.spec().clone();
        if max_episode_steps.is_some() {
            spec.max_episode_steps = max_episode_steps;
        }
        let max_steps = spec.max_episode_steps.unwrap_or(u32::MAX);
        TimeLimit {
            inner,
            spec,
            max_steps,
            elapsed: 0,
            has_reset: false,
        }
    }

    /// The wrapped environment.
    pub fn inner(&self) -> &E {
        &self.inner
    }

    /// Steps taken in the current episode.
    pub fn elapsed(&self) -> u32 {
        self.elapsed
    }
}

impl<E: Environment> Environment for TimeLimit<E> {
    fn spec(&self) -> &EnvSpec {
        &self.spec
    }

    #[inline]
    fn reset(&mut self, seed: u64, obs: &mut [f64]) -> Result<(), EnvError> {
        self.elapsed = 0;
        self.inner.reset(seed, obs)?;
        self.has_reset = true;
        Ok(())
    }

    #[inline]
    fn step(&mut self, action: Action<'_>, obs: &mut [f64]) -> Result<Step, EnvError> {
        if !self.has_reset {
            return Err(EnvError::ResetNeeded);
        }
        let mut s = self.inner.step(action, obs)?;
        self.elapsed = self.elapsed.saturating_add(1);
        if self.elapsed >= self.max_steps {
            s.truncated = true;
        }
        Ok(s)
    }

    fn state_len(&self) -> usize {
        self.inner.state_len()
    }

    fn state(&self, out: &mut [f64]) -> Result<(), EnvError> {
        self.inner.state(out)
    }

    fn set_state(&mut self, state: &[f64], obs: &mut [f64]) -> Result<(), EnvError> {
        self.elapsed = 0;
        self.inner.set_state(state, obs)?;
        self.has_reset = true;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::space::{BoxSpace, Space};

    /// Counts steps; terminates on step 3.
    struct Counter {
        spec: EnvSpec,
        t: u32,
    }

    impl Environment for Counter {
        fn spec(&self) -> &EnvSpec {
            &self.spec
        }
        fn reset(&mut self, _seed: u64, obs: &mut [f64]) -> Result<(), EnvError> {
            self.t = 0;
            obs[0] = 0.0;
            Ok(())
        }
        fn step(&mut self, _a: Action<'_>, obs: &mut [f64]) -> Result<Step, EnvError> {
            self.t += 1;
            obs[0] = self.t as f64;
            Ok(Step {
                reward: 1.0,
                terminated: self.t == 3,
                truncated: false,
            })
        }
    }

    fn counter(limit: Option<u32>) -> TimeLimit<Counter> {
        let spec = EnvSpec {
            id: "Counter-v0".into(),
            observation_space: Space::Box(BoxSpace::symmetric(&[10.0])),
            action_space: Space::Discrete { n: 1 },
            max_episode_steps: Some(5),
            reward_threshold: None,
        };
        TimeLimit::new(Counter { spec, t: 0 }, limit)
    }

    #[test]
    fn truncates_on_the_limit_step_and_allows_both_flags() {
        let mut env = counter(Some(3));
        let mut obs = [0.0];
        env.reset(0, &mut obs).unwrap();
        let a = Action::Discrete(0);
        assert!(!env.step(a, &mut obs).unwrap().truncated);
        assert!(!env.step(a, &mut obs).unwrap().truncated);
        let s = env.step(a, &mut obs).unwrap();
        assert!(s.truncated && s.terminated);
        env.reset(0, &mut obs).unwrap();
        assert!(!env.step(a, &mut obs).unwrap().truncated);
    }

    #[test]
    fn step_before_reset_is_refused() {
        let mut env = counter(None);
        let mut obs = [0.0];
        assert_eq!(
            env.step(Action::Discrete(0), &mut obs),
            Err(EnvError::ResetNeeded)
        );
    }

    #[test]
    fn uses_spec_limit_by_default() {
        let mut env = counter(None);
        assert_eq!(env.spec().max_episode_steps, Some(5));
        let mut obs = [0.0];
        env.reset(0, &mut obs).unwrap();
        let flags: Vec<bool> = (0..5)
            .map(|_| env.step(Action::Discrete(0), &mut obs).unwrap().truncated)
            .collect();
        assert_eq!(flags, [false, false, false, false, true]);
    }
}
