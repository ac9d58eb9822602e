//! `rwg rollout`: one episode with given actions, printed step by step.

use crate::step_lines::StepLines;
use anyhow::{bail, Context, Result};
use rwg_env::{Action, ActionDtype, Environment, Space};
use rwg_envs::{make, EnvOptions};
use rwg_study::env_source::{describe, Found, Plugins};
use std::io::{BufWriter, Write};
use std::path::PathBuf;

/// Arguments of `rwg rollout`.
#[derive(clap::Args)]
#[command(after_help = "\
Actions: steps are separated by commas (--actions) or newlines (--actions-file); \
the components of a vector action inside one step by spaces. Discrete actions are \
integers. Continuous actions are clipped to the action space exactly as Gymnasium \
clips them.

Output: the first line (step 0) is the observation after reset; then one line per \
step with the action, observation, reward, terminated and truncated. Floats are \
printed in shortest round-trip form. The rollout stops when the episode ends or the \
actions run out.

Examples:
  rwg rollout CartPole-v0 --seed 3 --actions 0,1,1,0
  rwg rollout Pendulum-v1 --seed 4 --actions 0.5,-2.5 --action-dtype float32
  rwg rollout Pendulum-v0 --state 3.0,0.5 --actions-file examples/actions.txt --format csv
  RWG_PLUGIN_PATH=target/release rwg rollout example/PointMass-v0 --actions \"0.5 -0.5,1 0\"
  rwg rollout gymnasium:LunarLanderContinuous-v3 --seed 1 --actions \"0.5 -0.5,1 0\"")]
pub struct Args {
    /// Environment id (see `rwg envs`).
    env: String,
    /// Reset seed, as in Gymnasium's `env.reset(seed=SEED)`.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Start from this internal state (comma-separated, Gymnasium's
    /// `env.unwrapped.state` order) instead of a seeded reset.
    #[arg(long, value_name = "X,Y,...", allow_hyphen_values = true)]
    state: Option<String>,
    /// Actions, one per step, separated by commas.
    #[arg(
        long,
        value_name = "A,A,...",
        allow_hyphen_values = true,
        conflicts_with = "actions_file"
    )]
    actions: Option<String>,
    /// File with one action per line (blank lines and lines starting with # are skipped).
    #[arg(long, value_name = "FILE")]
    actions_file: Option<PathBuf>,
    /// dtype of the continuous action array, as handed to Gymnasium's `step()`.
    #[arg(long, value_name = "DTYPE", default_value = "float64",
          value_parser = ["float64", "float32"])]
    action_dtype: String,
    /// Override the registered time limit.
    #[arg(long, value_name = "N")]
    max_episode_steps: Option<u32>,
    /// Plugin library providing ENV (otherwise ENV is built in, or found on
    /// RWG_PLUGIN_PATH).
    #[arg(long, value_name = "FILE")]
    plugin: Option<PathBuf>,
    /// Configuration string handed to the plugin's `create` (plugin envs only:
    /// from --plugin or found on RWG_PLUGIN_PATH).
    #[arg(long, value_name = "TEXT")]
    config: Option<String>,
    /// Output format.
    #[arg(long, default_value = "jsonl", value_parser = ["jsonl", "csv"])]
    format: String,
    #[command(flatten)]
    gym: crate::gym::GymArgs,
}

/// One parsed action: where it came from, and its components.
struct ParsedAction {
    origin: String,
    values: Vec<f64>,
    discrete: Option<i64>,
}

/// Splits the action text into steps, each with a description of where it
/// stands (for error messages).
fn action_texts(args: &Args) -> Result<Vec<(String, String)>> {
    if let Some(path) = &args.actions_file {
        let text =
            rwg_study::limits::read_bounded_text(path, rwg_study::limits::MAX_ACTIONS_FILE_BYTES)
                .with_context(|| format!("cannot read actions file {}", path.display()))?;
        Ok(text
            .lines()
            .enumerate()
            .filter(|(_, l)| !l.trim().is_empty() && !l.trim_start().starts_with('#'))
            .map(|(i, l)| {
                (
                    format!("{}:{}", path.display(), i + 1),
                    l.trim().to_string(),
                )
            })
            .collect())
    } else if let Some(list) = &args.actions {
        if list.trim().is_empty() {
            return Ok(vec![]);
        }
        Ok(list
            .split(',')
            .enumerate()
            .map(|(i, a)| (format!("--actions item {}", i + 1), a.trim().to_string()))
            .collect())
    } else {
        Ok(vec![])
    }
}

fn parse_actions(args: &Args, space: &Space) -> Result<Vec<ParsedAction>> {
    let mut out = vec![];
    for (step, (origin, text)) in action_texts(args)?.into_iter().enumerate() {
        let step = step + 1;
        let where_ = format!("{origin} (step {step})");
        match space {
            Space::Discrete { n } => {
                let a: i64 = text.parse().map_err(|_| {
                    anyhow::anyhow!(
                        "{where_}: '{text}' is not an integer action (Discrete({n}) takes 0..={})",
                        n - 1
                    )
                })?;
                out.push(ParsedAction {
                    origin: where_,
                    values: vec![a as f64],
                    discrete: Some(a),
                });
            }
            Space::Box(b) => {
                let parts: Vec<&str> = text
                    .split(|c: char| c.is_whitespace() || c == ',')
                    .filter(|s| !s.is_empty())
                    .collect();
                let values = parts
                    .iter()
                    .map(|p| p.parse::<f64>())
                    .collect::<Result<Vec<f64>, _>>()
                    .map_err(|_| anyhow::anyhow!("{where_}: '{text}' is not a number"))?;
                if values.len() != b.dim() {
                    bail!(
                        "{where_}: '{text}' has {} values, the action space has {}",
                        values.len(),
                        b.dim()
                    );
                }
                out.push(ParsedAction {
                    origin: where_,
                    values,
                    discrete: None,
                });
            }
        }
    }
    Ok(out)
}

fn parse_state(text: &str) -> Result<Vec<f64>> {
    text.split(',')
        .map(|p| {
            p.trim()
                .parse::<f64>()
                .map_err(|_| anyhow::anyhow!("--state: '{}' is not a number", p.trim()))
        })
        .collect()
}

/// The env to roll out: from `--plugin`, built in, or on `RWG_PLUGIN_PATH`.
fn make_env(args: &Args, opts: &EnvOptions) -> Result<Box<dyn Environment + Send>> {
    let plugin_env = |ty: &rwg_plugin_host::PluginEnvType| -> Result<Box<dyn Environment + Send>> {
        let env = ty
            .make(args.config.as_deref().unwrap_or(""), args.max_episode_steps)
            .with_context(|| format!("cannot create {} from {}", args.env, describe(ty)))?;
        Ok(Box::new(env))
    };
    if crate::gym::is_gym(&args.env) {
        let mut cfg = args.gym.config(&args.env)?;
        cfg.max_episode_steps = args.max_episode_steps;
        cfg.action_dtype = opts.action_dtype;
        return Ok(Box::new(rwg_gym::make_single(&cfg)?));
    }
    crate::gym::refuse_jax(&args.env, "rwg rollout")?;
    args.gym.refuse_for(&args.env)?;
    let mut plugins = Plugins::default();
    if let Some(path) = &args.plugin {
        let p = plugins.file(path).map_err(|e| anyhow::anyhow!("{e}"))?;
        let Some(ty) = p.env(&args.env) else {
            let ids: Vec<&str> = p.envs().iter().map(|e| e.id()).collect();
            bail!(
                "{} has no environment '{}'; it has: {}",
                path.display(),
                args.env,
                ids.join(", ")
            );
        };
        return plugin_env(ty);
    }
    match plugins.find(&args.env) {
        Found::Builtin if args.config.is_some() => bail!(
            "--config is for plugin envs: {} is built in and takes no configuration",
            args.env
        ),
        Found::Builtin => Ok(make(&args.env, opts)?),
        Found::OnPath(ty) => plugin_env(&ty),
        Found::Unknown(msg) => bail!(msg),
    }
}

/// Runs `rwg rollout`.
pub fn run(args: Args) -> Result<()> {
    let dtype: ActionDtype = args.action_dtype.parse().map_err(anyhow::Error::msg)?;
    if let Some(t) = args.max_episode_steps {
        use rwg_study::limits::{in_range, MAX_EPISODE_STEPS};
        in_range("max-episode-steps", t, 1, MAX_EPISODE_STEPS)
            .map_err(|m| anyhow::anyhow!("--{m}"))?;
    }
    let opts = EnvOptions {
        action_dtype: dtype,
        max_episode_steps: args.max_episode_steps,
    };
    let mut env = make_env(&args, &opts)?;
    let spec = env.spec().clone();
    let actions = parse_actions(&args, &spec.action_space)?;

    let mut obs = vec![0.0; spec.obs_dim()];
    match &args.state {
        Some(text) => {
            let state = parse_state(text)?;
            if env.state_len() == 0 {
                bail!(
                    "--state: {} does not expose its internal state (plugin environments \
                     cannot start from a given state in ABI v1); use --seed",
                    spec.id
                );
            }
            if state.len() != env.state_len() {
                bail!(
                    "--state has {} values; {} expects {} (its internal state, in Gymnasium's order)",
                    state.len(),
                    spec.id,
                    env.state_len()
                );
            }
            env.set_state(&state, &mut obs)
                .with_context(|| format!("--state for {}", spec.id))?;
        }
        None => env.reset(args.seed, &mut obs)?,
    }

    let stdout = crate::stdio::stdout();
    let mut out = BufWriter::new(stdout.lock());
    let lines = StepLines::new(&args.format, spec.action_space.flat_dim(), obs.len());
    lines.header(&mut out)?;
    lines.reset(&mut out, &obs)?;
    for (i, a) in actions.iter().enumerate() {
        let action = match a.discrete {
            Some(d) => Action::Discrete(d),
            None => Action::Continuous(&a.values),
        };
        let s = env
            .step(action, &mut obs)
            .with_context(|| a.origin.clone())?;
        lines.step(&mut out, i + 1, action, &obs, s)?;
        if s.terminated || s.truncated {
            break;
        }
    }
    out.flush()?;
    Ok(())
}
