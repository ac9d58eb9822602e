//! Tests of block files: group commits and what a resume trusts.

use super::*;
use crate::rundir::export;
use crate::rundir::finalize::finalize_cell;
use crate::rundir::{SAMPLES_CSV, SCORES_CSV};
use rwg_core::sampler::EpisodeResult;

/// The time limit of the test cells (their episodes last 10 to 200 steps).
pub(crate) const LIMIT: u32 = 500;

/// Block `b` of a cell of `samples` networks and `episodes` episodes each,
/// with made-up episodes (scores and lengths that tell rows apart).
pub(crate) fn block(b: u64, samples: u64, episodes: u32) -> BlockResult {
    let r = block_samples(b, samples);
    let n = (r.end - r.start) as usize * episodes as usize;
    let episodes = (0..n)
        .map(|i| EpisodeResult {
            score: (r.start as f64) + i as f64 * 0.5,
            steps: 10 + i as u32,
            non_finite: false,
        })
        .collect();
    BlockResult {
        samples: r,
        episodes,
    }
}

#[test]
fn a_group_commits_like_single_blocks_and_indexes_those_before_a_failure() {
    let base = std::env::temp_dir().join(format!("rwg-rundir-group-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&base);
    std::fs::create_dir_all(&base).unwrap();
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
