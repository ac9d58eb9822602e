//! The analysis commands on a real `rwg run` directory: statistics agree with
//! the run's own samples.csv, and stats, plot, report and compare all work.

mod common;
use common::*;
use serde_json::Value;

const MANIFEST: &str = r#"
seed = 5
samples = 50
episodes = 3
bias = [false, true]
[[architectures]]
name = "0HL"
hidden = []
[[architectures]]
name = "1HL-2"
hidden = [2]
[[envs]]
id = "CartPole-v0"
[[envs]]
id = "MountainCarContinuous-v0"
solved = 90
"#;

#[test]
fn analysis_of_a_real_run() {
    let dir = temp_dir("analysis-run");
    let m = dir.join("m.toml");
    std::fs::write(&m, MANIFEST).unwrap();
    let run = dir.join("run");
    let r = run.to_str().unwrap();
    let console = rwg_ok(&["run", m.to_str().unwrap(), "--out", r, "--threads", "1"]);
    // `rwg run` analyses the cells from the episodes it kept in memory; the
    // commands below read them back from disk and write the same files.
    let analysis = |run: &std::path::Path| -> Vec<(String, Vec<u8>)> {
        let mut files = vec![];
        for sub in ["", "figures"] {
            let mut names: Vec<_> = std::fs::read_dir(run.join(sub))
                .unwrap()
                .map(|e| e.unwrap().path())
                .filter(|p| {
                    p.is_file() && p.extension().is_some_and(|e| e != "toml" && e != "lock")
                })
                .filter(|p| p.file_name().is_some_and(|n| n != "run.json"))
                .collect();
            names.sort();
            files.extend(names.into_iter().map(|p| {
                let name = p.strip_prefix(run).unwrap().display().to_string();
                (name, std::fs::read(&p).unwrap())
            }));
        }
        files
    };
    let from_run = analysis(&run);
    let names: Vec<&str> = from_run.iter().map(|(n, _)| n.as_str()).collect();
    // stats.json, stats.csv, report.html; per cell 3 figures, 2 overviews, the bias histograms
    assert_eq!(from_run.len(), 3 + 8 * 3 + 3, "{names:?}");

    let stats: Value = serde_json::from_str(&rwg_ok(&["stats", r, "--format", "json"])).unwrap();
    let cells = stats["cells"].as_array().unwrap();
    assert_eq!(cells.len(), 8);
    for c in cells {
        // best mean and solved count agree with the run's samples.csv
        let samples = std::fs::read_to_string(
            run.join("cells")
                .join(c["dir"].as_str().unwrap())
                .join("samples.csv"),
        )
        .unwrap();
        let means: Vec<f64> = samples
            .lines()
            .skip(1)
            .map(|l| l.split(',').nth(1).unwrap().parse().unwrap())
            .collect();
        assert_eq!(means.len(), 50);
        let best = means.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        assert_eq!(c["best_mean"].as_f64().unwrap(), best, "{}", c["dir"]);
        let solved = c["solved"].as_f64().unwrap();
        let k = means.iter().filter(|&&x| x >= solved).count() as u64;
        assert_eq!(c["solved_fraction"]["successes"].as_u64().unwrap(), k);
    }
    assert!(run.join("stats.json").exists() && run.join("stats.csv").exists());

    // The console summary's best mean and median mean are stats.json's (the
    // interpolated median of the sample means, not the upper middle value).
    let mut upper_middle_differs = false;
    for c in cells {
        let dir = c["dir"].as_str().unwrap();
        let line = console
            .lines()
            .find(|l| l.split_whitespace().next() == Some(dir))
            .unwrap_or_else(|| panic!("no summary line for {dir} in:\n{console}"));
        let cols: Vec<&str> = line.split_whitespace().collect();
        let median = c["median_mean"].as_f64().unwrap();
        assert_eq!(
            cols[1],
            format!("{:.2}", c["best_mean"].as_f64().unwrap()),
            "{line}"
        );
        assert_eq!(cols[2], format!("{median:.2}"), "{line}");
        let samples =
            std::fs::read_to_string(run.join("cells").join(dir).join("samples.csv")).unwrap();
        let mut means: Vec<f64> = samples
            .lines()
            .skip(1)
            .map(|l| l.split(',').nth(1).unwrap().parse().unwrap())
            .collect();
        means.sort_by(f64::total_cmp);
        upper_middle_differs |= format!("{:.2}", means[means.len() / 2]) != format!("{median:.2}");
    }
    assert!(
        upper_middle_differs,
        "no cell tells the interpolated median from the upper middle value"
    );

    let table = rwg_ok(&["stats", r]);
    assert!(table.contains("MountainCarContinuous-v0") && table.contains("1HL-2"));
    let figs = rwg_ok(&["plot", r]);
    assert_eq!(figs.lines().count(), 3 + 8 * 3);
    rwg_ok(&["report", r]);
    let from_disk = analysis(&run);
    for ((name, a), (name_b, b)) in from_run.iter().zip(&from_disk) {
        assert_eq!(name, name_b);
        assert!(
            a == b,
            "{name} differs between rwg run and the analysis commands"
        );
    }
    let html = std::fs::read_to_string(run.join("report.html")).unwrap();
    assert!(html.contains("seed = 5"), "the manifest is in the report");
    // The run beside a copy of itself (the same run named twice is refused).
    let copy = run.with_file_name("run-copy");
    let cp = std::process::Command::new("cp")
        .args(["-r", r, copy.to_str().unwrap()])
        .status()
        .unwrap();
    assert!(cp.success());
    let cmp = rwg_ok(&["compare", r, copy.to_str().unwrap()]);
    assert!(cmp.contains("Comparison of 16 cells"));
}
