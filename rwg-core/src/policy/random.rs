//! Uniformly random actions: the random baseline a cell runs in place of
//! networks ([`PolicyKind::Random`]).
//!
//! Each episode has a generator of its own, seeded from the plan
//! ([`crate::plan::action_rng`]: numpy's `PCG64(SeedSequence([seed, 3,
//! env_key, n, e]))`), and every step draws from it: a discrete action of
//! `n` is `floor(n * u)` and a box action is `low + (high - low) * u` per
//! dimension in order, `u` being numpy's `Generator.random()`. So numpy
//! gives the same actions:
//!
//! ```python
//! rng = np.random.Generator(np.random.PCG64(np.random.SeedSequence([seed, 3, env_key, n, e])))
//! a = int(rng.random() * space.n)           # Discrete
//! a = rng.uniform(space.low, space.high)    # Box
//! ```
//!
//! Drawing allocates nothing; seeding (once per episode) builds the seed
//! sequence as [`crate::plan::reset_seed`] does.

use rwg_env::env::Action;
use rwg_env::seeding::Pcg64;
use rwg_env::space::Space;

/// What picks a cell's actions.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash)]
pub enum PolicyKind {
    /// The architecture's tanh networks, their weights drawn from the plan
    /// (the paper's controllers).
    #[default]
    Network,
    /// Uniformly random actions, no network and no weights: the random
    /// baseline of an env, run as a cell of N "samples" x E episodes.
    Random,
}

/// The action space, as random actions are drawn from it.
#[derive(Debug, Clone, PartialEq)]
enum Draw {
    /// `floor(n * u)`, at most `n - 1`.
    Discrete(usize),
    /// `low + (high - low) * u` per dimension.
    Box(Vec<f64>, Vec<f64>),
}

/// Uniformly random actions for `K` lanes, each lane with the generator of
/// the episode it runs. Acting allocates nothing.
#[derive(Debug, Clone)]
pub struct RandomActions<const K: usize> {
    draw: Draw,
    rngs: Vec<Pcg64>,
    /// Box actions of all lanes, lane-major.
    action: Vec<f64>,
}

impl<const K: usize> RandomActions<K> {
    /// Random actions of `space` for `K` lanes (each lane seeded with 0
    /// until [`RandomActions::seed_lane`]).
    ///
    /// Panics on a box with a bound that is not finite, or a discrete space
    /// of no action (the study refuses both before it runs).
    pub fn new(space: &Space) -> Self {
        let draw = match space {
            Space::Discrete { n } => {
                assert!(*n > 0, "a discrete space of no action");
                Draw::Discrete(*n)
            }
            Space::Box(b) => {
                assert!(
                    b.low.iter().chain(&b.high).all(|v| v.is_finite()),
                    "uniform actions need a box with finite bounds"
                );
                Draw::Box(b.low.clone(), b.high.clone())
            }
        };
        RandomActions {
            action: vec![0.0; K * space.flat_dim()],
            rngs: vec![Pcg64::from_seed(0); K],
            draw,
        }
    }

    /// Lane `lane` starts an episode whose actions come from `rng`.
    pub fn seed_lane(&mut self, lane: usize, rng: Pcg64) {
        self.rngs[lane] = rng;
    }

    /// Lane `lane`'s next action (one draw per dimension from its generator).
    #[inline]
    pub fn action(&mut self, lane: usize) -> Action<'_> {
        let rng = &mut self.rngs[lane];
        match &self.draw {
            Draw::Discrete(n) => Action::Discrete(discrete(rng, *n) as i64),
            Draw::Box(low, high) => {
                let d = low.len();
                let a = &mut self.action[lane * d..(lane + 1) * d];
                for ((a, l), h) in a.iter_mut().zip(low).zip(high) {
                    *a = rng.uniform(*l, *h);
                }
                Action::Continuous(a)
            }
        }
    }

    /// [`RandomActions::action`] of every lane `i` with `mask[i] == 1`, in
    /// the layout of a [`rwg_env::many::ManyEnv`]'s action buffer (as
    /// [`crate::policy::PolicyLanes::actions_into`]); other lanes' slots and
    /// generators are left as they are.
    #[inline]
    pub fn actions_into(&mut self, mask: &[u8; K], out: &mut [f64]) {
        let d = match &self.draw {
            Draw::Discrete(_) => 1,
            Draw::Box(low, _) => low.len(),
        };
        for (l, &m) in mask.iter().enumerate() {
            if m != 1 {
                continue;
            }
            match self.action(l) {
                Action::Discrete(a) => out[l] = a as f64,
                Action::Continuous(a) => out[l * d..(l + 1) * d].copy_from_slice(a),
            }
        }
    }
}

/// `floor(n * u)` for numpy's `u = Generator.random()`, kept below `n`.
#[inline]
fn discrete(rng: &mut Pcg64, n: usize) -> usize {
    ((rng.next_f64() * n as f64) as usize).min(n - 1)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plan::action_rng;
    use rwg_env::space::BoxSpace;

    /// numpy 2.x:
    ///   k = int.from_bytes(b"CartPole-v1", "little")
    ///   rng = np.random.Generator(np.random.PCG64(np.random.SeedSequence([0, 3, k, 5, 2])))
    ///   [int(rng.random() * 2) for _ in range(12)]
    ///   rng.uniform([-2.0, 0.0], [2.0, 1.0])  (after the 12 above)
    #[test]
    fn draws_are_numpys() {
        let mut r = RandomActions::<1>::new(&Space::Discrete { n: 2 });
        r.seed_lane(0, action_rng(0, "CartPole-v1", 5, 2));
        let got: Vec<i64> = (0..12)
            .map(|_| match r.action(0) {
                Action::Discrete(a) => a,
                Action::Continuous(_) => unreachable!(),
            })
            .collect();
        assert_eq!(got, NUMPY_DISCRETE);
        let mut rng = action_rng(0, "CartPole-v1", 5, 2);
        for _ in 0..12 {
            rng.next_f64();
        }
        let space = Space::Box(BoxSpace::new(vec![-2.0, 0.0], vec![2.0, 1.0]));
        let mut b = RandomActions::<1>::new(&space);
        b.seed_lane(0, rng);
        let Action::Continuous(a) = b.action(0) else {
            unreachable!()
        };
        assert_eq!(a, NUMPY_BOX);
    }
    const NUMPY_DISCRETE: [i64; 12] = [0, 0, 0, 1, 0, 1, 0, 0, 1, 0, 0, 0];
    const NUMPY_BOX: [f64; 2] = [-0.22348133889464172, 0.8882145400823203];

    #[test]
    fn every_action_is_drawn_and_lanes_are_independent() {
        let mut r = RandomActions::<4>::new(&Space::Discrete { n: 3 });
        for l in 0..4 {
            r.seed_lane(l, action_rng(1, "x", l as u64, 0));
        }
        let mut seen = [0usize; 3];
        let mut out = [9.0; 4];
        for _ in 0..300 {
            r.actions_into(&[1, 0, 1, 1], &mut out);
            assert_eq!(out[1], 9.0, "a masked-out lane is left as it is");
            for l in [0, 2, 3] {
                seen[out[l] as usize] += 1;
            }
        }
        assert!(seen.iter().all(|&c| c > 200), "{seen:?}");
        // lane 1 was never drawn: it still gives its episode's first action
        let mut fresh = RandomActions::<1>::new(&Space::Discrete { n: 3 });
        fresh.seed_lane(0, action_rng(1, "x", 1, 0));
        assert_eq!(
            format!("{:?}", r.action(1)),
            format!("{:?}", fresh.action(0))
        );
    }

    #[test]
    fn box_draws_stay_in_bounds() {
        let space = Space::Box(BoxSpace::new(vec![-1.0, 10.0], vec![1.0, 10.5]));
        let mut r = RandomActions::<2>::new(&space);
        r.seed_lane(1, action_rng(2, "y", 0, 0));
        let mut out = [0.0; 4];
        for _ in 0..1000 {
            r.actions_into(&[0, 1], &mut out);
            assert!((-1.0..1.0).contains(&out[2]) && (10.0..10.5).contains(&out[3]));
        }
    }
}
