//! `rwg bench envs --plugin`: raw step throughput of a plugin's
//! environments, each compared with the built-in env it re-exports, if any.

use super::envs::{env_cells, EnvBench, EnvsArgs, VsBuiltin, ENV_COLUMNS};
use super::print_row;
use anyhow::{bail, Context, Result};
use rwg_envs::{visit, EnvOptions};

/// `rwg bench envs --plugin`: the plugins' envs, each compared with the
/// built-in env it re-exports, if any.
pub(super) fn run(args: EnvsArgs) -> Result<()> {
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
