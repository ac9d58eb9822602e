//! `rwg plot` end to end on a synthetic run directory.

mod common;
use common::*;

#[test]
fn plot_writes_svg_then_png() {
    let dir = synthetic_run("plot", 40, 3);
    let d = dir.to_str().unwrap();
    let out = rwg_ok(&["plot", d]);
    let files: Vec<&str> = out.lines().collect();
    // 2 overviews + bias comparison + 8 cells × 3
    assert_eq!(files.len(), 27, "{out}");
    for f in &files {
        assert!(
            f.starts_with(&format!("{d}/figures/")) && f.ends_with(".svg"),
            "{f}"
        );
        let text = std::fs::read_to_string(f).unwrap();
        assert!(text.starts_with("<svg"), "{f}");
    }
    let png_dir = dir.join("png");
    let out = rwg_ok(&["plot", d, "--png", "--out", png_dir.to_str().unwrap()]);
    assert_eq!(out.lines().count(), 27);
    let bytes = std::fs::read(png_dir.join("CartPole-v0__0HL__bias.scores.png")).unwrap();
    assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n");
}
