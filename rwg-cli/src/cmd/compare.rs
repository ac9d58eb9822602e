//! `rwg compare`: envs from several runs side by side.

use super::stats::Format;
use anyhow::{bail, Context, Result};
use rwg_analysis::compare::{
    compare_csv, compare_rows, compare_table, normalised_series, settings_differences, CompareRun,
};
use rwg_analysis::plot::{compare_figure, ImageFormat};
use rwg_study::rundir::data::Run;
use std::path::PathBuf;

/// Arguments of `rwg compare`.
#[derive(clap::Args)]
pub struct Args {
    /// Run directories, as written by `rwg run`.
    #[arg(required = true)]
    run_dirs: Vec<PathBuf>,
    /// Output format: a table, or every row as CSV or JSON.
    #[arg(long, value_enum, default_value_t = Format::Table)]
    format: Format,
    /// Compare runs even if their episodes, weight distribution or
    /// architectures differ.
    #[arg(long)]
    force: bool,
    /// Also write the combined figure (normalised-score curves of every cell)
    /// to this file: SVG, or PNG if the name ends in `.png`.
    #[arg(long, value_name = "FILE")]
    figure: Option<PathBuf>,
}

/// Runs `rwg compare`.
pub fn run(args: Args) -> Result<()> {
    let runs: Vec<Run> = args
        .run_dirs
        .iter()
        .map(Run::open)
        .collect::<Result<_, _>>()?;
    let names: Vec<String> = args
        .run_dirs
        .iter()
        .map(|d| {
            d.file_name().map_or_else(
                || d.display().to_string(),
                |n| n.to_string_lossy().into_owned(),
            )
        })
        .collect();
    let unique = names
        .iter()
        .enumerate()
        .all(|(i, n)| !names[..i].contains(n));
    let labels: Vec<String> = if unique {
        names
    } else {
        args.run_dirs
            .iter()
            .map(|d| d.display().to_string())
            .collect()
    };
    let metas: Vec<(&str, &rwg_study::rundir::meta::RunMeta)> = labels
        .iter()
        .zip(&runs)
        .map(|(l, r)| (l.as_str(), &r.meta))
        .collect();
    let diffs = settings_differences(&metas);
    if !diffs.is_empty() {
        let list: String = diffs.iter().map(|d| format!("\n  - {d}")).collect();
        if !args.force {
            bail!("these runs are not comparable:{list}\n(use --force to compare them anyway)");
        }
        eprintln!("warning: comparing runs whose settings differ (--force):{list}");
    }
    let mut inputs = Vec::new();
    for (label, run) in labels.iter().zip(&runs) {
        let cells = rwg_analysis::load_cells(run)?;
        inputs.push(CompareRun::new(label.clone(), run, &cells));
    }
    let rows = compare_rows(&inputs);
    match args.format.table_format() {
        Some(f) => crate::out!("{}", compare_table(&rows).render(f)),
        None if args.format == Format::Csv => crate::out!("{}", compare_csv(&rows)),
        None => crate::outln!("{}", serde_json::to_string_pretty(&rows)?),
    }
    if let Some(path) = args.figure {
        let png = path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("png"));
        let format = if png {
            ImageFormat::Png
        } else {
            ImageFormat::Svg
        };
        let fig = compare_figure(&normalised_series(&inputs), format)?;
        std::fs::write(&path, &fig.bytes)
            .with_context(|| format!("cannot write {}", path.display()))?;
        eprintln!("wrote {}", path.display());
    }
    Ok(())
}
