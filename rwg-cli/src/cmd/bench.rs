//! `rwg bench`: throughput of the built-in environments and of the RWG sampler.
//!
//! Two measurements, both statically dispatched through [`rwg_envs::visit`]
//! (the step loop is monomorphised for each concrete env type):
//!
//! - `rwg bench envs`: raw `Environment::step` throughput under a fixed,
//!   pre-generated pseudo-random action sequence, resetting with successive
//!   seeds whenever an episode ends;
//! - `rwg bench sampler`: the whole RWG workload (weight draws, reset seed
//!   derivation, resets, policy forward pass, env steps) through
//!   [`rwg_core::sampler::run_cell`], for the configurations the peer
//!   implementations were measured on.
//!
//! Every figure comes from one timed run; the machine's noise is not averaged
//! out. Env steps are counted exactly: every step of every episode. The
//! comparison with the peers, by contrast, measures both sides in the same
//! invocation: `rwg bench peers` ([`super::bench_peers`]).

use super::bench_peers::PEER_WORKLOADS;
use anyhow::{bail, Context, Result};
use rwg_core::policy::Architecture;
use rwg_core::sampler::{run_cell, BlockResult, CellPlan, SampleError, WeightDist};
use rwg_env::seeding::Pcg64;
use rwg_env::{Action, Environment, Space};
use rwg_envs::{visit, EnvOptions, EnvVisitor, REGISTRY};
use serde::Serialize;
use std::time::Instant;

/// Arguments of `rwg bench`.
#[derive(clap::Args)]
#[command(after_help = "\
`envs` and `sampler` run in this process and report one timed run; repeat them to \
see the noise. `peers` runs rwg and a peer as child processes, interleaved, and \
reports medians with their spread. Build with --release for meaningful figures.")]
pub struct Args {
    #[command(subcommand)]
    what: What,
}

#[derive(clap::Subcommand)]
enum What {
    /// Raw environment steps per second under a fixed pseudo-random action sequence.
    #[command(after_help = "\
Measures Environment::step alone (plus the resets between episodes): for each env, a \
sequence of 4096 pseudo-random actions (discrete: uniform integers; continuous: uniform \
within the action bounds) is generated before timing and replayed cyclically. When an \
episode terminates or is truncated by the time limit, the env is reset with the next \
seed (0, 1, 2, ...); the resets are inside the timed span. No policy is evaluated.

Columns: steps = env steps timed, episodes = episodes started, steps/s and ns/step (wall \
clock), steps/CPU-s (process CPU time: steadier on a busy machine), and the sum of all \
rewards. With --hash, a hash of the bits of every observation and reward follows: it \
must be the same for every build (on the same libm) for the same --steps (the envs \
are bit-exact), so it checks that an optimisation changed no result.")]
    Envs(EnvsArgs),
    /// The RWG workload (env + policy) through the sampler alone.
    #[command(after_help = "\
Measures what `rwg` spends its time on: for each configuration, SAMPLES networks with \
i.i.d. N(0,1) weights (no bias) each run EPISODES episodes through rwg_core's sampler \
(weight draws, reset seeds, resets, policy forward passes and env steps, on a rayon \
pool of THREADS threads). Reported: env steps (every step of every episode), wall \
time, env steps/s in total and per thread, and env steps per CPU-second of the process \
(steadier than wall time on a busy machine). The sampler alone is not the whole `rwg \
run` command: compare with other implementations with `rwg bench peers`, which \
measures both sides in one invocation. Each thread runs several episodes side by side \
(the JSON's `lanes`); the results are those of running them one by one (`mean_score` \
does not depend on the build, the thread count or the lanes).

Configurations (the peers' workload): CartPole-v0 0HL, CartPole-v0 [4,4], Acrobot-v1 \
0HL, MountainCarContinuous-v0 [4,4], Pendulum-v1 [4].")]
    Sampler(SamplerArgs),
    /// The whole `rwg run --threads 1` against gymnax-raw, side by side, pinned to one core.
    #[command(after_help = "\
For each of the peers' five workloads (CartPole-v0 0HL, CartPole-v0 [4,4], Acrobot-v1 \
0HL, MountainCarContinuous-v0 [4,4], Pendulum-v1 [4]; no bias), runs ROUNDS times, \
interleaved (alternating which side goes first), with this process and its children \
pinned to one core:
  - `rwg run --threads 1` on a one-cell manifest (RWG_SAMPLES networks x EPISODES \
episodes, the report included): the child's whole CPU time (getrusage);
  - gymnax-raw (`gymnax_rwg.py --step raw` of the peer scripts, PEER_SAMPLES networks): \
the CPU time its JSON reports for the compiled run (JAX start-up and XLA compile \
excluded, as the peer reports them apart).
Prints env steps per CPU-second of each side and their ratio per round: median \
[min-max]. Env steps are the transitions inside episodes on both sides.

The peer needs a Python with jax and gymnax: --python (or RWG_PEER_PYTHON), or the \
virtualenv --venv, which --create-venv makes with
  python3 -m venv target/peers-venv
  target/peers-venv/bin/pip install numpy==2.4.6 gymnasium==1.3.0 jax==0.10.2 \
jaxlib==0.10.2 gymnax==1.0.1 flax==0.12.8 six==1.17.0
Build rwg with --release for meaningful figures.")]
    Peers(super::bench_peers::PeersArgs),
    /// Gymnasium envs through the bridge, beside a pure-Python loop (the ceiling) and a peer script.
    #[command(after_help = "\
For each gymnasium: env, interleaved REPEATS times: (1) the RWG workload (SAMPLES 0HL \
networks x EPISODES episodes, no bias) through the bridge on one sampler thread = one \
Python worker; (2) a pure-Python loop in one process that only calls env.step with \
pre-drawn random actions for the same number of steps (resetting with successive seeds), \
the ceiling for any bridge; (3) the same RWG workload on two threads = two workers; \
(4) with --peer, a peer script on SAMPLES/5 networks. Worker start-up is not timed. \
Reported: median [min-max] env steps/s, bridge / ceiling and 2 workers / 1 worker.

Example:
  rwg bench gym --env gymnasium:CartPole-v1 --peer ../shared/peers/ref_numpy.py")]
    Gym(super::bench_gym::GymBenchArgs),
}

/// Arguments of `rwg bench envs`.
#[derive(clap::Args)]
struct EnvsArgs {
    /// Env steps per environment.
    #[arg(long, value_name = "N", default_value_t = 5_000_000)]
    steps: u64,
    /// Benchmark only this environment (repeatable; default: every built-in env).
    #[arg(long = "env", value_name = "ID")]
    envs: Vec<String>,
    /// Also hash the bits of every observation and reward (a bit-exactness
    /// check between builds; costs a little time per step).
    #[arg(long)]
    hash: bool,
    /// Benchmark the environments of this plugin library instead (repeatable;
    /// --env picks among them). A plugin env whose id is `namespace/<built-in
    /// id>`, like the reference plugin's, is also compared with the built-in:
    /// what the plugin ABI costs per step.
    #[arg(long = "plugin", value_name = "FILE")]
    plugins: Vec<std::path::PathBuf>,
    /// Print a JSON array instead of a table.
    #[arg(long)]
    json: bool,
}

/// Arguments of `rwg bench sampler`.
#[derive(clap::Args)]
struct SamplerArgs {
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

/// Runs `rwg bench`.
pub fn run(args: Args) -> Result<()> {
    match args.what {
        What::Envs(a) => run_envs(a),
        What::Sampler(a) => run_sampler(a),
        What::Peers(a) => super::bench_peers::run(a),
        What::Gym(a) => super::bench_gym::run(a),
    }
}

// ---------------------------------------------------------------------------
// rwg bench envs

/// Length of the cyclic action sequence (a power of two).
const ACTION_CYCLE: usize = 4096;

/// The pre-generated actions of one env.
enum Actions {
    Discrete(Vec<i64>),
    /// `ACTION_CYCLE` vectors of `dim` components, back to back.
    Continuous {
        values: Vec<f64>,
        dim: usize,
    },
}

impl Actions {
    /// Uniform actions over `space`, from a fixed generator.
    fn generate(space: &Space) -> Actions {
        let mut rng = Pcg64::from_seed(0x5eed);
        match space {
            Space::Discrete { n } => Actions::Discrete(
                (0..ACTION_CYCLE)
                    .map(|_| (rng.next_f64() * *n as f64) as i64)
                    .collect(),
            ),
            Space::Box(b) => Actions::Continuous {
                values: (0..ACTION_CYCLE)
                    .flat_map(|_| {
                        b.low
                            .iter()
                            .zip(&b.high)
                            .map(|(&l, &h)| rng.uniform(l, h))
                            .collect::<Vec<_>>()
                    })
                    .collect(),
                dim: b.dim(),
            },
        }
    }
}

/// Result of one env's raw-step benchmark.
#[derive(Serialize)]
struct EnvRow {
    env: String,
    steps: u64,
    episodes: u64,
    seconds: f64,
    steps_per_s: f64,
    ns_per_step: f64,
    /// Process CPU time over the timed span (`null` where not measurable).
    cpu_s: Option<f64>,
    /// Env steps per CPU-second: less sensitive than `steps_per_s` to other
    /// processes on a busy machine.
    steps_per_cpu_s: Option<f64>,
    reward_sum: f64,
    /// With `--hash`: FNV-1a hash of the bits of every observation and reward.
    #[serde(skip_serializing_if = "Option::is_none")]
    obs_hash: Option<String>,
    /// For a plugin env that re-exports a built-in one: the built-in id and
    /// this env's time per step over the built-in's (same steps, same actions).
    #[serde(skip_serializing_if = "Option::is_none")]
    vs_builtin: Option<VsBuiltin>,
}

/// A plugin env compared with the built-in env it re-exports.
#[derive(Serialize)]
struct VsBuiltin {
    builtin: String,
    builtin_ns_per_step: f64,
    ratio: f64,
}

/// What the timed loop returns.
struct LoopOutcome {
    /// Episodes started (the first reset included).
    episodes: u64,
    reward_sum: f64,
    /// Hash of every observation's bits (0 unless `HASH`).
    obs_hash: u64,
}

/// The timed loop: `steps` steps with `action(i)`, resetting with the next
/// seed whenever an episode ends. With `HASH`, every observation (resets
/// included) is folded into a hash of its bits.
#[inline(always)]
fn step_loop<'a, E: Environment, const HASH: bool>(
    env: &mut E,
    obs: &mut [f64],
    steps: u64,
    action: impl Fn(usize) -> Action<'a>,
) -> Result<LoopOutcome> {
    fn fold(h: &mut u64, obs: &[f64]) {
        for x in obs {
            *h = (*h ^ x.to_bits()).wrapping_mul(0x0000_0100_0000_01b3); // FNV-1a prime
        }
    }
    let mut h = 0xcbf2_9ce4_8422_2325; // FNV offset basis
    let mut seed = 0u64;
    env.reset(seed, obs)?;
    if HASH {
        fold(&mut h, obs);
    }
    let mut reward_sum = 0.0;
    for i in 0..steps {
        let s = env.step(action(i as usize % ACTION_CYCLE), obs)?;
        reward_sum += s.reward;
        if HASH {
            fold(&mut h, obs);
            h = (h ^ s.reward.to_bits()).wrapping_mul(0x0000_0100_0000_01b3);
        }
        if s.terminated || s.truncated {
            seed += 1;
            env.reset(seed, obs)?;
            if HASH {
                fold(&mut h, obs);
            }
        }
    }
    Ok(LoopOutcome {
        episodes: seed + 1,
        reward_sum,
        obs_hash: if HASH { h } else { 0 },
    })
}

/// Runs [`step_loop`] with or without hashing.
fn run_loop<'a, E: Environment>(
    env: &mut E,
    obs: &mut [f64],
    steps: u64,
    hash: bool,
    action: impl Fn(usize) -> Action<'a>,
) -> Result<LoopOutcome> {
    if hash {
        step_loop::<E, true>(env, obs, steps, action)
    } else {
        step_loop::<E, false>(env, obs, steps, action)
    }
}

struct EnvBench {
    steps: u64,
    hash: bool,
}

impl EnvVisitor for EnvBench {
    type Output = Result<EnvRow>;
    fn visit<E: Environment + Clone + Send + Sync + 'static>(self, env: E) -> Result<EnvRow> {
        self.bench(env)
    }
}

impl EnvBench {
    /// Times `steps` raw steps of `env` (statically dispatched for `E`).
    fn bench<E: Environment>(self, mut env: E) -> Result<EnvRow> {
        let spec = env.spec().clone();
        let actions = Actions::generate(&spec.action_space);
        let mut obs = vec![0.0; spec.obs_dim()];
        let clock = Clock::start();
        let out = match &actions {
            Actions::Discrete(a) => run_loop(&mut env, &mut obs, self.steps, self.hash, |i| {
                Action::Discrete(a[i])
            })?,
            Actions::Continuous { values, dim } => {
                let dim = *dim;
                run_loop(&mut env, &mut obs, self.steps, self.hash, |i| {
                    Action::Continuous(&values[i * dim..(i + 1) * dim])
                })?
            }
        };
        let (seconds, cpu_s) = clock.stop();
        std::hint::black_box(&obs);
        Ok(EnvRow {
            env: spec.id,
            steps: self.steps,
            episodes: out.episodes,
            seconds,
            steps_per_s: self.steps as f64 / seconds,
            ns_per_step: seconds * 1e9 / self.steps as f64,
            cpu_s,
            steps_per_cpu_s: cpu_s.map(|c| self.steps as f64 / c),
            reward_sum: out.reward_sum,
            obs_hash: self.hash.then(|| format!("{:016x}", out.obs_hash)),
            vs_builtin: None,
        })
    }
}

/// Checks `--env` ids against the registry (with a suggestion for typos).
fn check_ids(ids: &[String]) -> Result<()> {
    for id in ids {
        rwg_envs::make(id, &EnvOptions::default())?;
    }
    Ok(())
}

fn run_envs(args: EnvsArgs) -> Result<()> {
    rwg_study::limits::in_range("steps", args.steps, 1, rwg_study::limits::MAX_BENCH_STEPS)
        .map_err(|m| anyhow::anyhow!("--{m}"))?;
    if !args.plugins.is_empty() {
        return run_plugin_envs(args);
    }
    check_ids(&args.envs)?;
    let ids: Vec<&str> = if args.envs.is_empty() {
        REGISTRY.iter().map(|r| r.id).collect()
    } else {
        args.envs.iter().map(String::as_str).collect()
    };
    let mut rows = Vec::new();
    for id in ids {
        let bench = EnvBench {
            steps: args.steps,
            hash: args.hash,
        };
        let row = visit(id, &EnvOptions::default(), bench)?
            .with_context(|| format!("benchmarking {id}"))?;
        if !args.json {
            if rows.is_empty() {
                let mut header = ENV_COLUMNS.map(|c| c.0.to_string());
                if args.hash {
                    header[6] = format!("{:>13}  obs hash", header[6]);
                }
                print_row(&ENV_COLUMNS, &header);
            }
            print_row(&ENV_COLUMNS, &env_cells(&row));
        }
        rows.push(row);
    }
    if args.json {
        crate::outln!("{}", serde_json::to_string_pretty(&rows)?);
    }
    Ok(())
}

/// `rwg bench envs --plugin`: the plugins' envs, each compared with the
/// built-in env it re-exports, if any.
fn run_plugin_envs(args: EnvsArgs) -> Result<()> {
    let mut rows = Vec::new();
    for path in &args.plugins {
        let plugin = rwg_plugin_host::load_plugin(path)?;
        for ty in plugin.envs() {
            if !args.envs.is_empty() && !args.envs.iter().any(|e| e == ty.id()) {
                continue;
            }
            let bench = || EnvBench {
                steps: args.steps,
                hash: args.hash,
            };
            let env = ty
                .make("", None)
                .with_context(|| format!("cannot create {}", ty.id()))?;
            let mut row = bench()
                .bench(env)
                .with_context(|| format!("benchmarking {}", ty.id()))?;
            let builtin = ty
                .id()
                .split_once('/')
                .map(|(_, b)| b)
                .filter(|b| rwg_study::env_source::is_builtin(b));
            if let Some(b) = builtin {
                let base = visit(b, &EnvOptions::default(), bench())??;
                row.vs_builtin = Some(VsBuiltin {
                    builtin: b.to_string(),
                    builtin_ns_per_step: base.ns_per_step,
                    ratio: row.ns_per_step / base.ns_per_step,
                });
            }
            rows.push(row);
        }
    }
    if rows.is_empty() {
        bail!("no environment to benchmark (check --env against `rwg envs --plugin FILE`)");
    }
    if args.json {
        crate::outln!("{}", serde_json::to_string_pretty(&rows)?);
        return Ok(());
    }
    let mut columns = ENV_COLUMNS;
    let widest = rows.iter().map(|r| r.env.len()).max().unwrap_or(0) as i32;
    columns[0].1 = columns[0].1.min(-widest);
    print_row(&columns, &columns.map(|c| c.0.to_string()));
    for r in &rows {
        print_row(&columns, &env_cells(r));
    }
    for r in &rows {
        if let Some(v) = &r.vs_builtin {
            crate::outln!(
                "{}: {:.1} ns/step vs {:.1} for the built-in {} ({:.2}x)",
                r.env,
                r.ns_per_step,
                v.builtin_ns_per_step,
                v.builtin,
                v.ratio
            );
        }
    }
    Ok(())
}

/// Columns of `rwg bench envs`: header and width (negative: left-aligned).
const ENV_COLUMNS: [(&str, i32); 7] = [
    ("env", -24),
    ("steps", 11),
    ("episodes", 9),
    ("steps/s", 12),
    ("ns/step", 7),
    ("steps/CPU-s", 12),
    ("reward sum", 13),
];

fn env_cells(r: &EnvRow) -> [String; 7] {
    [
        r.env.clone(),
        group(r.steps),
        group(r.episodes),
        group(r.steps_per_s.round() as u64),
        format!("{:.1}", r.ns_per_step),
        r.steps_per_cpu_s
            .map_or("-".into(), |v| group(v.round() as u64)),
        match &r.obs_hash {
            Some(h) => format!("{:>13}  {h}", format!("{:.6e}", r.reward_sum)),
            None => format!("{:.6e}", r.reward_sum),
        },
    ]
}

// ---------------------------------------------------------------------------
// rwg bench sampler

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
    /// Instruction set of the policy's forward pass on this CPU.
    forward_isa: &'static str,
}

/// Samples per block handed to a rayon task: as in `rwg run`.
const BLOCK: u64 = 32;

struct SamplerBench<'p> {
    plan: CellPlan,
    samples: u64,
    pool: &'p rayon::ThreadPool,
}

impl EnvVisitor for SamplerBench<'_> {
    /// (env steps, score sum, wall seconds, CPU seconds).
    type Output = Result<(u64, f64, f64, Option<f64>), SampleError>;
    fn visit<E: Environment + Clone + Send + Sync + 'static>(self, env: E) -> Self::Output {
        let threads = self.pool.current_num_threads();
        let mut steps = 0u64;
        let mut score = 0.0;
        let clock = Clock::start();
        self.pool.install(|| {
            run_cell(
                &self.plan,
                0..self.samples,
                BLOCK,
                2 * threads, // blocks per wave: as in `rwg run`
                || env.clone(),
                |b: BlockResult| -> Result<(), SampleError> {
                    for e in &b.episodes {
                        steps += e.steps as u64;
                        score += e.score;
                    }
                    Ok(())
                },
            )
        })?;
        let (seconds, cpu_s) = clock.stop();
        Ok((steps, score, seconds, cpu_s))
    }
}

fn run_sampler(args: SamplerArgs) -> Result<()> {
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
        };
        let bench = SamplerBench {
            plan,
            samples: args.samples,
            pool: &pool,
        };
        let (env_steps, score, seconds, cpu_s) = visit(env, &EnvOptions::default(), bench)??;
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
            lanes: rwg_core::sampler::LANES,
            forward_isa: rwg_core::policy::lanes_isa(),
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

// ---------------------------------------------------------------------------
// timing

/// Wall clock and process CPU time of a timed span.
struct Clock {
    wall: Instant,
    cpu: Option<f64>,
}

impl Clock {
    fn start() -> Clock {
        Clock {
            cpu: process_cpu_seconds(),
            wall: Instant::now(),
        }
    }

    /// (wall seconds, CPU seconds) since `start`.
    fn stop(self) -> (f64, Option<f64>) {
        let wall = self.wall.elapsed().as_secs_f64();
        let cpu = process_cpu_seconds().zip(self.cpu).map(|(b, a)| b - a);
        (wall, cpu)
    }
}

/// CPU time of this process (all threads) in seconds, where measurable.
fn process_cpu_seconds() -> Option<f64> {
    #[cfg(unix)]
    {
        let mut ts = libc::timespec {
            tv_sec: 0,
            tv_nsec: 0,
        };
        // SAFETY: `ts` is a valid, writable timespec for the call's duration.
        let rc = unsafe { libc::clock_gettime(libc::CLOCK_PROCESS_CPUTIME_ID, &mut ts) };
        (rc == 0).then_some(ts.tv_sec as f64 + ts.tv_nsec as f64 * 1e-9)
    }
    #[cfg(not(unix))]
    {
        None
    }
}

// ---------------------------------------------------------------------------
// table output

/// Prints one table line: each cell padded to its column's width (a negative
/// width left-aligns), columns separated by two spaces. Rows are printed as
/// soon as they are measured, so the widths are fixed in advance.
fn print_row<const N: usize>(columns: &[(&str, i32); N], cells: &[String; N]) {
    let parts: Vec<String> = columns
        .iter()
        .zip(cells)
        .map(|(&(_, w), c)| {
            let width = w.unsigned_abs() as usize;
            if w < 0 {
                format!("{c:<width$}")
            } else {
                format!("{c:>width$}")
            }
        })
        .collect();
    crate::outln!("{}", parts.join("  ").trim_end());
}

/// `1234567` -> `1,234,567`.
fn group(n: u64) -> String {
    let s = n.to_string();
    let mut out = String::with_capacity(s.len() + s.len() / 3);
    for (i, ch) in s.chars().enumerate() {
        if i > 0 && (s.len() - i) % 3 == 0 {
            out.push(',');
        }
        out.push(ch);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn digit_grouping() {
        assert_eq!(group(0), "0");
        assert_eq!(group(999), "999");
        assert_eq!(group(1000), "1,000");
        assert_eq!(group(8_774_515), "8,774,515");
    }

    #[test]
    fn generated_actions_lie_in_the_space() {
        let env = rwg_envs::make("Pendulum-v1", &EnvOptions::default()).unwrap();
        let Actions::Continuous { values, dim } = Actions::generate(&env.spec().action_space)
        else {
            panic!("Pendulum has a box action space")
        };
        assert_eq!((values.len(), dim), (ACTION_CYCLE, 1));
        assert!(values.iter().all(|a| (-2.0..2.0).contains(a)));
        let Actions::Discrete(a) = Actions::generate(&Space::Discrete { n: 3 }) else {
            panic!()
        };
        assert!(a.iter().all(|a| (0..3).contains(a)));
        assert!((0..3).all(|k| a.contains(&k)));
    }
}
