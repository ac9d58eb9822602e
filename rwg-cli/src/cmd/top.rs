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

/// `x` with 3 decimals, in scientific notation from 8 digits before the
/// point on (returns reach ±1e100).
fn fixed(x: f64) -> String {
    if x.abs() >= 1e7 {
        format!("{x:.3e}")
    } else {
        format!("{x:.3}")
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
        let samples = run_dir.load_samples(cell)?;
        let flagged = samples.iter().any(|r| r.non_finite.is_some());
        let mut rows: Vec<(u64, f64, f64, f64, f64, u32)> = samples
            .iter()
            .map(|r| {
                (
                    r.sample,
                    r.stats.mean,
                    r.stats.std,
                    r.stats.min,
                    r.stats.max,
                    r.non_finite.unwrap_or(0),
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
        let mut widths = vec![
            (8, Align::Right),
            (12, Align::Right),
            (10, Align::Right),
            (10, Align::Right),
            (10, Align::Right),
        ];
        let mut names = vec!["sample", "mean", "std", "min", "max"];
        if flagged {
            // the network's episodes a value not finite ended (non_finite = "end")
            widths.push((10, Align::Right));
            names.push("non-finite");
        }
        let columns = TextColumns::new(&widths, " ");
        writeln!(out, "  {}  replay", columns.line(&names))?;
        for (s, mean, std, min, max, cut) in rows.iter().take(args.n) {
            let mut values = vec![
                s.to_string(),
                fixed(*mean),
                fixed(*std),
                fixed(*min),
                fixed(*max),
            ];
            if flagged {
                values.push(cut.to_string());
            }
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
