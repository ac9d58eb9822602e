//! Storage of a cell's results in a run directory, built for long runs.
//!
//! A cell's networks are computed in blocks of [`BLOCK_SAMPLES`] consecutive
//! samples. Each finished block is committed atomically (temporary file, then
//! rename) as `cells/<cell>/blocks/b<index>.csv`, so a run killed at any
//! instant loses at most the blocks in flight, and a resumed run skips the
//! blocks on disk. When every block of a cell is there, [`finalize_cell`]
//! streams them into `scores.csv`, computes `samples.csv` and `cell.json`,
//! and removes the blocks. The final files depend only on the blocks' rows,
//! so they are byte-identical whether the cell ran in one go, was resumed, or
//! was computed in shards and merged.

use crate::rundir::checksum::{
    self, append_sum, append_sums_unsynced, read_sums, sums_text, Digest, SUMS,
};
use crate::rundir::env_record::ENV_JSON;
use crate::rundir::export::{
    self, sync_dir, write_atomic_hashed, write_sample_rows, write_score_rows, AtomicFile,
};
use crate::rundir::{rows, BLOCKS, CELL_JSON, SAMPLES_CSV, SCORES_CSV, SCORES_HEADER};
use crate::stats::{ranks, sample_stats};
use rwg_core::sampler::BlockResult;
use std::collections::BTreeMap;
use std::io::{self, Write};
use std::ops::Range;
use std::path::{Path, PathBuf};
use thiserror::Error;

/// Samples per block: the unit of parallel work, of commits and of shards.
pub const BLOCK_SAMPLES: u64 = 32;

/// Errors reading or writing a cell's files.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum RunDirError {
    /// An I/O error on a file.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The error.
        source: io::Error,
    },
    /// A file's contents are not what rwg wrote.
    #[error("{path}:{line}: {message}")]
    Corrupt {
        /// The file.
        path: PathBuf,
        /// 1-based line.
        line: usize,
        /// What is wrong.
        message: String,
    },
    /// A file does not have the checksum its index records.
    #[error(
        "{path}: checksum mismatch: the run's index records sha256 {recorded}, the file has \
         {found}; it was changed, truncated or damaged after rwg wrote it (a block: or it did \
         not reach the disk before a crash of the machine). Running the study (or shard) again \
         computes a damaged block again; for a finished cell's file, delete the cell's \
         directory first"
    )]
    Checksum {
        /// The file.
        path: PathBuf,
        /// The digest recorded when the file was committed.
        recorded: String,
        /// The digest of the file now.
        found: String,
    },
    /// A file has no checksum recorded, so it cannot count as committed.
    #[error("{path}: unverified: {message}")]
    Unverified {
        /// The file.
        path: PathBuf,
        /// Why.
        message: String,
    },
    /// A block listed as committed in the cell's block index is gone.
    #[error(
        "{path}: missing: listed in {index} as committed, but the file is gone (deleted, or \
         not written to disk before a crash of the machine); running the study (or shard) \
         again computes it again"
    )]
    ListedMissing {
        /// The block's file.
        path: PathBuf,
        /// The index that lists it.
        index: PathBuf,
    },
    /// A block is missing when the cell is finalised.
    #[error("{path}: missing (block {block} of the cell)")]
    MissingBlock {
        /// The block's file.
        path: PathBuf,
        /// Block index.
        block: u64,
    },
}

fn io_err(path: &Path) -> impl FnOnce(io::Error) -> RunDirError + '_ {
    move |source| RunDirError::Io {
        path: path.to_path_buf(),
        source,
    }
}

/// Number of blocks of a cell of `samples` networks.
pub fn n_blocks(samples: u64) -> u64 {
    samples.div_ceil(BLOCK_SAMPLES)
}

/// The samples of block `b`.
pub fn block_samples(b: u64, samples: u64) -> Range<u64> {
    let start = b * BLOCK_SAMPLES;
    start..(start + BLOCK_SAMPLES).min(samples)
}

/// The file of block `b` of the cell in `cell_dir`.
pub fn block_path(cell_dir: &Path, b: u64) -> PathBuf {
    cell_dir.join(BLOCKS).join(format!("b{b:07}.csv"))
}

/// The block index of a file name in a cell's `blocks/` folder, if it is the
/// name [`block_path`] gives a block (temporary files and strays are not).
pub fn block_index(file_name: &str) -> Option<u64> {
    let digits = file_name.strip_prefix('b')?.strip_suffix(".csv")?;
    if !digits.bytes().all(|c| c.is_ascii_digit()) {
        return None;
    }
    let b: u64 = digits.parse().ok()?;
    (format!("b{b:07}.csv") == file_name).then_some(b)
}

/// File name of block `b`.
fn block_name(b: u64) -> String {
    format!("b{b:07}.csv")
}

/// The committed blocks of a cell: those listed in `blocks/SHA256SUMS`
/// (with the digest recorded at commit) whose file exists. A block file
/// without an index line (a run killed between the rename and the append)
/// is not committed and is computed again.
#[derive(Debug, Clone, Default)]
pub struct BlockIndex {
    sums: BTreeMap<String, Digest>,
    dir: PathBuf,
}

impl BlockIndex {
    /// Reads the index of the cell in `cell_dir` (empty if none).
    pub fn load(cell_dir: &Path) -> Result<BlockIndex, RunDirError> {
        let sums = read_sums(&cell_dir.join(BLOCKS).join(SUMS), false)?.unwrap_or_default();
        Ok(BlockIndex {
            sums,
            dir: cell_dir.to_path_buf(),
        })
    }

    /// Reads the index of the cell in `cell_dir`, as [`BlockIndex::load`],
    /// and keeps only the blocks whose file has the recorded digest: what a
    /// resumed run may skip. Returns the index and the blocks dropped
    /// (listed, but a file that is missing, unreadable or changed, as a
    /// crash of the machine can leave one: they are computed again).
    pub fn load_checked(cell_dir: &Path) -> Result<(BlockIndex, Vec<String>), RunDirError> {
        let mut index = BlockIndex::load(cell_dir)?;
        let dir = cell_dir.join(BLOCKS);
        let mut dropped = vec![];
        index.sums.retain(|name, want| {
            let ok = checksum::hash_file(&dir.join(name)).is_ok_and(|got| got == *want);
            if !ok {
                dropped.push(name.clone());
            }
            ok
        });
        Ok((index, dropped))
    }

    /// The recorded digest of block `b`, if it is committed.
    pub fn digest(&self, b: u64) -> Option<&Digest> {
        self.sums
            .get(&block_name(b))
            .filter(|_| block_path(&self.dir, b).is_file())
    }

    /// Whether block `b` is committed.
    pub fn done(&self, b: u64) -> bool {
        self.digest(b).is_some()
    }

    /// Whether block `b` has a line in the index (its file may be gone).
    pub fn is_listed(&self, b: u64) -> bool {
        self.sums.contains_key(&block_name(b))
    }

    /// Every block file name the index lists, with its recorded digest
    /// (whether or not the file is there), in name order.
    pub fn listed(&self) -> impl Iterator<Item = (&str, &Digest)> {
        self.sums.iter().map(|(n, d)| (n.as_str(), d))
    }
}

/// Whether block `b` is committed (reads the cell's index; use
/// [`BlockIndex`] to ask about many blocks).
pub fn block_done(cell_dir: &Path, b: u64) -> bool {
    BlockIndex::load(cell_dir).is_ok_and(|i| i.done(b))
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

/// Commits a block atomically: its `scores.csv` rows, without header.
pub fn write_block(cell_dir: &Path, block: &BlockResult, episodes: u32) -> Result<(), RunDirError> {
    write_blocks(cell_dir, std::slice::from_ref(block), episodes)
}

/// Commits several blocks of one cell as a group: each block's file is
/// written and renamed into place, then the blocks' index lines are appended
/// in one write. A block counts as committed once its line is in the index
/// and its file is in place. If a block fails, the blocks before it are
/// still indexed, and the error is returned.
///
/// Nothing is synced: a committed block survives the process being killed
/// (SIGKILL, a crash, Ctrl-C), whose writes the kernel keeps, but after a
/// crash of the machine a block file or index line may not have reached the
/// disk. A resumed run therefore trusts a block only if its file has the
/// digest the index recorded ([`BlockIndex::load_checked`]) and computes any
/// other again. (An `fsync` per block cost about 0.5 ms of CPU on the
/// project's VM, a fifth of a fast CartPole cell's whole run; the cell's
/// final files are synced.)
pub fn write_blocks(
    cell_dir: &Path,
    blocks: &[BlockResult],
    episodes: u32,
) -> Result<(), RunDirError> {
    let dir = cell_dir.join(BLOCKS);
    if !dir.is_dir() {
        export::create_dir_all(&dir).map_err(io_err(&dir))?;
    }
    let mut done = Vec::with_capacity(blocks.len());
    let mut failed = None;
    for block in blocks {
        let b = block.samples.start / BLOCK_SAMPLES;
        let path = block_path(cell_dir, b);
        let written = AtomicFile::create(&path).and_then(|mut f| {
            write_score_rows(&mut f, block, episodes)?;
            f.commit_hashed_unsynced()
        });
        match written {
            Ok(digest) => done.push((block_name(b), digest)),
            Err(e) => {
                failed = Some(io_err(&path)(e));
                break;
            }
        }
    }
    if !done.is_empty() {
        let entries: Vec<(&str, Digest)> = done.iter().map(|(n, d)| (n.as_str(), *d)).collect();
        append_sums_unsynced(&dir.join(SUMS), &entries)?;
    }
    failed.map_or(Ok(()), Err)
}

/// Copies committed block `b` of the cell in `src` into the cell in `dst`
/// (for `merge`): checks it against `src`'s index while reading, then
/// commits it in `dst` like [`write_block`].
pub fn copy_block(src: &BlockIndex, dst: &Path, b: u64) -> Result<(), RunDirError> {
    let from = block_path(&src.dir, b);
    let want = *src.digest(b).ok_or_else(|| RunDirError::Unverified {
        path: from.clone(),
        message: format!(
            "not listed in {}: the block is not committed",
            src.dir.join(BLOCKS).join(SUMS).display()
        ),
    })?;
    let bytes = crate::limits::read_own_file(&from, crate::limits::MAX_BLOCK_BYTES)
        .map_err(io_err(&from))?;
    let got: Digest = {
        use sha2::Digest as _;
        sha2::Sha256::digest(&bytes).into()
    };
    checksum::check(&from, &want, &got)?;
    let to = block_path(dst, b);
    let dir = to.parent().expect("block path has a parent");
    export::create_dir_all(dir).map_err(io_err(dir))?;
    let digest = write_atomic_hashed(&to, &bytes).map_err(io_err(&to))?;
    append_sum(&dir.join(SUMS), &block_name(b), &digest)
}

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
}

/// Parses one `sample,episode,score,steps` row, checking it is the expected
/// one and holds what an episode can give: a finite score and
/// 1 ≤ steps ≤ `max_steps` (the cell's time limit).
fn parse_row(line: &str, sample: u64, episode: u32, max_steps: u32) -> Result<(f64, u64), String> {
    let [s, e, score, steps] =
        rows::split_fields::<4>(line).map_err(|_| format!("expected 4 columns: '{line}'"))?;
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
    check_episode(score, steps, max_steps)?;
    Ok((score, steps))
}

/// Whether an episode's score and length are ones an episode can have: a
/// finite score, and 1 ≤ `steps` ≤ `max_steps` (the cell's time limit). The
/// message says what is wrong, for a row read back from a file.
pub fn check_episode(score: f64, steps: u64, max_steps: u32) -> Result<(), String> {
    if !score.is_finite() {
        return Err(format!(
            "score {score} is not a finite number (an episode's score is a sum of finite rewards)"
        ));
    }
    if steps == 0 || steps > u64::from(max_steps) {
        return Err(format!(
            "{steps} steps: an episode of this cell lasts 1 to {max_steps} steps (its time limit)"
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
/// formatted as [`write_blocks`] would write them. Every row read from a
/// file must hold a finite score and 1 ≤ steps ≤ `max_steps` (the cell's
/// time limit, at least 1), whatever its checksum says. Memory: one block file (at
/// most 32 × [`crate::limits::MAX_EPISODES`] rows, ~8 MB), one sample's
/// scores and the per-sample summaries (with `keep`, every episode's score
/// and length too).
pub fn finalize_cell(
    cell_dir: &Path,
    samples: u64,
    episodes: u32,
    max_steps: u32,
    keep: bool,
    pending: &[BlockResult],
    cell_json: impl FnOnce(&CellTotals) -> Option<String>,
) -> Result<CellTotals, RunDirError> {
    let index = BlockIndex::load(cell_dir)?;
    let pending: BTreeMap<u64, &BlockResult> = pending
        .iter()
        .map(|b| (b.samples.start / BLOCK_SAMPLES, b))
        .collect();
    for b in 0..n_blocks(samples) {
        if let Some(p) = pending.get(&b) {
            assert_eq!(p.samples, block_samples(b, samples), "pending block {b}");
            assert_eq!(
                p.episodes.len(),
                p.samples.clone().count() * episodes as usize
            );
            continue;
        }
        if !index.done(b) {
            return Err(RunDirError::MissingBlock {
                path: block_path(cell_dir, b),
                block: b,
            });
        }
    }
    // A cell whose blocks are all pending has no directory yet.
    export::create_dir_all(cell_dir).map_err(io_err(cell_dir))?;
    let scores_path = cell_dir.join(SCORES_CSV);
    let mut scores = AtomicFile::create(&scores_path).map_err(io_err(&scores_path))?;
    writeln!(scores, "{SCORES_HEADER}").map_err(io_err(&scores_path))?;
    let mut summaries = Vec::with_capacity(samples as usize);
    let mut env_steps = 0u64;
    let mut buf = Vec::with_capacity(episodes as usize);
    let kept = if keep {
        samples as usize * episodes as usize
    } else {
        0
    };
    let (mut all_scores, mut all_steps): (Vec<f64>, Vec<u32>) =
        (Vec::with_capacity(kept), Vec::with_capacity(kept));
    let mut text = vec![];
    for b in 0..n_blocks(samples) {
        if let Some(block) = pending.get(&b) {
            // This process's own results: no file to read or check.
            for sample in block.episodes.chunks(episodes as usize) {
                buf.clear();
                for r in sample {
                    buf.push(r.score);
                    env_steps += u64::from(r.steps);
                    if keep {
                        all_scores.push(r.score);
                        all_steps.push(r.steps);
                    }
                }
                summaries.push(sample_stats(&buf));
            }
            text.clear();
            rows::push_score_rows(&mut text, block, episodes);
            scores.write_all(&text).map_err(io_err(&scores_path))?;
            continue;
        }
        // A block is small (32 networks' rows): read whole, checked row by
        // row, then copied as it is (rwg wrote it, in the form scores.csv
        // takes) and checked against its digest.
        let path = block_path(cell_dir, b);
        let text = crate::limits::read_own_file(&path, crate::limits::MAX_BLOCK_BYTES)
            .map_err(io_err(&path))?;
        let utf8 = std::str::from_utf8(&text).map_err(|e| {
            let line = 1 + text[..e.valid_up_to()]
                .iter()
                .filter(|&&c| c == b'\n')
                .count();
            RunDirError::Corrupt {
                path: path.clone(),
                line,
                message: "not UTF-8 text".into(),
            }
        })?;
        let mut rows = rows::lines(utf8);
        let mut line_no = 0;
        for sample in block_samples(b, samples) {
            buf.clear();
            for episode in 0..episodes {
                line_no += 1;
                let corrupt = |message: String| RunDirError::Corrupt {
                    path: path.clone(),
                    line: line_no,
                    message,
                };
                let row = rows
                    .next()
                    .ok_or_else(|| corrupt("file ends early".into()))?;
                let (score, steps) = parse_row(row, sample, episode, max_steps).map_err(corrupt)?;
                buf.push(score);
                env_steps += steps;
                if keep {
                    all_scores.push(score);
                    let steps = u32::try_from(steps)
                        .map_err(|_| corrupt(format!("{steps} steps: more than 2^32")))?;
                    all_steps.push(steps);
                }
            }
            summaries.push(sample_stats(&buf));
        }
        if let Some(extra) = rows.next() {
            let message = format!("unexpected row after the block's last sample: '{extra}'");
            return Err(RunDirError::Corrupt {
                path,
                line: line_no + 1,
                message,
            });
        }
        let got: Digest = {
            use sha2::Digest as _;
            sha2::Sha256::digest(&text).into()
        };
        checksum::check(&path, index.digest(b).expect("checked above"), &got)?;
        scores.write_all(&text).map_err(io_err(&scores_path))?;
    }
    let mut sums = vec![(
        SCORES_CSV,
        scores.commit_hashed().map_err(io_err(&scores_path))?,
    )];
    let means: Vec<f64> = summaries.iter().map(|s| s.mean).collect();
    let totals = CellTotals {
        env_steps,
        means,
        episodes: (all_scores, all_steps),
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
    write_sample_rows(&mut f, &summaries, &ranks).map_err(io_err(&samples_path))?;
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
    // Written last: the cell is complete once this exists.
    let sums_path = cell_dir.join(SUMS);
    write_atomic_hashed(&sums_path, sums_text(&sums).as_bytes()).map_err(io_err(&sums_path))?;
    let blocks = cell_dir.join(BLOCKS);
    if blocks.exists() {
        std::fs::remove_dir_all(&blocks).map_err(io_err(&blocks))?;
        sync_dir(&blocks).map_err(io_err(cell_dir))?;
    }
    Ok(totals)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rundir::export;
    use rwg_core::sampler::EpisodeResult;

    /// The time limit of the test cells (their episodes last 10 to 200 steps).
    const LIMIT: u32 = 500;

    fn block(b: u64, samples: u64, episodes: u32) -> BlockResult {
        let r = block_samples(b, samples);
        let n = (r.end - r.start) as usize * episodes as usize;
        let episodes = (0..n)
            .map(|i| EpisodeResult {
                score: (r.start as f64) + i as f64 * 0.5,
                steps: 10 + i as u32,
            })
            .collect();
        BlockResult {
            samples: r,
            episodes,
        }
    }

    #[test]
    fn blocks_finalise_into_scores_and_samples_in_any_commit_order() {
        let dir = std::env::temp_dir().join(format!("rwg-rundir-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let samples = 2 * BLOCK_SAMPLES + 5;
        assert_eq!(n_blocks(samples), 3);
        for b in [2, 0] {
            write_block(&dir, &block(b, samples, 2), 2).unwrap();
        }
        let err = finalize_cell(&dir, samples, 2, LIMIT, false, &[], |_| None).unwrap_err();
        assert!(
            matches!(err, RunDirError::MissingBlock { block: 1, .. }),
            "{err}"
        );
        write_block(&dir, &block(1, samples, 2), 2).unwrap();
        let totals = finalize_cell(&dir, samples, 2, LIMIT, true, &[], |t| {
            Some(format!("{}", t.env_steps))
        })
        .unwrap();
        assert_eq!(totals.means.len(), samples as usize);
        // What the analysis gets: the rows of scores.csv.
        let (scores, steps) = &totals.episodes;
        assert_eq!(
            (scores.len(), steps.len()),
            (2 * samples as usize, 2 * samples as usize)
        );
        // sample 33 is block 1's second: its first episode is the block's third
        assert_eq!((scores[2 * 33], steps[2 * 33]), (33.0, 12));
        assert_eq!(
            steps.iter().map(|&s| u64::from(s)).sum::<u64>(),
            totals.env_steps
        );
        let scores = std::fs::read_to_string(dir.join("scores.csv")).unwrap();
        assert_eq!(scores.lines().count(), 1 + 2 * samples as usize);
        assert!(scores.lines().nth(1 + 2 * 33).unwrap().starts_with("33,0,"));
        assert_eq!(
            std::fs::read_to_string(dir.join("cell.json")).unwrap(),
            totals.env_steps.to_string()
        );
        assert!(cell_complete(&dir));
        assert!(!dir.join("blocks").exists());
        // a kill between samples.csv and the removal leaves blocks behind
        write_block(&dir, &block(0, samples, 2), 2).unwrap();
        tidy_complete_cell(&dir).unwrap();
        assert!(!dir.join("blocks").exists());
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_group_commits_like_single_blocks_and_indexes_those_before_a_failure() {
        let base = std::env::temp_dir().join(format!("rwg-rundir-group-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&base);
        let (one, group) = (base.join("one"), base.join("group"));
        let samples = 5 * BLOCK_SAMPLES;
        let blocks: Vec<_> = (0..5).map(|b| block(b, samples, 3)).collect();
        for b in &blocks {
            write_block(&one, b, 3).unwrap();
        }
        write_blocks(&group, &blocks[..2], 3).unwrap();
        // Block 3's temporary path is taken by a directory: its commit fails.
        std::fs::create_dir_all(export::tmp_path(&block_path(&group, 3))).unwrap();
        let err = write_blocks(&group, &blocks[2..], 3)
            .unwrap_err()
            .to_string();
        assert!(err.contains("b0000003.csv"), "{err}");
        let index = BlockIndex::load(&group).unwrap();
        for b in 0..5 {
            assert_eq!(index.done(b), b < 3, "block {b}");
            if b < 3 {
                assert_eq!(
                    std::fs::read(block_path(&one, b)).unwrap(),
                    std::fs::read(block_path(&group, b)).unwrap()
                );
                assert_eq!(index.digest(b), BlockIndex::load(&one).unwrap().digest(b));
            }
        }
        assert!(!block_path(&group, 4).exists());
        std::fs::remove_dir_all(&base).unwrap();
    }

    #[test]
    fn corrupt_block_names_file_and_line() {
        let dir = std::env::temp_dir().join(format!("rwg-rundir-bad-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        write_block(&dir, &block(0, 3, 2), 2).unwrap();
        let p = block_path(&dir, 0);
        let text = std::fs::read_to_string(&p).unwrap().replace("1,1,", "1,7,");
        std::fs::write(&p, text).unwrap();
        let err = finalize_cell(&dir, 3, 2, LIMIT, false, &[], |_| None)
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("b0000000.csv:4: expected sample 1, episode 1"),
            "{err}"
        );
        let mut bytes = std::fs::read(&p).unwrap();
        let third = bytes
            .iter()
            .enumerate()
            .filter(|(_, &c)| c == b'\n')
            .nth(1)
            .unwrap()
            .0
            + 1;
        bytes[third + 2] = 0xff;
        std::fs::write(&p, bytes).unwrap();
        let err = finalize_cell(&dir, 3, 2, LIMIT, false, &[], |_| None)
            .unwrap_err()
            .to_string();
        assert!(err.contains("b0000000.csv:3: not UTF-8 text"), "{err}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn rows_a_episode_cannot_have_are_refused_even_when_indexed() {
        let dir = std::env::temp_dir().join(format!("rwg-rundir-rows-{}", std::process::id()));
        for (from, to, want) in [
            (
                ",10\n",
                ",0\n",
                "b0000000.csv:1: 0 steps: an episode of this cell lasts 1 to 500",
            ),
            (",10\n", ",501\n", "b0000000.csv:1: 501 steps"),
            (
                "0,0,0.0,",
                "0,0,NaN,",
                "b0000000.csv:1: score NaN is not a finite number",
            ),
            (
                "0,0,0.0,",
                "0,0,-inf,",
                "b0000000.csv:1: score -inf is not a finite number",
            ),
        ] {
            let _ = std::fs::remove_dir_all(&dir);
            write_block(&dir, &block(0, 3, 2), 2).unwrap();
            // The row changed and its index line recomputed: the digest matches.
            let p = block_path(&dir, 0);
            let text = std::fs::read_to_string(&p).unwrap().replacen(from, to, 1);
            std::fs::write(&p, &text).unwrap();
            let sums = dir.join(BLOCKS).join(SUMS);
            std::fs::remove_file(&sums).unwrap();
            let d = checksum::hash_file(&p).unwrap();
            append_sum(&sums, "b0000000.csv", &d).unwrap();
            let err = finalize_cell(&dir, 3, 2, LIMIT, false, &[], |_| None)
                .unwrap_err()
                .to_string();
            assert!(err.contains(want), "{from:?} -> {to:?}: {err}");
            assert!(!cell_complete(&dir));
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn changed_or_unindexed_blocks_do_not_count() {
        let dir = std::env::temp_dir().join(format!("rwg-rundir-sum-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        write_block(&dir, &block(0, 3, 2), 2).unwrap();
        assert!(block_done(&dir, 0));
        // A digit changed: the rows still parse, the checksum does not match.
        let p = block_path(&dir, 0);
        let text = std::fs::read_to_string(&p)
            .unwrap()
            .replacen(",10", ",11", 1);
        std::fs::write(&p, text).unwrap();
        let err = finalize_cell(&dir, 3, 2, LIMIT, false, &[], |_| None)
            .unwrap_err()
            .to_string();
        assert!(err.contains("b0000000.csv: checksum mismatch"), "{err}");
        assert!(!cell_complete(&dir));
        // A block file the index does not list is not committed.
        std::fs::remove_file(dir.join("blocks").join(SUMS)).unwrap();
        assert!(!block_done(&dir, 0));
        let err = finalize_cell(&dir, 3, 2, LIMIT, false, &[], |_| None).unwrap_err();
        assert!(
            matches!(err, RunDirError::MissingBlock { block: 0, .. }),
            "{err}"
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_resume_trusts_only_blocks_that_match_their_digest() {
        let dir = std::env::temp_dir().join(format!("rwg-rundir-crash-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let samples = 5 * BLOCK_SAMPLES;
        let blocks: Vec<_> = (0..5).map(|b| block(b, samples, 2)).collect();
        write_blocks(&dir, &blocks[..4], 2).unwrap();
        let (index, dropped) = BlockIndex::load_checked(&dir).unwrap();
        assert!(dropped.is_empty() && (0..4).all(|b| index.done(b)));
        // What a crash of the machine can leave of unsynced writes: a
        // zero-filled block, an empty one, a rename that did not reach the
        // disk, and a zero-filled tail of the index (whose line is skipped).
        let len = std::fs::metadata(block_path(&dir, 0)).unwrap().len();
        std::fs::write(block_path(&dir, 0), vec![0u8; len as usize]).unwrap();
        std::fs::write(block_path(&dir, 1), b"").unwrap();
        std::fs::remove_file(block_path(&dir, 2)).unwrap();
        let sums = dir.join(BLOCKS).join(SUMS);
        let mut text = std::fs::read(&sums).unwrap();
        text.extend_from_slice(&[0u8; 40]);
        std::fs::write(&sums, &text).unwrap();
        let (index, dropped) = BlockIndex::load_checked(&dir).unwrap();
        assert_eq!(dropped, ["b0000000.csv", "b0000001.csv", "b0000002.csv"]);
        assert!(!index.done(0) && !index.done(1) && !index.done(2) && index.done(3));
        // Computed again and appended after the damaged tail: the cell
        // finalises into what an undisturbed run gives.
        write_blocks(&dir, &[blocks[4].clone(), blocks[0].clone()], 2).unwrap();
        write_blocks(&dir, &blocks[1..3], 2).unwrap();
        let (index, dropped) = BlockIndex::load_checked(&dir).unwrap();
        assert!(dropped.is_empty() && (0..5).all(|b| index.done(b)));
        let totals = finalize_cell(&dir, samples, 2, LIMIT, false, &[], |_| None).unwrap();
        let clean = dir.with_extension("clean");
        let _ = std::fs::remove_dir_all(&clean);
        write_blocks(&clean, &blocks, 2).unwrap();
        assert_eq!(
            finalize_cell(&clean, samples, 2, LIMIT, false, &[], |_| None).unwrap(),
            totals
        );
        for f in [SCORES_CSV, SAMPLES_CSV] {
            assert_eq!(
                std::fs::read(dir.join(f)).unwrap(),
                std::fs::read(clean.join(f)).unwrap()
            );
        }
        std::fs::remove_dir_all(&dir).unwrap();
        std::fs::remove_dir_all(&clean).unwrap();
    }

    #[test]
    fn pending_blocks_finalise_as_committed_ones() {
        let base = std::env::temp_dir().join(format!("rwg-rundir-pend-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&base);
        let samples = 4 * BLOCK_SAMPLES + 9;
        let blocks: Vec<_> = (0..5).map(|b| block(b, samples, 3)).collect();
        let (files, mixed, memory) = (base.join("f"), base.join("m"), base.join("p"));
        write_blocks(&files, &blocks, 3).unwrap();
        let want = finalize_cell(&files, samples, 3, LIMIT, true, &[], |_| None).unwrap();
        write_blocks(&mixed, &[blocks[1].clone(), blocks[3].clone()], 3).unwrap();
        let pending = [blocks[0].clone(), blocks[2].clone(), blocks[4].clone()];
        let got = finalize_cell(&mixed, samples, 3, LIMIT, true, &pending, |_| None).unwrap();
        assert_eq!(got, want);
        let got = finalize_cell(&memory, samples, 3, LIMIT, true, &blocks, |_| None).unwrap();
        assert_eq!(got, want);
        for dir in [&mixed, &memory] {
            for f in [SCORES_CSV, SAMPLES_CSV, SUMS] {
                assert_eq!(
                    std::fs::read(dir.join(f)).unwrap(),
                    std::fs::read(files.join(f)).unwrap(),
                    "{f}"
                );
            }
            assert!(!dir.join(BLOCKS).exists());
        }
        // A block neither committed nor pending is missing.
        let err = finalize_cell(
            &base.join("none"),
            samples,
            3,
            LIMIT,
            false,
            &pending,
            |_| None,
        );
        assert!(
            matches!(err, Err(RunDirError::MissingBlock { block: 1, .. })),
            "{err:?}"
        );
        std::fs::remove_dir_all(&base).unwrap();
    }
}
