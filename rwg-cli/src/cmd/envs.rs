//! `rwg envs`: list the environments.

use anyhow::Result;
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
  RWG_PLUGIN_PATH=target/release rwg envs")]
pub struct Args {
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
}

fn plugin_rows(p: &Plugin) -> impl Iterator<Item = Row> + '_ {
    p.envs().iter().map(|ty| Row {
        spec: ty.spec().clone(),
        summary: ty.summary().to_string(),
        action_dtype_sensitive: false,
        plugin: Some(ty.plugin().path.clone()),
    })
}

/// Runs `rwg envs`.
pub fn run(args: Args) -> Result<()> {
    let mut rows: Vec<Row> = vec![];
    if args.plugin.is_empty() {
        rows.extend(REGISTRY.iter().map(|r| {
            Row {
                spec: make(r.id, &EnvOptions::default())
                    .expect("registered env")
                    .spec()
                    .clone(),
                summary: r.summary.to_string(),
                action_dtype_sensitive: r.dtype_sensitive,
                plugin: None,
            }
        }));
        let scan = scan_plugin_path();
        for p in &scan.plugins {
            rows.extend(plugin_rows(p));
        }
        if !scan.rejected.is_empty() {
            eprintln!("rejected on {PLUGIN_PATH_VAR}:");
            for r in &scan.rejected {
                eprintln!("  {r}");
            }
        }
    } else {
        for path in &args.plugin {
            rows.extend(plugin_rows(&load_plugin(path)?));
        }
    }
    if args.json {
        writeln!(
            crate::stdio::stdout(),
            "{}",
            serde_json::to_string_pretty(&rows)?
        )?;
        return Ok(());
    }
    let with_plugins = rows.iter().any(|r| r.plugin.is_some());
    let table: Vec<Vec<String>> = rows
        .iter()
        .map(|r| {
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
        })
        .collect();
    let mut header = vec!["id", "observation", "action", "time limit", "solved at"];
    if with_plugins {
        header.push("plugin");
    }
    let mut width: Vec<usize> = header.iter().map(|h| h.len()).collect();
    for row in &table {
        for (w, c) in width.iter_mut().zip(row) {
            *w = (*w).max(c.len());
        }
    }
    // (writeln, not println: `rwg envs | head` must not panic.)
    let mut out = crate::stdio::stdout().lock();
    let mut line = |cells: &[&str]| -> std::io::Result<()> {
        let parts: Vec<String> = cells
            .iter()
            .zip(&width)
            .map(|(c, w)| format!("{c:<w$}"))
            .collect();
        writeln!(out, "{}", parts.join("  ").trim_end())
    };
    line(&header)?;
    for row in &table {
        line(&row.iter().map(String::as_str).collect::<Vec<_>>())?;
    }
    Ok(())
}
