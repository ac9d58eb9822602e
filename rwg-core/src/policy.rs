//! The controllers RWG samples: small fully connected networks with tanh units.
//!
//! Layout follows the paper's reference implementation: layer sizes
//! `[obs_dim, hidden..., n_out]`; each layer computes `tanh(W · [x, 1])` where
//! the constant 1 input exists only with bias; `W` is row-major (out × in) with
//! the bias weight last in each row. Output to action: discrete spaces take the
//! argmax of the outputs (first index wins ties, like `numpy.argmax`);
//! continuous boxes map `tanh(output)` onto the bounds (`high · tanh` for
//! symmetric bounds, `low + (tanh + 1)/2 · (high − low)` otherwise).
//!
//! `tanh` is rwg's own [`crate::tanh::tanh`] (within 2 ulp of libm's, several
//! times faster), everywhere in the network and the action mapping.

use crate::tanh::tanh_lanes;
use rwg_env::env::Action;
use rwg_env::simd::Simd;
use rwg_env::space::Space;
use serde::Serialize;

mod argmax;
mod random;
mod shape;
pub use argmax::argmax_tanh;
pub use random::{PolicyKind, RandomActions};
pub use shape::NetShape;

/// The hidden-layer sizes and bias setting of a network family.
#[derive(Debug, Clone, PartialEq, Eq, Hash, Serialize)]
pub struct Architecture {
    /// Hidden layer sizes (empty: a linear controller, "0HL").
    pub hidden: Vec<usize>,
    /// Whether every layer has a bias input.
    pub bias: bool,
}

/// How the network's outputs become an action.
#[derive(Debug, Clone, PartialEq)]
enum ActionMap {
    Argmax,
    /// `high · tanh(y)` per dimension.
    Symmetric(Vec<f64>),
    /// `low + (tanh(y) + 1)/2 · (high − low)` per dimension.
    Affine(Vec<f64>, Vec<f64>),
}

impl ActionMap {
    /// The mapping for `action_space`.
    fn for_space(action_space: &Space) -> Self {
        match action_space {
            Space::Discrete { .. } => ActionMap::Argmax,
            Space::Box(b) => {
                if b.low.iter().zip(&b.high).all(|(l, h)| *l == -*h) {
                    ActionMap::Symmetric(b.high.clone())
                } else {
                    ActionMap::Affine(b.low.clone(), b.high.clone())
                }
            }
        }
    }
}

/// One value per lane, aligned to a cache line, so the forward pass's
/// vector loads and stores never straddle two lines, whatever address the
/// allocator hands out.
#[derive(Debug, Clone, Copy)]
#[repr(C, align(64))]
struct Lanes<const K: usize>([f64; K]);

impl<const K: usize> std::ops::Deref for Lanes<K> {
    type Target = [f64; K];
    #[inline(always)]
    fn deref(&self) -> &[f64; K] {
        &self.0
    }
}

impl<const K: usize> std::ops::DerefMut for Lanes<K> {
    #[inline(always)]
    fn deref_mut(&mut self) -> &mut [f64; K] {
        &mut self.0
    }
}

/// `K` networks of one shape evaluated side by side ("lanes"), each with its
/// own weights.
///
/// Every lane computes exactly what [`Policy::act`] computes with the same
/// weights (the same operations in the same order, so the same actions bit
/// for bit), but the lanes are interleaved operation by operation. A single
/// network's forward pass is a chain of dependent `tanh`s, whose latency
/// leaves most of the CPU idle; `K` independent chains fill it. The sampler
/// uses this to run `K` episodes at once ([`crate::sampler::LaneWorker`]).
/// Acting allocates nothing.
#[derive(Debug, Clone)]
pub struct PolicyLanes<const K: usize> {
    shape: NetShape,
    map: ActionMap,
    /// The weights in [`Policy::weights`] order, lane `l`'s at index `l`.
    weights: Vec<Lanes<K>>,
    /// The observations, transposed (obs_dim entries).
    x: Vec<Lanes<K>>,
    a: Vec<Lanes<K>>,
    b: Vec<Lanes<K>>,
    /// One lane's network outputs (argmax scratch).
    z: Vec<f64>,
    /// Continuous actions of all lanes, lane-major.
    action: Vec<f64>,
    /// Discrete actions of all lanes, from `forward`'s pass over all lanes;
    /// -1 where [`argmax_tanh`] must compare tanh values (`action` does).
    argmax: [i64; K],
    /// The SIMD level `forward` runs at. Its builds differ only in how
    /// many lanes one instruction handles: all are the same IEEE operations
    /// in the same order (no fused multiply-add), so they give the same bits.
    simd: Simd,
    /// Uniformly random actions instead of networks (no weights).
    random: Option<Box<RandomActions<K>>>,
}

/// The SIMD level [`PolicyLanes::forward`] runs at on this process:
/// `"avx512"`, `"avx2"` or `"scalar"` ([`rwg_env::simd::level`]; for
/// benchmark reports, the results are the same).
pub fn lanes_isa() -> &'static str {
    rwg_env::simd::level().name()
}

impl<const K: usize> PolicyLanes<K> {
    /// `K` networks of the given shape for `action_space`, with zero weights.
    pub fn new(shape: NetShape, action_space: &Space) -> Self {
        let map = ActionMap::for_space(action_space);
        let w = shape.max_width();
        let n_out = shape.layers.last().map_or(0, |l| l.0);
        let n_obs = shape
            .layers
            .first()
            .map_or(0, |l| l.1 - usize::from(shape.bias));
        PolicyLanes {
            weights: vec![Lanes([0.0; K]); shape.n_weights()],
            x: vec![Lanes([0.0; K]); n_obs],
            a: vec![Lanes([0.0; K]); w],
            b: vec![Lanes([0.0; K]); w],
            z: vec![0.0; n_out],
            action: vec![0.0; K * n_out],
            argmax: [0; K],
            shape,
            map,
            simd: rwg_env::simd::level(),
            random: None,
        }
    }

    /// `K` lanes of uniformly random actions of `action_space`
    /// ([`PolicyKind::Random`]): no weights; [`PolicyLanes::seed_lane`]
    /// gives each lane's episode its draws.
    pub fn random(action_space: &Space) -> Self {
        PolicyLanes {
            random: Some(Box::new(RandomActions::new(action_space))),
            ..PolicyLanes::new(NetShape::none(), action_space)
        }
    }

    /// Whether the lanes act at random (no network).
    #[inline(always)]
    pub fn is_random(&self) -> bool {
        self.random.is_some()
    }

    /// Lane `lane` of a random policy starts an episode whose actions come
    /// from `rng`; no effect on networks.
    pub fn seed_lane(&mut self, lane: usize, rng: rwg_env::seeding::Pcg64) {
        if let Some(r) = &mut self.random {
            r.seed_lane(lane, rng);
        }
    }

    /// The networks' shape.
    pub fn shape(&self) -> &NetShape {
        &self.shape
    }

    /// Sets lane `lane`'s weights, in [`Policy::weights`] order.
    ///
    /// Panics if `weights` does not have [`NetShape::n_weights`] entries.
    pub fn set_weights(&mut self, lane: usize, weights: &[f64]) {
        assert_eq!(weights.len(), self.weights.len(), "weight count");
        for (w, v) in self.weights.iter_mut().zip(weights) {
            w[lane] = *v;
        }
    }

    /// Lane `lane`'s weights, in [`Policy::weights`] order.
    pub fn lane_weights(&self, lane: usize) -> impl Iterator<Item = f64> + '_ {
        self.weights.iter().map(move |w| w[lane])
    }

    /// Runs every lane's network on its observation: `obs` holds `K`
    /// observations one after the other (lane-major). Read the actions with
    /// [`PolicyLanes::action`].
    ///
    /// Runs compiled for [`rwg_env::simd::level`]'s level: AVX-512, AVX2,
    /// or the target's baseline (the results are the same bits at each).
    #[inline]
    pub fn forward(&mut self, obs: &[f64]) {
        if self.random.is_some() {
            return; // random actions are drawn when they are read
        }
        #[cfg(target_arch = "x86_64")]
        match self.simd {
            // SAFETY: `rwg_env::simd::level` names only a level the CPU has
            // (and the tests set only `Simd::available_levels`).
            Simd::Avx512 => return unsafe { self.forward_avx512(obs) },
            // SAFETY: as above.
            Simd::Avx2 => return unsafe { self.forward_avx2(obs) },
            Simd::Scalar => {}
        }
        self.forward_generic(obs)
    }

    /// [`PolicyLanes::forward`] compiled for AVX2.
    ///
    /// # Safety
    /// The CPU must support AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn forward_avx2(&mut self, obs: &[f64]) {
        self.forward_generic(obs)
    }

    /// [`PolicyLanes::forward`] compiled for AVX-512 (F, DQ and VL).
    ///
    /// # Safety
    /// The CPU must support AVX-512F, DQ and VL.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f,avx512dq,avx512vl")]
    unsafe fn forward_avx512(&mut self, obs: &[f64]) {
        self.forward_generic(obs)
    }

    /// The forward pass, for whatever instruction set the caller is compiled for.
    #[inline(always)]
    fn forward_generic(&mut self, obs: &[f64]) {
        let d = self.x.len();
        assert_eq!(obs.len(), K * d, "observations of {K} lanes expected");
        for (i, xi) in self.x.iter_mut().enumerate() {
            for (l, v) in xi.iter_mut().enumerate() {
                *v = obs[l * d + i];
            }
        }
        let bias = self.shape.bias;
        let n_layers = self.shape.layers.len();
        let mut w = &self.weights[..];
        let mut input: &[Lanes<K>] = &self.x;
        let (mut cur, mut next) = (&mut self.a, &mut self.b);
        for (li, &(n_out, n_in)) in self.shape.layers.iter().enumerate() {
            let (lw, rest) = w.split_at(n_out * n_in);
            w = rest;
            let last = li + 1 == n_layers;
            let n_x = n_in - usize::from(bias);
            for (o, row) in cur[..n_out].iter_mut().zip(lw.chunks_exact(n_in)) {
                // Policy::act's sum, lane by lane: 0.0 + w0 x0 + w1 x1 + ... (+ bias)
                let mut s = [0.0; K];
                for (wi, xi) in row[..n_x].iter().zip(&input[..n_x]) {
                    for l in 0..K {
                        s[l] += wi[l] * xi[l];
                    }
                }
                if bias {
                    for l in 0..K {
                        s[l] += row[n_x][l];
                    }
                }
                **o = if last { s } else { tanh_lanes(s) };
            }
            std::mem::swap(&mut cur, &mut next);
            input = &next[..n_out];
        }
        let n_out = input.len();
        match &self.map {
            ActionMap::Argmax => {
                // argmax_tanh's first pass for all lanes at once, branch-free
                // so that it vectorises: the first maximum, and whether any
                // other output is close to it. Lanes with a close output get
                // -1 and go through argmax_tanh itself in `action`.
                let mut zb = input[0];
                let mut best = [0i64; K];
                for (o, y) in input.iter().enumerate().skip(1) {
                    for l in 0..K {
                        let gt = y[l] > zb[l];
                        zb[l] = if gt { y[l] } else { zb[l] };
                        best[l] = if gt { o as i64 } else { best[l] };
                    }
                }
                let mut close = [false; K];
                for (o, y) in input.iter().enumerate() {
                    for l in 0..K {
                        let near = (zb[l] - y[l] < 1e-6) | (zb[l] > 5.0) | (y[l] < -5.0);
                        close[l] |= (best[l] != o as i64) & near;
                    }
                }
                for l in 0..K {
                    self.argmax[l] = if close[l] { -1 } else { best[l] };
                }
            }
            ActionMap::Symmetric(high) => {
                for (d, (h, y)) in high.iter().zip(input).enumerate() {
                    let t = tanh_lanes(**y);
                    for (l, tl) in t.iter().enumerate() {
                        self.action[l * n_out + d] = h * tl;
                    }
                }
            }
            ActionMap::Affine(low, high) => {
                for (d, ((lo, h), y)) in low.iter().zip(high).zip(input).enumerate() {
                    let t = tanh_lanes(**y);
                    for (l, tl) in t.iter().enumerate() {
                        self.action[l * n_out + d] = lo + (tl + 1.0) / 2.0 * (h - lo);
                    }
                }
            }
        }
    }

    /// The network outputs of the last [`PolicyLanes::forward`] (before the
    /// action map): in `a` after an odd number of layers, else in `b`.
    fn outputs(&self) -> &[Lanes<K>] {
        let y = if self.shape.layers.len() % 2 == 1 {
            &self.a
        } else {
            &self.b
        };
        &y[..self.z.len()]
    }

    /// The lanes whose network outputs of the last [`PolicyLanes::forward`]
    /// are not all finite, as a bit mask (bit `l`: lane `l`; 0 in a sane
    /// run). A NaN anywhere in a network (an infinite product minus another:
    /// weights times observations beyond a 64-bit float) reaches its
    /// outputs, since tanh keeps a NaN.
    #[inline]
    pub fn non_finite_outputs(&self) -> u64 {
        const { assert!(K <= 64, "a lane mask of 64 bits") };
        let mut mask = 0u64;
        for y in self.outputs() {
            for (l, v) in y.iter().enumerate() {
                mask |= u64::from(!v.is_finite()) << l;
            }
        }
        mask
    }

    /// Lane `lane`'s first output that is not finite, if any.
    pub fn non_finite_output(&self, lane: usize) -> Option<f64> {
        self.outputs()
            .iter()
            .map(|y| y[lane])
            .find(|v| !v.is_finite())
    }

    /// Lane `lane`'s action for the observation of the last
    /// [`PolicyLanes::forward`].
    #[inline]
    pub fn action(&mut self, lane: usize) -> Action<'_> {
        if let Some(r) = &mut self.random {
            return r.action(lane);
        }
        let n_out = self.z.len();
        match &self.map {
            ActionMap::Argmax => {
                if self.argmax[lane] >= 0 {
                    return Action::Discrete(self.argmax[lane]);
                }
                let n = self.z.len();
                let y = if self.shape.layers.len() % 2 == 1 {
                    &self.a
                } else {
                    &self.b
                };
                for (z, yo) in self.z.iter_mut().zip(&y[..n]) {
                    *z = yo[lane];
                }
                Action::Discrete(argmax_tanh(&self.z) as i64)
            }
            _ => Action::Continuous(&self.action[lane * n_out..(lane + 1) * n_out]),
        }
    }

    /// [`PolicyLanes::action`] of every lane `i` with `mask[i] == 1`, in the
    /// layout of a [`rwg_env::many::ManyEnv`]'s action buffer: lane `i`'s at
    /// `out[i * len..(i + 1) * len]`, `len` being 1 for a discrete action
    /// (its index as a double) and the action's dimension otherwise. The
    /// other lanes' slots are left as they are.
    ///
    /// One pass over the lanes without a call per lane (the sampler's
    /// lockstep loop spent about 5 % of a Pendulum-v1 run calling
    /// `action` lane by lane); the same values as `action`.
    #[inline]
    pub fn actions_into(&mut self, mask: &[u8; K], out: &mut [f64]) {
        if let Some(r) = &mut self.random {
            return r.actions_into(mask, out);
        }
        let n_out = self.z.len();
        match &self.map {
            ActionMap::Argmax => {
                let out: &mut [f64; K] = (&mut out[..K]).try_into().expect("K lanes");
                let mut settle = false;
                for l in 0..K {
                    let x = self.argmax[l];
                    settle |= (mask[l] == 1) & (x < 0);
                    out[l] = if (mask[l] == 1) & (x >= 0) {
                        x as f64
                    } else {
                        out[l]
                    };
                }
                if settle {
                    self.settle_argmax(mask, out);
                }
            }
            _ if n_out == 1 => {
                let out: &mut [f64; K] = (&mut out[..K]).try_into().expect("K lanes");
                let action: &[f64; K] = self.action[..K].try_into().expect("K lanes");
                for l in 0..K {
                    out[l] = if mask[l] == 1 { action[l] } else { out[l] };
                }
            }
            _ => {
                for (l, &m) in mask.iter().enumerate() {
                    if m == 1 {
                        let r = l * n_out..(l + 1) * n_out;
                        out[r.clone()].copy_from_slice(&self.action[r]);
                    }
                }
            }
        }
    }

    /// The lanes of `mask` whose argmax the forward pass left open (-1):
    /// [`argmax_tanh`] of their outputs, as [`PolicyLanes::action`] does.
    #[cold]
    #[inline(never)]
    fn settle_argmax(&mut self, mask: &[u8; K], out: &mut [f64; K]) {
        for l in 0..K {
            if mask[l] == 1 && self.argmax[l] < 0 {
                match self.action(l) {
                    Action::Discrete(x) => out[l] = x as f64,
                    Action::Continuous(_) => unreachable!("an argmax policy acts discretely"),
                }
            }
        }
    }
}

mod single;
pub use single::Policy;

#[cfg(test)]
mod tests;
