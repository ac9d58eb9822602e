//! One network evaluated on its own ([`Policy`]): the sequential loop's
//! and `rwg replay`'s controller, with the arithmetic of
//! [`super::PolicyLanes`] lane by lane.

use super::{argmax_tanh, ActionMap, NetShape, RandomActions};
use crate::tanh::tanh;
use rwg_env::env::Action;
use rwg_env::space::Space;

/// A network with its weights and scratch buffers. Acting allocates nothing.
#[derive(Debug, Clone)]
pub struct Policy {
    shape: NetShape,
    weights: Vec<f64>,
    map: ActionMap,
    a: Vec<f64>,
    b: Vec<f64>,
    action: Vec<f64>,
    /// Uniformly random actions instead of the network (no weights).
    random: Option<Box<RandomActions<1>>>,
}

impl Policy {
    /// A policy of the given shape for `action_space`, with zero weights.
    pub fn new(shape: NetShape, action_space: &Space) -> Self {
        let map = ActionMap::for_space(action_space);
        let w = shape.max_width();
        let n_out = shape.layers.last().map_or(0, |l| l.0);
        Policy {
            weights: vec![0.0; shape.n_weights()],
            a: vec![0.0; w],
            b: vec![0.0; w],
            action: vec![0.0; n_out],
            shape,
            map,
            random: None,
        }
    }

    /// Uniformly random actions of `action_space` ([`super::PolicyKind::Random`]):
    /// no weights; [`Policy::seed_actions`] gives each episode its draws.
    pub fn random(action_space: &Space) -> Self {
        Policy {
            random: Some(Box::new(RandomActions::new(action_space))),
            ..Policy::new(NetShape::none(), action_space)
        }
    }

    /// A random policy's actions come from `rng` from now on (an episode
    /// starts); no effect on a network.
    pub fn seed_actions(&mut self, rng: rwg_env::seeding::Pcg64) {
        if let Some(r) = &mut self.random {
            r.seed_lane(0, rng);
        }
    }

    /// The network's shape.
    pub fn shape(&self) -> &NetShape {
        &self.shape
    }

    /// The weights, layer by layer, each row-major (out × in, bias last).
    pub fn weights(&self) -> &[f64] {
        &self.weights
    }

    /// Mutable weights, in the order of [`Policy::weights`].
    pub fn weights_mut(&mut self) -> &mut [f64] {
        &mut self.weights
    }

    /// Runs the network on `obs` and returns the action.
    #[inline]
    pub fn act(&mut self, obs: &[f64]) -> Action<'_> {
        if self.random.is_some() {
            // (a random policy has no network: see `Policy::random`)
            return random_action(&mut self.random);
        }
        self.forward(obs);
        self.map_output()
    }

    /// Runs the network on `obs` and returns the action, or the first
    /// output (before the action mapping) that is not finite: what the lane
    /// loops check ([`super::PolicyLanes::non_finite_outputs`]).
    #[inline]
    pub fn act_checked(&mut self, obs: &[f64]) -> Result<Action<'_>, f64> {
        if self.random.is_some() {
            return Ok(self.act(obs));
        }
        self.forward(obs);
        match self.output().iter().find(|v| !v.is_finite()) {
            Some(&v) => Err(v),
            None => Ok(self.map_output()),
        }
    }

    /// The network's outputs for `obs` into [`Policy::output`]'s buffer.
    #[inline]
    fn forward(&mut self, obs: &[f64]) {
        let bias = self.shape.bias;
        let mut w = &self.weights[..];
        let mut input: &[f64] = obs;
        let n_layers = self.shape.layers.len();
        let (mut cur, mut next) = (&mut self.a, &mut self.b);
        for (li, &(n_out, n_in)) in self.shape.layers.iter().enumerate() {
            let (lw, rest) = w.split_at(n_out * n_in);
            w = rest;
            let last = li + 1 == n_layers;
            let out = &mut cur[..n_out];
            let n_x = n_in - usize::from(bias);
            for (o, row) in out.iter_mut().zip(lw.chunks_exact(n_in)) {
                let mut s = 0.0;
                for (wi, xi) in row[..n_x].iter().zip(&input[..n_x]) {
                    s += wi * xi;
                }
                if bias {
                    s += row[n_x];
                }
                // The output layer's tanh is applied by the action mapping.
                *o = if last { s } else { tanh(s) };
            }
            std::mem::swap(&mut cur, &mut next);
            input = &next[..n_out];
        }
    }

    /// The outputs of the last forward pass: layer `i` is written into `a`
    /// for even `i`, `b` for odd `i`.
    fn output(&self) -> &[f64] {
        let n_out = self.shape.layers.last().map_or(0, |l| l.0);
        let y = if self.shape.layers.len() % 2 == 1 {
            &self.a
        } else {
            &self.b
        };
        &y[..n_out]
    }

    /// The action of the last forward pass's outputs.
    #[inline]
    fn map_output(&mut self) -> Action<'_> {
        let n_out = self.shape.layers.last().map_or(0, |l| l.0);
        let y = if self.shape.layers.len() % 2 == 1 {
            &self.a[..n_out]
        } else {
            &self.b[..n_out]
        };
        match &self.map {
            ActionMap::Argmax => Action::Discrete(argmax_tanh(y) as i64),
            ActionMap::Symmetric(high) => {
                for ((a, h), v) in self.action.iter_mut().zip(high).zip(y) {
                    *a = h * tanh(*v);
                }
                Action::Continuous(&self.action)
            }
            ActionMap::Affine(low, high) => {
                for (((a, l), h), v) in self.action.iter_mut().zip(low).zip(high).zip(y) {
                    *a = l + (tanh(*v) + 1.0) / 2.0 * (h - l);
                }
                Action::Continuous(&self.action)
            }
        }
    }
}

/// The next action of a random policy's only lane (`random` is `Some`).
#[inline]
fn random_action(random: &mut Option<Box<RandomActions<1>>>) -> Action<'_> {
    match random {
        Some(r) => r.action(0),
        None => unreachable!("a policy without random actions"),
    }
}
