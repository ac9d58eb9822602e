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

/// The sample means of a cell, in sample order, from its samples.csv.
fn cell_means(dir: &std::path::Path, cell: &str) -> Vec<f64> {
    let text = std::fs::read_to_string(dir.join("cells").join(cell).join("samples.csv")).unwrap();
    text.lines()
        .skip(1)
        .map(|l| l.split(',').nth(1).unwrap().parse().unwrap())
        .collect()
}

#[test]
fn stats_at_n_gives_the_spread_over_disjoint_blocks() {
    let dir = synthetic_run("stats-at-n", 210, 5);
    let d = dir.to_str().unwrap();
    // the default outputs first: they must come back byte for byte later
    rwg_ok(&["stats", d]);
    let csv0 = std::fs::read_to_string(dir.join("stats.csv")).unwrap();
    let json0 = std::fs::read_to_string(dir.join("stats.json")).unwrap();
    assert!(!json0.contains("at_n") && !csv0.contains("at_n"));

    // 210 networks, N = 50: 4 blocks, 10 networks left out
    let out = rwg_ok(&["stats", d, "--at-n", "50"]);
    for title in [
        "Best sample mean at N = 50 networks, median [min, max] over 4 disjoint blocks, no bias",
        "99.9th percentile of sample means at N = 50 networks, median [min, max] over 4 disjoint blocks, with bias",
        "probability (K − 1)/(K + 1) = 0.60 for K = 4",
    ] {
        assert!(out.contains(title), "{title}\n{out}");
    }
    let json: Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("stats.json")).unwrap()).unwrap();
    for cell in json["cells"].as_array().unwrap() {
        let a = &cell["at_n"];
        assert_eq!((a["n"].as_u64(), a["blocks"].as_u64()), (Some(50), Some(4)));
        assert_eq!(a["unused"], 10);
        // each block's best mean, recomputed from samples.csv
        let means = cell_means(&dir, cell["dir"].as_str().unwrap());
        let want: Vec<f64> = means
            .chunks_exact(50)
            .take(4)
            .map(|b| b.iter().copied().fold(f64::NEG_INFINITY, f64::max))
            .collect();
        let got: Vec<f64> = a["best_mean"]["blocks"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_f64().unwrap())
            .collect();
        assert_eq!(got, want, "{}", cell["dir"]);
        let (lo, hi) = (
            a["best_mean"]["min"].as_f64(),
            a["best_mean"]["max"].as_f64(),
        );
        assert_eq!(lo, want.iter().copied().reduce(f64::min));
        assert_eq!(hi, want.iter().copied().reduce(f64::max));
        assert!(a["p99_9_mean"]["max"].as_f64() <= hi);
    }
    // stats.csv: the default columns unchanged, 8 more at the end
    let csv = std::fs::read_to_string(dir.join("stats.csv")).unwrap();
    for (with, without) in csv.lines().zip(csv0.lines()) {
        let extra = with
            .strip_prefix(without)
            .expect("the same leading columns");
        assert_eq!(extra.matches(',').count(), 8, "{extra}");
    }
    assert!(csv.lines().next().unwrap().ends_with(
        ",at_n,at_n_blocks,best_mean_at_n_min,best_mean_at_n_median,best_mean_at_n_max,\
         p99.9_mean_at_n_min,p99.9_mean_at_n_median,p99.9_mean_at_n_max"
    ));
    // deterministic, and printed as written
    let printed = rwg_ok(&["stats", d, "--at-n", "50", "--no-write", "--format", "json"]);
    assert_eq!(
        serde_json::from_str::<Value>(&printed).unwrap(),
        serde_json::from_str::<Value>(&std::fs::read_to_string(dir.join("stats.json")).unwrap())
            .unwrap()
    );
    assert_eq!(
        printed,
        rwg_ok(&["stats", d, "--at-n", "50", "--no-write", "--format", "json"])
    );
    assert_eq!(
        rwg_ok(&["stats", d, "--at-n", "50", "--format", "csv"]),
        csv
    );

    // asked for no more: the default files come back byte for byte
    rwg_ok(&["stats", d]);
    assert_eq!(
        std::fs::read_to_string(dir.join("stats.csv")).unwrap(),
        csv0
    );
    assert_eq!(
        std::fs::read_to_string(dir.join("stats.json")).unwrap(),
        json0
    );

    // the report shows it where it shows best mean and p99.9
    let page = dir.join("at-n.html");
    rwg_ok(&["report", d, "--at-n", "70", "--out", page.to_str().unwrap()]);
    let html = std::fs::read_to_string(&page).unwrap();
    assert!(
        html.contains(
            "Best sample mean at N = 70 networks, median [min, max] over 3 disjoint blocks"
        ),
        "no spread table in the report"
    );
    assert!(
        html.contains("at N = 70 networks, median [min, max] over 3 disjoint blocks: best mean ")
    );
    rwg_ok(&["report", d, "--out", page.to_str().unwrap()]);
    assert!(!std::fs::read_to_string(&page)
        .unwrap()
        .contains("disjoint blocks"));
}

#[test]
fn stats_at_n_refuses_bad_sizes() {
    let dir = synthetic_run("stats-at-n-bad", 30, 2);
    let d = dir.to_str().unwrap();
    let err = rwg_err(&["stats", d, "--at-n", "0"]);
    assert!(
        err.contains("--at-n")
            && err.contains("the study size N must be at least 1 network, got 0"),
        "{err}"
    );
    for bad in ["abc", "2.5", "-3", "", "1e4"] {
        let err = rwg_err(&["stats", d, &format!("--at-n={bad}")]);
        assert!(
            err.contains("--at-n")
                && err.contains(&format!(
                    "expected a whole number of networks (such as 10000), found `{bad}`"
                )),
            "{bad}: {err}"
        );
    }
    // one block only, and more than the cell: the first cell is named
    for (n, needed) in [("16", "32"), ("30", "60"), ("1000", "2000")] {
        let err = rwg_err(&["stats", d, "--at-n", n]);
        assert!(
            err.contains(&format!(
                "error: --at-n {n}: cell CartPole-v0__0HL__nobias: 30 networks hold fewer than \
                 2 disjoint blocks of {n} (2 × {n} = {needed} are needed); choose N ≤ 15 or run \
                 more networks (rwg run MANIFEST --samples {needed} --out NEW_DIR)"
            )),
            "{err}"
        );
        assert_eq!(err.lines().count(), 1, "{err}");
    }
    assert!(
        !dir.join("stats.json").exists(),
        "a refused size wrote stats"
    );
    let err = rwg_err(&["report", d, "--at-n", "16"]);
    assert!(
        err.contains("--at-n 16: cell CartPole-v0__0HL__nobias: 30 networks"),
        "{err}"
    );
    assert!(rwg_ok(&["stats", d, "--at-n", "15", "--no-write"]).contains("over 2 disjoint blocks"));
}

#[test]
fn rows_no_episode_can_have_are_refused_though_their_digests_match() {
    let dir = synthetic_run("stats-nan", 20, 3);
    let d = dir.to_str().unwrap();
    let cell = dir.join("cells/CartPole-v0__0HL__nobias");
    // A score of NaN in scores.csv, its index line made to match.
    let scores = cell.join("scores.csv");
    let good = std::fs::read_to_string(&scores).unwrap();
    let line: Vec<&str> = good.lines().nth(2).unwrap().split(',').collect();
    let bad = format!("{},{},NaN,{}", line[0], line[1], line[3]);
    std::fs::write(
        &scores,
        good.replacen(good.lines().nth(2).unwrap(), &bad, 1),
    )
    .unwrap();
    reindex(&cell, "scores.csv");
    let err = rwg_err(&["stats", d, "--no-write"]);
    assert!(
        err.contains("scores.csv:3: score NaN is not a finite number"),
        "{err}"
    );
    // More steps than the cell's time limit (200).
    let bad = format!("{},{},1.0,201", line[0], line[1]);
    std::fs::write(
        &scores,
        good.replacen(good.lines().nth(2).unwrap(), &bad, 1),
    )
    .unwrap();
    reindex(&cell, "scores.csv");
    let err = rwg_err(&["stats", d, "--no-write"]);
    assert!(
        err.contains("scores.csv:3: 201 steps: an episode of this cell lasts 1 to 200"),
        "{err}"
    );
    std::fs::write(&scores, &good).unwrap();
    reindex(&cell, "scores.csv");
    // A mean of NaN in samples.csv: `rwg top` would rank it first.
    let samples = cell.join("samples.csv");
    let text = std::fs::read_to_string(&samples).unwrap();
    let first: Vec<&str> = text.lines().nth(1).unwrap().split(',').collect();
    let bad = format!("{},NaN,{}", first[0], first[2..].join(","));
    std::fs::write(
        &samples,
        text.replacen(text.lines().nth(1).unwrap(), &bad, 1),
    )
    .unwrap();
    reindex(&cell, "samples.csv");
    let err = rwg_err(&["top", d]);
    assert!(
        err.contains("samples.csv:2: mean NaN is not a finite number"),
        "{err}"
    );
}

/// A run of 4 cells stopped by an env error after its first `finished`
/// cells (CartPole-v1, with and without bias; then a plugin env whose 2nd
/// step fails), and the same study's CartPole cells alone, finished.
fn stopped_run(name: &str, finished: usize) -> (std::path::PathBuf, String) {
    let dir = temp_dir(name);
    let broken = format!(
        "[[envs]]\nid = \"broken/NaNReward-v0\"\nplugin = \"{}\"\n",
        broken_plugin().display()
    );
    let cartpole = "[[envs]]\nid = \"CartPole-v1\"\n";
    let head = "samples = 40\nepisodes = 2\nbias = [false, true]\n\
                [[architectures]]\nname = \"0HL\"\nhidden = []\n";
    let envs = match finished {
        0 => format!("{broken}{cartpole}"),
        _ => format!("{cartpole}{broken}"),
    };
    let m = dir.join("m.toml");
    std::fs::write(&m, format!("{head}{envs}")).unwrap();
    let run = dir.join("run");
    let err = rwg_err(&[
        "run",
        m.to_str().unwrap(),
        "--out",
        run.to_str().unwrap(),
        "-q",
    ]);
    assert!(err.contains("NaN"), "{err}");
    let whole = dir.join("whole");
    std::fs::write(&m, format!("{head}{cartpole}")).unwrap();
    rwg_ok(&[
        "run",
        m.to_str().unwrap(),
        "--out",
        whole.to_str().unwrap(),
        "-q",
    ]);
    (dir, run.to_str().unwrap().to_string())
}

#[test]
fn readers_of_a_run_in_progress_say_so_and_refuse_or_mark_partial_output() {
    let (dir, r) = stopped_run("stats-partial", 2);
    let partial = format!("{r} is a run in progress (or stopped): 2 of 4 cells finished");
    // stats --no-write: the finished cells, marked; writing them: refused.
    let out = rwg(&["stats", &r, "--no-write", "--format", "csv"]);
    assert!(out.status.success());
    let note = String::from_utf8_lossy(&out.stderr);
    assert!(note.contains(&partial), "{note}");
    assert_eq!(String::from_utf8_lossy(&out.stdout).lines().count(), 3);
    let err = rwg_err(&["stats", &r]);
    assert!(
        err.contains(&partial) && err.contains("--no-write prints"),
        "{err}"
    );
    assert!(
        err.contains(&format!("rwg run {r}/manifest.toml --out {r}")),
        "{err}"
    );
    assert!(!dir.join("run/stats.json").exists());
    let err = rwg_err(&["report", &r]);
    assert!(err.contains(&partial), "{err}");
    let out = rwg(&["top", &r, "-n", "1"]);
    assert!(out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains(&partial));
    let out = rwg_ok(&["verify", &r]);
    assert!(
        out.contains("a run in progress (or stopped): 2 of 4 cells finished"),
        "{out}"
    );
    // compare: the finished cells' architectures match the whole run's.
    let whole = dir.join("whole");
    let err = rwg_err(&["compare", whole.to_str().unwrap(), &r]);
    assert!(
        err.contains("not comparable")
            && err.contains("run is a run in progress (or stopped): 2 of 4"),
        "{err}"
    );
    let out = rwg(&["compare", whole.to_str().unwrap(), &r, "--force"]);
    assert!(out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("2 of 4 cells finished"));
}

#[test]
fn readers_of_a_run_whose_first_cell_has_not_finished_know_it() {
    let (_dir, r) = stopped_run("stats-none", 0);
    let partial = format!("{r} is a run in progress (or stopped): 0 of 4 cells finished");
    for cmd in ["stats", "top", "report", "verify"] {
        let out = rwg(&[cmd, &r]);
        let text = String::from_utf8_lossy(&out.stderr).into_owned()
            + &String::from_utf8_lossy(&out.stdout);
        assert!(
            text.contains(&partial) || text.contains("0 of 4 cells finished"),
            "{cmd}: {text}"
        );
        assert!(!text.contains("not a run directory"), "{cmd}: {text}");
    }
    // As an older rwg left it: no run.json before the first cell finished.
    std::fs::remove_file(std::path::Path::new(&r).join("run.json")).unwrap();
    for cmd in ["stats", "top", "report", "verify"] {
        let err = rwg_err(&[cmd, &r]);
        assert!(err.contains(&partial), "{cmd}: {err}");
    }
}
