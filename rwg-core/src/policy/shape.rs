//! The shape of a network on an env: `(out, in)` per layer.

use super::Architecture;
use rwg_env::space::Space;

/// Shapes of a network for a given env: `(out, in)` per layer, `in` counting
/// the bias input.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct NetShape {
    pub(super) layers: Vec<(usize, usize)>,
    pub(super) bias: bool,
}

impl NetShape {
    /// Shape for `obs_dim` inputs, `arch`'s hidden layers and `n_out` outputs.
    pub fn new(obs_dim: usize, arch: &Architecture, n_out: usize) -> Self {
        let mut sizes = vec![obs_dim];
        sizes.extend(&arch.hidden);
        sizes.push(n_out);
        let b = usize::from(arch.bias);
        let layers = sizes.windows(2).map(|w| (w[1], w[0] + b)).collect();
        NetShape {
            layers,
            bias: arch.bias,
        }
    }

    /// No network: no layers, no weights (a cell of random actions).
    pub fn none() -> Self {
        NetShape {
            layers: vec![],
            bias: false,
        }
    }

    /// Number of outputs a network needs for this action space.
    pub fn outputs_for(space: &Space) -> usize {
        match space {
            Space::Discrete { n } => *n,
            Space::Box(b) => b.dim(),
        }
    }

    /// `(out, in)` of every layer, `in` including the bias input.
    pub fn layers(&self) -> &[(usize, usize)] {
        &self.layers
    }

    /// Whether the layers have a bias input.
    pub fn bias(&self) -> bool {
        self.bias
    }

    /// Total number of weights.
    pub fn n_weights(&self) -> usize {
        self.layers.iter().map(|(o, i)| o * i).sum()
    }

    /// Width of the widest layer output (scratch buffer size).
    pub(super) fn max_width(&self) -> usize {
        self.layers.iter().map(|(o, _)| *o).max().unwrap_or(0)
    }
}
