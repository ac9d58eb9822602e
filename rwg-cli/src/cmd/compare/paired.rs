//! `rwg compare --paired ENV_A ENV_B`: two implementations of one benchmark,
//! network by network ([`rwg_analysis::paired`]).

use super::{image_format, write, Args};
use crate::cmd::stats::Format;
use anyhow::{bail, Result};
use rwg_analysis::paired::{
    cell_pairs, pair_differences, paired_comparison, paired_csv, paired_figure, paired_table,
    PairSide,
};
use rwg_study::rundir::data::Run;

/// What `--paired` refuses beside it.
fn refuse_run_outputs(args: &Args) -> Result<()> {
    for (given, flag) in [
        (args.ranking_figure.is_some(), "--ranking-figure"),
        (args.html.is_some(), "--html"),
    ] {
        if given {
            bail!(
                "{flag} belongs to the comparison of whole runs, not to --paired (which writes \
                 its table, --format csv or json, and --figure)"
            );
        }
    }
    if args.run_dirs.len() > 2 {
        bail!(
            "--paired compares two envs: give one run (ENV_A and ENV_B both in it) or two runs \
             (ENV_A in the first, ENV_B in the second), not {}",
            args.run_dirs.len()
        );
    }
    Ok(())
}

/// The cells of `env` in `run`, read, as one side of the comparison.
fn side(run: &Run, label: &str, env: &str) -> Result<PairSide> {
    let metas: Vec<_> = run.meta.cells.iter().filter(|c| c.id.env == env).collect();
    if metas.is_empty() {
        let mut envs: Vec<&str> = run.meta.cells.iter().map(|c| c.id.env.as_str()).collect();
        envs.dedup();
        let unfinished = run.unfinished().map_or_else(String::new, |p| {
            format!(
                " (the run is {p}: `rwg status {}` shows how far it got)",
                rwg_study::shell::sh_path(&run.dir)
            )
        });
        bail!(
            "{label} has no finished cell of {env}{unfinished}; its envs: {}",
            if envs.is_empty() {
                "none yet".to_string()
            } else {
                envs.join(", ")
            }
        );
    }
    if let Some(p) = run.unfinished() {
        crate::errln!(
            "warning: {label} is a run {p}: only its finished cells of {env} are compared"
        );
    }
    let cells = metas
        .into_iter()
        .map(|c| run.load_cell(c))
        .collect::<Result<_, _>>()?;
    Ok(PairSide {
        run: label.to_string(),
        meta: run.meta.clone(),
        env: env.to_string(),
        cells,
    })
}

/// Runs `rwg compare --paired`: `runs` are the opened runs with their
/// labels, `envs` the two env ids.
pub fn run(args: &Args, runs: &[Run], labels: &[String], envs: &[String]) -> Result<()> {
    refuse_run_outputs(args)?;
    let (ea, eb) = (&envs[0], &envs[1]);
    let (ra, la) = (&runs[0], &labels[0]);
    let (rb, lb) = if runs.len() == 2 {
        (&runs[1], &labels[1])
    } else {
        (ra, la)
    };
    if runs.len() == 1 && ea == eb {
        bail!(
            "--paired {ea} {ea} compares {ea} of {la} with itself; name two envs, or give two runs"
        );
    }
    let a = side(ra, la, ea)?;
    let b = side(rb, lb, eb)?;
    let diffs: Vec<String> = cell_pairs(&a, &b)
        .into_iter()
        .flat_map(pair_differences)
        .collect();
    if !diffs.is_empty() {
        let list: String = diffs.iter().map(|d| format!("\n  - {d}")).collect();
        if !args.force {
            bail!("these cells are not comparable:{list}\n(use --force to compare them anyway)");
        }
        crate::errln!("warning: comparing cells whose settings differ (--force):{list}");
    }
    let c = paired_comparison(&a, &b)?;
    match args.format.table_format() {
        Some(f) => crate::out!("{}", paired_table(&c).render(f)),
        None if args.format == Format::Csv => crate::out!("{}", paired_csv(&c)),
        None => crate::outln!("{}", serde_json::to_string_pretty(&c)?),
    }
    if let Some(path) = &args.figure {
        write(path, &paired_figure(&a, &b, &c, image_format(path))?.bytes)?;
    }
    Ok(())
}
