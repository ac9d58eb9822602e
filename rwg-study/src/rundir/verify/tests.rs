//! Tests of checking a cell's folder as a writer leaves it midway.

use super::*;
use crate::rundir::checksum::{append_sums, hash_file, sums_text};

/// A cell with `n` committed blocks, listed in its block index, and
/// finalised (its `SHA256SUMS` written, the blocks not yet removed) when
/// `finalised`.
fn cell_with_blocks(cell: &Path, n: u64, finalised: bool) {
    let _ = std::fs::remove_dir_all(cell);
    std::fs::create_dir_all(cell.join(BLOCKS)).unwrap();
    let mut listed = vec![];
    for b in 0..n {
        let p = block_path(cell, b);
        std::fs::write(&p, format!("{b},0,1,1\n")).unwrap();
        let name = p.file_name().unwrap().to_str().unwrap().to_string();
        listed.push((name, hash_file(&p).unwrap()));
    }
    let entries: Vec<(&str, _)> = listed.iter().map(|(n, d)| (n.as_str(), *d)).collect();
    append_sums(&cell.join(BLOCKS).join(SUMS), &entries).unwrap();
    if finalised {
        let scores = cell.join("scores.csv");
        std::fs::write(&scores, "sample,episode,score,steps\n").unwrap();
        let sums = [("scores.csv", hash_file(&scores).unwrap())];
        std::fs::write(cell.join(SUMS), sums_text(&sums)).unwrap();
    }
}

#[test]
fn blocks_half_removed_from_a_finalised_cell_are_no_problem_but_from_an_unfinished_one_are() {
    let cells = std::env::temp_dir().join(format!("rwg-verify-tidy-{}", std::process::id()));
    let cell = cells.join("c");
    for finalised in [true, false] {
        cell_with_blocks(&cell, 3, finalised);
        // The writer removing the blocks has taken one, not yet the index
        // (a directory's entries go in the order the file system lists them).
        std::fs::remove_file(block_path(&cell, 1)).unwrap();
        let mut r = VerifyReport::default();
        verify_cell_dir(&cells, "c", None, &mut r);
        if finalised {
            assert!(r.problems.is_empty(), "{:?}", r.problems);
            assert_eq!(r.ok, ["ok  cells/c: 1 files"]);
        } else {
            assert_eq!(r.problems.len(), 1, "{:?}", r.problems);
            assert!(r.problems[0].contains("b0000001.csv"), "{:?}", r.problems);
            assert!(r.problems[0].contains("missing"), "{:?}", r.problems);
        }
    }
    let _ = std::fs::remove_dir_all(&cells);
}
