//! `rwg bench plugin`: the RWG workload through the sampler on a plugin's
//! re-exported classic envs, side by side with their built-in twins: the
//! built-in env (one instance per lane, and in lockstep, `rwg run`'s default
//! for built-in envs), the plugin through its single calls, through ABI
//! 1.1's batched calls and through 1.2's vector env (`rwg run`'s default
//! for plugins that have one), interleaved, in this process, on one thread.

use super::{group, print_row, Clock};
use anyhow::{bail, Context, Result};
use rwg_core::many::run_blocks_many;
use rwg_core::policy::Architecture;
use rwg_core::sampler::{run_cell, BlockResult, CellPlan, SampleError, WeightDist, LANES};
use rwg_env::Environment;
use rwg_envs::{visit, visit_lockstep, EnvOptions, EnvVisitor, LockstepEnv, LockstepVisitor};
use rwg_plugin_host::LaneCalls;
use rwg_study::env_source::PluginSource;
use rwg_study::fault_context::Watched;
use serde::Serialize;
use std::path::PathBuf;

/// Arguments of `rwg bench plugin`.
#[derive(clap::Args)]
pub(super) struct PluginArgs {
    /// The plugin library re-exporting built-in envs as `NAMESPACE/ID`
    /// (e.g. the reference plugin, librwg_plugin_classic_control.so).
    #[arg(long, value_name = "FILE")]
    plugin: PathBuf,
    /// Only this built-in env id (repeatable; default: every one the plugin re-exports).
    #[arg(long = "env", value_name = "ID")]
    envs: Vec<String>,
    /// Only this architecture: 0HL, `[4]` or `[4,4]` (repeatable; default: all three).
    #[arg(long = "arch", value_name = "ARCH")]
    archs: Vec<String>,
    /// Networks per run.
    #[arg(long, value_name = "N", default_value_t = 1000)]
    samples: u64,
    /// Episodes per network.
    #[arg(long, value_name = "E", default_value_t = 5)]
    episodes: u32,
    /// Interleaved rounds (each runs the five variants once).
    #[arg(long, value_name = "R", default_value_t = 5)]
    rounds: usize,
    /// Print a JSON array instead of a table.
    #[arg(long)]
    json: bool,
    /// Run only this variant (for instruction counts under a profiler such
    /// as callgrind, where the five must run in separate processes; the
    /// other columns are then empty).
    #[arg(long, value_enum, value_name = "VARIANT")]
    only: Option<Variant>,
}

/// One of the five ways `rwg bench plugin` runs a workload.
#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum Variant {
    /// The built-in env, one instance per lane.
    Builtin,
    /// The plugin through its single calls.
    Single,
    /// The plugin through ABI 1.1's batched calls.
    Batched,
    /// The built-in env in lockstep (all lanes in one call), as `rwg run`
    /// steps built-in envs unless RWG_LOCKSTEP=0.
    Lockstep,
    /// The plugin through ABI 1.2's vector env, as `rwg run` steps plugin
    /// envs that have one (not measured for those that do not).
    Vec,
}

impl Variant {
    const ALL: [Variant; 5] = [
        Variant::Builtin,
        Variant::Single,
        Variant::Batched,
        Variant::Lockstep,
        Variant::Vec,
    ];
}

/// The architectures measured: the paper's three.
const ARCHS: [(&str, &[usize]); 3] = [("0HL", &[]), ("[4]", &[4]), ("[4,4]", &[4, 4])];
/// Samples per block: as in `rwg run`.
const BLOCK: u64 = 32;

/// Median and range of a variant's CPU ns per env step over the rounds.
#[derive(Serialize)]
struct Spread {
    median: f64,
    min: f64,
    max: f64,
}

impl Spread {
    /// NaN (shown as "-", null in JSON) for a variant not run (`--only`).
    fn of(v: Vec<f64>) -> Spread {
        let (median, min, max) = super::spread(&v);
        Spread { median, min, max }
    }

    fn show(&self, digits: usize) -> String {
        if self.median.is_nan() {
            return "-".to_string();
        }
        format!(
            "{:.d$} [{:.d$}-{:.d$}]",
            self.median,
            self.min,
            self.max,
            d = digits
        )
    }
}

/// One env and architecture.
#[derive(Serialize)]
struct Row {
    env: String,
    hidden: Vec<usize>,
    env_steps: u64,
    builtin_ns: Spread,
    single_ns: Spread,
    batched_ns: Spread,
    lockstep_ns: Spread,
    vec_ns: Spread,
    /// Per-round ratios to the built-in of the same round.
    single_ratio: Spread,
    batched_ratio: Spread,
    /// Per-round ratio of the batched plugin to the lockstep built-in.
    batched_lockstep_ratio: Spread,
    /// Per-round ratio of the plugin's vector env to the lockstep built-in:
    /// the plugin against `rwg run`'s path for the built-in, both on `rwg
    /// run`'s path.
    vec_lockstep_ratio: Spread,
}

/// (env steps, score sum as bits, CPU seconds) of one run.
type Measured = (u64, u64, f64);

fn measure(run: impl FnOnce(&mut dyn FnMut(BlockResult))) -> Result<Measured> {
    let (mut steps, mut score) = (0u64, 0.0f64);
    let clock = Clock::start();
    run(&mut |b: BlockResult| {
        for e in &b.episodes {
            steps += e.steps as u64;
            score += e.score;
        }
    });
    let (_, cpu) = clock.stop();
    let cpu = cpu.context("process CPU time is not measurable here")?;
    Ok((steps, score.to_bits(), cpu))
}

struct Builtin<'a> {
    plan: &'a CellPlan,
    samples: u64,
    on_block: &'a mut dyn FnMut(BlockResult),
}

impl EnvVisitor for Builtin<'_> {
    type Output = Result<(), SampleError>;
    fn visit<E: Environment + Clone + Send + Sync + 'static>(self, env: E) -> Self::Output {
        let on_block = self.on_block;
        run_cell(
            self.plan,
            0..self.samples,
            BLOCK,
            2,
            || env.clone(),
            |b| {
                on_block(b);
                Ok::<(), SampleError>(())
            },
        )
    }
}

/// The built-in env in lockstep ([`Variant::Lockstep`]).
struct Lockstep<'a> {
    plan: &'a CellPlan,
    blocks: &'a [std::ops::Range<u64>],
    on_block: &'a mut dyn FnMut(BlockResult),
}

impl LockstepVisitor for Lockstep<'_> {
    type Output = Result<(), SampleError>;
    fn visit<M: LockstepEnv + Clone + Send + Sync + 'static>(self, env: M) -> Self::Output {
        let on_block = self.on_block;
        run_blocks_many(
            self.plan,
            self.blocks,
            2,
            || Ok(env.clone()),
            |b| {
                on_block(b);
                Ok::<(), SampleError>(())
            },
        )
    }
}

pub(super) fn run(args: PluginArgs) -> Result<()> {
    if args.rounds == 0 || args.samples == 0 || args.episodes == 0 {
        bail!("--rounds, --samples and --episodes must be at least 1");
    }
    let plugin = rwg_plugin_host::load_plugin(&args.plugin)?;
    let twins = twins(&args, &plugin)?;
    if let Some(a) = args
        .archs
        .iter()
        .find(|a| !ARCHS.iter().any(|(n, _)| n == a))
    {
        bail!("--arch {a}: not one of 0HL, [4], [4,4]");
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .context("cannot start the thread pool")?;
    let blocks = rwg_core::sampler::blocks(0..args.samples, BLOCK);
    let mut rows = Vec::new();
    for (builtin, ty) in &twins {
        for (name, hidden) in ARCHS {
            if !args.archs.is_empty() && !args.archs.iter().any(|a| a == name) {
                continue;
            }
            let w = Workload::new(&args, builtin, ty, hidden, &blocks);
            let (times, seen) = pool.install(|| w.measure_rounds(name))?;
            let row = Row::of(builtin, hidden, &times, seen);
            if !args.json {
                if rows.is_empty() {
                    print_row(&COLUMNS, &COLUMNS.map(|c| c.0.to_string()));
                }
                print_row(&COLUMNS, &cells(&row, name));
            }
            rows.push(row);
        }
    }
    if args.json {
        crate::outln!("{}", serde_json::to_string_pretty(&rows)?);
    }
    Ok(())
}

/// The built-in envs the plugin re-exports (as `NAMESPACE/ID`), those
/// `--env` names if given, each with the plugin's env type; refused if
/// there is none or one has no batched calls.
fn twins(
    args: &PluginArgs,
    plugin: &rwg_plugin_host::Plugin,
) -> Result<Vec<(String, rwg_plugin_host::PluginEnvType)>> {
    let twins: Vec<(String, rwg_plugin_host::PluginEnvType)> = plugin
        .envs()
        .iter()
        .filter_map(|ty| {
            let (_, b) = ty.id().split_once('/')?;
            rwg_study::env_source::is_builtin(b).then(|| (b.to_string(), ty.clone()))
        })
        .filter(|(b, _)| args.envs.is_empty() || args.envs.contains(b))
        .collect();
    if twins.is_empty() {
        bail!(
            "{} re-exports no built-in env{} (ids NAMESPACE/ID of a built-in ID)",
            args.plugin.display(),
            if args.envs.is_empty() {
                ""
            } else {
                " of those given with --env"
            }
        );
    }
    if let Some((_, ty)) = twins.iter().find(|(_, t)| !t.has_batched_calls()) {
        bail!(
            "{} has no batched calls (ABI 1.1): nothing to compare",
            ty.id()
        );
    }
    Ok(twins)
}

/// CPU ns per env step of each variant ([`Variant::ALL`]'s order), one per
/// round, and the (env steps, score bits) every variant ran.
type Rounds = ([Vec<f64>; 5], Option<(u64, u64)>);

/// One env and architecture, measured in its five variants.
struct Workload<'a> {
    args: &'a PluginArgs,
    /// The built-in env's id.
    builtin: &'a str,
    ty: &'a rwg_plugin_host::PluginEnvType,
    plan: CellPlan,
    source: PluginSource,
    blocks: &'a [std::ops::Range<u64>],
}

impl<'a> Workload<'a> {
    fn new(
        args: &'a PluginArgs,
        builtin: &'a str,
        ty: &'a rwg_plugin_host::PluginEnvType,
        hidden: &[usize],
        blocks: &'a [std::ops::Range<u64>],
    ) -> Self {
        // The built-in id seeds all three, so they run the same episodes.
        let plan = CellPlan {
            seed: 0,
            env_id: builtin.to_string(),
            arch: Architecture {
                hidden: hidden.to_vec(),
                bias: false,
            },
            episodes: args.episodes,
            dist: WeightDist::Normal { std: 1.0 },
            policy: rwg_core::policy::PolicyKind::Network,
            non_finite: Default::default(),
        };
        let source = PluginSource {
            ty: ty.clone(),
            config: String::new(),
            max_episode_steps: None,
            isolated: None,
        };
        Workload {
            args,
            builtin,
            ty,
            plan,
            source,
            blocks,
        }
    }

    /// Whether variant `v` runs: `--only`, and the vector env only for a
    /// plugin env that has one.
    fn runs(&self, v: usize) -> bool {
        self.args.only.is_none_or(|o| o == Variant::ALL[v])
            && (Variant::ALL[v] != Variant::Vec || self.ty.has_vec_env())
    }

    /// Runs the variants `--rounds` times, interleaved (who goes first
    /// rotates); refused if two ran different episodes (a bug).
    fn measure_rounds(&self, name: &str) -> Result<Rounds> {
        let mut times: [Vec<f64>; 5] = Default::default();
        let mut seen: Option<(u64, u64)> = None;
        for round in 0..self.args.rounds {
            let mut round_ns = [0.0; 5];
            for k in 0..5 {
                let v = (k + round) % 5; // rotate who goes first
                if !self.runs(v) {
                    continue;
                }
                let (steps, score, cpu) = self.measure_variant(v)?;
                match seen {
                    None => seen = Some((steps, score)),
                    Some(s) if s != (steps, score) => bail!(
                        "{} {name}: the variants ran different episodes \
                         ({} vs {} env steps): a bug",
                        self.builtin,
                        s.0,
                        steps
                    ),
                    Some(_) => {}
                }
                round_ns[v] = cpu * 1e9 / steps as f64;
            }
            for v in 0..5 {
                if self.runs(v) {
                    times[v].push(round_ns[v]);
                }
            }
        }
        Ok((times, seen))
    }

    /// One run of variant `v` ([`Variant::ALL`]'s index).
    fn measure_variant(&self, v: usize) -> Result<Measured> {
        let (plan, samples, builtin) = (&self.plan, self.args.samples, self.builtin);
        match v {
            0 => measure(|on_block| {
                let b = Builtin {
                    plan,
                    samples,
                    on_block,
                };
                visit(builtin, &EnvOptions::default(), b)
                    .expect("a built-in id")
                    .expect("built-in envs do not fail")
            }),
            1 => measure(|on_block| {
                let make = || Watched::create(|| self.source.make().expect("a plugin instance"));
                run_cell(plan, 0..samples, BLOCK, 2, make, |b| {
                    on_block(b);
                    Ok::<(), SampleError>(())
                })
                .expect("the plugin env does not fail")
            }),
            3 => measure(|on_block| {
                let l = Lockstep {
                    plan,
                    blocks: self.blocks,
                    on_block,
                };
                match visit_lockstep::<LANES, _>(builtin, &EnvOptions::default(), l) {
                    Ok(r) => r.expect("built-in envs do not fail"),
                    Err(_) => panic!("{builtin} has no lockstep version"),
                }
            }),
            _ => measure(|on_block| {
                let calls = if v == 2 {
                    LaneCalls::Batched
                } else {
                    LaneCalls::Vec
                };
                rwg_study::plugin_batch::run_blocks(
                    &self.source,
                    calls,
                    plan,
                    self.blocks,
                    2,
                    |b| {
                        on_block(b);
                        Ok::<(), SampleError>(())
                    },
                )
                .expect("the plugin env does not fail")
            }),
        }
    }
}

impl Row {
    /// The row of env `builtin` with `hidden` layers, from its rounds.
    fn of(builtin: &str, hidden: &[usize], times: &[Vec<f64>; 5], seen: Option<(u64, u64)>) -> Row {
        let ratio_to = |v: usize, to: usize| {
            Spread::of(
                times[v]
                    .iter()
                    .zip(&times[to])
                    .map(|(p, b)| p / b)
                    .collect(),
            )
        };
        let ratio = |v: usize| ratio_to(v, 0);
        Row {
            env: builtin.to_string(),
            hidden: hidden.to_vec(),
            env_steps: seen.map_or(0, |s| s.0),
            single_ratio: ratio(1),
            batched_ratio: ratio(2),
            batched_lockstep_ratio: ratio_to(2, 3),
            vec_lockstep_ratio: ratio_to(4, 3),
            builtin_ns: Spread::of(times[0].clone()),
            single_ns: Spread::of(times[1].clone()),
            batched_ns: Spread::of(times[2].clone()),
            lockstep_ns: Spread::of(times[3].clone()),
            vec_ns: Spread::of(times[4].clone()),
        }
    }
}

/// Columns of `rwg bench plugin`: header and width (negative: left-aligned).
const COLUMNS: [(&str, i32); 12] = [
    ("env", -24),
    ("hidden", -6),
    ("env steps", 11),
    ("built-in ns/step", 19),
    ("single ns/step", 19),
    ("batched ns/step", 19),
    ("lockstep ns/step", 19),
    ("vec ns/step", 19),
    ("single x", 17),
    ("batched x", 17),
    ("batched x lockstep", 18),
    ("vec x lockstep", 17),
];

fn cells(r: &Row, arch: &str) -> [String; 12] {
    [
        r.env.clone(),
        arch.to_string(),
        group(r.env_steps),
        r.builtin_ns.show(1),
        r.single_ns.show(1),
        r.batched_ns.show(1),
        r.lockstep_ns.show(1),
        r.vec_ns.show(1),
        r.single_ratio.show(2),
        r.batched_ratio.show(2),
        r.batched_lockstep_ratio.show(2),
        r.vec_lockstep_ratio.show(2),
    ]
}
