//! One Gymnasium environment of a study ([`GymSource`]): its first worker,
//! the workers kept between cells, and single instances.

use crate::{GymConfig, GymError, GymInfo, GymLanes, GROUPS};
use rwg_core::remote::{run_blocks_remote, RemotePool, SingleLane};
use rwg_core::sampler::{BlockResult, CellPlan, SampleError, LANES};
use rwg_env::EnvError;
use std::ops::Range;

/// One Gymnasium environment of a study: its config, its description, and
/// the worker processes kept between cells.
pub struct GymSource {
    config: GymConfig,
    info: GymInfo,
    pool: RemotePool<GymLanes>,
}

impl std::fmt::Debug for GymSource {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("GymSource")
            .field("config", &self.config)
            .finish()
    }
}

impl GymSource {
    /// Starts one worker (checking that the env builds, its spaces are
    /// supported and its reset is deterministic) and keeps it for the run.
    pub fn open(mut config: GymConfig) -> Result<GymSource, GymError> {
        let first = GymLanes::spawn(&config, LANES, GROUPS, true)?;
        let info = first.info().clone();
        // The workers started later (and single instances) need not probe again.
        config.fresh_per_episode = Some(info.fresh_per_episode);
        let pool = RemotePool::default();
        pool.put(first);
        Ok(GymSource { config, info, pool })
    }

    /// The config.
    pub fn config(&self) -> &GymConfig {
        &self.config
    }

    /// The environment as Gymnasium describes it.
    pub fn info(&self) -> &GymInfo {
        &self.info
    }

    /// Runs blocks of a cell (see [`run_blocks_remote`]): one worker process
    /// per thread of the current rayon pool, reused across calls. Each
    /// worker started here must describe the env as the first did, its
    /// checked reset included ([`info_differences`](crate::info_differences)).
    pub fn run_blocks<G, X>(
        &self,
        plan: &CellPlan,
        blocks: &[Range<u64>],
        wave: usize,
        on_block: G,
    ) -> Result<(), X>
    where
        G: FnMut(BlockResult) -> Result<(), X>,
        X: From<SampleError> + Send,
    {
        run_blocks_remote(
            plan,
            blocks,
            wave,
            &self.pool,
            || {
                GymLanes::spawn(&self.config, LANES, GROUPS, true)
                    .and_then(|w| w.same_as(&self.info))
                    .map_err(EnvError::from)
            },
            on_block,
        )
    }

    /// CPU seconds used so far by the idle worker processes (all of them
    /// between runs), where the OS reports it.
    pub fn workers_cpu_seconds(&self) -> Option<f64> {
        self.pool
            .with_idle(|ws| ws.iter().map(|w| w.pipe.worker().cpu_seconds()).sum())
    }

    /// Number of worker processes started and idle.
    pub fn workers(&self) -> usize {
        self.pool.idle()
    }

    /// A single instance behind [`rwg_env::Environment`] (for rollouts,
    /// checks and replays), in a worker of its own.
    pub fn make_single(&self) -> Result<SingleLane<GymLanes>, GymError> {
        // (the config carries the probe's verdict on fresh instances)
        let worker = GymLanes::spawn(&self.config, 1, 1, true)?.same_as(&self.info)?;
        Ok(SingleLane::new(worker))
    }
}

/// A single instance of the env `config` describes, without the checks of
/// [`GymSource::open`].
pub fn make_single(config: &GymConfig) -> Result<SingleLane<GymLanes>, GymError> {
    Ok(SingleLane::new(GymLanes::spawn(config, 1, 1, false)?))
}
