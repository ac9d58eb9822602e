//! Tests of finalising a cell: from files, pending blocks or both, and
//! the rows and blocks it refuses.

use super::*;
use crate::rundir::blocks::tests::{block, LIMIT};
use crate::rundir::blocks::{block_done, write_block, write_blocks};
use crate::rundir::checksum::append_sum;

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
fn pending_blocks_finalise_as_committed_ones() {
    let base = std::env::temp_dir().join(format!("rwg-rundir-pend-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&base);
    std::fs::create_dir_all(&base).unwrap();
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
