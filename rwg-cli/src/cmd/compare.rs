//! `rwg compare`: envs from several runs side by side.

use super::stats::Format;
use anyhow::{bail, Result};
use rwg_analysis::compare::{
    compare_csv, compare_rows, compare_table, settings_differences, CompareRun,
};
use rwg_analysis::compare_page::compare_html;
use rwg_analysis::plot::{profiles_figure, ranking_figure, ImageFormat};
use rwg_analysis::ranking::ranking_table;
use rwg_study::rundir::data::Run;
use rwg_study::rundir::lock::RunLock;
use rwg_study::rundir::outputs::{resolve, Output, OutputKind};
use std::path::PathBuf;

mod paired;

/// Arguments of `rwg compare`.
#[derive(clap::Args)]
#[command(after_help = "\
Examples:
  rwg compare runs/quick runs/quick-seed1 --html compare.html
  rwg compare runs/quick runs/quick-seed1 --paired CartPole-v0 CartPole-v0 --format csv")]
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
    /// Also write the profiles figure (one panel per architecture: each env's
    /// fraction of networks reaching a normalised score, the first run grey)
    /// to this file: SVG, or PNG if the name ends in `.png`. With --paired,
    /// the paired figure (each network's two means; the two CDFs).
    #[arg(long, value_name = "FILE")]
    figure: Option<PathBuf>,
    /// Also write the difficulty-ranking figure to this file: SVG, or PNG if
    /// the name ends in `.png`.
    #[arg(long, value_name = "FILE")]
    ranking_figure: Option<PathBuf>,
    /// Also write a self-contained HTML page: the ranking, the figures, every
    /// cell and the runs' metadata.
    #[arg(long, value_name = "FILE")]
    html: Option<PathBuf>,
    /// Compare two implementations of one benchmark network by network: env
    /// ENV_A against env ENV_B, both of the one run given, or ENV_A of the
    /// first run and ENV_B of the second. One row per architecture and bias
    /// setting: p(solved) of each, the networks solved in both or one only,
    /// the rank correlation of the networks' means, a KS test of their
    /// distributions, McNemar's test of the solved flags, and a verdict
    /// (docs/guide.md, "Two implementations of one benchmark").
    #[arg(long, num_args = 2, value_names = ["ENV_A", "ENV_B"])]
    paired: Option<Vec<String>>,
}

fn image_format(path: &std::path::Path) -> ImageFormat {
    if path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("png"))
    {
        ImageFormat::Png
    } else {
        ImageFormat::Svg
    }
}

/// Writes an output file whole or not at all (nothing half-written is left
/// on a full disk).
fn write(path: &std::path::Path, bytes: &[u8]) -> Result<()> {
    crate::cmd::write_named_file(path, bytes)?;
    crate::errln!("wrote {}", path.display());
    Ok(())
}

/// Refuses a run directory given twice (under one name or two): its rows
/// would be listed twice, as if two runs agreed.
fn refuse_twice(dirs: &[PathBuf]) -> Result<()> {
    let key = |d: &PathBuf| std::fs::canonicalize(d).unwrap_or_else(|_| d.clone());
    for (i, d) in dirs.iter().enumerate() {
        if let Some(prev) = dirs[..i].iter().find(|p| key(p) == key(d)) {
            bail!(
                "{} is given twice{}: a run compared with itself lists every row twice; name \
                 each run once",
                d.display(),
                if prev == d {
                    String::new()
                } else {
                    format!(" (also as {})", prev.display())
                }
            );
        }
    }
    Ok(())
}

/// The files `--figure`, `--ranking-figure` and `--html` name, each checked
/// against the run directories around it ([`crate::cmd::claim_output`]) and
/// against the others (one file named twice would keep only the last).
/// Returns the locks of the runs they are written into.
fn claim_outputs(args: &Args) -> Result<Vec<RunLock>> {
    let named = [
        ("--figure", &args.figure),
        ("--ranking-figure", &args.ranking_figure),
        ("--html", &args.html),
    ];
    let mut seen: Vec<(&str, PathBuf)> = vec![];
    let mut locks = vec![];
    for (flag, path) in named {
        let Some(path) = path else { continue };
        let key = resolve(path).unwrap_or_else(|_| path.clone());
        if let Some((other, _)) = seen.iter().find(|(_, k)| *k == key) {
            bail!(
                "{flag} and {other} name the same file, {}: the one written last would \
                 replace the other; name two files",
                path.display()
            );
        }
        seen.push((flag, key));
        let elsewhere = format!("{flag} FILE outside the run writes it now");
        let output = Output::new(path, OutputKind::File);
        locks.extend(crate::cmd::claim_output(output, &elsewhere)?);
    }
    Ok(locks)
}

/// The runs' labels in tables and legends: their directory names, or their
/// paths where two names are alike.
fn labels(dirs: &[PathBuf], names: Vec<String>) -> Vec<String> {
    let unique = names
        .iter()
        .enumerate()
        .all(|(i, n)| !names[..i].contains(n));
    if unique {
        names
    } else {
        dirs.iter().map(|d| d.display().to_string()).collect()
    }
}

/// Runs `rwg compare`.
pub fn run(args: Args) -> Result<()> {
    refuse_twice(&args.run_dirs)?;
    let _locks = claim_outputs(&args)?;
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
    let labels = labels(&args.run_dirs, names);
    if let Some(envs) = &args.paired {
        return paired::run(&args, &runs, &labels, envs);
    }
    let metas: Vec<(&str, &rwg_study::rundir::meta::RunMeta)> = labels
        .iter()
        .zip(&runs)
        .map(|(l, r)| (l.as_str(), &r.meta))
        .collect();
    let mut diffs = settings_differences(&metas);
    // A run not finished has only some of its cells: compared, they would
    // pass for the whole run.
    for (label, run) in labels.iter().zip(&runs) {
        if let Some(progress) = run.unfinished() {
            diffs.push(format!(
                "{label} is a run {progress} (`rwg status {}` shows how far it got)",
                rwg_study::shell::sh_path(&run.dir)
            ));
        }
    }
    if !diffs.is_empty() {
        let list: String = diffs.iter().map(|d| format!("\n  - {d}")).collect();
        if !args.force {
            bail!("these runs are not comparable:{list}\n(use --force to compare them anyway)");
        }
        crate::errln!("warning: comparing runs whose settings differ (--force):{list}");
    }
    let mut inputs = Vec::new();
    for (label, run) in labels.iter().zip(&runs) {
        let cells = rwg_analysis::load_cells(run)?;
        inputs.push(CompareRun::new(label.clone(), run, &cells));
    }
    let rows = compare_rows(&inputs);
    match args.format.table_format() {
        Some(f) => crate::out!(
            "{}\n{}",
            compare_table(&rows).render(f),
            ranking_table(&rows).render(f)
        ),
        None if args.format == Format::Csv => crate::out!("{}", compare_csv(&rows)),
        None => crate::outln!("{}", serde_json::to_string_pretty(&rows)?),
    }
    if let Some(path) = &args.figure {
        write(path, &profiles_figure(&inputs, image_format(path))?.bytes)?;
    }
    if let Some(path) = &args.ranking_figure {
        write(
            path,
            &ranking_figure(&inputs, &rows, image_format(path))?.bytes,
        )?;
    }
    if let Some(path) = &args.html {
        let figures = [
            ranking_figure(&inputs, &rows, ImageFormat::Svg)?,
            profiles_figure(&inputs, ImageFormat::Svg)?,
        ];
        write(path, compare_html(&inputs, &rows, &figures).as_bytes())?;
    }
    Ok(())
}
