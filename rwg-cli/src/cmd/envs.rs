//! `rwg envs`: list the environments.

use anyhow::Result;
use rwg_core::float::fmt_f64;
use rwg_envs::{make, EnvOptions, REGISTRY};
use serde::Serialize;

/// Arguments of `rwg envs`.
#[derive(clap::Args)]
pub struct Args {
    /// Print a JSON array instead of a table.
    #[arg(long)]
    json: bool,
}

#[derive(Serialize)]
struct Row {
    #[serde(flatten)]
    spec: rwg_core::EnvSpec,
    summary: &'static str,
    /// Whether `--action-dtype` changes the env's arithmetic.
    action_dtype_sensitive: bool,
}

/// Runs `rwg envs`.
pub fn run(args: Args) -> Result<()> {
    let rows: Vec<Row> = REGISTRY
        .iter()
        .map(|r| Row {
            spec: make(r.id, &EnvOptions::default())
                .expect("registered env")
                .spec()
                .clone(),
            summary: r.summary,
            action_dtype_sensitive: r.dtype_sensitive,
        })
        .collect();
    if args.json {
        println!("{}", serde_json::to_string_pretty(&rows)?);
        return Ok(());
    }
    let table: Vec<[String; 5]> = rows
        .iter()
        .map(|r| {
            [
                r.spec.id.clone(),
                r.spec.observation_space.short(),
                r.spec.action_space.short(),
                r.spec
                    .max_episode_steps
                    .map_or("-".into(), |m| m.to_string()),
                r.spec.reward_threshold.map_or("-".into(), fmt_f64),
            ]
        })
        .collect();
    let header = ["id", "observation", "action", "time limit", "solved at"];
    let mut width = header.map(str::len);
    for row in &table {
        for (w, c) in width.iter_mut().zip(row) {
            *w = (*w).max(c.len());
        }
    }
    let line = |cells: [&str; 5]| {
        let parts: Vec<String> = cells
            .iter()
            .zip(width)
            .map(|(c, w)| format!("{c:<w$}"))
            .collect();
        println!("{}", parts.join("  ").trim_end());
    };
    line(header);
    for row in &table {
        line([&row[0], &row[1], &row[2], &row[3], &row[4]]);
    }
    Ok(())
}
