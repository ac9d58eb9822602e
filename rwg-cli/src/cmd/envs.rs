//! `rwg envs`: list the environments.

use anyhow::Result;
use rwg_analysis::table::{Align, TextColumns};
use rwg_env::float::fmt_f64;
use rwg_envs::{make, EnvOptions, REGISTRY};
use rwg_plugin_host::{load_plugin, Plugin, PLUGIN_PATH_VAR};
use rwg_study::env_source::scan_plugin_path;
use serde::Serialize;
use std::io::Write;
use std::path::PathBuf;

/// Arguments of `rwg envs`.
#[derive(clap::Args)]
#[command(after_help = "\
Without --plugin: the built-in environments, then those of the plugins found in the
folders of RWG_PLUGIN_PATH (colon-separated, like PATH). Plugin files found there
but rejected (not loadable, an id already taken) are listed on stderr with the reason.

Examples:
  rwg envs
  rwg envs --plugin target/release/librwg_plugin_classic_control.so --json
  RWG_PLUGIN_PATH=target/release rwg envs
  rwg envs gymnasium:LunarLander-v3 gymnasium:InvertedPendulum-v5
  rwg envs gymnasium:LunarLander-v3 --kwargs '{\"continuous\": true}' --json

A gymnasium: id is described by Gymnasium itself (a Python worker is started):
its spaces as rwg sees them (flattened), its registered time limit and reward
threshold; --json adds Gymnasium's own text of the spaces and the Gymnasium and
Python versions. A JAX id (gymnax:ID, brax:NAME, playground:NAME, jumanji:ID,
craftax:NAME, navix:ID, xminigrid:ID, pgx:ID, jax:module:callable) is described
by a JAX worker: its spaces (an observation's leaves, in the order they are
flattened), time limit, legal-action mask, the versions of JAX and the env's
library, and the device JAX runs it on.")]
pub struct Args {
    /// Describe these gymnasium: envs (gymnasium:ID or gymnasium:module:ID)
    /// or JAX envs (gymnax:ID, brax:NAME, playground:NAME, jumanji:ID, ...,
    /// jax:module:callable) instead of
    /// listing the built-in and plugin ones.
    ids: Vec<String>,
    #[command(flatten)]
    gym: crate::gym::GymArgs,
    /// Print a JSON array instead of a table.
    #[arg(long)]
    json: bool,
    /// List only the environments of this plugin library (repeatable).
    #[arg(long, value_name = "LIBRARY")]
    plugin: Vec<PathBuf>,
}

#[derive(Serialize)]
struct Row {
    #[serde(flatten)]
    spec: rwg_env::EnvSpec,
    summary: String,
    /// Whether `--action-dtype` changes the env's arithmetic.
    action_dtype_sensitive: bool,
    /// The plugin library providing the env (`null`: built in).
    plugin: Option<PathBuf>,
    /// For a gymnasium: env: what Gymnasium says about it.
    #[serde(skip_serializing_if = "Option::is_none")]
    gymnasium: Option<GymRow>,
    /// For a JAX env: what its worker says about it.
    #[serde(skip_serializing_if = "Option::is_none")]
    jax: Option<JaxRow>,
}

#[derive(Serialize)]
struct JaxRow {
    observation_space: String,
    action_space: String,
    obs_dim: usize,
    versions: std::collections::BTreeMap<String, String>,
    device: String,
    device_kind: String,
    platform: String,
    precision: &'static str,
    networks_per_call: u32,
    observation_leaves: Vec<rwg_jax::protocol::Leaf>,
    action_mask: String,
    settings: std::collections::BTreeMap<String, String>,
    python: String,
}

/// A JAX env's row, from a worker started for it.
fn jax_row(id: &str, gym: &crate::gym::GymArgs) -> Result<Row> {
    let cfg = gym.jax_config(id)?;
    let python = cfg.python.clone();
    let src = rwg_jax::JaxSource::open(cfg).map_err(|e| anyhow::anyhow!("{id}: {e}"))?;
    let info = src.info().clone();
    Ok(Row {
        summary: format!("{} -> {}", info.observation_space, info.action_space),
        action_dtype_sensitive: false,
        plugin: None,
        gymnasium: None,
        jax: Some(JaxRow {
            observation_space: info.observation_space,
            action_space: info.action_space,
            obs_dim: info.spec.obs_dim(),
            versions: info.versions,
            device: info.device,
            device_kind: info.device_kind,
            platform: info.platform,
            precision: info.precision.name(),
            networks_per_call: src.networks_per_call(),
            observation_leaves: info.observation_leaves,
            action_mask: info.action_mask,
            settings: info.settings,
            python,
        }),
        spec: info.spec,
    })
}

/// What is printed below the table about a JAX env: its library's spaces,
/// versions and device.
fn jax_lines(id: &str, j: &JaxRow) -> String {
    let mut versions: Vec<String> = j
        .versions
        .iter()
        .filter(|(k, _)| *k != "python")
        .map(|(k, v)| format!("{k} {v}"))
        .collect();
    if let Some(p) = j.versions.get("python") {
        versions.push(format!("Python {p} ({})", j.python));
    }
    format!(
        "\n{id}\n  observation: {} ({} values)\n  action: {} (legal-action mask: {})\n  \
         versions: {}\n  device: {} ({}, platform {}), {}, {} networks per call",
        j.observation_space,
        j.obs_dim,
        j.action_space,
        j.action_mask,
        versions.join(", "),
        j.device,
        j.device_kind,
        j.platform,
        j.precision,
        j.networks_per_call
    )
}

#[derive(Serialize)]
struct GymRow {
    observation_space: String,
    action_space: String,
    obs_dim: usize,
    gymnasium_version: String,
    python_version: String,
    python: String,
}

fn plugin_rows(p: &Plugin) -> impl Iterator<Item = Row> + '_ {
    p.envs().iter().map(|ty| Row {
        spec: ty.spec().clone(),
        summary: ty.summary().to_string(),
        action_dtype_sensitive: false,
        plugin: Some(ty.plugin().path.clone()),
        gymnasium: None,
        jax: None,
    })
}

/// Runs `rwg envs`.
pub fn run(args: Args) -> Result<()> {
    let rows = if !args.ids.is_empty() {
        args.ids
            .iter()
            .map(|id| described_row(id, &args.gym))
            .collect::<Result<Vec<Row>>>()?
    } else if args.plugin.is_empty() {
        listed_rows()
    } else {
        let mut rows = vec![];
        for path in &args.plugin {
            rows.extend(plugin_rows(&load_plugin(path)?));
        }
        rows
    };
    if args.json {
        writeln!(
            crate::stdio::stdout(),
            "{}",
            serde_json::to_string_pretty(&rows)?
        )?;
        return Ok(());
    }
    print_table(&rows)
}

/// The row of a gymnasium: or JAX env given by id (refused for others).
fn described_row(id: &str, gym: &crate::gym::GymArgs) -> Result<Row> {
    if rwg_jax::jax_id(id).is_some() {
        return jax_row(id, gym);
    }
    if !crate::gym::is_gym(id) {
        anyhow::bail!(
            "'{id}': only gymnasium: and JAX ({}) ids are described one by one (rwg envs \
             lists the others)",
            rwg_jax::id_forms()
        );
    }
    let cfg = gym.config(id)?;
    let env = rwg_gym::make_single(&cfg).map_err(|e| anyhow::anyhow!("{id}: {e}"))?;
    let info = env.inner().info().clone();
    Ok(Row {
        summary: format!("{} -> {}", info.observation_space, info.action_space),
        action_dtype_sensitive: false,
        plugin: None,
        gymnasium: Some(GymRow {
            observation_space: info.observation_space.clone(),
            action_space: info.action_space.clone(),
            obs_dim: info.spec.obs_dim(),
            gymnasium_version: info.gymnasium.clone(),
            python_version: info.python.clone(),
            python: cfg.python.clone(),
        }),
        jax: None,
        spec: info.spec,
    })
}

/// The built-in envs and those of the plugins on RWG_PLUGIN_PATH (the
/// files it rejects told on stderr).
fn listed_rows() -> Vec<Row> {
    let mut rows: Vec<Row> = REGISTRY
        .iter()
        .map(|r| Row {
            spec: make(r.id, &EnvOptions::default())
                .expect("registered env")
                .spec()
                .clone(),
            summary: r.summary.to_string(),
            action_dtype_sensitive: r.dtype_sensitive,
            plugin: None,
            gymnasium: None,
            jax: None,
        })
        .collect();
    let scan = scan_plugin_path();
    for p in &scan.plugins {
        rows.extend(plugin_rows(p));
    }
    if !scan.rejected.is_empty() {
        crate::errln!("rejected on {PLUGIN_PATH_VAR}:");
        for r in &scan.rejected {
            crate::errln!("  {r}");
        }
    }
    rows
}

/// Prints the table of envs (with a plugin column if one is a plugin's),
/// then the JAX envs' details.
fn print_table(rows: &[Row]) -> Result<()> {
    let jax_lines: Vec<String> = rows
        .iter()
        .filter_map(|r| r.jax.as_ref().map(|j| jax_lines(&r.spec.id, j)))
        .collect();
    let with_plugins = rows.iter().any(|r| r.plugin.is_some());
    let table: Vec<Vec<String>> = rows.iter().map(|r| table_cells(r, with_plugins)).collect();
    let mut header = vec!["id", "observation", "action", "time limit", "solved at"];
    if with_plugins {
        header.push("plugin");
    }
    let rows: Vec<Vec<&str>> = table
        .iter()
        .map(|r| r.iter().map(String::as_str).collect())
        .collect();
    let columns = TextColumns::fit(&header, &rows, |_| Align::Left, "  ");
    // (writeln, not println: `rwg envs | head` must not panic.)
    let mut out = crate::stdio::stdout().lock();
    writeln!(out, "{}", columns.line(&header))?;
    for row in &rows {
        writeln!(out, "{}", columns.line(row))?;
    }
    for line in &jax_lines {
        writeln!(out, "{line}")?;
    }
    Ok(())
}

/// The cells of one env's line of the table.
fn table_cells(r: &Row, with_plugins: bool) -> Vec<String> {
    let mut cells = vec![
        r.spec.id.clone(),
        r.spec.observation_space.short(),
        r.spec.action_space.short(),
        r.spec
            .max_episode_steps
            .map_or("-".into(), |m| m.to_string()),
        r.spec.reward_threshold.map_or("-".into(), fmt_f64),
    ];
    if with_plugins {
        cells.push(
            r.plugin
                .as_ref()
                .map_or("(built in)".into(), |p| p.display().to_string()),
        );
    }
    cells
}
