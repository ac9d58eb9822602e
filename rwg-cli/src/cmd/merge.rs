//! `rwg merge`: combine the shards of a study into one run directory.

use crate::study::{new_meta, plan_cells, read_meta, summary_header, write_meta};
use anyhow::{bail, Context, Result};
use rwg_core::export::{rfc3339, write_atomic};
use rwg_core::manifest::Manifest;
use rwg_core::run_meta::RunMeta;
use rwg_core::rundir::{block_done, block_path, n_blocks};
use std::path::PathBuf;
use std::time::SystemTime;

/// Arguments of `rwg merge`.
#[derive(clap::Args)]
#[command(after_help = "\
Checks that the shard directories come from the same study and together hold every
block of networks exactly once, then writes a run directory byte-identical to an
unsharded run's (timing metadata aside).

Example:
  for k in 0 1 2; do rwg run examples/paper.toml --shard $k/3 --out runs/paper-s$k; done
  rwg merge runs/paper-s0 runs/paper-s1 runs/paper-s2 --out runs/paper")]
pub struct Args {
    /// Shard directories written by `rwg run --shard K/N`.
    #[arg(required = true)]
    shards: Vec<PathBuf>,
    /// The merged run directory (must not hold a run).
    #[arg(long)]
    out: PathBuf,
}

/// Runs `rwg merge`.
pub fn run(args: Args) -> Result<()> {
    let mut shards: Vec<(PathBuf, Manifest, RunMeta)> = vec![];
    for d in &args.shards {
        let m = Manifest::load(&d.join("manifest.toml"))
            .with_context(|| format!("{} is not an rwg run directory", d.display()))?;
        let meta = read_meta(d)?;
        if meta.shard.is_none() {
            bail!("{} holds a whole run, not a shard", d.display());
        }
        shards.push((d.clone(), m, meta));
    }
    let (first_dir, m, first_meta) = &shards[0];
    let count = first_meta.shard.expect("checked").count;
    for (d, other, meta) in &shards[1..] {
        let diffs = m.study_differences(other);
        if !diffs.is_empty() {
            bail!(
                "{} and {} hold different studies: {}",
                first_dir.display(),
                d.display(),
                diffs.join("; ")
            );
        }
        let s = meta.shard.expect("checked");
        if s.count != count {
            bail!(
                "{} is shard {}/{}, but {} is one of {count} shards",
                d.display(),
                s.index,
                s.count,
                first_dir.display()
            );
        }
    }
    let mut owner: Vec<Option<&PathBuf>> = vec![None; count as usize];
    for (d, _, meta) in &shards {
        let k = meta.shard.expect("checked").index as usize;
        if let Some(prev) = owner[k] {
            bail!(
                "shard {k}/{count} is given twice: {} and {}",
                prev.display(),
                d.display()
            );
        }
        owner[k] = Some(d);
    }
    let missing: Vec<String> = owner
        .iter()
        .enumerate()
        .filter(|(_, o)| o.is_none())
        .map(|(k, _)| format!("{k}/{count}"))
        .collect();
    if !missing.is_empty() {
        bail!("missing shard(s) {} of {count}", missing.join(", "));
    }

    // The shards' manifests name their plugin files already: nothing to fill in.
    let cells = plan_cells(&mut m.clone())?;
    let nb = n_blocks(m.samples);
    // Every block must be in the shard that owns it.
    for (ci, cell) in cells.iter().enumerate() {
        for b in 0..nb {
            let k = ((ci as u64 * nb + b) % count) as usize;
            let dir = owner[k].expect("checked").join("cells").join(&cell.dir);
            if !block_done(&dir, b) {
                bail!(
                    "shard {k}/{count} ({}) is incomplete: block {b} of cell {} is missing; finish it with \
                     rwg run <manifest> --shard {k}/{count} --out {}",
                    owner[k].expect("checked").display(),
                    cell.dir,
                    owner[k].expect("checked").display()
                );
            }
        }
    }

    let out = &args.out;
    if out.join("run.json").exists() || out.join("manifest.toml").exists() {
        bail!(
            "{} already holds a run; choose another --out",
            out.display()
        );
    }
    std::fs::create_dir_all(out.join("cells"))
        .with_context(|| format!("cannot create {}", out.display()))?;
    write_atomic(&out.join("manifest.toml"), m.to_toml().as_bytes())?;
    let threads = shards.iter().map(|s| s.2.threads).max().unwrap_or(1);
    let start = shards
        .iter()
        .map(|s| s.2.start_time.clone())
        .min()
        .unwrap_or_default();
    let mut meta = new_meta(m, threads, start, None);
    meta.wall_s = shards.iter().map(|s| s.2.wall_s).sum();
    println!("{}", summary_header());
    for (ci, cell) in cells.iter().enumerate() {
        let dest = out.join("cells").join(&cell.dir);
        for b in 0..nb {
            let k = ((ci as u64 * nb + b) % count) as usize;
            let src = block_path(&owner[k].expect("checked").join("cells").join(&cell.dir), b);
            let dst = block_path(&dest, b);
            std::fs::create_dir_all(dst.parent().expect("has parent"))?;
            std::fs::copy(&src, &dst)
                .with_context(|| format!("cannot copy {} to {}", src.display(), dst.display()))?;
        }
        let (cm, totals) = cell.finalize(m, out, 0.0)?;
        println!("{}", cell.summary_line(&totals.means, f64::NAN));
        meta.env_steps += cm.env_steps;
        meta.cells.push(cm);
    }
    meta.steps_per_s = if meta.wall_s > 0.0 {
        meta.env_steps as f64 / meta.wall_s
    } else {
        0.0
    };
    meta.end_time = Some(rfc3339(SystemTime::now()));
    write_meta(out, &meta)?;
    println!(
        "\nMerged {count} shards ({} env steps) into {}",
        meta.env_steps,
        out.display()
    );
    Ok(())
}
