//! `rwg stats` end to end on synthetic run directories.

mod common;
use common::*;
use serde_json::Value;

#[test]
fn stats_prints_tables_and_writes_files() {
    let dir = synthetic_run("stats", 200, 5);
    let d = dir.to_str().unwrap();
    let out = rwg_ok(&["stats", d]);
    assert!(
        out.contains("Best sample mean (99.9th percentile of sample means), no bias"),
        "{out}"
    );
    assert!(out.contains("with bias"));
    assert!(out.contains("CartPole-v0") && out.contains("Pendulum-v1"));
    assert!(out.contains("Fraction of samples with mean ≥ solved score"));
    assert!(dir.join("stats.json").exists() && dir.join("stats.csv").exists());

    let json: Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("stats.json")).unwrap()).unwrap();
    let cells = json["cells"].as_array().unwrap();
    assert_eq!(cells.len(), 8);
    assert_eq!(cells[0]["samples"], 200);
    let printed: Value = serde_json::from_str(&rwg_ok(&["stats", d, "--format", "json"])).unwrap();
    assert_eq!(printed, json);

    let csv = rwg_ok(&["stats", d, "--format", "csv"]);
    assert_eq!(csv, std::fs::read_to_string(dir.join("stats.csv")).unwrap());
    assert_eq!(csv.lines().count(), 9);

    let tex = rwg_ok(&["stats", d, "--format", "latex"]);
    assert!(tex.contains("\\toprule") && tex.contains("\\midrule") && tex.contains("\\bottomrule"));
    assert_eq!(
        tex.matches("\\begin{table}").count(),
        tex.matches("\\end{table}").count()
    );
    let md = rwg_ok(&["stats", d, "--format", "markdown"]);
    assert!(md.contains("| env | 0HL | 1HL-4 |"), "{md}");
}

#[test]
fn stats_no_write_and_errors() {
    let dir = synthetic_run("stats-nowrite", 20, 3);
    let d = dir.to_str().unwrap();
    rwg_ok(&["stats", d, "--no-write"]);
    assert!(!dir.join("stats.json").exists());

    let scores = dir.join("cells/CartPole-v0__0HL__nobias/scores.csv");
    let text = std::fs::read_to_string(&scores).unwrap();
    std::fs::write(&scores, text.replacen("\n0,1,", "\n0,1,x", 1)).unwrap();
    let err = rwg_err(&["stats", d]);
    assert!(
        err.contains("scores.csv:3:") && err.contains("is not a valid number"),
        "{err}"
    );

    let err = rwg_err(&["stats", "/nonexistent/run"]);
    assert!(
        err.contains("/nonexistent/run is not a run directory (it does not exist)"),
        "{err}"
    );
}
