//! How far a run directory has got: which cells are finalised and which
//! blocks are committed, for a whole run or for one shard of a study.
//!
//! Everything here only reads, and only counts what is committed (block
//! files listed in `blocks/SHA256SUMS`, a cell's `SHA256SUMS`, each appearing
//! by atomic rename), so it is safe to call while `rwg run` or `rwg merge`
//! writes the same directory: the answer is what was committed at that
//! instant, never a half-written file.

use crate::manifest::Manifest;
use crate::rundir::blocks::{block_index, n_blocks, BlockIndex};
use crate::rundir::finalize::cell_complete;
use crate::rundir::meta::{CellId, ShardMeta};
use crate::rundir::{cell_dir, BLOCKS};
use std::path::Path;

/// Progress of one cell.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CellProgress {
    /// Directory of the cell under `cells/`.
    pub dir: String,
    /// Blocks this run owns: all of the cell's for a whole run, the shard's
    /// share for a shard.
    pub blocks_total: u64,
    /// Of those, the blocks committed (all of them once the cell is finalised).
    pub blocks_done: u64,
    /// Whether `scores.csv` and `samples.csv` are written (whole runs only;
    /// shards never finalise cells).
    pub finalised: bool,
}

impl CellProgress {
    /// Whether nothing is left to compute or write for this cell: finalised
    /// for a whole run, every owned block committed for a shard.
    pub fn done(&self, shard: bool) -> bool {
        if shard {
            self.blocks_done == self.blocks_total
        } else {
            self.finalised
        }
    }
}

/// The cell directory names of a study, in the order the cells run (env,
/// then architecture, then bias), named as [`CellId`] names them. Depends on
/// the manifest only: no plugin is loaded.
pub fn cell_dirs(m: &Manifest) -> Vec<String> {
    let mut dirs = vec![];
    for e in &m.envs {
        for a in &m.architectures {
            for &bias in a.biases(&m.bias) {
                dirs.push(CellId::new(&e.id, &a.name, &a.hidden, bias).dir);
            }
        }
    }
    dirs
}

/// The indices of the committed blocks of the cell in `cell_dir` (sorted):
/// block files the cell's block index lists ([`BlockIndex`]). A missing
/// directory has none; temporary files and unlisted blocks do not count.
pub fn committed_blocks(cell_dir: &Path) -> Vec<u64> {
    let index = BlockIndex::load(cell_dir).unwrap_or_default();
    let Ok(entries) = std::fs::read_dir(cell_dir.join(BLOCKS)) else {
        return vec![];
    };
    let mut found: Vec<u64> = entries
        .filter_map(|e| e.ok())
        .filter_map(|e| block_index(e.file_name().to_str()?))
        .filter(|&b| index.done(b))
        .collect();
    found.sort_unstable();
    found
}

/// Progress of every cell of study `m` in `run_dir`, which holds the whole
/// study (`shard = None`) or the given shard of it.
pub fn progress(run_dir: &Path, m: &Manifest, shard: Option<ShardMeta>) -> Vec<CellProgress> {
    let nb = n_blocks(m.samples);
    cell_dirs(m)
        .into_iter()
        .enumerate()
        .map(|(ci, dir)| {
            let cell_dir = cell_dir(run_dir, &dir);
            let owns = |b: u64| shard.is_none_or(|s| s.owns(ci, nb, b));
            let blocks_total = (0..nb).filter(|&b| owns(b)).count() as u64;
            let finalised = shard.is_none() && cell_complete(&cell_dir);
            let blocks_done = if finalised {
                blocks_total
            } else {
                committed_blocks(&cell_dir)
                    .into_iter()
                    .filter(|&b| b < nb && owns(b))
                    .count() as u64
            };
            CellProgress {
                dir,
                blocks_total,
                blocks_done,
                finalised,
            }
        })
        .collect()
}

/// Sums of a run's progress.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Totals {
    /// Cells with nothing left to do.
    pub cells_done: usize,
    /// Cells of the study.
    pub cells: usize,
    /// Blocks committed (or finalised).
    pub blocks_done: u64,
    /// Blocks owned.
    pub blocks: u64,
}

impl Totals {
    /// Adds up `cells` (of a shard when `shard`).
    pub fn of(cells: &[CellProgress], shard: bool) -> Totals {
        Totals {
            cells_done: cells.iter().filter(|c| c.done(shard)).count(),
            cells: cells.len(),
            blocks_done: cells.iter().map(|c| c.blocks_done).sum(),
            blocks: cells.iter().map(|c| c.blocks_total).sum(),
        }
    }

    /// Whether every cell is done.
    pub fn complete(&self) -> bool {
        self.cells_done == self.cells
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rundir::blocks::{block_path, BLOCK_SAMPLES};

    const STUDY: &str = r#"
samples = 70
episodes = 1
bias = [false, true]
[[architectures]]
name = "0HL"
hidden = []
[[envs]]
id = "CartPole-v1"
"#;

    fn touch(p: &Path) {
        std::fs::create_dir_all(p.parent().unwrap()).unwrap();
        std::fs::write(p, "").unwrap();
    }

    /// An (empty) block, committed: its file and its index line.
    fn commit(cell: &Path, b: u64) {
        let p = block_path(cell, b);
        touch(&p);
        let d = crate::rundir::checksum::hash_file(&p).unwrap();
        let name = p.file_name().unwrap().to_str().unwrap();
        crate::rundir::checksum::append_sum(&cell.join("blocks/SHA256SUMS"), name, &d).unwrap();
    }

    #[test]
    fn counts_committed_blocks_finalised_cells_and_shard_shares() {
        let m = Manifest::parse(STUDY, "s.toml", Path::new(".")).unwrap();
        assert_eq!(
            cell_dirs(&m),
            ["CartPole-v1__0HL__nobias", "CartPole-v1__0HL__bias"]
        );
        let dir = std::env::temp_dir().join(format!("rwg-status-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        assert_eq!(n_blocks(70), 3);
        let c0 = dir.join("cells/CartPole-v1__0HL__nobias");
        let c1 = dir.join("cells/CartPole-v1__0HL__bias");
        commit(&c0, 0);
        commit(&c0, 2);
        // a temporary file, stray names and a block the index does not list
        // do not count
        touch(&c0.join("blocks/b0000001.csv.tmp"));
        touch(&c0.join("blocks/notes.csv"));
        touch(&c0.join("blocks/b1.csv"));
        touch(&c0.join("blocks/b0000001.csv"));
        touch(&c1.join("SHA256SUMS"));
        let p = progress(&dir, &m, None);
        assert_eq!((p[0].blocks_done, p[0].blocks_total), (2, 3));
        assert!(!p[0].done(false));
        assert!(p[1].finalised && p[1].done(false));
        let t = Totals::of(&p, false);
        assert_eq!(
            (t.cells_done, t.cells, t.blocks_done, t.blocks),
            (1, 2, 5, 6)
        );
        assert!(!t.complete());

        // Shard 0/2 owns global blocks 0, 2, 4: cell 0 blocks 0 and 2, cell 1 block 1.
        let s: ShardMeta = "0/2".parse().unwrap();
        let p = progress(&dir, &m, Some(s));
        assert_eq!((p[0].blocks_done, p[0].blocks_total), (2, 2));
        assert!(p[0].done(true));
        assert_eq!((p[1].blocks_done, p[1].blocks_total), (0, 1));
        assert!(!p[1].finalised);
        commit(&c1, 1);
        assert!(Totals::of(&progress(&dir, &m, Some(s)), true).complete());
        assert_eq!(BLOCK_SAMPLES, 32);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
