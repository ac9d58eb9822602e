//! Tests of the pairing, the rows' tests, the verdicts and the CSV.

use super::*;
use rwg_study::rundir::data::CellData;

/// A run of one env with a cell per `(arch, hidden)`, each holding one
/// episode per network with the scores `scores`.
fn side(run: &str, env: &str, seed: u64, solved: Option<f64>, scores: &[f64]) -> PairSide {
    let n = scores.len() as u64;
    let cells = vec![
        crate::fixtures::cell(env, "0HL", &[], n, 1, solved),
        crate::fixtures::cell(env, "1HL-4", &[4], n, 1, solved),
    ];
    let meta = crate::fixtures::run(seed, "normal", cells.clone());
    PairSide {
        run: run.into(),
        meta,
        env: env.into(),
        cells: cells
            .into_iter()
            .map(|m| CellData::new(m, 1, scores.to_vec(), vec![1; scores.len()]))
            .collect(),
    }
}

/// 200 scores spread over 0..500, a few at or above 475.
fn scores() -> Vec<f64> {
    (0..200).map(|i| ((i * 89) % 200) as f64 * 2.5).collect()
}

#[test]
fn one_implementation_twice_is_one_benchmark() {
    let a = side("r", "CartPole-v1", 0, Some(475.0), &scores());
    let b = side("r", "gymnax:CartPole-v1", 0, Some(475.0), &scores());
    let c = paired_comparison(&a, &b).unwrap();
    assert_eq!(
        (c.label_a.as_str(), c.label_b.as_str()),
        ("CartPole-v1", "gymnax:CartPole-v1")
    );
    assert_eq!(c.rows.len(), 2);
    let r = &c.rows[0];
    assert!(r.paired, "{:?}", r.unpaired_reason);
    assert_eq!(r.networks, 200);
    assert_eq!(r.spearman, Some(1.0));
    let ks = r.ks.unwrap();
    assert_eq!((ks.statistic, ks.p_value), (0.0, 1.0));
    assert_eq!(r.solved_test, Some(SolvedTest::Mcnemar));
    // 475, 477.5, ..., 497.5: 10 of the 200
    assert_eq!(
        r.solved_pairs,
        Some(SolvedPairs {
            both: 10,
            only_a: 0,
            only_b: 0,
            neither: 190
        })
    );
    assert_eq!(r.verdict, Verdict::OneBenchmark);
    assert_eq!(c.verdict, Verdict::OneBenchmark);
    assert!(
        verdict_line(&c).contains("are one benchmark"),
        "{}",
        verdict_line(&c)
    );
}

#[test]
fn a_shifted_implementation_is_different() {
    let a = side("r", "CartPole-v1", 0, Some(475.0), &scores());
    let shifted: Vec<f64> = scores().iter().map(|x| (x + 100.0).min(500.0)).collect();
    let b = side("r", "gymnax:CartPole-v1", 0, Some(475.0), &shifted);
    let c = paired_comparison(&a, &b).unwrap();
    let r = &c.rows[0];
    assert!(r.ks_rejected && r.solved_rejected, "{r:?}");
    // the 40 networks of 375..472.5 reach 475 only in b
    assert_eq!(r.solved_pairs.unwrap().only_b, 40);
    assert_eq!(r.verdict, Verdict::Different);
    assert_eq!(c.verdict, Verdict::Different);
    let text = verdict_text(r);
    assert!(
        text.starts_with("different: the means are distributed differently (KS p = ")
            && text.contains("; p(solved) differs (McNemar p = "),
        "{text}"
    );
    assert!(verdict_line(&c).contains("differ in 0HL no bias, 1HL-4 no bias"));
}

#[test]
fn other_seed_ids_are_two_samples() {
    let a = side("r", "CartPole-v1", 0, Some(475.0), &scores());
    let b = side("r", "CartPole-v0", 0, Some(475.0), &scores());
    let r = &paired_comparison(&a, &b).unwrap().rows[0];
    assert!(!r.paired);
    assert_eq!(
        r.unpaired_reason.as_deref(),
        Some("the seed ids differ (CartPole-v1 and CartPole-v0)")
    );
    assert_eq!((r.spearman, r.solved_pairs), (None, None));
    assert_eq!(r.solved_test, Some(SolvedTest::Fisher));
    assert_eq!(r.solved_result.unwrap().p_value, 1.0);

    let b = side("s", "CartPole-v1", 1, Some(475.0), &scores());
    let c = paired_comparison(&a, &b).unwrap();
    // one env in two runs: the sides are named by their runs
    assert_eq!((c.label_a.as_str(), c.label_b.as_str()), ("r", "s"));
    assert_eq!(
        c.rows[0].unpaired_reason.as_deref(),
        Some("the manifest seeds differ (0 and 1)")
    );
}

#[test]
fn other_solved_scores_skip_ks_and_untested_rows_say_so() {
    let a = side("r", "CartPole-v1", 0, Some(475.0), &scores());
    let b = side("r", "gymnax:CartPole-v1", 0, Some(195.0), &scores());
    let r = &paired_comparison(&a, &b).unwrap().rows[0];
    assert!(r.ks.is_none());
    assert_eq!(
        r.ks_skipped.as_deref(),
        Some("the solved scores differ (475 and 195): the means are on different scales")
    );
    assert!(r.solved_result.is_some());

    let b = side("r", "gymnax:CartPole-v1", 0, None, &scores());
    let c = paired_comparison(&a, &b).unwrap();
    assert!(c.rows.iter().all(|r| r.verdict == Verdict::Untested));
    assert_eq!(c.verdict, Verdict::Untested);
}

#[test]
fn unequal_counts_compare_the_first_networks() {
    let a = side("r", "CartPole-v1", 0, Some(475.0), &scores());
    let b = side("s", "gymnax:CartPole-v1", 0, Some(475.0), &scores()[..150]);
    let c = paired_comparison(&a, &b).unwrap();
    assert_eq!(c.rows[0].networks, 150);
    assert_eq!(
        c.notes[0],
        "0HL: the cells hold 200 and 150 networks; networks 0 to 149 of each are compared"
    );
}

#[test]
fn no_common_setting_is_an_error() {
    let a = side("r", "CartPole-v1", 0, None, &scores());
    let mut b = side("r", "gymnax:CartPole-v1", 0, None, &scores());
    for c in &mut b.cells {
        c.meta.id.bias = true;
    }
    let e = paired_comparison(&a, &b).unwrap_err().to_string();
    assert_eq!(
        e,
        "CartPole-v1 and gymnax:CartPole-v1 share no architecture and bias setting \
         (CartPole-v1: 0HL no bias, 1HL-4 no bias; gymnax:CartPole-v1: 0HL with bias, \
         1HL-4 with bias)"
    );
}

#[test]
fn csv_has_a_field_per_column_and_the_table_a_row_per_pair() {
    let a = side("r", "CartPole-v1", 0, Some(475.0), &scores());
    let b = side("r", "gymnax:CartPole-v1", 0, Some(475.0), &scores());
    let c = paired_comparison(&a, &b).unwrap();
    let csv = paired_csv(&c);
    let lines: Vec<&str> = csv.lines().collect();
    assert_eq!(lines.len(), 3);
    assert_eq!(lines[0], PAIRED_CSV_HEADER.join(","));
    assert_eq!(
        lines[1].split(',').count(),
        PAIRED_CSV_HEADER.len(),
        "{csv}"
    );
    assert!(
        lines[1].starts_with(
            "r,CartPole-v1,r,gymnax:CartPole-v1,0HL,false,200,1,true,475.0,475.0,0.05,"
        ),
        "{csv}"
    );
    assert!(
        lines[1].ends_with(",1.0,0.0,1.0,mcnemar,1.0,false,false,one_benchmark,"),
        "{csv}"
    );
    let t = paired_table(&c);
    assert_eq!(t.rows.len(), 2);
    assert_eq!(t.header[3].text, "p(solved) CartPole-v1");
    assert_eq!(t.notes.last().unwrap(), &verdict_line(&c));
}
