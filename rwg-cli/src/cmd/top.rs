//! `rwg top`: the best networks of each cell, with the command that replays each.

use anyhow::Result;
use rwg_analysis::table::{Align, TextColumns};
use rwg_env::float::fmt_f64;
use rwg_study::rundir::data::Run;
use rwg_study::shell::{sh_path, sh_quote};
use std::io::Write;
use std::path::PathBuf;

/// Arguments of `rwg top`.
#[derive(clap::Args)]
pub struct Args {
    /// Run directory.
    run_dir: PathBuf,
    /// Networks per cell (at least 1).
    #[arg(short = 'n', default_value_t = 10, value_parser = parse_n)]
    n: usize,
}

/// Parses `-n`: a whole number of networks, at least 1.
fn parse_n(s: &str) -> Result<usize, String> {
    match s.trim().parse::<usize>() {
        Ok(0) => Err("the networks shown per cell must be at least 1, got 0".into()),
        Ok(n) => Ok(n),
        Err(_) => Err(format!(
            "expected a whole number of networks (such as 10), found `{s}`"
        )),
    }
}

/// Runs `rwg top`.
pub fn run(args: Args) -> Result<()> {
    rwg_study::rundir::data::require_run_dir(&args.run_dir)?;
    let run_dir = Run::open(&args.run_dir)?;
    crate::cmd::warn_unverified(&run_dir);
    if let Some(progress) = run_dir.unfinished() {
        crate::errln!(
            "note: {} is a run {progress}: the best networks of the finished cells only",
            args.run_dir.display()
        );
    }
    let run = sh_path(&args.run_dir);
    // (a jax: env of the user's: the PYTHONPATH its module was found
    // through; rwg replay plans every cell, so any cell's)
    let pythonpath = rwg_study::rundir::env_record::recorded_pythonpath(&args.run_dir);
    let stdout = crate::stdio::stdout();
    let mut out = std::io::BufWriter::new(stdout.lock());
    for cell in &run_dir.meta.cells {
        let mut rows: Vec<(u64, f64, f64, f64, f64)> = run_dir
            .load_samples(cell)?
            .iter()
            .map(|r| {
                (
                    r.sample,
                    r.stats.mean,
                    r.stats.std,
                    r.stats.min,
                    r.stats.max,
                )
            })
            .collect();
        // best first; ties keep sample order
        rows.sort_by(|a, b| b.1.total_cmp(&a.1).then(a.0.cmp(&b.0)));
        writeln!(
            out,
            "{} (solved at {})",
            cell.id.dir,
            cell.solved.map_or("-".into(), fmt_f64)
        )?;
        let columns = TextColumns::new(
            &[
                (8, Align::Right),
                (12, Align::Right),
                (10, Align::Right),
                (10, Align::Right),
                (10, Align::Right),
            ],
            " ",
        );
        writeln!(
            out,
            "  {}  replay",
            columns.line(&["sample", "mean", "std", "min", "max"])
        )?;
        for (s, mean, std, min, max) in rows.iter().take(args.n) {
            let values = [
                s.to_string(),
                format!("{mean:.3}"),
                format!("{std:.3}"),
                format!("{min:.3}"),
                format!("{max:.3}"),
            ];
            let replay = format!(
                "rwg replay {run} --env {} --arch {} --bias {} --sample {s}",
                sh_quote(&cell.id.env),
                sh_quote(&cell.id.arch),
                cell.id.bias
            );
            let replay = rwg_study::shell::with_pythonpath(pythonpath.as_deref(), replay);
            writeln!(out, "  {}  {replay}", columns.line(&values))?;
        }
    }
    out.flush()?;
    Ok(())
}
