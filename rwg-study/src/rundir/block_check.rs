//! The one check of a cell's committed blocks, shared by `rwg verify` and
//! `rwg merge`: every block `blocks/SHA256SUMS` lists must be there with the
//! digest recorded, and a shard marked finished must hold every block it
//! owns. A block file without an index line is not committed (a resumed
//! run computes it again) and is no problem.

use crate::rundir::blocks::{block_index, BlockIndex};
use crate::rundir::checksum::{self, SUMS};
use crate::rundir::error::RunDirError;
use crate::rundir::meta::ShardMeta;
use crate::rundir::BLOCKS;
use std::path::Path;

/// What [`check_blocks`] found in one cell.
#[derive(Debug, Default)]
pub struct BlockCheck {
    /// The cell's index (the blocks listed in `blocks/SHA256SUMS` whose file
    /// is there).
    pub index: BlockIndex,
    /// Blocks listed whose file is there with the recorded digest.
    pub committed: usize,
    /// Block files without an index line (to be computed again).
    pub uncommitted: usize,
    /// Listed blocks that are gone, unreadable or changed, each naming its file.
    pub problems: Vec<RunDirError>,
}

/// Checks the committed blocks of the cell in `cell_dir`: every block its
/// index lists must exist and have the digest recorded. `Err` only when the
/// index itself cannot be read.
pub fn check_blocks(cell_dir: &Path) -> Result<BlockCheck, RunDirError> {
    let index = BlockIndex::load(cell_dir)?;
    let dir = cell_dir.join(BLOCKS);
    let mut check = BlockCheck::default();
    for (name, want) in index.listed() {
        let path = dir.join(name);
        match checksum::hash_file(&path) {
            Ok(got) => match checksum::check(&path, want, &got) {
                Ok(()) => check.committed += 1,
                Err(e) => check.problems.push(e),
            },
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                check.problems.push(RunDirError::ListedMissing {
                    path,
                    index: dir.join(SUMS),
                })
            }
            Err(source) => check.problems.push(RunDirError::Io { path, source }),
        }
    }
    check.uncommitted = match std::fs::read_dir(&dir) {
        Ok(rd) => rd
            .filter_map(|e| e.ok())
            .filter_map(|e| e.file_name().to_str().and_then(block_index))
            .filter(|&b| !index.is_listed(b))
            .count(),
        Err(_) => 0,
    };
    check.index = index;
    Ok(check)
}

/// The first block of cell `cell` (of `blocks_per_cell`) that `shard` owns
/// and `index` does not hold committed, if any: what a finished shard must
/// not lack.
pub fn first_missing_owned(
    index: &BlockIndex,
    shard: ShardMeta,
    cell: usize,
    blocks_per_cell: u64,
) -> Option<u64> {
    (0..blocks_per_cell).find(|&b| shard.owns(cell, blocks_per_cell, b) && !index.done(b))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rundir::blocks::block_path;
    use crate::rundir::checksum::{append_sum, hash_file};

    #[test]
    fn a_listed_block_that_is_gone_or_changed_is_a_problem_and_an_unlisted_one_is_not() {
        let cell = std::env::temp_dir().join(format!("rwg-block-check-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&cell);
        let dir = cell.join(BLOCKS);
        std::fs::create_dir_all(&dir).unwrap();
        for b in 0..3u64 {
            let p = block_path(&cell, b);
            std::fs::write(&p, format!("{b}\n")).unwrap();
            let name = p.file_name().unwrap().to_str().unwrap().to_string();
            append_sum(&dir.join(SUMS), &name, &hash_file(&p).unwrap()).unwrap();
        }
        std::fs::write(block_path(&cell, 3), "3\n").unwrap(); // never listed
        let c = check_blocks(&cell).unwrap();
        assert_eq!((c.committed, c.uncommitted, c.problems.len()), (3, 1, 0));
        std::fs::remove_file(block_path(&cell, 0)).unwrap();
        std::fs::write(block_path(&cell, 2), "two\n").unwrap();
        let c = check_blocks(&cell).unwrap();
        assert_eq!((c.committed, c.uncommitted), (1, 1));
        let msgs: Vec<String> = c.problems.iter().map(|p| p.to_string()).collect();
        assert!(
            msgs[0].contains("b0000000.csv: missing: listed in"),
            "{msgs:?}"
        );
        assert!(
            msgs[1].contains("b0000002.csv: checksum mismatch"),
            "{msgs:?}"
        );
        let shard = ShardMeta { index: 0, count: 2 };
        // shard 0 of 2 owns blocks 0 and 2 of cell 0 (3 blocks per cell)
        assert_eq!(first_missing_owned(&c.index, shard, 0, 3), Some(0));
        let _ = std::fs::remove_dir_all(&cell);
    }
}
