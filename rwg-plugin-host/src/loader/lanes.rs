//! [`PluginLanes`]: many lanes of a plugin environment stepped by one call,
//! through ABI 1.2's vector env or 1.1's batched calls, behind one type, so
//! the sampler and `rwg check` drive either the same way.

use rwg_env::env::{EnvError, EnvSpec};

use super::{LaneFailure, PluginBatch, PluginEnvType, PluginVecEnv};

/// Which of a plugin's many-lane calls a [`PluginLanes`] uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LaneCalls {
    /// ABI 1.2's vector env: one plugin object holding every lane.
    Vec,
    /// ABI 1.1's batched calls over one instance per lane.
    Batched,
}

impl LaneCalls {
    /// The calls' name in messages ("vector env", "batched calls").
    pub fn name(self) -> &'static str {
        match self {
            LaneCalls::Vec => "vector env",
            LaneCalls::Batched => "batched calls",
        }
    }
}

/// Lanes of one plugin env with one config, through [`LaneCalls`].
#[derive(Debug)]
pub enum PluginLanes {
    /// Through ABI 1.2's vector env.
    Vec(PluginVecEnv),
    /// Through ABI 1.1's batched calls.
    Batch(PluginBatch),
}

impl PluginEnvType {
    /// Whether the plugin provides `calls` for this env.
    pub fn has_lane_calls(&self, calls: LaneCalls) -> bool {
        match calls {
            LaneCalls::Vec => self.has_vec_env(),
            LaneCalls::Batched => self.has_batched_calls(),
        }
    }

    /// `lanes` lanes with `config` through `calls`, with the descriptor's
    /// time limit (or `max_episode_steps` if given) applied by the host.
    pub fn make_lanes(
        &self,
        calls: LaneCalls,
        config: &str,
        lanes: usize,
        max_episode_steps: Option<u32>,
    ) -> Result<PluginLanes, EnvError> {
        Ok(match calls {
            LaneCalls::Vec => PluginLanes::Vec(self.make_vec(config, lanes, max_episode_steps)?),
            LaneCalls::Batched => {
                PluginLanes::Batch(self.make_batch(config, lanes, max_episode_steps)?)
            }
        })
    }
}

impl PluginLanes {
    /// The environment's spec, with the host's time limit.
    pub fn spec(&self) -> &EnvSpec {
        match self {
            PluginLanes::Vec(v) => v.spec(),
            PluginLanes::Batch(b) => b.spec(),
        }
    }

    /// Number of lanes.
    pub fn len(&self) -> usize {
        match self {
            PluginLanes::Vec(v) => v.len(),
            PluginLanes::Batch(b) => b.len(),
        }
    }

    /// Whether there are no lanes.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// [`PluginVecEnv::reset_many`] or [`PluginBatch::reset_many`].
    pub fn reset_many(
        &mut self,
        mask: &[u8],
        seeds: &[u64],
        obs: &mut [f64],
        on_fail: impl FnMut(LaneFailure),
    ) {
        match self {
            PluginLanes::Vec(v) => v.reset_many(mask, seeds, obs, on_fail),
            PluginLanes::Batch(b) => b.reset_many(mask, seeds, obs, on_fail),
        }
    }

    /// [`PluginVecEnv::step_many`] or [`PluginBatch::step_many`].
    #[expect(
        clippy::too_many_arguments,
        reason = "`ManyEnv::step_many`'s buffers, one argument each"
    )]
    pub fn step_many(
        &mut self,
        mask: &[u8],
        actions: &[f64],
        obs: &mut [f64],
        rewards: &mut [f64],
        terminated: &mut [u8],
        truncated: &mut [u8],
        on_fail: impl FnMut(LaneFailure),
    ) {
        match self {
            PluginLanes::Vec(v) => {
                v.step_many(mask, actions, obs, rewards, terminated, truncated, on_fail)
            }
            PluginLanes::Batch(b) => {
                b.step_many(mask, actions, obs, rewards, terminated, truncated, on_fail)
            }
        }
    }
}
