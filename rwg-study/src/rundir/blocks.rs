//! Block files: the unit a cell's networks are computed and committed in.
//!
//! A cell's networks are computed in blocks of [`BLOCK_SAMPLES`] consecutive
//! samples. Each finished block is committed atomically (temporary file, then
//! rename) as `cells/<cell>/blocks/b<index>.csv` and listed with its digest
//! in `blocks/SHA256SUMS` ([`BlockIndex`]), so a run killed at any instant
//! loses at most the blocks in flight, and a resumed run skips the blocks on
//! disk. When every block of a cell is there, [`finalize_cell`] (in
//! [`crate::rundir::finalize`]) turns them into the cell's final files.

use crate::rundir::checksum::{self, append_sum, append_sums_unsynced, read_sums, Digest, SUMS};
use crate::rundir::error::io_err;
use crate::rundir::export::{self, write_atomic_hashed, write_score_rows, AtomicFile};
use crate::rundir::rows::CellRows;
use crate::rundir::BLOCKS;
use rwg_core::sampler::BlockResult;
use std::collections::BTreeMap;
use std::ops::Range;
use std::path::{Path, PathBuf};

pub use crate::rundir::error::RunDirError;
pub use crate::rundir::finalize::{
    cell_complete, check_episode, finalize_cell, tidy_complete_cell, CellTotals,
};

/// Samples per block: the unit of parallel work, of commits and of shards.
pub const BLOCK_SAMPLES: u64 = 32;

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

/// Commits a block atomically: its `scores.csv` rows, without header.
pub fn write_block(
    cell_dir: &Path,
    block: &BlockResult,
    rows: impl Into<CellRows>,
) -> Result<(), RunDirError> {
    write_blocks(cell_dir, std::slice::from_ref(block), rows)
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
    rows: impl Into<CellRows>,
) -> Result<(), RunDirError> {
    let rows = rows.into();
    let dir = cell_dir.join(BLOCKS);
    if !dir.is_dir() {
        // (only the cell's folder and its blocks/: never cells/ or the run
        // directory, should they have been moved or deleted)
        export::create_dir_in(cell_dir).map_err(io_err(cell_dir))?;
        export::create_dir_in(&dir).map_err(io_err(&dir))?;
    }
    let mut done = Vec::with_capacity(blocks.len());
    let mut failed = None;
    for block in blocks {
        let b = block.samples.start / BLOCK_SAMPLES;
        let path = block_path(cell_dir, b);
        let written = AtomicFile::create(&path).and_then(|mut f| {
            write_score_rows(&mut f, block, rows)?;
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
    checksum::check(&from, &want, &checksum::digest_of(&bytes))?;
    let to = block_path(dst, b);
    let dir = to.parent().expect("block path has a parent");
    export::create_dir_in(dir).map_err(io_err(dir))?;
    let digest = write_atomic_hashed(&to, &bytes).map_err(io_err(&to))?;
    append_sum(&dir.join(SUMS), &block_name(b), &digest)
}

#[cfg(test)]
pub(crate) mod tests;
