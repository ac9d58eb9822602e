//! Loader tests on run directories written here.

use super::synthetic::{write_synthetic_run, SyntheticCell, SyntheticRun};
use super::*;
use crate::rundir::{rows, STATS_CSV, STATS_JSON};

fn temp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("rwg-core-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn small_run(name: &str) -> (PathBuf, RunMeta) {
    let dir = temp_dir(name);
    let meta = write_synthetic_run(
        &dir,
        &SyntheticRun {
            samples: 50,
            episodes: 4,
            seed: 7,
            cells: vec![
                SyntheticCell::cartpole("0HL", &[], false),
                SyntheticCell::pendulum("1HL-4", &[4], true),
            ],
        },
    )
    .unwrap();
    (dir, meta)
}

/// Rewrites the run as written before checksums (format 1): read unverified,
/// so the row-level checks below see the edited files.
fn make_legacy(dir: &Path, meta: &RunMeta) {
    let mut m = meta.clone();
    m.format = 1;
    write_run_json(dir, &m).unwrap();
    assert!(!Run::open(dir).unwrap().verified);
}

fn scores_path(dir: &Path, meta: &RunMeta) -> PathBuf {
    dir.join("cells")
        .join(&meta.cells[0].id.dir)
        .join("scores.csv")
}

#[test]
fn load_round_trips_written_run() {
    let (dir, meta) = small_run("roundtrip");
    let run = Run::open(&dir).unwrap();
    assert_eq!(run.meta, meta);
    assert!(run.manifest.is_none());
    let cell = run.load_cell(&meta.cells[0]).unwrap();
    assert_eq!((cell.samples(), cell.episodes), (50, 4));
    assert_eq!(cell.scores.len(), 200);
    assert_eq!(cell.sample_scores(1), &cell.scores[4..8]);
    let best = cell.ranks.iter().position(|&r| r == 49).unwrap();
    let means = cell.means();
    assert!(means.iter().all(|&m| m <= means[best]));
    let stats = run.summarize().unwrap();
    assert_eq!(stats.cells.len(), 2);
    assert_eq!(stats.cells[0].best_mean, means[best]);
    assert!(stats.cells[1].solved_fraction.is_none());

    write_stats(&dir, &stats).unwrap();
    let back: RunStats =
        serde_json::from_str(&std::fs::read_to_string(dir.join(STATS_JSON)).unwrap()).unwrap();
    assert_eq!(back, stats);
    let csv = std::fs::read_to_string(dir.join(STATS_CSV)).unwrap();
    let lines: Vec<&str> = csv.lines().collect();
    assert_eq!(lines.len(), 3);
    let header: Vec<&str> = lines[0].split(',').collect();
    assert_eq!(header.len(), stats_csv_header().len());
    for l in &lines[1..] {
        assert_eq!(l.split(',').count(), header.len(), "{l}");
    }
    let col = header.iter().position(|&h| h == "best_mean").unwrap();
    let best_field = lines[1].split(',').nth(col).unwrap();
    assert_eq!(best_field.parse::<f64>().unwrap(), stats.cells[0].best_mean);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn samples_csv_matches_numpy_layout() {
    let text = samples_csv(
        &crate::stats::per_sample(&[1.0, 2.0, 3.0, 4.0, 0.5, 0.5], 2),
        &[1, 2, 0],
    );
    assert_eq!(
        text,
        "sample,mean,variance,std,min,max,rank\n\
         0,1.5,0.25,0.5,1.0,2.0,1\n\
         1,3.5,0.25,0.5,3.0,4.0,2\n\
         2,0.5,0.0,0.0,0.5,0.5,0\n"
    );
}

#[test]
fn manifest_is_read_when_present() {
    let (dir, _) = small_run("manifest");
    std::fs::write(dir.join(MANIFEST), "samples = 50\n").unwrap();
    assert_eq!(
        Run::open(&dir).unwrap().manifest.as_deref(),
        Some("samples = 50\n")
    );
    let _ = std::fs::remove_dir_all(&dir);
}

fn load_err(dir: &Path, meta: &RunMeta) -> String {
    Run::open(dir)
        .and_then(|r| r.load_cell(&meta.cells[0]))
        .unwrap_err()
        .to_string()
}

#[test]
fn malformed_scores_name_file_and_line() {
    let (dir, meta) = small_run("malformed");
    make_legacy(&dir, &meta);
    let path = scores_path(&dir, &meta);
    let good = std::fs::read_to_string(&path).unwrap();
    let mut lines: Vec<String> = good.lines().map(String::from).collect();

    lines[3] = "0,2,abc,12".into();
    std::fs::write(&path, lines.join("\n")).unwrap();
    let e = load_err(&dir, &meta);
    assert!(
        e.contains("scores.csv:4:") && e.contains("score \"abc\""),
        "{e}"
    );

    lines[3] = "0,2,12".into();
    std::fs::write(&path, lines.join("\n")).unwrap();
    let e = load_err(&dir, &meta);
    assert!(
        e.contains("scores.csv:4: expected 4 fields, found 3"),
        "{e}"
    );

    lines[3] = "0,3,12.0,12".into();
    std::fs::write(&path, lines.join("\n")).unwrap();
    let e = load_err(&dir, &meta);
    assert!(
        e.contains("scores.csv:4: expected sample 0 episode 2")
            && e.contains("found sample 0 episode 3"),
        "{e}"
    );

    std::fs::write(
        &path,
        good.replace("sample,episode,score,steps", "s,e,score,steps"),
    )
    .unwrap();
    let e = load_err(&dir, &meta);
    assert!(e.contains("scores.csv:1: header is"), "{e}");

    let short: Vec<&str> = good.lines().take(1 + 4 * 49).collect();
    std::fs::write(&path, short.join("\n")).unwrap();
    let e = load_err(&dir, &meta);
    assert!(
        e.contains("196 episode rows, but run.json says 50 samples × 4 episodes"),
        "{e}"
    );

    let short: Vec<&str> = good.lines().take(1 + 4 * 49 + 2).collect();
    std::fs::write(&path, short.join("\n")).unwrap();
    let e = load_err(&dir, &meta);
    assert!(e.contains("the last sample has 2 of 4 episodes"), "{e}");

    std::fs::remove_file(&path).unwrap();
    let e = load_err(&dir, &meta);
    assert!(
        e.starts_with("cannot read ") && e.contains("scores.csv"),
        "{e}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn inconsistent_samples_csv_is_refused() {
    let (dir, meta) = small_run("samples");
    make_legacy(&dir, &meta);
    let path = dir
        .join("cells")
        .join(&meta.cells[0].id.dir)
        .join("samples.csv");
    let good = std::fs::read_to_string(&path).unwrap();
    let mut lines: Vec<String> = good.lines().map(String::from).collect();
    let f: Vec<&str> = lines[5].split(',').collect();
    let mean: f64 = f[1].parse().unwrap();
    lines[5] = format!("{},{},{}", f[0], mean + 1.0, f[2..].join(","));
    std::fs::write(&path, lines.join("\n")).unwrap();
    let e = load_err(&dir, &meta);
    assert!(
        e.contains("samples.csv:6: mean") && e.contains("disagrees"),
        "{e}"
    );

    // swap two ranks
    let mut lines: Vec<String> = good.lines().map(String::from).collect();
    let rank = |l: &str| l.rsplit(',').next().unwrap().to_string();
    let (r1, r2) = (rank(&lines[1]), rank(&lines[2]));
    let swap = |l: &str, r: &str| format!("{},{r}", l.rsplit_once(',').unwrap().0);
    lines[1] = swap(&lines[1], &r2);
    lines[2] = swap(&lines[2], &r1);
    std::fs::write(&path, lines.join("\n")).unwrap();
    let e = load_err(&dir, &meta);
    assert!(e.contains("samples.csv:2: rank"), "{e}");

    // a missing samples.csv is recomputed, not an error
    std::fs::remove_file(&path).unwrap();
    assert!(Run::open(&dir).unwrap().load_cell(&meta.cells[0]).is_ok());
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn bad_run_json() {
    let dir = temp_dir("badjson");
    let e = Run::open(&dir).unwrap_err().to_string();
    assert!(
        e.contains("is not a run directory (it has no run.json)"),
        "{e}"
    );
    std::fs::write(dir.join(RUN_JSON), "{\"format\": 1}").unwrap();
    let e = Run::open(&dir).unwrap_err().to_string();
    assert!(
        e.contains("run.json is not a readable run.json")
            && e.contains("resuming the run rebuilds it"),
        "{e}"
    );
    let _ = std::fs::remove_dir_all(&dir);
    let (dir, mut meta) = small_run("format");
    meta.format = 99;
    write_run_json(&dir, &meta).unwrap();
    let e = Run::open(&dir).unwrap_err().to_string();
    assert!(e.contains("run format 99"), "{e}");
    meta.format = RUN_FORMAT;
    meta.shard = Some(crate::rundir::meta::ShardMeta { index: 1, count: 3 });
    write_run_json(&dir, &meta).unwrap();
    let e = Run::open(&dir).unwrap_err().to_string();
    assert!(e.contains("shard 1/3") && e.contains("rwg merge"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn damaged_files_are_caught_by_their_checksums() {
    let (dir, meta) = small_run("damaged");
    assert!(Run::open(&dir).unwrap().verified);
    let path = scores_path(&dir, &meta);
    let good = std::fs::read(&path).unwrap();
    let text = String::from_utf8(good.clone()).unwrap();

    // An edited score that still parses: the checksum catches it and the
    // intact samples.csv names the sample's rows.
    let mut lines: Vec<String> = text.lines().map(String::from).collect();
    let f: Vec<&str> = lines[9].split(',').collect();
    lines[9] = format!(
        "{},{},{},{}",
        f[0],
        f[1],
        f[2].parse::<f64>().unwrap() + 7.0,
        f[3]
    );
    std::fs::write(&path, lines.join("\n") + "\n").unwrap();
    let e = load_err(&dir, &meta);
    assert!(e.contains("scores.csv: checksum mismatch"), "{e}");
    assert!(
        e.contains("first bad row: ") && e.contains("scores.csv:10: sample 2 (rows 10-13)"),
        "{e}"
    );

    // Truncated at a sample boundary: it parses, but does not count.
    std::fs::write(&path, &good[..good.len() / 2]).unwrap();
    let cut = String::from_utf8(good[..good.len() / 2].to_vec()).unwrap();
    let keep = cut.rfind('\n').unwrap() + 1;
    std::fs::write(&path, &good[..keep]).unwrap();
    let e = load_err(&dir, &meta);
    assert!(e.contains("scores.csv: checksum mismatch"), "{e}");

    // Zero-filled (as after a crash of the machine): named with its row.
    std::fs::write(&path, vec![0u8; good.len()]).unwrap();
    let e = load_err(&dir, &meta);
    assert!(e.contains("scores.csv: checksum mismatch"), "{e}");
    assert!(
        e.contains("first bad row: ") && e.contains("scores.csv:1: header is"),
        "{e}"
    );
    std::fs::write(&path, &good).unwrap();
    assert!(Run::open(&dir).unwrap().load_cell(&meta.cells[0]).is_ok());

    // samples.csv: edited, then deleted.
    let spath = path.with_file_name("samples.csv");
    let samples = std::fs::read_to_string(&spath).unwrap();
    std::fs::write(&spath, samples.replacen("0,19.25,", "0,19.5,", 1)).unwrap();
    let e = load_err(&dir, &meta);
    assert!(e.contains("samples.csv: checksum mismatch"), "{e}");
    std::fs::remove_file(&spath).unwrap();
    let e = load_err(&dir, &meta);
    assert!(e.contains("samples.csv"), "{e}");
    std::fs::write(&spath, samples).unwrap();

    // A cell without its SHA256SUMS is not finished.
    std::fs::remove_file(path.with_file_name("SHA256SUMS")).unwrap();
    let e = load_err(&dir, &meta);
    assert!(
        e.contains("unverified") && e.contains("not finished"),
        "{e}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// The plain-file fast path and the `csv` crate give the same values and the
/// same errors (a BOM, which the csv path allows, sends the same rows there).
#[test]
fn plain_and_csv_paths_read_the_same() {
    let dir = temp_dir("plain-vs-csv");
    let path = dir.join("scores.csv");
    let good = "sample,episode,score,steps\n0,0,1.5,3\n0,1,-0.1,7\n1,0,1e-20,1\n1,1,200.0,200";
    let texts = [
        good.to_string(),
        format!("{good}\n"),
        good.replace("1.5", "abc"),
        good.replace("0,1,-0.1,7", "0,1,7"),
        good.replace("0,1,-0.1,7", "0,1,-0.1,7,"),
        good.replace("1,0,1e-20", "1,1,1e-20"),
        good.replace("steps", "step"),
        good.replace(",200\n", ",-1\n").replace(",200", ",x"),
        good.lines().take(4).collect::<Vec<_>>().join("\n"),
        String::new(),
        "sample,episode,score,steps\n".into(),
    ];
    for text in texts {
        assert!(rows::is_plain(text.as_bytes()), "{text:?}");
        std::fs::write(&path, &text).unwrap();
        let plain = read_scores_csv(&path, 2).map_err(|e| e.to_string());
        let sample = read_sample_scores(&path, 1, 2).map_err(|e| e.to_string());
        std::fs::write(&path, format!("\u{feff}{text}")).unwrap();
        if !text.is_empty() {
            assert!(!rows::is_plain_file(&path).unwrap());
            assert_eq!(
                read_scores_csv(&path, 2).map_err(|e| e.to_string()),
                plain,
                "{text:?}"
            );
            assert_eq!(
                read_sample_scores(&path, 1, 2).map_err(|e| e.to_string()),
                sample,
                "{text:?}"
            );
        }
    }
    std::fs::remove_dir_all(&dir).unwrap();
}
