//! Figure tests on a synthetic run: every figure renders, SVGs embed their
//! scatter layers as PNG images, PNGs decode to the expected size.

use super::*;
use rwg_study::rundir::data::synthetic::{write_synthetic_run, SyntheticCell, SyntheticRun};
use rwg_study::rundir::data::Run;

fn cells(name: &str, both_bias: bool) -> Vec<(CellData, CellSummary)> {
    let dir = std::env::temp_dir().join(format!("rwg-plot-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let mut cells = vec![
        SyntheticCell::cartpole("0HL", &[], false),
        SyntheticCell::pendulum("1HL-4", &[4], false),
    ];
    if both_bias {
        cells.push(SyntheticCell::cartpole("0HL", &[], true));
    }
    write_synthetic_run(
        &dir,
        &SyntheticRun {
            samples: 60,
            episodes: 5,
            seed: 11,
            cells,
        },
    )
    .unwrap();
    let cells = crate::load_cells(&Run::open(&dir).unwrap()).unwrap();
    let _ = std::fs::remove_dir_all(&dir);
    cells
}

fn svg_text(f: &Figure) -> &str {
    assert_eq!(f.format, ImageFormat::Svg);
    std::str::from_utf8(&f.bytes).unwrap()
}

#[test]
fn run_figures_svg() {
    let cells = cells("svg", true);
    let figs = run_figures(&cells, ImageFormat::Svg).unwrap();
    let names: Vec<String> = figs.iter().map(Figure::file_name).collect();
    assert_eq!(
        names,
        [
            "overview_nobias.svg",
            "overview_bias.svg",
            "bias_histograms.svg",
            "CartPole-v0__0HL__nobias.hist.svg",
            "CartPole-v0__0HL__nobias.scores.svg",
            "CartPole-v0__0HL__nobias.variance.svg",
            "Pendulum-v1__1HL-4__nobias.hist.svg",
            "Pendulum-v1__1HL-4__nobias.scores.svg",
            "Pendulum-v1__1HL-4__nobias.variance.svg",
            "CartPole-v0__0HL__bias.hist.svg",
            "CartPole-v0__0HL__bias.scores.svg",
            "CartPole-v0__0HL__bias.variance.svg",
        ]
    );
    for f in &figs {
        let svg = svg_text(f);
        assert!(
            svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"),
            "{}",
            f.name
        );
        assert!(!svg.contains("fill=\"#0100"), "sentinel left in {}", f.name);
    }
    let scores = svg_text(&figs[4]);
    assert_eq!(scores.matches("<image ").count(), 1);
    assert!(scores.contains("href=\"data:image/png;base64,iVBORw0KGgo"));
    for label in [
        "CartPole-v0 · 0HL · no bias: episode scores by sample rank",
        "sample rank by mean score M",
        "episode score",
        "top 0.1% of episodes",
        "sample mean M",
        "solved (195)",
    ] {
        assert!(scores.contains(label), "missing {label:?}");
    }
    let hist = svg_text(&figs[3]);
    assert!(hist.contains("samples (log scale)") && hist.contains("sample mean score M"));
    assert_eq!(hist.matches("<image ").count(), 0);
    assert!(svg_text(&figs[5]).contains("variance V of episode scores"));
    // overview: 2 envs × (1 scores panel + V over M) rasters
    assert_eq!(svg_text(&figs[0]).matches("<image ").count(), 4);
    assert!(svg_text(&figs[2]).contains("with bias") && svg_text(&figs[2]).contains("no bias"));
}

#[test]
fn no_bias_figure_without_both_settings() {
    let cells = cells("nobias", false);
    assert!(bias_figure(&cells, ImageFormat::Svg).unwrap().is_none());
    assert!(overview_figure(&cells, true, ImageFormat::Svg)
        .unwrap()
        .is_none());
}

#[test]
fn png_figures_decode() {
    let cells = cells("png", false);
    let (c, s) = &cells[0];
    for f in cell_figures(c, s, ImageFormat::Png).unwrap() {
        assert!(f.file_name().ends_with(".png"));
        let dec = png::Decoder::new(std::io::Cursor::new(&f.bytes));
        let reader = dec.read_info().unwrap();
        let info = reader.info();
        assert_eq!((info.width, info.height), (760, 480));
        // text is drawn: the title row is not blank
        let mut reader = reader;
        let mut buf = vec![0; reader.output_buffer_size()];
        reader.next_frame(&mut buf).unwrap();
        let row = 20 * 760 * 3;
        assert!(
            buf[row..row + 760 * 3].iter().any(|&b| b < 128),
            "no title text in {}",
            f.name
        );
    }
}

#[test]
fn png_levels_are_lossless_and_deterministic() {
    // A scatter-like RGBA raster: mostly transparent, some blended dots.
    let (w, h) = (97u32, 61u32);
    let px: Vec<u8> = (0..w * h * 4)
        .map(|i| {
            let p = i / 4;
            if p.wrapping_mul(2_654_435_761) % 7 < 2 {
                (i * 37 % 251) as u8
            } else {
                0
            }
        })
        .collect();
    for level in [super::raster::EMBEDDED, super::raster::STANDALONE] {
        let a = encode_png(&px, w, h, png::ColorType::Rgba, level).unwrap();
        let b = encode_png(&px, w, h, png::ColorType::Rgba, level).unwrap();
        assert_eq!(a, b, "{level:?}: same pixels, other bytes");
        let mut reader = png::Decoder::new(std::io::Cursor::new(&a))
            .read_info()
            .unwrap();
        let mut buf = vec![0; reader.output_buffer_size()];
        reader.next_frame(&mut buf).unwrap();
        assert_eq!(buf, px, "{level:?}: pixels changed");
    }
}

/// Decodes a PNG to 8-bit RGBA (palettes and tRNS expanded).
fn decode_rgba(bytes: &[u8]) -> (u32, u32, Vec<u8>) {
    let mut dec = png::Decoder::new(std::io::Cursor::new(bytes));
    dec.set_transformations(png::Transformations::EXPAND | png::Transformations::ALPHA);
    let mut reader = dec.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size()];
    let frame = reader.next_frame(&mut buf).unwrap();
    assert_eq!(frame.color_type, png::ColorType::Rgba);
    buf.truncate(frame.buffer_size());
    (frame.width, frame.height, buf)
}

#[test]
fn embedded_rasters_decode_to_their_exact_pixels_indexed_or_not() {
    let (w, h) = (53u32, 41u32);
    // Few colours (a scatter's blends): indexed. Every pixel its own colour: RGBA.
    let few: Vec<u8> = (0..w * h)
        .flat_map(|p| match p.wrapping_mul(2_654_435_761) % 9 {
            0..=4 => [0, 0, 0, 0],
            5 => [0, 0, 255, 51],
            6 => [0, 0, 255, 92],
            7 => [0, 128, 0, 255],
            _ => [12, 34, 200, 180],
        })
        .collect();
    let many: Vec<u8> = (0..w * h).flat_map(|p| (p * 977).to_le_bytes()).collect();
    for (px, want_indexed) in [(few, true), (many, false)] {
        assert_eq!(super::raster::indexed(&px).is_some(), want_indexed);
        let r = Raster::from_rgba(w, h, px.clone());
        let bytes = r.png().unwrap();
        let info = png::Decoder::new(std::io::Cursor::new(&bytes))
            .read_info()
            .unwrap()
            .info()
            .color_type;
        let want = if want_indexed {
            png::ColorType::Indexed
        } else {
            png::ColorType::Rgba
        };
        assert_eq!(info, want);
        assert_eq!(decode_rgba(&bytes), (w, h, px));
    }
}

/// FNV-1a, 64 bits: a fingerprint of figure bytes (not a security hash).
fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| {
        (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3)
    })
}

/// Every figure of a dense synthetic run (2000 networks × 12 episodes:
/// 2-pixel dots, overlapping blends) and of a sparse one, SVG and PNG, has
/// the bytes the figure code wrote before the raster's blend was made
/// cheaper (fingerprints recorded with that code; the SVGs' again when
/// their embedded rasters became indexed PNGs: the standalone PNG figures,
/// which paint the same rasters, kept theirs, and
/// `embedded_rasters_decode_to_their_exact_pixels_indexed_or_not` checks
/// the encoding). Changing how figures look changes these on purpose:
/// update them then, never for a speed-up.
#[test]
fn figure_bytes_unchanged() {
    let dense_dir = std::env::temp_dir().join(format!("rwg-plot-{}-dense", std::process::id()));
    let _ = std::fs::remove_dir_all(&dense_dir);
    write_synthetic_run(
        &dense_dir,
        &SyntheticRun {
            samples: 2000,
            episodes: 12,
            seed: 5,
            cells: vec![
                SyntheticCell::cartpole("0HL", &[], false),
                SyntheticCell::pendulum("1HL-4", &[4], true),
            ],
        },
    )
    .unwrap();
    let dense = crate::load_cells(&Run::open(&dense_dir).unwrap()).unwrap();
    let _ = std::fs::remove_dir_all(&dense_dir);
    let sparse = cells("golden", true);
    let mut got = Vec::new();
    for (cells, format) in [
        (&dense, ImageFormat::Svg),
        (&dense, ImageFormat::Png),
        (&sparse, ImageFormat::Svg),
    ] {
        for f in run_figures(cells, format).unwrap() {
            got.push(format!("{} {:016x}", f.file_name(), fnv1a(&f.bytes)));
        }
    }
    let _ = std::fs::remove_dir_all(&dense_dir);
    let want: &[&str] = &[
        "overview_nobias.svg d26feba6fb2f501a",
        "overview_bias.svg d583285ebf0e5545",
        "CartPole-v0__0HL__nobias.hist.svg f4bc4d2507d81484",
        "CartPole-v0__0HL__nobias.scores.svg dcefb267b4cba71f",
        "CartPole-v0__0HL__nobias.variance.svg 4039affcb8899f16",
        "Pendulum-v1__1HL-4__bias.hist.svg ab1aa1fd69d05dba",
        "Pendulum-v1__1HL-4__bias.scores.svg 3d7bcc25bfc26321",
        "Pendulum-v1__1HL-4__bias.variance.svg 0a7fa241c64dbf66",
        "overview_nobias.png 4a460098b5510123",
        "overview_bias.png f036aa70fd06961e",
        "CartPole-v0__0HL__nobias.hist.png 00b6488e8f8005c3",
        "CartPole-v0__0HL__nobias.scores.png 9b1e54a13ef3d20e",
        "CartPole-v0__0HL__nobias.variance.png e8ea767c46a3b16e",
        "Pendulum-v1__1HL-4__bias.hist.png 82d7a99f1dfc30ff",
        "Pendulum-v1__1HL-4__bias.scores.png dc21aef91e10fa4e",
        "Pendulum-v1__1HL-4__bias.variance.png 7667674326bb21b1",
        "overview_nobias.svg 0f81a014dd86618e",
        "overview_bias.svg 7390aa1f879f2439",
        "bias_histograms.svg 33c5253cb9634431",
        "CartPole-v0__0HL__nobias.hist.svg 5cfe5250c05adc3f",
        "CartPole-v0__0HL__nobias.scores.svg 8e1ec51f0b54aca2",
        "CartPole-v0__0HL__nobias.variance.svg d8ebe008bcb093ab",
        "Pendulum-v1__1HL-4__nobias.hist.svg a5a196fd157e7827",
        "Pendulum-v1__1HL-4__nobias.scores.svg b5aaf9b55de1c07a",
        "Pendulum-v1__1HL-4__nobias.variance.svg 23d24a3f1d422a4c",
        "CartPole-v0__0HL__bias.hist.svg f8675566e851b426",
        "CartPole-v0__0HL__bias.scores.svg 952865c127dafd21",
        "CartPole-v0__0HL__bias.variance.svg 7ae976aac4bcdb88",
    ];
    assert_eq!(got, want, "figure bytes changed:\n{}", got.join("\n"));
}

#[test]
fn figures_and_cells_do_not_depend_on_the_thread_count() {
    let dir = std::env::temp_dir().join(format!("rwg-plot-{}-threads", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let cells: Vec<SyntheticCell> = (0..7)
        .map(|i| SyntheticCell::cartpole(&format!("0HL-{}", i / 2), &[], i % 2 == 1))
        .collect();
    write_synthetic_run(
        &dir,
        &SyntheticRun {
            samples: 40,
            episodes: 3,
            seed: 5,
            cells,
        },
    )
    .unwrap();
    let run = Run::open(&dir).unwrap();
    let on = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| {
                let cells = crate::load_cells(&run).unwrap();
                let summaries: Vec<String> = cells.iter().map(|(_, s)| format!("{s:?}")).collect();
                let figures: Vec<(String, Vec<u8>)> = run_figures(&cells, ImageFormat::Svg)
                    .unwrap()
                    .into_iter()
                    .map(|f| (f.file_name(), f.bytes))
                    .collect();
                (summaries, figures)
            })
    };
    let one = on(1);
    assert_eq!(one.1.len(), 2 + 1 + 7 * 3);
    assert_eq!(on(3), one);
    let _ = std::fs::remove_dir_all(&dir);
}
