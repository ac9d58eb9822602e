//! [`JaxSource`]: one JAX env of a study, its first worker started early,
//! the workers kept between cells, what a cell's program is (its shape,
//! networks per call, lanes) and the line a run says about it.

use crate::protocol::CellShape;
use crate::worker::{JaxWorker, Starting};
use crate::{
    run, warm_up, CallError, JaxConfig, JaxError, JaxInfo, CACHE_VAR, DEFAULT_LANES_ACCELERATOR,
    DEFAULT_LANES_CPU, EPISODES_PER_LANE, MAX_DEFAULT_NETWORKS, MEMORY_SHARE, NETWORKS_MULTIPLE,
};
use rwg_core::policy::PolicyKind;
use rwg_core::sampler::{BlockResult, CellPlan, NonFinite, SampleError};
use std::ops::Range;

/// One JAX environment of a study: its config, its description, and the
/// worker processes kept between cells.
pub struct JaxSource {
    pub(crate) config: JaxConfig,
    pub(crate) info: JaxInfo,
    pool: std::sync::Mutex<Vec<JaxWorker>>,
    pub(crate) warm_ups: warm_up::WarmUps,
}

impl std::fmt::Debug for JaxSource {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("JaxSource")
            .field("config", &self.config)
            .finish()
    }
}

/// A JAX env whose first worker is starting (importing JAX and the env's
/// library, making the env): [`StartingSource::open`] waits for it.
pub struct StartingSource {
    config: JaxConfig,
    first: Result<Starting, JaxError>,
}

impl StartingSource {
    /// Waits for the first worker to be ready (the env made, its spaces and
    /// the devices checked) and keeps it for the run.
    pub fn open(self) -> Result<JaxSource, JaxError> {
        let (first, info) = self.first?.ready(&self.config)?;
        Ok(JaxSource {
            config: self.config,
            info,
            pool: std::sync::Mutex::new(vec![first]),
            warm_ups: warm_up::WarmUps::default(),
        })
    }
}

impl JaxSource {
    /// Starts the env's first worker and returns at once: its start-up
    /// runs while rwg does other things.
    pub fn start(config: JaxConfig) -> StartingSource {
        let first = JaxWorker::start(&config);
        StartingSource { config, first }
    }

    /// Starts one worker (imports, makes the env, checks its spaces and the
    /// device) and keeps it for the run.
    pub fn open(config: JaxConfig) -> Result<JaxSource, JaxError> {
        Self::start(config).open()
    }

    /// What a cell message names for `plan`: its layers, the call's
    /// networks and episodes, the lanes, when ended lanes refill (an eighth
    /// of them), the matmul precision, whether the actions are uniformly
    /// random instead of the networks', whether a value that is not finite
    /// ends an episode.
    pub fn cell_shape(&self, plan: &CellPlan) -> CellShape {
        // a random cell's shape has no weights
        let shape = plan.net_shape(&self.info.spec);
        let lanes = self.lanes();
        CellShape {
            hidden: plan.arch.hidden.clone(),
            bias: plan.arch.bias,
            networks: self.networks_per_call(plan.episodes, shape.n_weights()).0,
            episodes: plan.episodes,
            n_weights: shape.n_weights(),
            lanes,
            refill: (lanes / 8).max(1),
            matmul_precision: self.config.matmul_precision,
            random: plan.policy == PolicyKind::Random,
            non_finite_ends: plan.non_finite == NonFinite::End,
        }
    }

    /// Tells `observer` when the workers of each cell run from now on warm
    /// up (start, compile) and when they are ready.
    pub fn observe(&self, observer: std::sync::Arc<dyn warm_up::WarmUpObserver>) {
        self.warm_ups.observe(observer);
    }

    /// The wall time of every cell's warm-up so far, added up: from the
    /// start of [`JaxSource::run_blocks`] until its last worker has started
    /// (if it was not idle) and compiled the cell.
    pub fn warm_up_time(&self) -> std::time::Duration {
        self.warm_ups.total()
    }

    /// The environment as the worker described it.
    pub fn info(&self) -> &JaxInfo {
        &self.info
    }

    /// The config.
    pub fn config(&self) -> &JaxConfig {
        &self.config
    }

    /// Lanes of the cells' programs: [`DEFAULT_LANES_CPU`] on a CPU,
    /// [`DEFAULT_LANES_ACCELERATOR`] on a GPU or TPU. Part of the program,
    /// so of the results' bits.
    pub fn lanes(&self) -> u32 {
        if self.on_cpu() {
            DEFAULT_LANES_CPU
        } else {
            DEFAULT_LANES_ACCELERATOR
        }
    }

    /// Networks per compiled call of a cell of `episodes` episodes and
    /// `n_weights` weights per network, and where the number comes from:
    /// the config's, else [`EPISODES_PER_LANE`] episodes per lane, fewer
    /// where two chunks would take more than [`MEMORY_SHARE`] of a GPU's or
    /// TPU's memory; a multiple of 32 up to [`MAX_DEFAULT_NETWORKS`]. How,
    /// not what: a network's results do not depend on it.
    pub fn networks_per_call(&self, episodes: u32, n_weights: usize) -> (u32, String) {
        if let Some(n) = self.config.networks_per_call {
            return (n, "the manifest's".into());
        }
        let m = NETWORKS_MULTIPLE as u64;
        let want = (u64::from(EPISODES_PER_LANE) * u64::from(self.lanes()))
            .div_ceil(u64::from(episodes.max(1)));
        let fit = self.info.memory.map(|mem| {
            // per network: its weights, and per episode its key, its start
            // (observation and state) and its results
            let per = 8 * n_weights as u64 + u64::from(episodes) * (24 + self.info.item_bytes);
            ((mem as f64 * MEMORY_SHARE / 2.0) / per.max(1) as f64) as u64
        });
        let n = fit.map_or(want, |f| want.min(f));
        let n = (n / m * m).clamp(m, u64::from(MAX_DEFAULT_NETWORKS)) as u32;
        let why = match (fit, self.info.memory) {
            (Some(f), Some(mem)) if f < want => format!(
                "default: what two chunks fit in a quarter of the device's {} MiB",
                mem >> 20
            ),
            _ => format!(
                "default: {EPISODES_PER_LANE} episodes for each of the {} lanes",
                self.lanes()
            ),
        };
        (n, why)
    }

    fn on_cpu(&self) -> bool {
        self.info.platform == "cpu"
    }

    /// How the env runs, for a run's first lines: the devices, the networks
    /// per call (for `plan`'s cell) and why, the lanes, the matmul precision
    /// and where compiled programs are cached.
    pub fn run_line(&self, plan: &CellPlan) -> String {
        let shape = self.cell_shape(plan);
        let (_, why) = self.networks_per_call(plan.episodes, shape.n_weights);
        let i = &self.info;
        let devices = if i.devices == 1 {
            "1 device".to_string()
        } else {
            format!("{} devices", i.devices)
        };
        let cache = match &self.config.compile_cache {
            Some(p) => format!("compiled programs cached in {} ({CACHE_VAR})", p.display()),
            None => format!("no compilation cache ({CACHE_VAR}=off)"),
        };
        format!(
            "{}: JAX on {} ({}, {devices}), {} networks per call ({why}), {} lanes ({}), \
             matmul precision {}; {cache}",
            i.spec.id,
            i.device,
            i.device_kind,
            shape.networks,
            shape.lanes,
            loop_text(&i.episode_loop),
            self.config.matmul_precision.name()
        )
    }

    /// Worker processes a run with `threads` threads uses: `threads` on a
    /// CPU device, 1 on a GPU or TPU (which runs every device it was given).
    pub fn workers_for(&self, threads: usize) -> usize {
        if self.on_cpu() {
            threads.max(1)
        } else {
            1
        }
    }

    /// CPU seconds used so far by the idle worker processes, where the OS
    /// reports it.
    pub fn workers_cpu_seconds(&self) -> Option<f64> {
        self.lock_pool().iter().map(|w| w.cpu_seconds()).sum()
    }

    /// Ends the idle worker processes (a later cell starts new ones).
    pub fn release_workers(&self) {
        let idle = std::mem::take(&mut *self.lock_pool());
        drop(idle);
    }

    pub(crate) fn lock_pool(&self) -> std::sync::MutexGuard<'_, Vec<JaxWorker>> {
        self.pool.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// An idle worker, or a new one (which must describe the env as the
    /// first did).
    pub(crate) fn take_worker(&self) -> Result<JaxWorker, JaxError> {
        if let Some(w) = self.lock_pool().pop() {
            return Ok(w);
        }
        let (w, info) = JaxWorker::spawn(&self.config)?;
        if info != self.info {
            return Err(JaxError::OtherInfo(format!(
                "{info:?} where the first reported {:?}",
                self.info
            )));
        }
        Ok(w)
    }

    /// Runs `blocks` of a cell on [`JaxSource::workers_for`]`(threads)`
    /// workers (kept between calls), in chunks of
    /// [`JaxSource::networks_per_call`] networks of consecutive blocks, one
    /// chunk in flight per worker, and hands the results to `on_block` in
    /// block order. Stops at the first failure in network order (an
    /// episode's fault bit: a [`SampleError`]; a worker's error, death or
    /// timeout: a [`CallError`]) or the first error `on_block` returns; the
    /// blocks handed out before stay valid.
    pub fn run_blocks<G, X>(
        &self,
        plan: &CellPlan,
        blocks: &[Range<u64>],
        threads: usize,
        on_block: G,
    ) -> Result<(), X>
    where
        G: FnMut(BlockResult) -> Result<(), X>,
        X: From<SampleError> + From<CallError> + Send,
    {
        run::run_blocks(self, plan, blocks, threads, on_block)
    }
}

/// How the run's first line names a cell's episode loop.
fn loop_text(l: &crate::protocol::EpisodeLoop) -> String {
    match l.kind.as_str() {
        "plain" => format!("run together to the end: {}", l.why),
        _ => "an ended lane takes the next episode".to_string(),
    }
}
