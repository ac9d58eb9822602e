//! A paired comparison written out: the table of `rwg compare --paired`
//! and its CSV.

use super::rows::{verdict_text, PairedRow, Verdict, ALPHA};
use super::PairedComparison;
use crate::fmt::{prob_ci, sig};
use crate::table_render::{Cell, Table};
use rwg_env::float::fmt_f64;
use rwg_study::rundir::export::csv_writer;
use rwg_study::stats::Proportion;

fn p_solved(p: Option<Proportion>) -> Cell {
    p.map_or_else(
        || Cell::plain("no solved score"),
        |p| prob_ci(p.p, p.lo, p.hi),
    )
}

fn count(x: Option<u64>) -> Cell {
    Cell::plain(x.map_or_else(|| "–".into(), |x| x.to_string()))
}

/// `D = 0.012 (p = 0.87)`, `–` when not made.
fn test_cell(t: Option<super::two_sample::TestResult>, with_stat: bool) -> Cell {
    match t {
        None => Cell::plain("–"),
        Some(t) if with_stat => Cell::plain(format!(
            "{} (p = {})",
            sig(t.statistic, 3),
            sig(t.p_value, 2)
        )),
        Some(t) => Cell::plain(sig(t.p_value, 2)),
    }
}

/// The comparison's verdict in a sentence.
pub fn verdict_line(c: &PairedComparison) -> String {
    let (a, b) = (&c.label_a, &c.label_b);
    match c.verdict {
        Verdict::OneBenchmark => format!(
            "verdict: {a} and {b} are one benchmark: no test tells them apart \
             (family-wise error {ALPHA})"
        ),
        Verdict::Different => {
            let archs: Vec<String> = c
                .rows
                .iter()
                .filter(|r| r.verdict == Verdict::Different)
                .map(|r| format!("{} {}", r.arch, crate::run_tables::bias_label(r.bias)))
                .collect();
            format!(
                "verdict: {a} and {b} are different benchmarks: they differ in {} \
                 (family-wise error {ALPHA})",
                archs.join(", ")
            )
        }
        Verdict::Untested => format!("verdict: none: no test applies to {a} and {b}"),
    }
}

/// The paired comparison as a table, one row per architecture × bias.
pub fn paired_table(c: &PairedComparison) -> Table {
    let (a, b) = (&c.label_a, &c.label_b);
    let solved_name = c
        .rows
        .iter()
        .find_map(|r| r.solved_test)
        .map_or("solved test", |t| t.name());
    let header: Vec<Cell> = [
        "arch".to_string(),
        "bias".into(),
        "networks".into(),
        format!("p(solved) {a}"),
        format!("p(solved) {b}"),
        "solved in both".into(),
        format!("only {a}"),
        format!("only {b}"),
        "Spearman ρ".into(),
        "KS D (p)".into(),
        format!("{solved_name} p"),
        "verdict".into(),
    ]
    .into_iter()
    .map(Cell::plain)
    .collect();
    let body = c
        .rows
        .iter()
        .map(|r| {
            let sp = r.solved_pairs;
            vec![
                Cell::plain(r.arch.clone()),
                Cell::plain(if r.bias { "yes" } else { "no" }),
                Cell::plain(r.networks.to_string()),
                p_solved(r.p_solved_a),
                p_solved(r.p_solved_b),
                count(sp.map(|s| s.both)),
                count(sp.map(|s| s.only_a)),
                count(sp.map(|s| s.only_b)),
                Cell::plain(r.spearman.map_or_else(|| "–".into(), |x| format!("{x:.3}"))),
                test_cell(r.ks, true),
                test_cell(r.solved_result, false),
                Cell::plain(match r.verdict {
                    Verdict::OneBenchmark => "one benchmark",
                    Verdict::Different => "different",
                    Verdict::Untested => "untested",
                }),
            ]
        })
        .collect();
    Table {
        title: format!(
            "Paired comparison of {}, {}",
            sides(c),
            episodes_title(&c.rows)
        ),
        header,
        rows: body,
        notes: notes(c),
    }
}

/// What is compared: `E in R and in S`, `E and F in R`, or `E in R and F
/// in S`.
pub fn sides(c: &PairedComparison) -> String {
    let Some(r) = c.rows.first() else {
        return format!("{} and {}", c.label_a, c.label_b);
    };
    if r.env_a == r.env_b {
        format!("{} in {} and in {}", r.env_a, r.run_a, r.run_b)
    } else if r.run_a == r.run_b {
        format!("{} and {} in {}", r.env_a, r.env_b, r.run_a)
    } else {
        format!("{} in {} and {} in {}", r.env_a, r.run_a, r.env_b, r.run_b)
    }
}

fn episodes_title(rows: &[PairedRow]) -> String {
    let e = rows.first().map_or(0, |r| r.episodes);
    format!("{e} episodes per network")
}

/// The notes under the table: why pairs are unpaired or tests not made,
/// how the verdict was reached, and the verdict.
fn notes(c: &PairedComparison) -> Vec<String> {
    let mut out = Vec::new();
    let mut seen = Vec::new();
    for r in &c.rows {
        for why in [&r.unpaired_reason, &r.ks_skipped].into_iter().flatten() {
            if !seen.contains(why) {
                seen.push(why.clone());
            }
        }
    }
    for r in &c.rows {
        if let Some(why) = &r.unpaired_reason {
            if seen.contains(why) {
                out.push(format!(
                    "not the same networks: {why}; the solved flags are compared as two \
                     independent samples (Fisher) and no correlation is given"
                ));
                seen.retain(|s| s != why);
            }
        }
        if let Some(why) = &r.ks_skipped {
            if seen.contains(why) {
                out.push(format!("no KS test: {why}"));
                seen.retain(|s| s != why);
            }
        }
    }
    out.extend(c.notes.iter().cloned());
    out.push(format!(
        "tests: KS compares the distributions of the networks' means; {} the solved flags; \
         Holm's correction over all {} tests keeps the chance of any false \"different\" \
         at {ALPHA}",
        if c.rows.iter().any(|r| r.paired) {
            "McNemar (the same networks)"
        } else {
            "Fisher (different networks)"
        },
        c.rows
            .iter()
            .map(|r| usize::from(r.ks.is_some()) + usize::from(r.solved_result.is_some()))
            .sum::<usize>()
    ));
    for r in &c.rows {
        if r.verdict == Verdict::Different {
            out.push(format!(
                "{} {}: {}",
                r.arch,
                crate::run_tables::bias_label(r.bias),
                verdict_text(r)
            ));
        }
    }
    out.push(verdict_line(c));
    out
}

/// The columns of [`paired_csv`].
pub const PAIRED_CSV_HEADER: [&str; 32] = [
    "run_a",
    "env_a",
    "run_b",
    "env_b",
    "arch",
    "bias",
    "networks",
    "episodes",
    "paired",
    "solved_a",
    "solved_b",
    "p_solved_a",
    "p_solved_a_lo",
    "p_solved_a_hi",
    "p_solved_b",
    "p_solved_b_lo",
    "p_solved_b_hi",
    "solved_both",
    "solved_only_a",
    "solved_only_b",
    "solved_neither",
    "median_mean_a",
    "median_mean_b",
    "spearman_rho",
    "ks_d",
    "ks_p",
    "solved_test",
    "solved_p",
    "ks_rejected",
    "solved_rejected",
    "verdict",
    "unpaired_reason",
];

/// The paired comparison as CSV, one row per architecture × bias, floats
/// in shortest round-trip form, an empty field for what was not computed.
pub fn paired_csv(c: &PairedComparison) -> String {
    let opt = |x: Option<f64>| x.map(fmt_f64).unwrap_or_default();
    let cnt = |x: Option<u64>| x.map(|x| x.to_string()).unwrap_or_default();
    let mut out = Vec::new();
    let mut w = csv_writer(&mut out);
    w.write_record(PAIRED_CSV_HEADER)
        .expect("writing to memory");
    for r in &c.rows {
        let (pa, pb, sp) = (r.p_solved_a, r.p_solved_b, r.solved_pairs);
        let fields = [
            r.run_a.clone(),
            r.env_a.clone(),
            r.run_b.clone(),
            r.env_b.clone(),
            r.arch.clone(),
            r.bias.to_string(),
            r.networks.to_string(),
            r.episodes.to_string(),
            r.paired.to_string(),
            opt(r.solved_a),
            opt(r.solved_b),
            opt(pa.map(|p| p.p)),
            opt(pa.map(|p| p.lo)),
            opt(pa.map(|p| p.hi)),
            opt(pb.map(|p| p.p)),
            opt(pb.map(|p| p.lo)),
            opt(pb.map(|p| p.hi)),
            cnt(sp.map(|s| s.both)),
            cnt(sp.map(|s| s.only_a)),
            cnt(sp.map(|s| s.only_b)),
            cnt(sp.map(|s| s.neither)),
            fmt_f64(r.median_a),
            fmt_f64(r.median_b),
            opt(r.spearman),
            opt(r.ks.map(|t| t.statistic)),
            opt(r.ks.map(|t| t.p_value)),
            r.solved_test
                .map(|t| t.name().to_lowercase())
                .unwrap_or_default(),
            opt(r.solved_result.map(|t| t.p_value)),
            r.ks_rejected.to_string(),
            r.solved_rejected.to_string(),
            match r.verdict {
                Verdict::OneBenchmark => "one_benchmark",
                Verdict::Different => "different",
                Verdict::Untested => "untested",
            }
            .to_string(),
            r.unpaired_reason.clone().unwrap_or_default(),
        ];
        w.write_record(&fields).expect("writing to memory");
    }
    drop(w);
    String::from_utf8(out).expect("UTF-8 fields")
}
