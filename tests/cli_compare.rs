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

    // the ranking: a table after the comparison, a column in CSV and JSON
    assert!(
        out.contains("Difficulty ranking of 16 cells, easiest first"),
        "{out}"
    );
    let ranks: Vec<u64> = rows
        .iter()
        .map(|r| r["difficulty_rank"].as_u64().unwrap())
        .collect();
    let mut sorted = ranks.clone();
    sorted.sort();
    assert_eq!(sorted, (1..=16).collect::<Vec<u64>>());
    assert!(csv
        .lines()
        .next()
        .unwrap()
        .ends_with(",difficulty_rank,non_finite_episodes"));

    let dir = temp_dir("compare-fig");
    let (fig, rank_fig, page) = (
        dir.join("cmp.svg"),
        dir.join("rank.png"),
        dir.join("cmp.html"),
    );
    rwg_ok(&[
        "compare",
        a,
        b,
        "--figure",
        fig.to_str().unwrap(),
        "--ranking-figure",
        rank_fig.to_str().unwrap(),
        "--html",
        page.to_str().unwrap(),
    ]);
    let svg = std::fs::read_to_string(&fig).unwrap();
    // one panel per architecture × bias, the first run as the grey reference
    for want in [
        "0HL · no bias",
        "1HL-4 · with bias",
        "grey: the reference set (rwg-test-",
        "normalised mean",
        "shade: 95% Wilson interval",
    ] {
        assert!(svg.contains(want), "profiles figure lacks {want:?}");
    }
    let png = std::fs::read(&rank_fig).unwrap();
    assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
    let html = std::fs::read_to_string(&page).unwrap();
    for want in [
        "<h2>Difficulty ranking</h2>",
        "Difficulty ranking of 16 cells",
        "<h2>Profiles per architecture</h2>",
        "Comparison of 16 cells",
        "<th>episodes per sample</th><td>4</td><td>4</td>",
        "id=\"fig-ranking\"",
        "id=\"fig-profiles\"",
    ] {
        assert!(html.contains(want), "page lacks {want:?}");
    }
    assert!(!html.contains("http://") && !html.contains("https://") || html.contains("xmlns"));

    let tex = rwg_ok(&["compare", a, b, "--format", "latex"]);
    assert!(tex.contains("\\toprule"));
    // the ranking is in every format: a table in the text ones
    assert!(tex.contains("Difficulty ranking of 16 cells"), "{tex}");
    let md = rwg_ok(&["compare", a, b, "--format", "markdown"]);
    assert!(md.contains("**Difficulty ranking of 16 cells"), "{md}");
    assert!(md.contains("| rank | run | env |"), "{md}");
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

/// A run of one CartPole-like cell, for the two-cell comparison.
fn one_cell_run(name: &str, seed: u64) -> std::path::PathBuf {
    use rwg_study::rundir::data::synthetic::{write_synthetic_run, SyntheticCell, SyntheticRun};
    let dir = temp_dir(name);
    write_synthetic_run(
        &dir,
        &SyntheticRun {
            samples: 200,
            episodes: 4,
            seed,
            cells: vec![SyntheticCell::cartpole("0HL", &[], false)],
        },
    )
    .unwrap();
    dir
}

#[test]
fn compare_page_renders_in_headless_chromium() {
    let Some(browser) = browser() else {
        skip(
            "compare_page_renders_in_headless_chromium",
            "no headless browser found (install Debian's `chromium`, or set RWG_CHROMIUM)",
        );
        return;
    };
    // 16 cells from two runs, and 2 cells from two one-cell runs
    let many = (
        synthetic_run("compare-page-a", 80, 4),
        synthetic_run("compare-page-b", 50, 4),
    );
    let few = (
        one_cell_run("compare-page-c", 5),
        one_cell_run("compare-page-d", 6),
    );
    for (k, (a, b)) in [many, few].iter().enumerate() {
        let page = a.with_file_name(format!("rwg-test-compare-page-{k}.html"));
        rwg_ok(&[
            "compare",
            a.to_str().unwrap(),
            b.to_str().unwrap(),
            "--html",
            page.to_str().unwrap(),
        ]);
        let dom = check_page_in_browser(
            &browser,
            &page,
            2,
            &temp_dir(&format!("compare-page-profile-{k}")),
        );
        assert!(dom.contains("2 of 2 figures rendered"));
        let shot = page.with_extension("png");
        headless(
            &browser,
            &page,
            &[
                &format!("--screenshot={}", shot.display()),
                "--window-size=1280,2400",
            ],
            &temp_dir(&format!("compare-page-shot-{k}")),
        );
        let png = std::fs::read(&shot).expect("no screenshot written");
        assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
        assert!(
            png.len() > 30_000,
            "screenshot suspiciously small: {} bytes",
            png.len()
        );
    }
}

#[test]
fn outputs_that_fill_the_disk_leave_nothing_half_written() {
    let disk = match SmallDisk::mount("compare-full", "16k") {
        Ok(d) => d,
        Err(why) => {
            return skip(
                "outputs_that_fill_the_disk_leave_nothing_half_written",
                &why,
            )
        }
    };
    let a = synthetic_run("compare-full-a", 60, 4);
    let b = synthetic_run("compare-full-b", 60, 4);
    let html = disk.0.join("compare.html");
    let err = rwg_err(&[
        "compare",
        a.to_str().unwrap(),
        b.to_str().unwrap(),
        "--html",
        html.to_str().unwrap(),
    ]);
    assert!(
        err.contains(&format!("cannot write {}", html.display()))
            && err.contains("No space left on device"),
        "{err}"
    );
    let left: Vec<_> = std::fs::read_dir(&disk.0)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert!(left.is_empty(), "left behind: {left:?}");
}

/// A study of CartPole-v1 and CartPole-v0, both solved at 195, with `extra`
/// added to CartPole-v1's entry.
fn paired_study(episodes: u32, extra: &str) -> String {
    format!(
        "seed = 0\nsamples = 256\nepisodes = {episodes}\nbias = [false]\n\
         [[architectures]]\nname = \"0HL\"\nhidden = []\n\
         [[architectures]]\nname = \"1HL-4\"\nhidden = [4]\n\
         [[envs]]\nid = \"CartPole-v1\"\nsolved = 195\n{extra}\n\
         [[envs]]\nid = \"CartPole-v0\"\nsolved = 195\n"
    )
}

#[test]
fn compare_paired_two_implementations() {
    let dir = temp_dir("compare-paired");
    let a = finished_run(&dir, "a", &paired_study(3, ""));
    let same = finished_run(&dir, "same", &paired_study(3, ""));
    // the same networks, their episodes cut at 150 steps: none reaches 195
    let cut = finished_run(&dir, "cut", &paired_study(3, "max_episode_steps = 150"));
    let (a, same, cut) = (path_str(&a), path_str(&same), path_str(&cut));

    // one implementation twice: the same numbers, one benchmark
    let out = rwg_ok(&["compare", a, same, "--paired", "CartPole-v1", "CartPole-v1"]);
    assert!(
        out.starts_with(
            "Paired comparison of CartPole-v1 in a and in same, 3 episodes per network"
        ),
        "{out}"
    );
    let row0 = out.lines().find(|l| l.starts_with("0HL")).unwrap();
    assert!(
        row0.contains("1.000") && row0.contains("0 (p = 1.0)"),
        "{out}"
    );
    assert!(row0.ends_with("one benchmark"), "{out}");
    assert!(
        out.contains("verdict: a and same are one benchmark: no test tells them apart"),
        "{out}"
    );

    // the same networks under a shorter time limit: p(solved) differs
    let csv = rwg_ok(&[
        "compare",
        a,
        cut,
        "--paired",
        "CartPole-v1",
        "CartPole-v1",
        "--format",
        "csv",
    ]);
    let lines: Vec<&str> = csv.lines().collect();
    assert_eq!(lines.len(), 3, "{csv}");
    assert!(lines[0].starts_with("run_a,env_a,run_b,env_b,arch,bias,networks,episodes,paired,"));
    let field = |line: &str, name: &str| -> String {
        let i = lines[0].split(',').position(|h| h == name).unwrap();
        line.split(',').nth(i).unwrap().to_string()
    };
    for l in &lines[1..] {
        assert_eq!(field(l, "paired"), "true", "{csv}");
        assert_eq!(field(l, "solved_only_b"), "0", "{csv}");
        assert_eq!(field(l, "solved_both"), "0", "{csv}");
        let only_a: u64 = field(l, "solved_only_a").parse().unwrap();
        assert!(only_a >= 8, "{csv}");
        // McNemar's exact p of k discordant pairs all one way: 2 / 2^k
        let p: f64 = field(l, "solved_p").parse().unwrap();
        assert!(
            (p - 2.0 * 0.5f64.powi(only_a as i32)).abs() < 1e-12,
            "{csv}"
        );
        assert_eq!(field(l, "verdict"), "different", "{csv}");
    }

    // two envs of one run: other seed ids, so other networks
    let json = rwg_ok(&[
        "compare",
        a,
        "--paired",
        "CartPole-v1",
        "CartPole-v0",
        "--format",
        "json",
    ]);
    let v: Value = serde_json::from_str(&json).unwrap();
    let r0 = &v["rows"][0];
    assert_eq!(r0["paired"], false);
    assert_eq!(
        r0["unpaired_reason"],
        "the seed ids differ (CartPole-v1 and CartPole-v0)"
    );
    assert_eq!(r0["solved_test"], "fisher");
    assert!(r0["spearman"].is_null());
    assert!(["different", "one_benchmark"].contains(&v["verdict"].as_str().unwrap()));

    // the figure: per architecture each network's two means and the CDFs
    let fig = dir.join("paired.svg");
    rwg_ok(&[
        "compare",
        a,
        cut,
        "--paired",
        "CartPole-v1",
        "CartPole-v1",
        "--figure",
        path_str(&fig),
    ]);
    let svg = std::fs::read_to_string(&fig).unwrap();
    for want in [
        "Paired comparison of CartPole-v1 in a and in cut",
        "0HL · no bias: each network (Spearman ρ",
        "1HL-4 · no bias",
        "CDF of the means: KS D",
        "solved in one",
        "verdict: a and cut are different benchmarks",
    ] {
        assert!(svg.contains(want), "paired figure lacks {want:?}");
    }
}

#[test]
fn compare_paired_refuses_what_it_cannot_pair() {
    let dir = temp_dir("compare-paired-refusals");
    let a = finished_run(&dir, "a", &paired_study(3, ""));
    let b = finished_run(&dir, "b", &paired_study(2, ""));
    let (a, b) = (path_str(&a), path_str(&b));
    let err = rwg_err(&["compare", a, "--paired", "CartPole-v1", "Acrobot-v1"]);
    assert!(
        err.contains("a has no finished cell of Acrobot-v1; its envs: CartPole-v1, CartPole-v0"),
        "{err}"
    );
    let err = rwg_err(&["compare", a, "--paired", "CartPole-v1", "CartPole-v1"]);
    assert!(
        err.contains("compares CartPole-v1 of a with itself"),
        "{err}"
    );
    let third = synthetic_run("compare-paired-third", 10, 3);
    let err = rwg_err(&[
        "compare",
        a,
        b,
        path_str(&third),
        "--paired",
        "CartPole-v1",
        "CartPole-v1",
    ]);
    assert!(
        err.contains("--paired compares two envs: give one run"),
        "{err}"
    );
    let err = rwg_err(&[
        "compare",
        a,
        "--paired",
        "CartPole-v1",
        "CartPole-v0",
        "--html",
        "x.html",
    ]);
    assert!(
        err.contains("--html belongs to the comparison of whole runs"),
        "{err}"
    );
    // other episode counts: means that spread differently
    let err = rwg_err(&["compare", a, b, "--paired", "CartPole-v1", "CartPole-v1"]);
    assert!(
        err.contains("0HL: episodes per network differ (3 and 2)") && err.contains("--force"),
        "{err}"
    );
    rwg_ok(&[
        "compare",
        a,
        b,
        "--paired",
        "CartPole-v1",
        "CartPole-v1",
        "--force",
    ]);
}
