//! Finalising a cell: its blocks (committed files, or this process's own
//! results not committed) streamed into `scores.csv`, then `samples.csv`,
//! `cell.json` and the cell's `SHA256SUMS`, written last; and whether a cell
//! is finalised. The final files depend only on the blocks' rows, so they are
//! byte-identical whether the cell ran in one go, was resumed, or was
//! computed in shards and merged.

use crate::rundir::blocks::{block_path, block_samples, n_blocks, BlockIndex, BLOCK_SAMPLES};
use crate::rundir::checksum::{self, sums_text, Digest, SUMS};
use crate::rundir::env_record::ENV_JSON;
use crate::rundir::error::{io_err, RunDirError};
use crate::rundir::export::{self, sync_dir, write_atomic_hashed, write_sample_rows, AtomicFile};
use crate::rundir::rows::CellRows;
use crate::rundir::{rows, BLOCKS, CELL_JSON, SAMPLES_CSV, SCORES_CSV};
use crate::stats::{ranks, sample_stats, SampleStats};
use rwg_core::sampler::BlockResult;
use rwg_core::sampler::MAX_RETURN;
use std::collections::BTreeMap;
use std::io::{self, Write};
use std::ops::Range;
use std::path::{Path, PathBuf};

/// What finalising a cell found.
#[derive(Debug, Clone, PartialEq)]
pub struct CellTotals {
    /// Environment steps over all episodes of the cell.
    pub env_steps: u64,
    /// Mean score of every sample, in sample order.
    pub means: Vec<f64>,
    /// With `keep` ([`finalize_cell`]): every episode's score and length,
    /// row-major `samples × episodes`, as `scores.csv` holds them (for the
    /// analysis of a run that just finalised the cell); else empty.
    pub episodes: (Vec<f64>, Vec<u32>),
    /// With flagged rows (`non_finite = "end"`): how many episodes a value
    /// that was not finite ended; else `None`.
    pub non_finite: Option<u64>,
}

/// Whether the cell is finalised: its `SHA256SUMS`, written last, exists.
/// (Whether its files still match it is [`checksum::verify_cell`]'s job.)
pub fn cell_complete(cell_dir: &Path) -> bool {
    cell_dir.join(SUMS).is_file()
}

/// Removes what a finalised cell no longer needs: the blocks, which remain
/// when a run was killed between writing `samples.csv` and removing them.
pub fn tidy_complete_cell(cell_dir: &Path) -> Result<(), RunDirError> {
    let blocks = cell_dir.join(BLOCKS);
    if cell_complete(cell_dir) && blocks.exists() {
        std::fs::remove_dir_all(&blocks).map_err(io_err(&blocks))?;
    }
    Ok(())
}

/// Parses one `sample,episode,score,steps` row (with `,non_finite` when
/// `flagged`), checking it is the expected one and holds what an episode
/// can give ([`check_episode`]). Returns its score, steps and flag.
fn parse_row(
    line: &str,
    (sample, episode): (u64, u32),
    max_steps: u32,
    flagged: bool,
) -> Result<(f64, u64, bool), String> {
    let (fields, cut) = if flagged {
        let [s, e, score, steps, flag] =
            rows::split_fields::<5>(line).map_err(|_| format!("expected 5 columns: '{line}'"))?;
        let cut = match flag {
            "0" => false,
            "1" => true,
            _ => return Err(format!("non_finite '{flag}' is not 0 or 1")),
        };
        ([s, e, score, steps], cut)
    } else {
        let f =
            rows::split_fields::<4>(line).map_err(|_| format!("expected 4 columns: '{line}'"))?;
        (f, false)
    };
    let [s, e, score, steps] = fields;
    if s.parse::<u64>().ok() != Some(sample) || e.parse::<u32>().ok() != Some(episode) {
        return Err(format!(
            "expected sample {sample}, episode {episode}: '{line}'"
        ));
    }
    let score = score
        .parse::<f64>()
        .map_err(|_| format!("bad score '{score}'"))?;
    let steps = steps
        .parse::<u64>()
        .map_err(|_| format!("bad steps '{steps}'"))?;
    check_episode(score, steps, max_steps, cut)?;
    Ok((score, steps, cut))
}

/// Whether an episode's score and length are ones an episode can have: a
/// score within ±[`MAX_RETURN`], and 1 ≤ `steps` ≤ `max_steps` (the cell's
/// time limit; 0 steps too for an episode `cut` by a value that was not
/// finite, which a network's output can end before its first step). The
/// message says what is wrong, for a row read back from a file.
pub fn check_episode(score: f64, steps: u64, max_steps: u32, cut: bool) -> Result<(), String> {
    if !score.is_finite() {
        return Err(format!(
            "score {score} is not a finite number (an episode's score is a sum of finite rewards)"
        ));
    }
    if score.abs() > MAX_RETURN {
        return Err(format!(
            "score {score:e} is beyond ±{MAX_RETURN:e}, the largest return rwg takes"
        ));
    }
    let least = u64::from(!cut);
    if steps < least || steps > u64::from(max_steps) {
        return Err(format!(
            "{steps} steps: an episode of this cell lasts {least} to {max_steps} steps (its \
             time limit)"
        ));
    }
    Ok(())
}

/// Streams the cell's blocks into `scores.csv`, writes `samples.csv` (and,
/// before it, `cell.json` = `cell_json` if given), lists them (and the cell's
/// `env.json`, when there is one) in the cell's `SHA256SUMS`, then removes
/// the blocks.
/// The blocks are the committed block files, except those in `pending`:
/// blocks of this process not committed to files (the last ones a run
/// computed, [`crate::committer::CommitThreads::finish`]), whose rows are
/// formatted as [`crate::rundir::blocks::write_blocks`] would write them.
/// Every row read from a file must hold a finite score and
/// 1 ≤ steps ≤ `max_steps` (the cell's time limit, at least 1), whatever its
/// checksum says. Memory: one block file (at most 32 ×
/// [`crate::limits::MAX_EPISODES`] rows, ~8 MB), one sample's scores and the
/// per-sample summaries (with `keep`, every episode's score and length too).
pub fn finalize_cell(
    cell_dir: &Path,
    samples: u64,
    rows: impl Into<CellRows>,
    max_steps: u32,
    keep: bool,
    pending: &[BlockResult],
    cell_json: impl FnOnce(&CellTotals) -> Option<String>,
) -> Result<CellTotals, RunDirError> {
    let rows = rows.into();
    let cell = CellBlocks {
        dir: cell_dir,
        samples,
        rows,
        max_steps,
        index: BlockIndex::load(cell_dir)?,
    };
    let pending: BTreeMap<u64, &BlockResult> = pending
        .iter()
        .map(|b| (b.samples.start / BLOCK_SAMPLES, b))
        .collect();
    cell.check_all_there(&pending)?;
    // A cell whose blocks are all pending has no directory yet.
    export::create_dir_all(cell_dir).map_err(io_err(cell_dir))?;
    let scores_path = cell_dir.join(SCORES_CSV);
    let mut scores = AtomicFile::create(&scores_path).map_err(io_err(&scores_path))?;
    writeln!(scores, "{}", rows.scores_header()).map_err(io_err(&scores_path))?;
    let mut tally = Tally::new(samples, rows, keep);
    for b in 0..n_blocks(samples) {
        let text = match pending.get(&b) {
            Some(block) => tally.add_pending(block, rows),
            None => tally.add_file(&cell, b)?,
        };
        scores.write_all(&text).map_err(io_err(&scores_path))?;
    }
    let scores_sum = scores.commit_hashed().map_err(io_err(&scores_path))?;
    write_final_files(cell_dir, scores_sum, tally, cell_json)
}

/// The cell being finalised and its committed blocks.
struct CellBlocks<'a> {
    dir: &'a Path,
    samples: u64,
    rows: CellRows,
    max_steps: u32,
    index: BlockIndex,
}

impl CellBlocks<'_> {
    /// Checks that every block is committed or pending (and that a pending
    /// one holds its samples' episodes).
    fn check_all_there(&self, pending: &BTreeMap<u64, &BlockResult>) -> Result<(), RunDirError> {
        for b in 0..n_blocks(self.samples) {
            if let Some(p) = pending.get(&b) {
                assert_eq!(
                    p.samples,
                    block_samples(b, self.samples),
                    "pending block {b}"
                );
                assert_eq!(
                    p.episodes.len(),
                    p.samples.clone().count() * self.rows.episodes as usize
                );
                continue;
            }
            if !self.index.done(b) {
                return Err(RunDirError::MissingBlock {
                    path: block_path(self.dir, b),
                    block: b,
                });
            }
        }
        Ok(())
    }
}

/// What the cell's blocks add up to, sample by sample.
struct Tally {
    summaries: Vec<SampleStats>,
    env_steps: u64,
    /// The current sample's scores.
    buf: Vec<f64>,
    keep: bool,
    all_scores: Vec<f64>,
    all_steps: Vec<u32>,
    /// With flagged rows: per sample, its episodes a value that was not
    /// finite ended (the current sample's last).
    cut: Option<Vec<u32>>,
}

impl Tally {
    fn new(samples: u64, rows: CellRows, keep: bool) -> Tally {
        let kept = if keep {
            samples as usize * rows.episodes as usize
        } else {
            0
        };
        Tally {
            summaries: Vec::with_capacity(samples as usize),
            env_steps: 0,
            buf: Vec::with_capacity(rows.episodes as usize),
            keep,
            all_scores: Vec::with_capacity(kept),
            all_steps: Vec::with_capacity(kept),
            cut: rows.flagged.then(|| Vec::with_capacity(samples as usize)),
        }
    }

    /// One episode of the current sample (`cut`: a value that was not
    /// finite ended it).
    fn episode(&mut self, score: f64, steps: u32, cut: bool) {
        if self.buf.is_empty() {
            if let Some(c) = &mut self.cut {
                c.push(0);
            }
        }
        self.buf.push(score);
        self.env_steps += u64::from(steps);
        if let (true, Some(c)) = (cut, &mut self.cut) {
            *c.last_mut().expect("pushed") += 1;
        }
        if self.keep {
            self.all_scores.push(score);
            self.all_steps.push(steps);
        }
    }

    /// Closes the current sample: its statistics.
    fn end_sample(&mut self) {
        self.summaries.push(sample_stats(&self.buf));
        self.buf.clear();
    }

    /// Adds a block of this process's own results (no file to read or
    /// check); returns its rows as [`crate::rundir::blocks::write_blocks`]
    /// writes them.
    fn add_pending(&mut self, block: &BlockResult, rows: CellRows) -> Vec<u8> {
        for sample in block.episodes.chunks(rows.episodes as usize) {
            for r in sample {
                self.episode(r.score, r.steps, r.non_finite);
            }
            self.end_sample();
        }
        let mut text = vec![];
        rows::push_score_rows(&mut text, block, rows);
        text
    }

    /// Adds committed block `b`, returning its bytes. A block is small (32
    /// networks' rows): read whole, checked row by row, then copied as it is
    /// (rwg wrote it, in the form scores.csv takes) and checked against its
    /// digest.
    fn add_file(&mut self, cell: &CellBlocks, b: u64) -> Result<Vec<u8>, RunDirError> {
        let path = block_path(cell.dir, b);
        let text = crate::limits::read_own_file(&path, crate::limits::MAX_BLOCK_BYTES)
            .map_err(io_err(&path))?;
        let utf8 = block_text(&path, &text)?;
        self.add_rows(cell, &path, utf8, block_samples(b, cell.samples))?;
        let want = cell.index.digest(b).expect("checked by check_all_there");
        checksum::check(&path, want, &checksum::digest_of(&text))?;
        Ok(text)
    }

    /// Adds the rows of a block file of `samples`, each checked
    /// ([`parse_row`]), and refuses a row after the last.
    fn add_rows(
        &mut self,
        cell: &CellBlocks,
        path: &Path,
        text: &str,
        samples: Range<u64>,
    ) -> Result<(), RunDirError> {
        let mut rows = rows::lines(text);
        let mut line_no = 0;
        for sample in samples {
            for episode in 0..cell.rows.episodes {
                line_no += 1;
                let corrupt = |message: String| RunDirError::Corrupt {
                    path: path.to_path_buf(),
                    line: line_no,
                    message,
                };
                let row = rows
                    .next()
                    .ok_or_else(|| corrupt("file ends early".into()))?;
                let (score, steps, cut) =
                    parse_row(row, (sample, episode), cell.max_steps, cell.rows.flagged)
                        .map_err(corrupt)?;
                // parse_row bounds steps by max_steps, a u32.
                let steps = u32::try_from(steps)
                    .map_err(|_| corrupt(format!("{steps} steps: more than 2^32")))?;
                self.episode(score, steps, cut);
            }
            self.end_sample();
        }
        match rows.next() {
            None => Ok(()),
            Some(extra) => Err(RunDirError::Corrupt {
                path: path.to_path_buf(),
                line: line_no + 1,
                message: format!("unexpected row after the block's last sample: '{extra}'"),
            }),
        }
    }
}

/// A block file's bytes as text; the error names the line of the first byte
/// that is not UTF-8.
fn block_text<'a>(path: &Path, text: &'a [u8]) -> Result<&'a str, RunDirError> {
    std::str::from_utf8(text).map_err(|e| {
        let line = 1 + text[..e.valid_up_to()]
            .iter()
            .filter(|&&c| c == b'\n')
            .count();
        RunDirError::Corrupt {
            path: path.to_path_buf(),
            line,
            message: "not UTF-8 text".into(),
        }
    })
}

/// After `scores.csv` (committed with digest `scores_sum`): `cell.json`
/// (when `cell_json` gives one), `samples.csv`, then the cell's
/// `SHA256SUMS`, written last, and the blocks removed.
fn write_final_files(
    cell_dir: &Path,
    scores_sum: Digest,
    tally: Tally,
    cell_json: impl FnOnce(&CellTotals) -> Option<String>,
) -> Result<CellTotals, RunDirError> {
    let mut sums = vec![(SCORES_CSV, scores_sum)];
    let means: Vec<f64> = tally.summaries.iter().map(|s| s.mean).collect();
    let totals = CellTotals {
        env_steps: tally.env_steps,
        means,
        episodes: (tally.all_scores, tally.all_steps),
        non_finite: tally
            .cut
            .as_ref()
            .map(|c| c.iter().map(|&n| u64::from(n)).sum()),
    };
    if let Some(json) = cell_json(&totals) {
        let p = cell_dir.join(CELL_JSON);
        sums.push((
            CELL_JSON,
            write_atomic_hashed(&p, json.as_bytes()).map_err(io_err(&p))?,
        ));
    }
    let ranks = ranks(&totals.means);
    let samples_path = cell_dir.join(SAMPLES_CSV);
    let mut f = AtomicFile::create(&samples_path).map_err(io_err(&samples_path))?;
    write_sample_rows(&mut f, &tally.summaries, &ranks, tally.cut.as_deref())
        .map_err(io_err(&samples_path))?;
    sums.push((
        SAMPLES_CSV,
        f.commit_hashed().map_err(io_err(&samples_path))?,
    ));
    // The env the cell's blocks were computed under, when it was recorded.
    let env_path = cell_dir.join(ENV_JSON);
    match checksum::hash_file(&env_path) {
        Ok(d) => sums.push((ENV_JSON, d)),
        Err(e) if e.kind() == io::ErrorKind::NotFound => {}
        Err(e) => return Err(io_err(&env_path)(e)),
    }
    write_sums_and_remove_blocks(cell_dir, &sums)?;
    Ok(totals)
}

/// Writes the cell's `SHA256SUMS` (the cell is complete once it exists),
/// then removes its blocks.
fn write_sums_and_remove_blocks(
    cell_dir: &Path,
    sums: &[(&str, Digest)],
) -> Result<(), RunDirError> {
    let sums_path: PathBuf = cell_dir.join(SUMS);
    write_atomic_hashed(&sums_path, sums_text(sums).as_bytes()).map_err(io_err(&sums_path))?;
    let blocks = cell_dir.join(BLOCKS);
    if blocks.exists() {
        std::fs::remove_dir_all(&blocks).map_err(io_err(&blocks))?;
        sync_dir(&blocks).map_err(io_err(cell_dir))?;
    }
    Ok(())
}

#[cfg(test)]
mod tests;
