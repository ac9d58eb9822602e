//! `rwg replay`: regenerate one network of a run from the seed and re-run it.

use crate::step_lines::StepLines;
use anyhow::{bail, Context, Result};
use rwg_core::policy::{Policy, PolicyKind};
use rwg_core::sampler::{reset_seed, run_episode, BlockResult, EpisodeResult};
use rwg_env::float::fmt_f64;
use rwg_env::{Environment, Space};
use rwg_study::cells::{plan_cells, Cell};
use rwg_study::env_source::EnvSource;
use rwg_study::manifest::Manifest;
use rwg_study::rundir;
use rwg_study::rundir::data::Run;
use rwg_study::rundir::env_record::check_record;
use rwg_study::rundir::export::csv_writer;
use rwg_study::rundir::outputs::{Output, OutputKind};
use serde::Serialize;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

/// Arguments of `rwg replay`.
#[derive(clap::Args)]
#[command(after_help = "\
Without --episode: prints every episode's reset seed, score and steps, next to the
stored score, and fails if any differs. With --episode: prints that episode step by
step, like `rwg rollout`. --export-weights writes the network as JSON so it can be
rebuilt in numpy and run in Gymnasium (docs/guide.md shows how).

A JAX env's cell (gymnax:, playground:, ...) is replayed through a JAX worker, by
the cell's compiled program on the device kind its env.json records, so the
returns are the run's bit for bit; its episodes are not shown step by step.

Example:
  rwg replay runs/quick --env CartPole-v0 --arch 0HL --sample 17 --episode 3")]
pub struct Args {
    /// Run directory.
    run_dir: PathBuf,
    /// Environment id.
    #[arg(long)]
    env: String,
    /// Architecture name (as in the manifest).
    #[arg(long)]
    arch: String,
    /// Bias setting (needed when the run has both).
    #[arg(long)]
    bias: Option<bool>,
    /// Network index.
    #[arg(long)]
    sample: u64,
    /// Print this episode step by step.
    #[arg(long)]
    episode: Option<u32>,
    /// Output format of --episode.
    #[arg(long, default_value = "jsonl", value_parser = ["jsonl", "csv"])]
    format: String,
    /// Write the network's weights, activation, action mapping and the
    /// episodes' reset seeds to this JSON file.
    #[arg(long, value_name = "FILE.json")]
    export_weights: Option<PathBuf>,
}

/// Finds the cell of `env`, `arch`, `bias` in the run's manifest.
pub fn find_cell<'a>(
    cells: &'a [Cell],
    m: &Manifest,
    env: &str,
    arch: &str,
    bias: Option<bool>,
) -> Result<&'a Cell> {
    // The env as the manifest names it (`gymnasium:CartPole-v1`), else by the
    // id that enters the seeds.
    let pick = |by_manifest_id: bool| -> Vec<&Cell> {
        cells
            .iter()
            .filter(|c| {
                (if by_manifest_id {
                    c.id.env == env
                } else {
                    c.plan.env_id == env
                }) && c.id.arch == arch
                    && bias.is_none_or(|b| c.id.bias == b)
            })
            .collect()
    };
    let mut matching = pick(true);
    if matching.is_empty() {
        matching = pick(false);
    }
    match matching.as_slice() {
        [c] => Ok(c),
        [] => {
            let envs: Vec<&str> = m.envs.iter().map(|e| e.id.as_str()).collect();
            let archs: Vec<&str> = m.architectures.iter().map(|a| a.name.as_str()).collect();
            bail!(
                "the run has no cell {env} / {arch}{}; its envs: {}; its architectures: {}; bias: {:?}",
                bias.map_or(String::new(), |b| format!(" / bias={b}")),
                envs.join(", "),
                archs.join(", "),
                m.bias
            )
        }
        _ => bail!("the run has both bias settings: add --bias true or --bias false"),
    }
}

/// The stored scores of `sample` (one per episode): the cell's scores.csv,
/// read and checked against its checksum by the run directory's loader.
fn stored_scores(run_dir: &Path, cell_dir: &str, sample: u64) -> Result<Vec<f64>> {
    let run = Run::open(run_dir)?;
    crate::cmd::warn_unverified(&run);
    let Some(meta) = run.meta.cells.iter().find(|c| c.id.dir == cell_dir) else {
        bail!(
            "{}: cell {cell_dir} is not finished yet (run.json does not list it): nothing stored \
             to compare with; finish the run first",
            run_dir.display()
        );
    };
    let data = run.load_cell(meta)?;
    Ok(data.sample_scores(sample as usize).to_vec())
}

#[derive(Serialize)]
struct Layer {
    /// `[out, in]`, `in` counting the bias input.
    shape: [usize; 2],
    /// Row-major, the bias weight last in each row.
    weights: Vec<Vec<f64>>,
}

#[derive(Serialize)]
struct Export<'a> {
    env: &'a str,
    arch: &'a str,
    hidden: &'a [usize],
    bias: bool,
    sample: u64,
    max_episode_steps: Option<u32>,
    action_space: &'a Space,
    action_dtype: &'static str,
    activation: &'static str,
    forward: &'static str,
    action: String,
    layers: Vec<Layer>,
    reset_seeds: Vec<u64>,
    /// `gym.make`'s keyword arguments, for a `gymnasium:` env (whose `env`
    /// is then the id to give `gym.make`).
    #[serde(skip_serializing_if = "Option::is_none")]
    gym_kwargs: Option<serde_json::Map<String, serde_json::Value>>,
}

fn export<'a>(cell: &'a Cell, policy: &Policy, sample: u64, episodes: u32) -> Export<'a> {
    let mut rest = policy.weights();
    let layers = policy
        .shape()
        .layers()
        .iter()
        .map(|&(o, i)| {
            let (w, r) = rest.split_at(o * i);
            rest = r;
            Layer {
                shape: [o, i],
                weights: w.chunks(i).map(<[f64]>::to_vec).collect(),
            }
        })
        .collect();
    let action = match &cell.spec.action_space {
        Space::Discrete { n } => format!("argmax over the {n} outputs (first index wins ties)"),
        Space::Box(b) if b.low.iter().zip(&b.high).all(|(l, h)| *l == -*h) => {
            format!("high * y with high = {:?}", b.high)
        }
        Space::Box(b) => format!(
            "low + (y + 1) / 2 * (high - low) with low = {:?}, high = {:?}",
            b.low, b.high
        ),
    };
    Export {
        env: &cell.id.env,
        arch: &cell.id.arch,
        hidden: &cell.id.hidden,
        bias: cell.id.bias,
        sample,
        max_episode_steps: cell.spec.max_episode_steps,
        action_space: &cell.spec.action_space,
        action_dtype: cell.action_dtype().name(),
        activation: "tanh",
        forward: "for W in layers: x = tanh(W @ (concat(x, [1.0]) if bias else x)); y = x",
        action,
        layers,
        reset_seeds: (0..episodes)
            .map(|e| reset_seed(cell.plan.seed, &cell.plan.env_id, sample, e))
            .collect(),
        gym_kwargs: match &cell.source {
            EnvSource::Gym(g) => Some(g.config().kwargs.clone()),
            EnvSource::Jax(j) => Some(j.config().kwargs.clone()),
            _ => None,
        },
    }
}

/// Runs `rwg replay`.
pub fn run(args: Args) -> Result<()> {
    rwg_study::rundir::data::require_run_dir(&args.run_dir)?;
    // The export's place checked (and its run's lock taken) first; every
    // path made absolute before plugin code runs, which may change the
    // working directory.
    let _lock = match &args.export_weights {
        Some(path) => crate::cmd::claim_output(
            Output::new(path, OutputKind::File),
            "--export-weights FILE outside the run writes it now",
        )?,
        None => None,
    };
    let args = Args {
        run_dir: crate::cmd::absolute(&args.run_dir)?,
        export_weights: args
            .export_weights
            .as_deref()
            .map(crate::cmd::absolute)
            .transpose()?,
        ..args
    };
    let mut m = Manifest::load(&args.run_dir.join(rundir::MANIFEST))
        .with_context(|| format!("{} is not an rwg run directory", args.run_dir.display()))?;
    let cells = plan_cells(&mut m)?;
    let cell = find_cell(&cells, &m, &args.env, &args.arch, args.bias)?;
    if args.sample >= m.samples {
        bail!(
            "--sample {} is out of range: the run has samples 0..{}",
            args.sample,
            m.samples - 1
        );
    }
    if let EnvSource::Jax(j) = &cell.source {
        return replay_jax(&args, &m, cell, j);
    }
    let mut env = cell.make_env()?;
    let mut policy = cell.plan.policy(&cell.spec, args.sample);
    let mut obs = vec![0.0; cell.spec.obs_dim()];
    write_export(&args, cell, &policy, m.episodes)?;

    let stdout = crate::stdio::stdout();
    let mut out = BufWriter::new(stdout.lock());
    if let Some(ep) = args.episode {
        if ep >= m.episodes {
            bail!(
                "--episode {ep} is out of range: the run has episodes 0..{}",
                m.episodes - 1
            );
        }
        let lines = StepLines::new(&args.format, cell.spec.action_space.flat_dim(), obs.len());
        env.reset(
            reset_seed(cell.plan.seed, &cell.plan.env_id, args.sample, ep),
            &mut obs,
        )?;
        cell.plan.begin_episode(&mut policy, args.sample, ep);
        lines.header(&mut out)?;
        lines.reset(&mut out, &obs)?;
        let mut t = 0;
        loop {
            t += 1;
            let action = policy.act(&obs);
            // copy the action out of the policy's buffer before stepping
            let owned: Vec<f64>;
            let action = match action {
                rwg_env::Action::Continuous(a) => {
                    owned = a.to_vec();
                    rwg_env::Action::Continuous(&owned)
                }
                d => d,
            };
            let s = env
                .step(action, &mut obs)
                .with_context(|| format!("step {t}"))?;
            lines.step(&mut out, t, action, &obs, s)?;
            if s.terminated || s.truncated {
                break;
            }
        }
        out.flush()?;
        return Ok(());
    }

    let stored = stored_scores(&args.run_dir, &cell.id.dir, args.sample)?;
    compare_episodes(&mut out, cell, args.sample, m.episodes, &stored, |e, r| {
        cell.plan.begin_episode(&mut policy, args.sample, e);
        run_episode(
            &mut env,
            &mut policy,
            &mut obs,
            r,
            (cell.plan.non_finite, cell.plan.dist.scale()),
        )
        .map_err(|(step, err)| anyhow::anyhow!("episode {e}, step {step}: {err}"))
    })
}

/// With --export-weights: writes the network's export.
fn write_export(args: &Args, cell: &Cell, policy: &Policy, episodes: u32) -> Result<()> {
    if let Some(path) = &args.export_weights {
        if cell.plan.policy == PolicyKind::Random {
            bail!(
                "--export-weights: cell {} runs uniformly random actions (policy = \"random\"), \
                 not a network: it has no weights to export",
                cell.id.dir
            );
        }
        let e = export(cell, policy, args.sample, episodes);
        crate::cmd::write_named_file(path, serde_json::to_string_pretty(&e)?.as_bytes())?;
        crate::errln!("wrote {}", path.display());
    }
    Ok(())
}

/// Prints each episode's reset seed, score and steps (from `run(e, seed)`)
/// next to the stored score; fails if any differs.
fn compare_episodes(
    out: &mut impl Write,
    cell: &Cell,
    sample: u64,
    episodes: u32,
    stored: &[f64],
    mut run: impl FnMut(u32, u64) -> Result<EpisodeResult>,
) -> Result<()> {
    let mut csv = csv_writer(&mut *out);
    csv.write_record([
        "episode",
        "reset_seed",
        "score",
        "steps",
        "stored_score",
        "same",
    ])?;
    let mut differ = 0;
    for e in 0..episodes {
        let r = reset_seed(cell.plan.seed, &cell.plan.env_id, sample, e);
        let res = run(e, r)?;
        let st = stored.get(e as usize).copied();
        let same = st.is_some_and(|s| s.to_bits() == res.score.to_bits());
        differ += usize::from(!same);
        csv.write_record([
            e.to_string(),
            r.to_string(),
            fmt_f64(res.score),
            res.steps.to_string(),
            st.map_or("-".into(), fmt_f64),
            same.to_string(),
        ])?;
    }
    csv.flush()?;
    drop(csv);
    out.flush()?;
    if differ > 0 {
        bail!("{differ} episode(s) differ from the stored scores");
    }
    Ok(())
}

/// What a replay under another JAX env than the cell's says to do.
const JAX_REPLAY_REFUSED: &str = "a JAX cell is replayed under the JAX, env library, kind of \
    device, precisions and lanes its blocks were computed under (other ones may give other \
    bits): run the replay where they are the same";

/// `rwg replay` of a JAX env's cell: the network's episodes by the cell's
/// compiled program, through a worker of the cell's env.
fn replay_jax(args: &Args, m: &Manifest, cell: &Cell, j: &rwg_jax::JaxSource) -> Result<()> {
    let policy = cell.plan.policy(&cell.spec, args.sample);
    write_export(args, cell, &policy, m.episodes)?;
    if args.episode.is_some() {
        bail!(
            "{}: a JAX env runs its episodes whole in compiled calls, so they are not shown \
             step by step; without --episode, rwg replay runs the network's episodes through a \
             JAX worker and compares their returns with the stored ones",
            cell.id.env
        );
    }
    let dir = rundir::cell_dir(&args.run_dir, &cell.id.dir);
    check_record(&dir, &cell.env_record(), JAX_REPLAY_REFUSED)?;
    let stored = stored_scores(&args.run_dir, &cell.id.dir, args.sample)?;
    let mut results: Vec<EpisodeResult> = vec![];
    let network = args.sample..args.sample + 1;
    j.run_blocks(&cell.plan, &[network], 1, |b: BlockResult| {
        results = b.episodes;
        Ok::<(), rwg_jax::RunError>(())
    })?;
    if results.len() != m.episodes as usize {
        bail!(
            "the JAX worker returned {} episodes of network {}, not {}",
            results.len(),
            args.sample,
            m.episodes
        );
    }
    let stdout = crate::stdio::stdout();
    let mut out = BufWriter::new(stdout.lock());
    compare_episodes(&mut out, cell, args.sample, m.episodes, &stored, |e, _| {
        Ok(results[e as usize])
    })
}
