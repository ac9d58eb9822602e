//! `rwg compare` end to end on synthetic run directories.

mod common;
use common::*;
use serde_json::Value;

#[test]
fn compare_side_by_side() {
    let a = synthetic_run("compare-a", 60, 4);
    let b = synthetic_run("compare-b", 30, 4);
    let (a, b) = (a.to_str().unwrap(), b.to_str().unwrap());
    let out = rwg_ok(&["compare", a, b]);
    assert!(
        out.contains("Comparison of 16 cells, 4 episodes per sample"),
        "{out}"
    );
    let body: Vec<&str> = out
        .lines()
        .filter(|l| l.starts_with("CartPole-v0"))
        .collect();
    assert_eq!(body.len(), 8);
    // the two runs of one env × arch × bias are adjacent
    assert!(
        body[0].contains("compare-a") && body[1].contains("compare-b"),
        "{out}"
    );
    assert!(out.contains("norm. best") && out.contains("no solved score"));

    let json: Value =
        serde_json::from_str(&rwg_ok(&["compare", a, b, "--format", "json"])).unwrap();
    let rows = json.as_array().unwrap();
    assert_eq!(rows.len(), 16);
    let r0 = &rows[0];
    assert_eq!(r0["env"], "CartPole-v0");
    let (best, med, solved) = (
        r0["best_mean"].as_f64().unwrap(),
        r0["median_mean"].as_f64().unwrap(),
        r0["solved"].as_f64().unwrap(),
    );
    let norm = r0["normalised_best"].as_f64().unwrap();
    assert!((norm - (best - med) / (solved - med)).abs() < 1e-12);

    let csv = rwg_ok(&["compare", a, b, "--format", "csv"]);
    assert_eq!(csv.lines().count(), 17);
    assert!(csv.starts_with("run,env,arch,bias,samples,"));

    let fig = temp_dir("compare-fig").join("cmp.svg");
    rwg_ok(&["compare", a, b, "--figure", fig.to_str().unwrap()]);
    let svg = std::fs::read_to_string(&fig).unwrap();
    assert!(svg.contains("normalised mean") && svg.contains("compare-a: CartPole-v0"));

    let tex = rwg_ok(&["compare", a, b, "--format", "latex"]);
    assert!(tex.contains("\\toprule"));
}

#[test]
fn compare_refuses_different_settings_unless_forced() {
    let a = synthetic_run("compare-c", 20, 4);
    let b = synthetic_run("compare-d", 20, 3);
    let (a, b) = (a.to_str().unwrap(), b.to_str().unwrap());
    let err = rwg_err(&["compare", a, b]);
    assert!(
        err.contains("not comparable")
            && err.contains("episodes per sample differ: ")
            && err.contains("compare-c has 4, ")
            && err.contains("compare-d has 3"),
        "{err}"
    );
    assert!(err.contains("--force"));
    let out = rwg(&["compare", a, b, "--force"]);
    assert!(out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr)
        .contains("warning: comparing runs whose settings differ"));
}
