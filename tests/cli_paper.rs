//! `docs/paper.md` cannot drift from the runs it reports: every number of its
//! tables is recomputed here, in Rust, from the committed run outputs
//! (`docs/paper-run/stats.csv`; `docs/paper-blocks/{nobias,bias}/stats.json`
//! and `stats.csv`, `bias/stats-at-20000.json`, `runtime.csv`) and the
//! paper's published values (`examples/paper-published.csv`), independently
//! of `examples/paper-tables.py`, which printed them; every decimal number of
//! its prose is one of those; and the manifests in `examples/` are the
//! studies of the committed runs.

mod common;
use common::shows;
use rwg_study::manifest::Manifest;
use serde_json::Value;
use std::collections::{BTreeMap, BTreeSet};
use std::path::PathBuf;

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn read(rel: &str) -> String {
    std::fs::read_to_string(repo().join(rel)).unwrap_or_else(|e| panic!("{rel}: {e}"))
}

fn doc() -> String {
    read("docs/paper.md").replace('−', "-")
}

type Key = (String, String);

/// CSV rows (lines starting `#` skipped) as maps from the header's names.
fn csv_rows(rel: &str) -> Vec<BTreeMap<String, String>> {
    let text = read(rel);
    let mut lines = text.lines().filter(|l| !l.starts_with('#'));
    let header: Vec<String> = lines.next().unwrap().split(',').map(String::from).collect();
    lines
        .map(|l| {
            header
                .iter()
                .cloned()
                .zip(l.split(',').map(String::from))
                .collect()
        })
        .collect()
}

fn keyed(rows: Vec<BTreeMap<String, String>>) -> BTreeMap<Key, BTreeMap<String, String>> {
    rows.into_iter()
        .map(|r| ((r["env"].clone(), r["arch"].clone()), r))
        .collect()
}

fn num(row: &BTreeMap<String, String>, k: &str) -> f64 {
    row[k]
        .parse()
        .unwrap_or_else(|_| panic!("{k} = '{}'", row[k]))
}

/// A run's `stats.json` cells by (env, arch).
fn cells(rel: &str) -> BTreeMap<Key, Value> {
    let v: Value = serde_json::from_str(&read(rel)).unwrap();
    v["cells"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| {
            let key = (
                c["env"].as_str().unwrap().into(),
                c["arch"].as_str().unwrap().into(),
            );
            (key, c.clone())
        })
        .collect()
}

fn blocks(cell: &Value, stat: &str) -> Vec<f64> {
    cell["at_n"][stat]["blocks"]
        .as_array()
        .unwrap()
        .iter()
        .map(|b| b.as_f64().unwrap())
        .collect()
}

/// The numbers in `text`, as shown.
fn numbers(text: &str) -> Vec<String> {
    text.split(|c: char| " []():≥×%".contains(c))
        .map(|t| t.trim_end_matches([',', '.', ';']))
        .filter(|t| t.replace(',', "").parse::<f64>().is_ok())
        .map(String::from)
        .collect()
}

/// The rows of the doc's table whose header starts with `header`, as cells.
fn table(doc: &str, header: &str) -> Vec<Vec<String>> {
    let mut lines = doc.lines().skip_while(|l| !l.starts_with(header));
    let head = lines
        .next()
        .unwrap_or_else(|| panic!("docs/paper.md: no table `{header}`"));
    let width = head.split('|').count();
    lines
        .skip(1)
        .take_while(|l| l.starts_with('|'))
        .map(|l| {
            let c: Vec<String> = l.split('|').map(|c| c.trim().to_string()).collect();
            assert_eq!(c.len(), width, "docs/paper.md: a row of another width: {l}");
            c[1..width - 1].to_vec()
        })
        .collect()
}

/// The paper's published values: (table, env, arch, bias, statistic) -> value.
fn published() -> Vec<(String, String, String, bool, String, f64)> {
    csv_rows("examples/paper-published.csv")
        .into_iter()
        .map(|r| {
            (
                r["table"].clone(),
                r["env"].clone(),
                r["arch"].clone(),
                r["bias"] == "true",
                r["statistic"].clone(),
                num(&r, "value"),
            )
        })
        .collect()
}

/// A published value's place among blocks: (below, level, above, position
/// u, statistic).
type Placed = (usize, usize, usize, f64, String);

/// Where `v` (printed to one decimal) lies among `blocks`: (below, level,
/// above, position u).
fn place(v: f64, blocks: &[f64]) -> (usize, usize, usize, f64) {
    let below = blocks.iter().filter(|&&b| b < v - 0.05).count();
    let above = blocks.iter().filter(|&&b| b >= v + 0.05).count();
    let level = blocks.len() - below - above;
    let u = (below as f64 + level as f64 / 2.0 + 0.5) / (blocks.len() as f64 + 1.0);
    (below, level, above, u)
}

fn verdict(below: usize, level: usize, above: usize) -> String {
    let k = below + level + above;
    if below == k {
        format!("above all {k}")
    } else if above == k {
        format!("below all {k}")
    } else {
        "inside".into()
    }
}

/// `[median, min, max]` of a statistic's blocks as `rwg stats` recorded them.
fn spread(cell: &Value, stat: &str) -> [f64; 3] {
    let s = &cell["at_n"][stat];
    ["median", "min", "max"].map(|k| s[k].as_f64().unwrap())
}

fn check_spread(what: &str, shown: &str, cell: &Value, stat: &str) {
    let n = numbers(shown);
    let want = spread(cell, stat);
    assert_eq!(n.len(), 3, "{what}: `{shown}` is not `median [min, max]`");
    for (s, w) in n.iter().zip(want) {
        assert!(shows(s, w), "{what}: shows {shown}, the run has {want:?}");
    }
    // and the recorded spread is the blocks'
    let mut b = blocks(cell, stat);
    b.sort_by(f64::total_cmp);
    assert_eq!(
        (b[0], b[b.len() - 1]),
        (want[1], want[2]),
        "{what}: min/max"
    );
}

fn check_place(what: &str, reach: &str, place_shown: &str, v: f64, b: &[f64]) {
    let (below, level, above, _) = place(v, b);
    assert_eq!(
        reach,
        format!("{} of {}", level + above, b.len()),
        "{what}: blocks reaching"
    );
    assert_eq!(place_shown, verdict(below, level, above), "{what}: place");
}

fn stat_name(s: &str) -> &'static str {
    match s {
        "best" => "best_mean",
        "p99.9" => "p99_9_mean",
        _ => panic!("statistic `{s}`"),
    }
}

struct Runs {
    nobias: BTreeMap<Key, Value>,
    bias: BTreeMap<Key, Value>,
    bias2: BTreeMap<Key, Value>,
    nobias_csv: BTreeMap<Key, BTreeMap<String, String>>,
    bias_csv: BTreeMap<Key, BTreeMap<String, String>>,
}

fn runs() -> Runs {
    Runs {
        nobias: cells("docs/paper-blocks/nobias/stats.json"),
        bias: cells("docs/paper-blocks/bias/stats.json"),
        bias2: cells("docs/paper-blocks/bias/stats-at-20000.json"),
        nobias_csv: keyed(csv_rows("docs/paper-blocks/nobias/stats.csv")),
        bias_csv: keyed(csv_rows("docs/paper-blocks/bias/stats.csv")),
    }
}

fn key(env: &str, arch: &str) -> Key {
    (env.to_string(), arch.to_string())
}

#[test]
fn the_manifests_are_the_studies_of_the_committed_runs() {
    for (example, run, samples) in [
        ("paper-blocks-nobias", "nobias", 200_000),
        ("paper-blocks-bias", "bias", 200_000),
    ] {
        let m = Manifest::load(&repo().join(format!("examples/{example}.toml"))).unwrap();
        let committed =
            Manifest::load(&repo().join(format!("docs/paper-blocks/{run}/manifest.toml"))).unwrap();
        assert_eq!(
            m.study_differences(&committed),
            Vec::<String>::new(),
            "examples/{example}.toml is not the study of docs/paper-blocks/{run}/"
        );
        assert_eq!(m.samples, samples, "{example}: networks per cell");
    }
    let r = runs();
    let at = |c: &BTreeMap<Key, Value>| {
        let a = &c.values().next().unwrap()["at_n"];
        (a["n"].as_u64().unwrap(), a["blocks"].as_u64().unwrap())
    };
    assert_eq!(at(&r.nobias), (10_000, 20), "no bias: 20 blocks of 10^4");
    assert_eq!(at(&r.bias), (10_000, 20), "bias: 20 blocks of 10^4");
    assert_eq!(at(&r.bias2), (20_000, 10), "bias: 10 blocks of 2*10^4");
    assert_eq!(r.nobias.len(), 15);
    assert_eq!(r.bias.len(), 15);
}

#[test]
fn the_no_bias_table_is_the_runs() {
    let (doc, r) = (doc(), runs());
    let rows = table(
        &doc,
        "| env | arch | statistic | paper | rwg: median [min, max] |",
    );
    let want: Vec<_> = published()
        .into_iter()
        .filter(|p| p.0 == "score" && !p.3)
        .collect();
    assert_eq!(
        rows.len(),
        want.len(),
        "one row per published no-bias value"
    );
    for (row, (_, env, arch, _, stat, v)) in rows.iter().zip(want) {
        let what = format!("no bias, {env} {arch} {stat}");
        assert_eq!((&row[0], &row[1]), (&env, &arch), "{what}: row order");
        assert_eq!(stat_name(&row[2]), stat, "{what}");
        assert!(shows(&row[3], v), "{what}: the paper's value");
        let cell = &r.nobias[&key(&env, &arch)];
        check_spread(&what, &row[4], cell, &stat);
        check_place(&what, &row[5], &row[6], v, &blocks(cell, &stat));
    }
}

#[test]
fn the_with_bias_table_and_the_fit_of_n_are_the_runs() {
    let (doc, r) = (doc(), runs());
    let rows = table(&doc, "| env | arch | statistic | paper | rwg at 10000:");
    let want: Vec<_> = published()
        .into_iter()
        .filter(|p| p.0 == "score" && p.3)
        .collect();
    assert_eq!(
        rows.len(),
        want.len(),
        "one row per published with-bias value"
    );
    let mut fit: [Vec<Placed>; 2] = [vec![], vec![]];
    for (row, (_, env, arch, _, stat, v)) in rows.iter().zip(want) {
        let what = format!("bias, {env} {arch} {stat}");
        assert_eq!((&row[0], &row[1]), (&env, &arch), "{what}: row order");
        assert_eq!(stat_name(&row[2]), stat, "{what}");
        assert!(shows(&row[3], v), "{what}: the paper's value");
        let mut informative = false;
        let mut placed = vec![];
        for (i, runs) in [&r.bias, &r.bias2].into_iter().enumerate() {
            let cell = &runs[&key(&env, &arch)];
            let b = blocks(cell, &stat);
            check_spread(&what, &row[4 + 3 * i], cell, &stat);
            check_place(&what, &row[5 + 3 * i], &row[6 + 3 * i], v, &b);
            let p = place(v, &b);
            informative |= p.1 != b.len();
            placed.push(p);
        }
        if informative {
            for (i, p) in placed.into_iter().enumerate() {
                fit[i].push((p.0, p.1, p.2, p.3, stat.clone()));
            }
        }
    }
    let rows = table(&doc, "| N | statistic | values | mean position u |");
    assert_eq!(rows.len(), 6, "best, p99.9 and both at each N");
    let mut rows = rows.iter();
    for (n, placed) in [10_000, 20_000].iter().zip(&fit) {
        for (name, keep) in [
            ("best", Some("best_mean")),
            ("p99.9", Some("p99_9_mean")),
            ("both", None),
        ] {
            let row = rows.next().unwrap();
            let sel: Vec<_> = placed
                .iter()
                .filter(|p| keep.is_none_or(|k| p.4 == k))
                .collect();
            let m = sel.len();
            let mean_u = sel.iter().map(|p| p.3).sum::<f64>() / m as f64;
            let z = (mean_u - 0.5) / (1.0 / (12.0 * m as f64)).sqrt();
            let above_all = sel.iter().filter(|p| p.0 == p.0 + p.1 + p.2).count();
            let below_all = sel.iter().filter(|p| p.2 == p.0 + p.1 + p.2).count();
            let what = format!("fit at N = {n}, {name}");
            assert_eq!(
                (&row[0][..], &row[1][..]),
                (&n.to_string()[..], name),
                "{what}"
            );
            assert_eq!(row[2], m.to_string(), "{what}: values");
            assert!(
                shows(&row[3], mean_u),
                "{what}: mean u {} vs {mean_u}",
                row[3]
            );
            assert!(
                shows(&row[4].replace('+', ""), z),
                "{what}: z {} vs {z}",
                row[4]
            );
            assert_eq!(row[5], above_all.to_string(), "{what}: above all");
            assert_eq!(
                row[6],
                (m - above_all - below_all).to_string(),
                "{what}: inside"
            );
            assert_eq!(row[7], below_all.to_string(), "{what}: below all");
        }
    }
}

/// The Hodges-Lehmann shift `b - a` and its 95% interval (Mann-Whitney,
/// normal approximation).
fn hodges_lehmann(a: &[f64], b: &[f64]) -> [f64; 3] {
    let mut d: Vec<f64> = a
        .iter()
        .flat_map(|x| b.iter().map(move |y| y - x))
        .collect();
    d.sort_by(f64::total_cmp);
    let (n1, n2) = (a.len(), b.len());
    let m = n1 * n2;
    let mid = (d[(m - 1) / 2] + d[m / 2]) / 2.0;
    let c = (m as f64 / 2.0 - 1.96 * ((m * (n1 + n2 + 1)) as f64 / 12.0).sqrt()).floor();
    if c < 1.0 {
        return [mid, d[0], d[m - 1]];
    }
    let c = c as usize;
    [mid, d[c - 1], d[m - c]]
}

/// Newcombe's interval for p(bias) - p(no bias) from the Wilson intervals.
fn newcombe(a: &BTreeMap<String, String>, b: &BTreeMap<String, String>) -> [f64; 3] {
    let (p1, l1, u1) = (
        num(a, "p_solved"),
        num(a, "p_solved_lo"),
        num(a, "p_solved_hi"),
    );
    let (p2, l2, u2) = (
        num(b, "p_solved"),
        num(b, "p_solved_lo"),
        num(b, "p_solved_hi"),
    );
    let d = p2 - p1;
    [
        d,
        d - ((p2 - l2).powi(2) + (u1 - p1).powi(2)).sqrt(),
        d + ((u2 - p2).powi(2) + (p1 - l1).powi(2)).sqrt(),
    ]
}

fn direction(lo: f64, hi: f64) -> &'static str {
    if hi < 0.0 {
        "lower"
    } else if lo > 0.0 {
        "higher"
    } else {
        "no difference shown"
    }
}

fn check_interval(what: &str, shown: &str, want: [f64; 3]) {
    let (nums, word) = shown
        .split_once(": ")
        .unwrap_or_else(|| panic!("{what}: `{shown}` is not `d [lo, hi]: verdict`"));
    let n = numbers(&nums.replace('+', ""));
    assert_eq!(n.len(), 3, "{what}: `{shown}`");
    for (s, w) in n.iter().zip(want) {
        assert!(shows(s, w), "{what}: shows {shown}, want {want:?}");
    }
    assert_eq!(word, direction(want[1], want[2]), "{what}: verdict");
}

#[test]
fn the_bias_comparison_is_the_runs() {
    let (doc, r) = (doc(), runs());
    let rows = table(&doc, "| env | arch | p(solved) | best mean | p99.9 |");
    assert_eq!(rows.len(), 15, "one row per env and architecture");
    let mut tally: BTreeMap<&str, BTreeMap<&str, usize>> = BTreeMap::new();
    for row in &rows {
        let k = key(&row[0], &row[1]);
        let what = format!("bias vs no bias, {} {}", row[0], row[1]);
        let (a, b) = (&r.nobias_csv[&k], &r.bias_csv[&k]);
        if num(a, "solved_count") == 0.0 && num(b, "solved_count") == 0.0 {
            assert_eq!(row[2], "none solved", "{what}");
            *tally
                .entry("p")
                .or_default()
                .entry("none solved")
                .or_default() += 1;
        } else {
            let w = newcombe(a, b);
            check_interval(&format!("{what}: p(solved)"), &row[2], w);
            *tally
                .entry("p")
                .or_default()
                .entry(direction(w[1], w[2]))
                .or_default() += 1;
        }
        for (col, stat) in [(3, "best_mean"), (4, "p99_9_mean")] {
            let w = hodges_lehmann(&blocks(&r.nobias[&k], stat), &blocks(&r.bias[&k], stat));
            check_interval(&format!("{what}: {stat}"), &row[col], w);
            *tally
                .entry(stat)
                .or_default()
                .entry(direction(w[1], w[2]))
                .or_default() += 1;
        }
    }
    // the tally under the table
    for (stat, name) in [
        ("p", "p(solved)"),
        ("best_mean", "best mean"),
        ("p99_9_mean", "p99.9"),
    ] {
        let parts: Vec<String> = tally[stat]
            .iter()
            .map(|(w, n)| format!("{w} {n}"))
            .collect();
        let line = format!("- {name}: {}", parts.join(", "));
        assert!(
            doc.contains(&line),
            "docs/paper.md lacks the tally line `{line}`"
        );
    }
}

#[test]
fn the_runtime_table_is_the_measurement() {
    let doc = doc();
    let rt = keyed(csv_rows("docs/paper-blocks/runtime.csv"));
    let rows = table(&doc, "| env | arch | paper (s) | rwg CPU (s)");
    let want: Vec<_> = published()
        .into_iter()
        .filter(|p| p.0 == "runtime")
        .collect();
    assert_eq!(rows.len(), want.len());
    for (row, (_, env, arch, _, _, v)) in rows.iter().zip(want) {
        let what = format!("runtime, {env} {arch}");
        assert_eq!((&row[0], &row[1]), (&env, &arch), "{what}");
        assert!(shows(&row[2], v), "{what}: the paper's seconds");
        let m = &rt[&key(&env, &arch)];
        let (med, lo, hi) = (
            num(m, "cpu_s_median"),
            num(m, "cpu_s_min"),
            num(m, "cpu_s_max"),
        );
        let n = numbers(&row[3]);
        for (s, w) in n.iter().zip([med, lo, hi]) {
            assert!(
                shows(s, w),
                "{what}: shows {}, measured {med} [{lo}, {hi}]",
                row[3]
            );
        }
        let scale = 10_000.0 * 20.0 / (num(m, "samples") * num(m, "episodes"));
        assert!(
            shows(&row[4], v / (med * scale)),
            "{what}: ratio {}",
            row[4]
        );
    }
    let head = read("docs/paper-blocks/runtime.csv");
    let first = head.lines().next().unwrap();
    assert!(
        first.starts_with("# rwg "),
        "runtime.csv names the rwg it timed"
    );
}

#[test]
fn the_paper_toml_tables_are_its_committed_run() {
    let doc = doc();
    let stats = keyed(
        csv_rows("docs/paper-run/stats.csv")
            .into_iter()
            .filter(|r| r["bias"] == "false")
            .collect(),
    );
    let archs = ["0HL", "1HL-4", "2HL-4-4"];
    let tables: Vec<Vec<Vec<String>>> = doc
        .match_indices("| env | 0HL | 1HL-4 | 2HL-4-4 |")
        .map(|(i, _)| table(&doc[i..], "| env | 0HL | 1HL-4 | 2HL-4-4 |"))
        .collect();
    assert_eq!(tables.len(), 3, "Table 3, p(solved) and 1/p of runs/paper");
    for (t, kind) in tables.iter().zip(["table3", "p", "guesses"]) {
        assert_eq!(t.len(), 5, "{kind}: five envs");
        for row in t {
            for (arch, shown) in archs.iter().zip(&row[1..]) {
                let s = &stats[&key(&row[0], arch)];
                let what = format!("runs/paper {kind}, {} {arch}: `{shown}`", row[0]);
                let n = numbers(shown);
                let want: Vec<f64> = match kind {
                    "table3" => vec![num(s, "best_mean"), num(s, "p99.9_mean")],
                    "p" => vec![
                        num(s, "p_solved"),
                        num(s, "p_solved_lo"),
                        num(s, "p_solved_hi"),
                    ],
                    _ if shown.starts_with("none seen") => vec![num(s, "expected_guesses_lo")],
                    _ => vec![
                        num(s, "expected_guesses"),
                        num(s, "expected_guesses_lo"),
                        num(s, "expected_guesses_hi"),
                    ],
                };
                assert_eq!(n.len(), want.len(), "{what}");
                for (x, w) in n.iter().zip(&want) {
                    assert!(shows(x, *w), "{what}: the run has {want:?}");
                }
            }
        }
    }
}

/// Decimal numbers of the prose (outside tables and code blocks) that are
/// not in a table the tests above check: each with why it may stand.
const PROSE_CONSTANTS: &[(&str, &str)] = &[
    ("0.05", "the rounding band of a one-decimal published value"),
    ("0.5", "the mean of a position uniform on (0, 1)"),
    ("99.9", "the percentile the paper reports"),
    (
        "0.1",
        "the top 0.1% of episodes; MountainCarContinuous' effort cost, 0.1 a^2",
    ),
    ("1.96", "the normal quantile of a 95% interval"),
    ("2.10", "the paper's Xeon E5-2620's clock, GHz"),
];

#[test]
fn every_decimal_of_the_prose_is_checked() {
    let doc = doc();
    let mut known: BTreeSet<String> = BTreeSet::new();
    let mut in_code = false;
    for line in doc.lines() {
        if line.starts_with("```") {
            in_code = !in_code;
        } else if line.starts_with('|') && !in_code {
            known.extend(
                numbers(&line.replace('|', " "))
                    .into_iter()
                    .map(|n| n.replace('+', "")),
            );
        }
    }
    for p in published() {
        known.insert(format!("{:.1}", p.5));
    }
    // the coverage of K blocks, (K - 1)/(K + 1), as a percentage
    for k in [10, 20, 40] {
        known.insert(format!("{:.0}", 100.0 * (k - 1) as f64 / (k + 1) as f64));
        known.insert(format!("{:.1}", 100.0 * (k - 1) as f64 / (k + 1) as f64));
    }
    known.extend(PROSE_CONSTANTS.iter().map(|(n, _)| n.to_string()));
    // the committed runs' env steps, as `2.25 × 10^9`
    for run in [
        "docs/paper-run",
        "docs/paper-blocks/nobias",
        "docs/paper-blocks/bias",
    ] {
        let v: Value = serde_json::from_str(&read(&format!("{run}/run.json"))).unwrap();
        let steps = v["env_steps"].as_f64().unwrap();
        let exp = steps.log10().floor() as i32;
        known.insert(format!("{:.2}", steps / 10f64.powi(exp)));
    }
    let mut in_code = false;
    for (i, line) in doc.lines().enumerate() {
        if line.starts_with("```") {
            in_code = !in_code;
            continue;
        }
        if in_code || line.starts_with('|') {
            continue;
        }
        let text = line.replace(['`', '*'], "");
        for n in numbers(&text) {
            if n.contains('.') {
                let bare = n.trim_start_matches('+').to_string();
                assert!(
                    known.contains(&bare)
                        || known.contains(&format!("-{bare}"))
                        || known.contains(bare.trim_start_matches('-')),
                    "docs/paper.md:{}: {n} is in no checked table (line: {line})",
                    i + 1
                );
            }
        }
    }
}

/// The 95% Wilson interval of `c` successes in `n`.
fn wilson(c: f64, n: f64) -> (f64, f64) {
    let (z, p) = (1.96f64, c / n);
    let den = 1.0 + z * z / n;
    let mid = (p + z * z / (2.0 * n)) / den;
    let half = z * (p * (1.0 - p) / n + z * z / (4.0 * n * n)).sqrt() / den;
    ((mid - half).max(0.0), (mid + half).min(1.0))
}

/// How many of `n` networks must reach a value for the statistic to reach it.
fn needed(stat: &str, n: usize) -> usize {
    if stat == "best_mean" {
        1
    } else {
        n - (0.999 * (n - 1) as f64).floor() as usize
    }
}

/// P(Binomial(n, q) >= j).
fn at_least(j: usize, n: usize, q: f64) -> f64 {
    if q <= 0.0 {
        return if j > 0 { 0.0 } else { 1.0 };
    }
    if q >= 1.0 {
        return 1.0;
    }
    let (mut below, mut log_c) = (0.0, 0.0);
    for k in 0..j {
        if k > 0 {
            log_c += ((n - k + 1) as f64 / k as f64).ln();
        }
        below += (log_c + k as f64 * q.ln() + (n - k) as f64 * (-q).ln_1p()).exp();
    }
    (1.0 - below).max(0.0)
}

#[test]
fn the_values_outside_the_blocks_and_their_chances_are_the_runs() {
    let (doc, r) = (doc(), runs());
    // which published values lie outside their blocks, from the blocks
    let mut outside = BTreeSet::new();
    for (table, env, arch, bias, stat, v) in published() {
        if table != "score" {
            continue;
        }
        let sets: Vec<&BTreeMap<Key, Value>> = if bias {
            vec![&r.bias, &r.bias2]
        } else {
            vec![&r.nobias]
        };
        for cells in sets {
            let cell = &cells[&key(&env, &arch)];
            let b = blocks(cell, &stat);
            let (below, level, above, _) = place(v, &b);
            let word = verdict(below, level, above);
            if word != "inside" {
                let n = cell["at_n"]["n"].as_u64().unwrap();
                outside.insert((env.clone(), arch.clone(), bias, stat.clone(), n, word));
            }
        }
    }
    let tails = csv_rows("docs/paper-blocks/tails.csv");
    let listed: BTreeSet<_> = tails
        .iter()
        .map(|t| {
            (
                t["env"].clone(),
                t["arch"].clone(),
                t["bias"] == "true",
                t["statistic"].clone(),
                t["n"].parse::<u64>().unwrap(),
                t["place"].clone(),
            )
        })
        .collect();
    assert_eq!(
        listed, outside,
        "tails.csv lists exactly the values outside their blocks"
    );
    let rows = table(
        &doc,
        "| env | arch | bias | statistic | paper | N | place |",
    );
    assert_eq!(
        rows.len(),
        tails.len(),
        "one row per value outside its blocks"
    );
    for (row, t) in rows.iter().zip(&tails) {
        let what = format!("outside: {row:?}");
        assert_eq!((&row[0], &row[1]), (&t["env"], &t["arch"]), "{what}");
        assert_eq!(
            row[2],
            if t["bias"] == "true" { "yes" } else { "no" },
            "{what}"
        );
        assert_eq!(stat_name(&row[3]), t["statistic"], "{what}");
        assert!(shows(&row[4], num(t, "value")), "{what}");
        assert_eq!((&row[5], &row[6]), (&t["n"], &t["place"]), "{what}");
        let (c, m) = (num(t, "beyond"), num(t, "networks"));
        assert_eq!(
            row[7],
            format!("{} of {}", t["beyond"], t["networks"]),
            "{what}"
        );
        let (lo, hi) = wilson(c, m);
        let n: usize = t["n"].parse().unwrap();
        let j = needed(&t["statistic"], n);
        let chance: Vec<f64> = if t["place"].starts_with("above") {
            [c / m, lo, hi].iter().map(|&q| at_least(j, n, q)).collect()
        } else {
            [c / m, hi, lo]
                .iter()
                .map(|&q| 1.0 - at_least(j, n, q))
                .collect()
        };
        let shown = numbers(&row[8]);
        assert_eq!(shown.len(), 3, "{what}");
        for (s, w) in shown.iter().zip(&chance) {
            assert!(shows(s, *w), "{what}: chance {} vs {chance:?}", row[8]);
        }
    }
}
