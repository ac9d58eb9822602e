//! `rwg bench envs`: raw `Environment::step` throughput of the built-in
//! environments (and the shared step loop the plugin benchmark uses).

use super::{check_ids, group, print_row, Clock};
use anyhow::{Context, Result};
use rwg_env::seeding::Pcg64;
use rwg_env::{Action, Environment, Space};
use rwg_envs::{visit, EnvOptions, EnvVisitor, REGISTRY};
use serde::Serialize;

/// Arguments of `rwg bench envs`.
#[derive(clap::Args)]
pub(super) struct EnvsArgs {
    /// Env steps per environment.
    #[arg(long, value_name = "N", default_value_t = 5_000_000)]
    pub(super) steps: u64,
    /// Benchmark only this environment (repeatable; default: every built-in env).
    #[arg(long = "env", value_name = "ID")]
    pub(super) envs: Vec<String>,
    /// Also hash the bits of every observation and reward (a bit-exactness
    /// check between builds; costs a little time per step).
    #[arg(long)]
    pub(super) hash: bool,
    /// Benchmark the environments of this plugin library instead (repeatable;
    /// --env picks among them). A plugin env whose id is `namespace/<built-in
    /// id>`, like the reference plugin's, is also compared with the built-in:
    /// what the plugin ABI costs per step.
    #[arg(long = "plugin", value_name = "FILE")]
    pub(super) plugins: Vec<std::path::PathBuf>,
    /// Print a JSON array instead of a table.
    #[arg(long)]
    pub(super) json: bool,
}

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
pub(super) struct EnvRow {
    pub(super) env: String,
    steps: u64,
    episodes: u64,
    seconds: f64,
    steps_per_s: f64,
    pub(super) ns_per_step: f64,
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
    pub(super) vs_builtin: Option<VsBuiltin>,
    /// The process's SIMD level (`RWG_SIMD`, else AVX2 where the CPU has it). The
    /// scalar envs stepped here run no vector code, so their figures and
    /// hash do not depend on it; the lockstep envs and the policies do
    /// (`rwg bench sampler`).
    simd: &'static str,
}

/// A plugin env compared with the built-in env it re-exports.
#[derive(Serialize)]
pub(super) struct VsBuiltin {
    pub(super) builtin: String,
    pub(super) builtin_ns_per_step: f64,
    pub(super) ratio: f64,
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

pub(super) struct EnvBench {
    pub(super) steps: u64,
    pub(super) hash: bool,
}

impl EnvVisitor for EnvBench {
    type Output = Result<EnvRow>;
    fn visit<E: Environment + Clone + Send + Sync + 'static>(self, env: E) -> Result<EnvRow> {
        self.bench(env)
    }
}

impl EnvBench {
    /// Times `steps` raw steps of `env` (statically dispatched for `E`).
    pub(super) fn bench<E: Environment>(self, mut env: E) -> Result<EnvRow> {
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
            simd: rwg_env::simd::level().name(),
        })
    }
}

pub(super) fn run(args: EnvsArgs) -> Result<()> {
    rwg_study::limits::in_range("steps", args.steps, 1, rwg_study::limits::MAX_BENCH_STEPS)
        .map_err(|m| anyhow::anyhow!("--{m}"))?;
    if !args.plugins.is_empty() {
        return super::plugin::run(args);
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
    } else {
        crate::outln!(
            "SIMD level: {} ({}; the scalar envs stepped here run no vector code)",
            rwg_env::simd::level(),
            rwg_env::simd::VAR
        );
    }
    Ok(())
}

/// Columns of `rwg bench envs`: header and width (negative: left-aligned).
pub(super) const ENV_COLUMNS: [(&str, i32); 7] = [
    ("env", -24),
    ("steps", 11),
    ("episodes", 9),
    ("steps/s", 12),
    ("ns/step", 7),
    ("steps/CPU-s", 12),
    ("reward sum", 13),
];

pub(super) fn env_cells(r: &EnvRow) -> [String; 7] {
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

#[cfg(test)]
mod tests {
    use super::*;

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
