//! `rwg report` end to end: the page is self-contained, and headless
//! Chromium renders every figure in it, with no script error and no
//! sideways scrolling at 1280 px (skipped with a message when no browser is
//! installed, a failure under CI).

mod common;
use common::*;
use std::path::PathBuf;

/// Figures of the synthetic run: 2 overviews + bias comparison + 8 cells × 3.
const FIGURES: usize = 27;

fn report(name: &str) -> (PathBuf, String) {
    let dir = synthetic_run(name, 60, 4);
    std::fs::write(
        dir.join("manifest.toml"),
        "samples = 60\nepisodes = 4 # <&>\n",
    )
    .unwrap();
    let out = rwg_ok(&["report", dir.to_str().unwrap()]);
    let path = dir.join("report.html");
    assert_eq!(out.trim(), path.to_str().unwrap());
    let html = std::fs::read_to_string(&path).unwrap();
    (path, html)
}

#[test]
fn report_is_self_contained() {
    let (_, html) = report("report-static");
    assert!(html.starts_with("<!DOCTYPE html>"));
    assert_eq!(html.matches("<figure class=\"rwg-figure").count(), FIGURES);
    assert_eq!(html.matches("<svg ").count(), FIGURES);
    // nothing is fetched: no links, scripts or images from elsewhere
    for bad in ["<link", "src=", "href=\"http", "url(", "@import"] {
        assert!(!html.contains(bad), "report contains {bad:?}");
    }
    assert!(!html.contains("<?xml"));
    // overview grids are wider than the page: shown to fit, full size on a click
    assert!(html.contains("<figure class=\"rwg-figure zoomable\" id=\"fig-overview_nobias\""));
    assert!(html.contains("click the figure to see it at full size"));
    // wide tables scroll in their own box; no negative zero anywhere
    assert_eq!(
        html.matches("<div class=\"table-scroll\">").count(),
        html.matches("<table>").count()
    );
    assert!(!html.contains("-0.00"));
    for want in [
        "Best sample mean (99.9th percentile of sample means), no bias",
        "Fraction of samples with mean ≥ solved score",
        "CartPole-v0 · 0HL · with bias",
        "samples = 60\nepisodes = 4 # &lt;&amp;&gt;",
        "<th>episodes per sample</th><td>4</td>",
    ] {
        assert!(html.contains(want), "report lacks {want:?}");
    }
}

#[test]
fn report_renders_in_headless_chromium() {
    let Some(browser) = browser() else {
        skip(
            "report_renders_in_headless_chromium",
            "no headless browser found (install Debian's `chromium`, or set RWG_CHROMIUM)",
        );
        return;
    };
    let (page, html) = report("report-browser");
    let profile = temp_dir("report-browser-profile");

    let dom = check_page_in_browser(&browser, &page, FIGURES, &profile);
    assert!(dom.contains(&format!("{FIGURES} of {FIGURES} figures rendered")));

    // a screenshot of the page is a real, non-trivial PNG
    let shot = page.with_file_name("report.png");
    headless(
        &browser,
        &page,
        &[
            &format!("--screenshot={}", shot.display()),
            "--window-size=1400,3000",
        ],
        &temp_dir("report-browser-profile2"),
    );
    let png = std::fs::read(&shot).expect("no screenshot written");
    assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
    assert!(
        png.len() > 50_000,
        "screenshot suspiciously small: {} bytes",
        png.len()
    );

    // the check can fail: a corrupted embedded raster is reported
    let i = html.find("base64,iVBORw0KGgo").unwrap() + "base64,".len();
    let mut broken = html.clone();
    broken.replace_range(i..i + 16, "AAAAAAAAAAAAAAAA");
    let bad_page = page.with_file_name("broken.html");
    std::fs::write(&bad_page, broken).unwrap();
    let dom = headless(
        &browser,
        &bad_page,
        &["--dump-dom"],
        &temp_dir("report-browser-profile3"),
    );
    assert_eq!(body_attr(&dom, "rendered"), Some(FIGURES - 1));
    assert_eq!(dom.matches("data-rendered=\"failed\"").count(), 1);
}

#[test]
fn report_with_a_spread_at_n_renders_in_headless_chromium() {
    let Some(browser) = browser() else {
        skip(
            "report_with_a_spread_at_n_renders_in_headless_chromium",
            "no headless browser found (install Debian's `chromium`, or set RWG_CHROMIUM)",
        );
        return;
    };
    let dir = synthetic_run("report-at-n", 60, 4);
    let page = dir.join("spread.html");
    rwg_ok(&[
        "report",
        dir.to_str().unwrap(),
        "--at-n",
        "20",
        "--out",
        page.to_str().unwrap(),
    ]);
    let html = std::fs::read_to_string(&page).unwrap();
    // the spread tables (2 statistics × 2 bias settings) and one line per cell
    assert_eq!(html.matches("over 3 disjoint blocks, ").count(), 4);
    assert_eq!(
        html.matches("at N = 20 networks, median [min, max] over 3 disjoint blocks: best mean ")
            .count(),
        8
    );
    assert_eq!(
        html.matches("<div class=\"table-scroll\">").count(),
        html.matches("<table>").count()
    );
    assert!(!html.contains("-0.00"));
    // same layout as without: every figure renders, no error, no sideways scrolling
    let dom = check_page_in_browser(&browser, &page, FIGURES, &temp_dir("report-at-n-profile"));
    assert!(dom.contains(&format!("{FIGURES} of {FIGURES} figures rendered")));
}

#[test]
fn a_report_that_fills_the_disk_leaves_no_temporary_file() {
    let disk = match SmallDisk::mount("report-full", "16k") {
        Ok(d) => d,
        Err(why) => {
            return skip(
                "a_report_that_fills_the_disk_leaves_no_temporary_file",
                &why,
            )
        }
    };
    let run = synthetic_run("report-full-run", 60, 4);
    let out = disk.0.join("report.html");
    let err = rwg_err(&[
        "report",
        run.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(
        err.contains(&format!("cannot write {}", out.display())),
        "{err}"
    );
    assert!(err.contains("No space left on device"), "{err}");
    let left: Vec<_> = std::fs::read_dir(&disk.0)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert!(left.is_empty(), "left behind: {left:?}");
}
