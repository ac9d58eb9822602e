//! Deterministic synthetic run directories, for tests and demos of the
//! analysis: scores are drawn from a simple model, no environment is run.

use super::{write_cell_files, write_run_json};
use crate::rundir::meta::{CellId, CellMeta, RunMeta, WeightsMeta, RUN_FORMAT};
use std::path::Path;

/// One synthetic cell.
#[derive(Debug, Clone)]
pub struct SyntheticCell {
    /// Environment id.
    pub env: String,
    /// Architecture name.
    pub arch: String,
    /// Hidden layer sizes.
    pub hidden: Vec<usize>,
    /// Bias inputs.
    pub bias: bool,
    /// Solved score.
    pub solved: Option<f64>,
    /// Lowest possible episode score.
    pub low: f64,
    /// Highest possible episode score.
    pub high: f64,
    /// Round scores to integers and use them as the step counts (as
    /// CartPole's +1 per step); otherwise every episode lasts the time limit.
    pub integer: bool,
    /// Time limit.
    pub max_episode_steps: u32,
    /// Skill exponent: a sample's skill is `u^skew` for uniform `u`, so a
    /// larger value makes good networks rarer.
    pub skew: f64,
}

impl SyntheticCell {
    /// A CartPole-v0-like cell (scores 8–200, solved at 195).
    pub fn cartpole(arch: &str, hidden: &[usize], bias: bool) -> Self {
        SyntheticCell {
            env: "CartPole-v0".into(),
            arch: arch.into(),
            hidden: hidden.to_vec(),
            bias,
            solved: Some(195.0),
            low: 8.0,
            high: 200.0,
            integer: true,
            max_episode_steps: 200,
            skew: 3.0 + hidden.len() as f64,
        }
    }

    /// A Pendulum-like cell (scores −1600 to −100, no solved score).
    pub fn pendulum(arch: &str, hidden: &[usize], bias: bool) -> Self {
        SyntheticCell {
            env: "Pendulum-v1".into(),
            arch: arch.into(),
            hidden: hidden.to_vec(),
            bias,
            solved: None,
            low: -1600.0,
            high: -100.0,
            integer: false,
            max_episode_steps: 200,
            skew: 2.0,
        }
    }
}

/// A whole synthetic run.
#[derive(Debug, Clone)]
pub struct SyntheticRun {
    /// Samples per cell.
    pub samples: u64,
    /// Episodes per sample.
    pub episodes: u32,
    /// Seed of the score model.
    pub seed: u64,
    /// The cells, in order.
    pub cells: Vec<SyntheticCell>,
}

/// SplitMix64: a tiny deterministic generator.
struct Rng(u64);

impl Rng {
    fn next_f64(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^= z >> 31;
        (z >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// Writes `run.json` and every cell's `scores.csv` and `samples.csv` into
/// `dir` (created if needed); returns the metadata written.
pub fn write_synthetic_run(dir: &Path, spec: &SyntheticRun) -> std::io::Result<RunMeta> {
    std::fs::create_dir_all(dir)?;
    let mut rng = Rng(spec.seed);
    let e = spec.episodes as usize;
    let mut cells = Vec::new();
    let mut total_steps = 0;
    for c in &spec.cells {
        let mut scores = Vec::with_capacity(spec.samples as usize * e);
        let mut steps = Vec::with_capacity(scores.capacity());
        for _ in 0..spec.samples {
            let skill = rng.next_f64().powf(c.skew);
            let spread = 0.3 * rng.next_f64();
            for _ in 0..e {
                let x = (skill + spread * (rng.next_f64() - 0.5)).clamp(0.0, 1.0);
                let mut s = c.low + (c.high - c.low) * x;
                if c.integer {
                    s = s.round();
                }
                scores.push(s);
                steps.push(if c.integer {
                    s as u32
                } else {
                    c.max_episode_steps
                });
            }
        }
        let env_steps: u64 = steps.iter().map(|&s| u64::from(s)).sum();
        total_steps += env_steps;
        let meta = CellMeta {
            non_finite_episodes: None,
            id: CellId::new(&c.env, &c.arch, &c.hidden, c.bias),
            n_weights: 4 * (c.hidden.first().copied().unwrap_or(2)),
            obs_dim: 4,
            max_episode_steps: c.max_episode_steps,
            solved: c.solved,
            solved_source: c.solved.map(|_| "env".into()),
            samples: spec.samples,
            episodes: spec.episodes,
            wall_s: 1.0,
            env_steps,
            steps_per_s: env_steps as f64,
        };
        write_cell_files(dir, &meta, &scores, &steps)?;
        cells.push(meta);
    }
    let meta = RunMeta {
        format: RUN_FORMAT,
        rwg_version: "synthetic".into(),
        seed: spec.seed,
        samples: spec.samples,
        episodes: spec.episodes,
        weights: WeightsMeta {
            distribution: "normal".into(),
            scale: 1.0,
        },
        threads: 1,
        start_time: "2020-05-09T00:00:00Z".into(),
        end_time: Some("2020-05-09T00:00:01Z".into()),
        wall_s: cells.len() as f64,
        env_steps: total_steps,
        steps_per_s: total_steps as f64 / cells.len().max(1) as f64,
        cells,
        block_samples: spec.samples,
        shard: None,
        study: None,
    };
    write_run_json(dir, &meta)?;
    Ok(meta)
}
