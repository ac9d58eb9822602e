//! Tests of the comparison's settings check and CSV.

use super::*;
use rwg_study::rundir::data::CellData;
use rwg_study::rundir::meta::RunMeta;

fn meta(episodes: u32, dist: &str, archs: &[&str]) -> RunMeta {
    let cells = archs
        .iter()
        .map(|a| crate::fixtures::cell("E", a, &[], 10, episodes, None))
        .collect();
    crate::fixtures::run(0, dist, cells)
}

#[test]
fn differences_are_named() {
    let a = meta(20, "normal", &["0HL"]);
    assert!(settings_differences(&[("a", &a), ("b", &a.clone())]).is_empty());
    let b = meta(10, "uniform", &["0HL", "1HL-4"]);
    let d = settings_differences(&[("a", &a), ("b", &b)]);
    assert_eq!(d.len(), 3, "{d:?}");
    assert_eq!(d[0], "episodes per sample differ: a has 20, b has 10");
    assert_eq!(
        d[1],
        "weight distributions differ: a has normal, b has uniform"
    );
    assert!(
        d[2].starts_with("architectures differ: a has 0HL [] nobias; b has 0HL [] nobias, 1HL-4")
    );
}

/// The header and quoting of the hand-written writer this replaced: a
/// field is quoted only when it holds a comma, a quote or a line break.
#[test]
fn csv_keeps_its_header_and_quotes_only_what_must_be() {
    let m = meta(2, "normal", &["0HL"]);
    let data = CellData::new(m.cells[0].clone(), 2, vec![1.0, 2.0, 3.0, 4.0], vec![1; 4]);
    let row = |run: &str| CompareRow {
        run: run.into(),
        summary: data.summary(),
        normalised_best: None,
        normalised_p99_9: Some(0.5),
        difficulty_rank: 1,
    };
    let csv = compare_csv(&[row("plain"), row("a,\"b\""), row("two\nlines")]);
    // a cell with non_finite = "end" gives its count; others leave it empty
    let mut counted = row("counted");
    counted.summary.non_finite_episodes = Some(3);
    assert!(compare_csv(&[counted])
        .lines()
        .nth(1)
        .unwrap()
        .ends_with(",1,3"));
    assert!(csv.ends_with('\n') && !csv.contains('\r'), "{csv:?}");
    let lines: Vec<&str> = csv.lines().collect();
    assert_eq!(
        lines[0],
        "run,env,arch,bias,samples,episodes,solved,p_solved,p_solved_lo,p_solved_hi,\
         expected_guesses,expected_guesses_lo,best_mean,p99.9_mean,median_mean,\
         normalised_best,normalised_p99.9,difficulty_rank,non_finite_episodes"
    );
    assert!(lines[1].starts_with("plain,E,0HL,false,"), "{csv}");
    assert!(lines[1].ends_with(",,0.5,1,"), "{csv}");
    assert_eq!(lines[1].split(',').count(), 19, "{csv}");
    assert_eq!(lines[2], lines[1].replacen("plain", "\"a,\"\"b\"\"\"", 1));
    assert_eq!(
        format!("{}\n{}", lines[3], lines[4]),
        lines[1].replacen("plain", "\"two\nlines\"", 1)
    );
}
