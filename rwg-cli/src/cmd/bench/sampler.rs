//! `rwg bench sampler`: the whole RWG workload through the sampler, for the
//! configurations the peer implementations were measured on.

use super::peers::PEER_WORKLOADS;
use super::{check_ids, group, print_row, Clock};
use anyhow::{bail, Context, Result};
use rwg_core::many::run_blocks_many;
use rwg_core::policy::Architecture;
use rwg_core::sampler::{blocks, run_cell, BlockResult, CellPlan, SampleError, WeightDist, LANES};
use rwg_env::Environment;
use rwg_envs::{visit, visit_lockstep, EnvOptions, EnvVisitor, LockstepEnv, LockstepVisitor};
use serde::Serialize;

/// Arguments of `rwg bench sampler`.
#[derive(clap::Args)]
pub(super) struct SamplerArgs {
    /// Networks per configuration.
    #[arg(long, value_name = "N", default_value_t = 1000)]
    samples: u64,
    /// Episodes per network.
    #[arg(long, value_name = "E", default_value_t = 20)]
    episodes: u32,
    /// Worker threads (default: the number of available cores).
    #[arg(long, value_name = "T")]
    threads: Option<usize>,
    /// Run only the configurations of this environment (repeatable).
    #[arg(long = "env", value_name = "ID")]
    envs: Vec<String>,
    /// Seed of the weights and reset seeds.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Print a JSON array instead of a table.
    #[arg(long)]
    json: bool,
}

/// Result of one sampler configuration.
#[derive(Serialize)]
struct SamplerRow {
    env: String,
    hidden: Vec<usize>,
    bias: bool,
    samples: u64,
    episodes: u32,
    threads: usize,
    env_steps: u64,
    seconds: f64,
    steps_per_s: f64,
    steps_per_s_per_thread: f64,
    /// Process CPU time (all threads; `null` where not measurable).
    cpu_s: Option<f64>,
    /// Env steps per CPU-second.
    steps_per_cpu_s: Option<f64>,
    /// Mean episode score: independent of the build, threads and lanes (a check).
    mean_score: f64,
    /// Episodes each worker runs side by side (`rwg_core::sampler::LANES`).
    lanes: usize,
    /// How the lanes' envs are stepped: `"lockstep"` (all lanes in one call,
    /// `rwg run`'s default for built-in envs) or `"per-lane"` (one instance
    /// per lane; `RWG_LOCKSTEP=0`, as for `rwg run`).
    path: &'static str,
    /// The SIMD level (`RWG_SIMD`, else AVX2 where the CPU has it) the policies'
    /// forward pass and the lockstep envs' steps ran at: `"avx512"`,
    /// `"avx2"` or `"scalar"` (the results are the same at each).
    simd: &'static str,
}

/// Samples per block handed to a rayon task: as in `rwg run`.
const BLOCK: u64 = 32;

struct SamplerBench<'p> {
    plan: CellPlan,
    samples: u64,
    pool: &'p rayon::ThreadPool,
}

/// (env steps, score sum, wall seconds, CPU seconds) of one measurement.
type Measured = Result<(u64, f64, f64, Option<f64>), SampleError>;

impl SamplerBench<'_> {
    /// Times `run` on the bench's pool, handing it the block sink that
    /// counts env steps and sums scores, and the blocks' wave size (as in
    /// `rwg run`: two blocks per thread).
    fn measure(
        &self,
        run: impl FnOnce(
                usize,
                &mut dyn FnMut(BlockResult) -> Result<(), SampleError>,
            ) -> Result<(), SampleError>
            + Send,
    ) -> Measured {
        let wave = 2 * self.pool.current_num_threads();
        let (mut steps, mut score) = (0u64, 0.0);
        let clock = Clock::start();
        self.pool.install(|| {
            run(wave, &mut |b: BlockResult| {
                for e in &b.episodes {
                    steps += e.steps as u64;
                    score += e.score;
                }
                Ok(())
            })
        })?;
        let (seconds, cpu_s) = clock.stop();
        Ok((steps, score, seconds, cpu_s))
    }
}

impl EnvVisitor for SamplerBench<'_> {
    type Output = Measured;
    fn visit<E: Environment + Clone + Send + Sync + 'static>(self, env: E) -> Measured {
        self.measure(|wave, on_block| {
            run_cell(
                &self.plan,
                0..self.samples,
                BLOCK,
                wave,
                || env.clone(),
                on_block,
            )
        })
    }
}

/// The same workload with the env in lockstep ([`SamplerRow::path`]).
impl LockstepVisitor for SamplerBench<'_> {
    type Output = Measured;
    fn visit<M: LockstepEnv + Clone + Send + Sync + 'static>(self, env: M) -> Measured {
        let blocks = blocks(0..self.samples, BLOCK);
        self.measure(|wave, on_block| {
            run_blocks_many(&self.plan, &blocks, wave, || Ok(env.clone()), on_block)
        })
    }
}

pub(super) fn run(args: SamplerArgs) -> Result<()> {
    use rwg_study::limits::{in_range, MAX_EPISODES, MAX_SAMPLES, MAX_THREADS};
    let flag = |m: String| anyhow::anyhow!("--{m}");
    in_range("samples", args.samples, 1, MAX_SAMPLES).map_err(flag)?;
    in_range("episodes", args.episodes, 1, MAX_EPISODES).map_err(flag)?;
    check_ids(&args.envs)?;
    let threads = match args.threads {
        Some(t) => in_range("threads", t, 1, MAX_THREADS).map_err(flag)?,
        None => std::thread::available_parallelism()
            .map_or(1, |n| n.get())
            .min(MAX_THREADS),
    };
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .context("cannot start the thread pool")?;
    let configs: Vec<(&str, &[usize])> = PEER_WORKLOADS
        .iter()
        .copied()
        .filter(|c| args.envs.is_empty() || args.envs.iter().any(|e| e == c.0))
        .collect();
    if configs.is_empty() {
        bail!(
            "no benchmark configuration uses {}; configurations: {}",
            args.envs.join(", "),
            PEER_WORKLOADS.map(|c| c.0).join(", ")
        );
    }
    let mut rows = Vec::new();
    for (env, hidden) in configs {
        let arch = Architecture {
            hidden: hidden.to_vec(),
            bias: false,
        };
        let plan = CellPlan {
            seed: args.seed,
            env_id: env.to_string(),
            arch: arch.clone(),
            episodes: args.episodes,
            dist: WeightDist::Normal { std: 1.0 },
            policy: rwg_core::policy::PolicyKind::Network,
            non_finite: Default::default(),
        };
        let bench = SamplerBench {
            plan,
            samples: args.samples,
            pool: &pool,
        };
        // As `rwg run`: in lockstep unless RWG_LOCKSTEP=0 (every peer
        // workload's env has a lockstep version).
        let opts = EnvOptions::default();
        let (path, measured) = if rwg_study::runner::use_lockstep() {
            match visit_lockstep::<LANES, _>(env, &opts, bench) {
                Ok(r) => ("lockstep", r),
                Err(bench) => ("per-lane", visit(env, &opts, bench)?),
            }
        } else {
            ("per-lane", visit(env, &opts, bench)?)
        };
        let (env_steps, score, seconds, cpu_s) = measured?;
        let steps_per_s = env_steps as f64 / seconds;
        let per_thread = steps_per_s / threads as f64;
        let row = SamplerRow {
            env: env.to_string(),
            hidden: arch.hidden,
            bias: false,
            samples: args.samples,
            episodes: args.episodes,
            threads,
            env_steps,
            seconds,
            steps_per_s,
            steps_per_s_per_thread: per_thread,
            cpu_s,
            steps_per_cpu_s: cpu_s.map(|c| env_steps as f64 / c),
            mean_score: score / (args.samples * args.episodes as u64) as f64,
            lanes: LANES,
            path,
            simd: rwg_core::policy::lanes_isa(),
        };
        if !args.json {
            if rows.is_empty() {
                print_row(&SAMPLER_COLUMNS, &SAMPLER_COLUMNS.map(|c| c.0.to_string()));
            }
            print_row(&SAMPLER_COLUMNS, &sampler_cells(&row));
        }
        rows.push(row);
    }
    if args.json {
        crate::outln!("{}", serde_json::to_string_pretty(&rows)?);
    } else {
        crate::outln!(
            "SIMD level: {} ({}: avx512, avx2 or scalar; the same results at each)",
            rwg_core::policy::lanes_isa(),
            rwg_env::simd::VAR
        );
    }
    Ok(())
}

/// Columns of `rwg bench sampler`: header and width (negative: left-aligned).
const SAMPLER_COLUMNS: [(&str, i32); 7] = [
    ("env", -24),
    ("hidden", -6),
    ("env steps", 11),
    ("seconds", 7),
    ("steps/s", 11),
    ("steps/s/thread", 14),
    ("steps/CPU-s", 11),
];

fn sampler_cells(r: &SamplerRow) -> [String; 7] {
    let hidden = if r.hidden.is_empty() {
        "0HL".to_string()
    } else {
        let h: Vec<String> = r.hidden.iter().map(|h| h.to_string()).collect();
        format!("[{}]", h.join(","))
    };
    [
        r.env.clone(),
        hidden,
        group(r.env_steps),
        format!("{:.3}", r.seconds),
        group(r.steps_per_s.round() as u64),
        group(r.steps_per_s_per_thread.round() as u64),
        r.steps_per_cpu_s
            .map_or("-".into(), |v| group(v.round() as u64)),
    ]
}
