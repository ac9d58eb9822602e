//! Run and cell records for the unit tests of the comparisons.

use rwg_study::rundir::meta::{CellId, CellMeta, RunMeta, WeightsMeta};

/// A cell of env `env`, architecture `arch` with hidden layers `hidden` and
/// no bias: `samples` networks x `episodes` episodes, `solved` its threshold.
pub(crate) fn cell(
    env: &str,
    arch: &str,
    hidden: &[usize],
    samples: u64,
    episodes: u32,
    solved: Option<f64>,
) -> CellMeta {
    CellMeta {
        id: CellId::new(env, arch, hidden, false),
        n_weights: 10,
        obs_dim: 4,
        max_episode_steps: 500,
        solved,
        solved_source: None,
        samples,
        episodes,
        wall_s: 0.0,
        env_steps: 0,
        steps_per_s: 0.0,
        non_finite_episodes: None,
    }
}

/// A finished, unsharded run of `cells` drawn with `seed` from weights of
/// distribution `distribution` (scale 1).
pub(crate) fn run(seed: u64, distribution: &str, cells: Vec<CellMeta>) -> RunMeta {
    RunMeta {
        format: 2,
        rwg_version: "t".into(),
        seed,
        samples: cells.first().map_or(0, |c| c.samples),
        episodes: cells.first().map_or(0, |c| c.episodes),
        weights: WeightsMeta {
            distribution: distribution.into(),
            scale: 1.0,
        },
        threads: 1,
        start_time: String::new(),
        end_time: None,
        wall_s: 0.0,
        env_steps: 0,
        steps_per_s: 0.0,
        cells,
        block_samples: 32,
        shard: None,
        study: None,
    }
}
