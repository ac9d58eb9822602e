//! What a cell computes and where its randomness comes from: the
//! [`CellPlan`], the weights of network `n` and the reset seed of its
//! episode `e`, and what an episode or a failure reports. The loops that
//! run the plan are [`crate::sampler`], [`crate::many`] and [`crate::remote`]
//! (which re-export these names from [`crate::sampler`]).
//!
//! # Seeds
//! Nothing depends on scheduling, thread count or on which other cells a
//! manifest contains:
//! - the weights of network `n` of a cell come from
//!   `PCG64(SeedSequence([seed, 1, env_key, bias, len(hidden), *hidden, n]))`,
//!   drawn layer by layer, row-major, bias weight last in each row;
//! - episode `e` of network `n` starts with `env.reset(seed=r)` where
//!   `r = SeedSequence([seed, 2, env_key, n, e]).generate_state(1, np.uint64)[0]`.
//!
//! - a cell of random actions ([`PolicyKind::Random`]) draws the actions of
//!   episode `e` of its "network" `n` from
//!   `PCG64(SeedSequence([seed, 3, env_key, n, e]))` ([`action_rng`];
//!   `crate::policy::RandomActions` says how), and resets as every cell does.
//!
//! `env_key = int.from_bytes(env_id.encode(), "little")` and `bias` is 0 or 1,
//! all as in numpy (`SeedSequence` takes a list of non-negative integers). The
//! reset seeds do not depend on the architecture, so network `n` of every
//! architecture meets the same initial conditions (a paired comparison), and a
//! user can replay any episode in Gymnasium with `env.reset(seed=r)`.

use crate::policy::{Architecture, NetShape, Policy, PolicyKind, PolicyLanes};
use rand_distr::{Distribution, StandardNormal};
use rwg_env::env::EnvError;
use rwg_env::seeding::{Pcg64, SeedSequence};
use thiserror::Error;

/// Distribution of every weight.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum WeightDist {
    /// Normal(0, std).
    Normal {
        /// Standard deviation (the paper: 1).
        std: f64,
    },
    /// Uniform(-a, a), drawn as numpy's `uniform(-a, a)`.
    Uniform {
        /// Half-width.
        a: f64,
    },
}

impl WeightDist {
    /// `normal` or `uniform`.
    pub fn name(&self) -> &'static str {
        match self {
            WeightDist::Normal { .. } => "normal",
            WeightDist::Uniform { .. } => "uniform",
        }
    }

    /// The scale parameter (std or a).
    pub fn scale(&self) -> f64 {
        match *self {
            WeightDist::Normal { std } => std,
            WeightDist::Uniform { a } => a,
        }
    }
    /// The largest scale whose every draw is a finite 64-bit float: a
    /// normal draw is `std * z`, and rand_distr's ziggurat gives |z| < 14
    /// (its tail is `R - ln(u) / R` with `u` at least 2^-53: at most 13.7);
    /// a uniform one is numpy's `-a + 2a * u`, whose `2a` must be finite.
    pub fn max_scale(&self) -> f64 {
        match self {
            WeightDist::Normal { .. } => 1e307,
            WeightDist::Uniform { .. } => 8e307,
        }
    }
}

/// Seed stream tag of network weights.
const STREAM_WEIGHTS: u64 = 1;
/// Seed stream tag of episode reset seeds.
const STREAM_RESETS: u64 = 2;
/// Seed stream tag of the random actions of an episode.
const STREAM_ACTIONS: u64 = 3;

/// The 32-bit words of `int.from_bytes(id.encode(), "little")`, i.e. numpy's
/// entropy words for that integer (at least one word).
pub(crate) fn env_key_words(env_id: &str, out: &mut Vec<u32>) {
    let bytes = env_id.as_bytes();
    let mut len = bytes.len();
    while len > 0 && bytes[len - 1] == 0 {
        len -= 1; // a big integer has no leading zero bytes
    }
    if len == 0 {
        out.push(0);
        return;
    }
    for chunk in bytes[..len].chunks(4) {
        let mut w = [0u8; 4];
        w[..chunk.len()].copy_from_slice(chunk);
        out.push(u32::from_le_bytes(w));
    }
}

fn push_int(n: u64, out: &mut Vec<u32>) {
    rwg_env::seeding::int_to_words(n, out);
}

/// The reset seed of episode `episode` of network `sample` (see the module docs).
pub fn reset_seed(seed: u64, env_id: &str, sample: u64, episode: u32) -> u64 {
    let mut w = Vec::with_capacity(16);
    push_int(seed, &mut w);
    push_int(STREAM_RESETS, &mut w);
    env_key_words(env_id, &mut w);
    push_int(sample, &mut w);
    push_int(episode as u64, &mut w);
    let [r] = SeedSequence::from_words(&w).generate_u64::<1>();
    r
}

/// The random generator of the actions of episode `episode` of "network"
/// `sample` in a cell of random actions (see the module docs).
pub fn action_rng(seed: u64, env_id: &str, sample: u64, episode: u32) -> Pcg64 {
    let mut w = Vec::with_capacity(16);
    push_int(seed, &mut w);
    push_int(STREAM_ACTIONS, &mut w);
    env_key_words(env_id, &mut w);
    push_int(sample, &mut w);
    push_int(episode as u64, &mut w);
    Pcg64::from_seed_sequence(&SeedSequence::from_words(&w))
}

/// The random generator of network `sample`'s weights (see the module docs).
pub fn weight_rng(seed: u64, env_id: &str, arch: &Architecture, sample: u64) -> Pcg64 {
    let mut w = Vec::with_capacity(24);
    push_int(seed, &mut w);
    push_int(STREAM_WEIGHTS, &mut w);
    env_key_words(env_id, &mut w);
    push_int(arch.bias as u64, &mut w);
    push_int(arch.hidden.len() as u64, &mut w);
    for &h in &arch.hidden {
        push_int(h as u64, &mut w);
    }
    push_int(sample, &mut w);
    Pcg64::from_seed_sequence(&SeedSequence::from_words(&w))
}

/// Fills `weights` with draws from `dist` using `rng`.
pub fn draw_weights(rng: &mut Pcg64, dist: WeightDist, weights: &mut [f64]) {
    for w in weights {
        *w = match dist {
            WeightDist::Normal { std } => {
                let z: f64 = StandardNormal.sample(rng);
                z * std
            }
            WeightDist::Uniform { a } => rng.uniform(-a, a),
        };
    }
}

/// What an episode that meets a value that is not finite does: an
/// observation or reward a step returns that is NaN or infinite (as the
/// physics of a body driven by a random controller can give), a network
/// output that is not finite, or a return that leaves ±[`MAX_RETURN`]. A
/// manifest's `non_finite` key; part of the study.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum NonFinite {
    /// The episode fails, naming the network, episode, step and value: the
    /// cell, and the study, stop (the default).
    #[default]
    Stop,
    /// The episode ends there, flagged ([`EpisodeResult::non_finite`]): its
    /// length counts the step that gave the value, its return is the sum of
    /// the rewards before that step. A network output that is not finite
    /// ends it before the step it would choose. A reset's observation that
    /// is not finite still fails (an env that cannot start an episode).
    End,
}

impl NonFinite {
    /// The manifest's name: `stop` or `end`.
    pub fn name(self) -> &'static str {
        match self {
            NonFinite::Stop => "stop",
            NonFinite::End => "end",
        }
    }
}

impl std::str::FromStr for NonFinite {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "stop" => Ok(NonFinite::Stop),
            "end" => Ok(NonFinite::End),
            _ => Err(format!(
                "'{s}' is not a choice: \"stop\" (the default: the study stops, naming the \
                 episode) or \"end\" (the episode ends there, flagged in scores.csv)"
            )),
        }
    }
}

/// What one cell of the study runs: an environment with one architecture.
#[derive(Debug, Clone)]
pub struct CellPlan {
    /// Manifest seed.
    pub seed: u64,
    /// Environment id (part of every seed).
    pub env_id: String,
    /// Architecture and bias.
    pub arch: Architecture,
    /// Episodes per network.
    pub episodes: u32,
    /// Weight distribution.
    pub dist: WeightDist,
    /// Networks of `arch` (the paper's), or uniformly random actions (then
    /// `arch` is unused: no layers, no weights).
    pub policy: PolicyKind,
    /// What an episode that meets a value that is not finite does.
    pub non_finite: NonFinite,
}

impl CellPlan {
    /// The networks' shape on an env with `spec`: `arch`'s layers, or none
    /// (no weights) for random actions.
    pub fn net_shape(&self, spec: &rwg_env::EnvSpec) -> NetShape {
        match self.policy {
            PolicyKind::Network => NetShape::new(
                spec.obs_dim(),
                &self.arch,
                NetShape::outputs_for(&spec.action_space),
            ),
            PolicyKind::Random => NetShape::none(),
        }
    }

    /// `K` lanes of this cell's policy on an env with `spec` (zero weights;
    /// the lane loops load each network's).
    pub fn lanes<const K: usize>(&self, spec: &rwg_env::EnvSpec) -> PolicyLanes<K> {
        match self.policy {
            PolicyKind::Network => PolicyLanes::new(self.net_shape(spec), &spec.action_space),
            PolicyKind::Random => PolicyLanes::random(&spec.action_space),
        }
    }

    /// Network `sample` of this cell for an env with `spec`: the same weights
    /// the sampler draws (for replay and export). For random actions, a
    /// policy without weights; [`CellPlan::begin_episode`] seeds its draws.
    pub fn policy(&self, spec: &rwg_env::EnvSpec, sample: u64) -> Policy {
        if self.policy == PolicyKind::Random {
            return Policy::random(&spec.action_space);
        }
        let mut policy = Policy::new(self.net_shape(spec), &spec.action_space);
        let mut rng = weight_rng(self.seed, &self.env_id, &self.arch, sample);
        draw_weights(&mut rng, self.dist, policy.weights_mut());
        policy
    }

    /// Before episode `episode` of network `sample` runs with `policy`
    /// (made by [`CellPlan::policy`]): a random policy gets the episode's
    /// generator ([`action_rng`]); a network needs nothing.
    pub fn begin_episode(&self, policy: &mut Policy, sample: u64, episode: u32) {
        if self.policy == PolicyKind::Random {
            policy.seed_actions(action_rng(self.seed, &self.env_id, sample, episode));
        }
    }
}

/// Score and length of one episode.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EpisodeResult {
    /// Undiscounted total reward.
    pub score: f64,
    /// Number of steps.
    pub steps: u32,
    /// The episode ended at a value that was not finite ([`NonFinite::End`]):
    /// `score` is the return of the steps before it.
    pub non_finite: bool,
}

/// The largest magnitude of an episode's return rwg takes: a larger one is
/// refused where it enters. The statistics of a cell square returns and sum
/// them over its episodes and networks (a variance is `sum((x - mean)^2) / n`,
/// computed as numpy does), so returns up to this bound keep every statistic
/// finite for the largest study rwg runs (10^7 networks x 10^4 episodes:
/// `4 * 10^11 * MAX_RETURN^2` is far below `f64::MAX`, about 1.8e308).
pub const MAX_RETURN: f64 = 1e100;

/// Whether a return `total` is one rwg takes: within ±[`MAX_RETURN`]
/// (false for NaN).
#[inline(always)]
pub fn return_within_bound(total: f64) -> bool {
    total.abs() <= MAX_RETURN
}

impl EpisodeResult {
    /// A result not filled in yet (the slots a loop writes into).
    pub const EMPTY: EpisodeResult = EpisodeResult {
        score: 0.0,
        steps: 0,
        non_finite: false,
    };

    /// An episode that ended after `steps` steps with the return `score`.
    #[inline]
    pub fn new(score: f64, steps: u32) -> EpisodeResult {
        EpisodeResult {
            score,
            steps,
            non_finite: false,
        }
    }

    /// An episode cut after `steps` steps by a value that was not finite
    /// ([`NonFinite::End`]), with the return `score` of the steps before it.
    #[inline]
    pub fn cut(score: f64, steps: u32) -> EpisodeResult {
        EpisodeResult {
            score,
            steps,
            non_finite: true,
        }
    }

    /// The result of an episode that ended after `steps` steps with the
    /// total reward `score`, or the error of a total that is not finite
    /// (finite rewards whose sum overflows an `f64`) or beyond
    /// [`MAX_RETURN`] (for the sources that only know an episode's total).
    #[inline]
    pub fn finished(score: f64, steps: u32) -> Result<EpisodeResult, EnvError> {
        if return_within_bound(score) {
            Ok(EpisodeResult::new(score, steps))
        } else {
            Err(return_refused(score, score))
        }
    }
}

/// The error of a step whose `reward` is not finite or takes the episode's
/// return to `total`, not finite or beyond [`MAX_RETURN`].
#[cold]
pub(crate) fn return_refused(reward: f64, total: f64) -> EnvError {
    if !reward.is_finite() {
        return EnvError::NonFinite(format!(
            "the step's reward is {reward}, not a finite number"
        ));
    }
    let why = if total.is_finite() {
        format!(
            ", beyond ±{MAX_RETURN:e}, the largest return rwg takes: the statistics square the \
             returns and sum them over networks and episodes, which would overflow a 64-bit float"
        )
    } else {
        ": its rewards are finite but their sum overflows a 64-bit float".to_string()
    };
    EnvError::NonFinite(format!(
        "the episode's total reward is {total:e}{why}; scale the rewards down (e.g. divide \
         them by a constant) so that an episode's total stays within ±{MAX_RETURN:e}"
    ))
}

/// The error `err` of a step that stops the study: a value that was not
/// finite ([`EnvError::NonFinite`]) gets the way to go on instead.
pub(crate) fn stopping(err: EnvError) -> EnvError {
    match err {
        EnvError::NonFinite(m) => EnvError::NonFinite(with_end_hint(&m)),
        e => e,
    }
}

/// `message` (a value that was not finite stopped the study) with the way
/// to go on instead.
pub fn with_end_hint(message: &str) -> String {
    format!(
        "{message}; to count such an episode as ended there (its return that of the steps \
         before, flagged in scores.csv) instead of stopping, set non_finite = \"end\" on the \
         env's [[envs]] entry"
    )
}

/// An environment failure while sampling, with where it happened. The
/// message includes the environment's error (which is therefore not also
/// given as the error's `source()`, so error chains print it once).
#[derive(Debug, Error, Clone, PartialEq)]
#[error("{env}: sample {sample}, episode {episode}, step {step}: {error}")]
pub struct SampleError {
    /// Environment id.
    pub env: String,
    /// Network index.
    pub sample: u64,
    /// Episode index.
    pub episode: u32,
    /// Step (0 = reset).
    pub step: u32,
    /// What the environment reported.
    pub error: EnvError,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn env_key_is_int_from_bytes_little() {
        // int.from_bytes(b"CartPole-v0", "little") split into 32-bit words
        let mut w = vec![];
        env_key_words("CartPole-v0", &mut w);
        assert_eq!(
            w,
            [
                u32::from_le_bytes(*b"Cart"),
                u32::from_le_bytes(*b"Pole"),
                0x0030_762d
            ]
        );
    }

    // Values from numpy:
    //   k = int.from_bytes(b"CartPole-v0", "little")
    //   np.random.SeedSequence([7, 2, k, 3, 5]).generate_state(1, np.uint64)[0]
    #[test]
    fn reset_seed_matches_numpy() {
        assert_eq!(reset_seed(7, "CartPole-v0", 3, 5), RESET_SEED_7_3_5);
    }
    const RESET_SEED_7_3_5: u64 = 17368565813789276978;

    #[test]
    fn weights_depend_on_arch_and_sample_only() {
        let a = Architecture {
            hidden: vec![4],
            bias: false,
        };
        let b = Architecture {
            hidden: vec![4],
            bias: true,
        };
        let draw = |arch: &Architecture, n| {
            let mut w = [0.0; 5];
            draw_weights(
                &mut weight_rng(0, "CartPole-v0", arch, n),
                WeightDist::Normal { std: 1.0 },
                &mut w,
            );
            w
        };
        assert_eq!(draw(&a, 3), draw(&a, 3));
        assert_ne!(draw(&a, 3), draw(&a, 4));
        assert_ne!(draw(&a, 3), draw(&b, 3));
    }

    /// Draws at the largest scale accepted are finite, and the largest
    /// normal draws stay below the bound `max_scale` rests on.
    #[test]
    fn draws_at_the_largest_scale_are_finite() {
        let arch = Architecture {
            hidden: vec![],
            bias: false,
        };
        let mut w = vec![0.0; 4096];
        let mut largest = 0.0f64;
        for dist in [
            WeightDist::Normal { std: 1.0 },
            WeightDist::Uniform { a: 1.0 },
        ] {
            let top = match dist {
                WeightDist::Normal { .. } => WeightDist::Normal {
                    std: dist.max_scale(),
                },
                WeightDist::Uniform { .. } => WeightDist::Uniform {
                    a: dist.max_scale(),
                },
            };
            for n in 0..64 {
                draw_weights(&mut weight_rng(0, "x", &arch, n), top, &mut w);
                assert!(w.iter().all(|v| v.is_finite()), "{top:?}");
            }
        }
        for n in 0..256 {
            draw_weights(
                &mut weight_rng(1, "x", &arch, n),
                WeightDist::Normal { std: 1.0 },
                &mut w,
            );
            largest = w.iter().fold(largest, |m, v| m.max(v.abs()));
        }
        assert!(largest < 14.0, "{largest}");
        assert!(WeightDist::Normal { std: 1.0 }.max_scale() * 14.0 < f64::MAX);
        assert!(WeightDist::Uniform { a: 1.0 }.max_scale() * 2.0 < f64::MAX);
    }
}
