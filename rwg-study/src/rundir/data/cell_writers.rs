//! Writing a run's files from scores in memory: a cell's `scores.csv` and
//! `samples.csv` (as the run writer writes them, bit for bit), `run.json`.

use crate::rundir::checksum;
use crate::rundir::export::csv_writer;
use crate::rundir::meta::{CellMeta, RunMeta};
use crate::rundir::{cell_dir, SAMPLES_CSV, SCORES_CSV, SCORES_HEADER};
use crate::stats::{self, SampleStats};
use rwg_env::float::fmt_f64;
use std::path::Path;

/// The text of a `samples.csv` for the given per-sample statistics and ranks
/// (the run writer's own format, [`crate::rundir::export::write_sample_rows`]).
pub fn samples_csv(stats: &[SampleStats], ranks: &[usize]) -> String {
    let mut out = Vec::with_capacity(64 * (stats.len() + 1));
    crate::rundir::export::write_sample_rows(&mut out, stats, ranks, None)
        .expect("writing to memory");
    String::from_utf8(out).expect("ASCII")
}

/// Writes `samples.csv` for a row-major `N × episodes` score matrix: what the
/// run writer calls so the file matches the analysis bit for bit.
pub fn write_samples_csv(path: &Path, scores: &[f64], episodes: usize) -> std::io::Result<()> {
    let st = stats::per_sample(scores, episodes);
    let ranks = stats::ranks(&st.iter().map(|s| s.mean).collect::<Vec<_>>());
    crate::rundir::export::write_atomic(path, samples_csv(&st, &ranks).as_bytes())
}

/// The text of a `scores.csv` for row-major `N × episodes` scores and steps.
pub fn scores_csv(scores: &[f64], steps: &[u32], episodes: usize) -> String {
    let mut w = csv_writer(Vec::with_capacity(24 * (scores.len() + 1)));
    w.write_record(SCORES_HEADER.split(','))
        .expect("writing to memory");
    for (i, (s, st)) in scores.iter().zip(steps).enumerate() {
        w.write_record([
            (i / episodes).to_string(),
            (i % episodes).to_string(),
            fmt_f64(*s),
            st.to_string(),
        ])
        .expect("writing to memory");
    }
    String::from_utf8(w.into_inner().expect("writing to memory")).expect("ASCII")
}

/// Writes `run.json` into `dir`.
pub fn write_run_json(dir: &Path, meta: &RunMeta) -> std::io::Result<()> {
    crate::rundir::meta::write_run_meta(dir, meta).map_err(std::io::Error::other)
}

/// Writes one cell's `scores.csv` and `samples.csv` under
/// `run_dir/cells/<cell.dir>/`, from row-major `N × cell.episodes` scores
/// and steps.
pub fn write_cell_files(
    run_dir: &Path,
    cell: &CellMeta,
    scores: &[f64],
    steps: &[u32],
) -> std::io::Result<()> {
    use crate::rundir::export::write_atomic_hashed;
    let dir = cell_dir(run_dir, &cell.id.dir);
    std::fs::create_dir_all(&dir)?;
    let e = cell.episodes as usize;
    let st = stats::per_sample(scores, e);
    let ranks = stats::ranks(&st.iter().map(|s| s.mean).collect::<Vec<_>>());
    let sums = [
        (
            SCORES_CSV,
            write_atomic_hashed(
                &dir.join(SCORES_CSV),
                scores_csv(scores, steps, e).as_bytes(),
            )?,
        ),
        (
            SAMPLES_CSV,
            write_atomic_hashed(&dir.join(SAMPLES_CSV), samples_csv(&st, &ranks).as_bytes())?,
        ),
    ];
    write_atomic_hashed(
        &dir.join(checksum::SUMS),
        checksum::sums_text(&sums).as_bytes(),
    )
    .map(|_| ())
}
