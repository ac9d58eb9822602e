//! The paper's figures, drawn with `plotters`, as SVG (default) or PNG.
//!
//! Per cell ([`cell_figures`]):
//! - (a) histogram of the sample means `M`, log-scale count axis;
//! - (b) every episode score over its sample's rank by `M`, the `M` curve
//!   overlaid, the top 0.1% of episodes in green;
//! - (c) the sample variances `V` over `M`.
//!
//! Per run: the overview grid ([`overview_figure`]: one row per env, the
//! scores-over-rank panel of every architecture, then `V` over `M` and the
//! histogram of the largest architecture), and, when the run has both bias
//! settings, the with/without-bias histogram comparison
//! ([`bias_figure`]). The solved score is drawn as a dashed red line.
//!
//! For `rwg compare`: the performance profiles per architecture
//! ([`profiles_figure`]) and the difficulty ranking ([`ranking_figure`]).
//!
//! Text in PNG figures is rendered with DejaVu Sans, embedded in the binary:
//! no system font is needed. SVG figures name the `sans-serif` family and
//! leave the glyphs to the viewer.

pub(crate) mod panels;
pub mod raster;

/// The comparison figures, drawn in [`crate::compare`], where they are also
/// named.
pub use crate::compare::{profiles_figure, ranking_figure};

use panels::{histogram_panel, scores_panel, variance_panel, HistSeries, PanelText};
use plotters::coord::Shift;
use plotters::prelude::*;
use raster::{base64, encode_png, Raster};
use rayon::prelude::*;
use rwg_study::rundir::data::CellData;
use rwg_study::stats::CellSummary;

use crate::run_tables::bias_label;

/// Image formats of figures.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ImageFormat {
    /// SVG (dense scatter layers embedded as PNG images).
    Svg,
    /// PNG.
    Png,
}

impl ImageFormat {
    /// File extension, without the dot.
    pub fn extension(self) -> &'static str {
        match self {
            ImageFormat::Svg => "svg",
            ImageFormat::Png => "png",
        }
    }
}

/// Why a figure could not be drawn.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum PlotError {
    /// The plotting backend failed.
    #[error("drawing failed: {0}")]
    Draw(String),
    /// PNG encoding failed.
    #[error("PNG encoding failed: {0}")]
    Png(String),
}

pub(crate) fn draw_err<E: std::fmt::Display>(e: E) -> PlotError {
    PlotError::Draw(e.to_string())
}

/// One rendered figure.
#[derive(Debug, Clone)]
pub struct Figure {
    /// File name stem (no extension), unique within a run.
    pub name: String,
    /// One-line description.
    pub caption: String,
    /// Image format of `bytes`.
    pub format: ImageFormat,
    /// The encoded image (SVG text or PNG).
    pub bytes: Vec<u8>,
}

impl Figure {
    /// File name with extension.
    pub fn file_name(&self) -> String {
        format!("{}.{}", self.name, self.format.extension())
    }
}

/// Registers the embedded DejaVu Sans as plotters' `sans-serif` family, once.
fn init_fonts() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        let _ = plotters::style::register_font(
            "sans-serif",
            FontStyle::Normal,
            dejavu::sans::regular(),
        );
        let _ = plotters::style::register_font("sans-serif", FontStyle::Bold, dejavu::sans::bold());
    });
}

/// Raster layers of a figure being drawn: painted at once into a bitmap, or
/// marked by a sentinel rectangle in an SVG and swapped for an `<image>`
/// when the SVG is finished.
pub(crate) struct Layers {
    svg: bool,
    pending: Vec<Raster>,
}

impl Layers {
    fn sentinel(k: usize) -> RGBColor {
        RGBColor(1, (k >> 8) as u8, (k & 0xff) as u8)
    }

    /// Adds a raster drawn over `area` (the area it was created over).
    pub(crate) fn add<DB: DrawingBackend>(
        &mut self,
        area: &DrawingArea<DB, Shift>,
        raster: Raster,
    ) -> Result<(), PlotError> {
        if self.svg {
            let k = self.pending.len();
            assert!(k < 0xff00, "too many raster layers");
            area.draw(&Rectangle::new(
                [(0, 0), (1, 1)],
                Self::sentinel(k).filled(),
            ))
            .map_err(draw_err)?;
            self.pending.push(raster);
            Ok(())
        } else {
            raster.paint(area)
        }
    }

    /// Replaces every sentinel rectangle in `svg` with its raster as an
    /// embedded PNG image.
    fn finish_svg(&self, mut svg: String) -> Result<String, PlotError> {
        for (k, r) in self.pending.iter().enumerate() {
            let RGBColor(a, b, c) = Self::sentinel(k);
            let key = format!("fill=\"#{a:02X}{b:02X}{c:02X}\"");
            let at = svg
                .find(&key)
                .ok_or_else(|| PlotError::Draw("raster sentinel missing".into()))?;
            let start = svg[..at].rfind("<rect").expect("sentinel inside a rect");
            let end = at + svg[at..].find("/>").expect("rect closes") + 2;
            let image = format!(
                "<image x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" \
                 preserveAspectRatio=\"none\" href=\"data:image/png;base64,{}\"/>",
                r.x0,
                r.y0,
                r.w,
                r.h,
                base64(&r.png()?)
            );
            svg.replace_range(start..end, &image);
        }
        Ok(svg)
    }
}

/// Something drawable on a whole figure.
pub(crate) trait Paint {
    /// Draws the figure on `root`, its raster layers into `layers`.
    fn paint<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, Shift>,
        layers: &mut Layers,
    ) -> Result<(), PlotError>;
}

/// Renders `what` at `size` pixels.
pub(crate) fn render(
    what: &impl Paint,
    size: (u32, u32),
    format: ImageFormat,
) -> Result<Vec<u8>, PlotError> {
    init_fonts();
    match format {
        ImageFormat::Svg => {
            let mut svg = String::new();
            let mut layers = Layers {
                svg: true,
                pending: Vec::new(),
            };
            {
                let root = SVGBackend::with_string(&mut svg, size).into_drawing_area();
                root.fill(&WHITE).map_err(draw_err)?;
                what.paint(&root, &mut layers)?;
                root.present().map_err(draw_err)?;
            }
            Ok(layers.finish_svg(svg)?.into_bytes())
        }
        ImageFormat::Png => {
            let mut buf = vec![0u8; size.0 as usize * size.1 as usize * 3];
            {
                let root = BitMapBackend::with_buffer(&mut buf, size).into_drawing_area();
                root.fill(&WHITE).map_err(draw_err)?;
                let mut layers = Layers {
                    svg: false,
                    pending: Vec::new(),
                };
                what.paint(&root, &mut layers)?;
                root.present().map_err(draw_err)?;
            }
            encode_png(
                &buf,
                size.0,
                size.1,
                png::ColorType::Rgb,
                raster::STANDALONE,
            )
        }
    }
}

/// `env · arch · bias`.
pub fn cell_label(s: &CellSummary) -> String {
    format!("{} · {} · {}", s.id.env, s.id.arch, bias_label(s.id.bias))
}

/// The three figures of a cell.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CellFigure {
    /// (a) Histogram of the sample means, log-scale counts.
    Histogram,
    /// (b) Episode scores over sample rank, `M` curve, top 0.1% green.
    Scores,
    /// (c) Sample variance over sample mean.
    Variance,
}

impl CellFigure {
    /// All three, in the paper's order.
    pub const ALL: [CellFigure; 3] = [
        CellFigure::Histogram,
        CellFigure::Scores,
        CellFigure::Variance,
    ];

    /// File name suffix.
    pub fn suffix(self) -> &'static str {
        match self {
            CellFigure::Histogram => "hist",
            CellFigure::Scores => "scores",
            CellFigure::Variance => "variance",
        }
    }
}

struct CellPaint<'a> {
    kind: CellFigure,
    cell: &'a CellData,
    summary: &'a CellSummary,
}

impl Paint for CellPaint<'_> {
    fn paint<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, Shift>,
        layers: &mut Layers,
    ) -> Result<(), PlotError> {
        let label = cell_label(self.summary);
        let text = PanelText::LARGE;
        match self.kind {
            CellFigure::Histogram => histogram_panel(
                root,
                &format!("{label}: sample means"),
                &[HistSeries {
                    label: None,
                    values: &self.cell.means(),
                    color: panels::BLUE,
                }],
                self.summary.solved,
                text,
            ),
            CellFigure::Scores => scores_panel(
                root,
                layers,
                &format!("{label}: episode scores by sample rank"),
                self.cell,
                self.summary,
                text,
            ),
            CellFigure::Variance => variance_panel(
                root,
                layers,
                &format!("{label}: variance over mean"),
                self.cell,
                self.summary,
                text,
            ),
        }
    }
}

/// One figure of a cell.
pub fn cell_figure(
    kind: CellFigure,
    cell: &CellData,
    summary: &CellSummary,
    format: ImageFormat,
) -> Result<Figure, PlotError> {
    let caption = match kind {
        CellFigure::Histogram => "Histogram of the sample means M (log-scale counts)",
        CellFigure::Scores => {
            "Every episode score over its sample's rank by M; M in red; top 0.1% of episodes in green"
        }
        CellFigure::Variance => "Variance V of each sample's episode scores over its mean M",
    };
    Ok(Figure {
        name: format!("{}.{}", summary.id.dir, kind.suffix()),
        caption: format!("{}: {caption}", cell_label(summary)),
        format,
        bytes: render(
            &CellPaint {
                kind,
                cell,
                summary,
            },
            (760, 480),
            format,
        )?,
    })
}

/// The three figures of a cell, in the paper's order.
pub fn cell_figures(
    cell: &CellData,
    summary: &CellSummary,
    format: ImageFormat,
) -> Result<Vec<Figure>, PlotError> {
    CellFigure::ALL
        .iter()
        .map(|&k| cell_figure(k, cell, summary, format))
        .collect()
}

/// Distinct values in order of first appearance.
pub(crate) fn distinct<T: PartialEq + Clone>(xs: impl IntoIterator<Item = T>) -> Vec<T> {
    let mut out = Vec::new();
    for x in xs {
        if !out.contains(&x) {
            out.push(x);
        }
    }
    out
}

struct OverviewPaint<'a> {
    /// Rows: env, then its cells in architecture order.
    rows: Vec<Vec<(&'a CellData, &'a CellSummary)>>,
    cols: usize,
}

impl Paint for OverviewPaint<'_> {
    fn paint<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, Shift>,
        layers: &mut Layers,
    ) -> Result<(), PlotError> {
        let grid = root.split_evenly((self.rows.len(), self.cols));
        let text = PanelText::SMALL;
        for (r, row) in self.rows.iter().enumerate() {
            for (c, (cell, s)) in row.iter().enumerate() {
                let title = format!("{} · {}: scores by rank", s.id.env, s.id.arch);
                scores_panel(&grid[r * self.cols + c], layers, &title, cell, s, text)?;
            }
            let (cell, s) = *row
                .iter()
                .max_by_key(|(_, s)| s.n_weights)
                .expect("non-empty row");
            let base = r * self.cols + self.cols - 2;
            let title = format!("{} · {}: V over M", s.id.env, s.id.arch);
            variance_panel(&grid[base], layers, &title, cell, s, text)?;
            let title = format!("{} · {}: histogram of M", s.id.env, s.id.arch);
            histogram_panel(
                &grid[base + 1],
                &title,
                &[HistSeries {
                    label: None,
                    values: &cell.means(),
                    color: panels::BLUE,
                }],
                s.solved,
                text,
            )?;
        }
        Ok(())
    }
}

/// The overview grid for one bias setting: one row per env with the
/// scores-over-rank panel of every architecture, then `V` over `M` and the
/// histogram of `M` for the env's largest architecture (most weights).
/// `None` when no cell has that bias setting.
pub fn overview_figure(
    cells: &[(CellData, CellSummary)],
    bias: bool,
    format: ImageFormat,
) -> Result<Option<Figure>, PlotError> {
    let chosen: Vec<&(CellData, CellSummary)> =
        cells.iter().filter(|(_, s)| s.id.bias == bias).collect();
    if chosen.is_empty() {
        return Ok(None);
    }
    let envs = distinct(chosen.iter().map(|(_, s)| s.id.env.clone()));
    let rows: Vec<Vec<(&CellData, &CellSummary)>> = envs
        .iter()
        .map(|e| {
            chosen
                .iter()
                .filter(|(_, s)| &s.id.env == e)
                .map(|(c, s)| (c, s))
                .collect()
        })
        .collect();
    let cols = rows.iter().map(Vec::len).max().unwrap_or(1) + 2;
    let size = (cols as u32 * 400, rows.len() as u32 * 300);
    let tag = if bias { "bias" } else { "nobias" };
    Ok(Some(Figure {
        name: format!("overview_{tag}"),
        caption: format!(
            "Overview, {}: per env, episode scores by rank for every architecture, then V over M \
             and the histogram of M for the largest architecture",
            bias_label(bias)
        ),
        format,
        bytes: render(&OverviewPaint { rows, cols }, size, format)?,
    }))
}

struct BiasPaint<'a> {
    /// (env, arch, without-bias cell, with-bias cell)
    pairs: Vec<(&'a CellSummary, &'a CellData, &'a CellSummary, &'a CellData)>,
    rows: usize,
    cols: usize,
    envs: Vec<String>,
    archs: Vec<String>,
}

impl Paint for BiasPaint<'_> {
    fn paint<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, Shift>,
        _layers: &mut Layers,
    ) -> Result<(), PlotError> {
        let grid = root.split_evenly((self.rows, self.cols));
        for (s0, c0, _, c1) in &self.pairs {
            let r = self.envs.iter().position(|e| e == &s0.id.env).expect("env");
            let c = self
                .archs
                .iter()
                .position(|a| a == &s0.id.arch)
                .expect("arch");
            let (m0, m1) = (c0.means(), c1.means());
            histogram_panel(
                &grid[r * self.cols + c],
                &format!("{} · {}: M with and without bias", s0.id.env, s0.id.arch),
                &[
                    HistSeries {
                        label: Some("no bias"),
                        values: &m0,
                        color: panels::BLUE,
                    },
                    HistSeries {
                        label: Some("with bias"),
                        values: &m1,
                        color: panels::ORANGE,
                    },
                ],
                s0.solved,
                PanelText::SMALL,
            )?;
        }
        Ok(())
    }
}

/// Histograms of `M` with and without bias overlaid, one panel per env ×
/// architecture that has both settings. `None` when no cell has both.
pub fn bias_figure(
    cells: &[(CellData, CellSummary)],
    format: ImageFormat,
) -> Result<Option<Figure>, PlotError> {
    let mut pairs = Vec::new();
    for (c0, s0) in cells.iter().filter(|(_, s)| !s.id.bias) {
        if let Some((c1, s1)) = cells
            .iter()
            .find(|(_, s)| s.id.bias && s.id.env == s0.id.env && s.id.arch == s0.id.arch)
        {
            pairs.push((s0, c0, s1, c1));
        }
    }
    if pairs.is_empty() {
        return Ok(None);
    }
    let envs = distinct(pairs.iter().map(|p| p.0.id.env.clone()));
    let archs = distinct(pairs.iter().map(|p| p.0.id.arch.clone()));
    let (rows, cols) = (envs.len(), archs.len());
    let size = (cols as u32 * 420, rows as u32 * 300);
    Ok(Some(Figure {
        name: "bias_histograms".into(),
        caption: "Histograms of the sample means M without (blue) and with (orange) bias".into(),
        format,
        bytes: render(
            &BiasPaint {
                pairs,
                rows,
                cols,
                envs,
                archs,
            },
            size,
            format,
        )?,
    }))
}

/// Every figure of a run: per cell (a), (b), (c); the overview per bias
/// setting; the bias comparison when the run has both settings.
pub fn run_figures(
    cells: &[(CellData, CellSummary)],
    format: ImageFormat,
) -> Result<Vec<Figure>, PlotError> {
    // Drawn on the current rayon pool, returned in this order whatever the
    // pool: the overviews, the bias figure, then each cell's figures.
    let (run_level, per_cell) = rayon::join(
        || -> Result<Vec<Figure>, PlotError> {
            let mut out = Vec::new();
            for bias in distinct(cells.iter().map(|(_, s)| s.id.bias)) {
                out.extend(overview_figure(cells, bias, format)?);
            }
            out.extend(bias_figure(cells, format)?);
            Ok(out)
        },
        || {
            cells
                .par_iter()
                .map(|(c, s)| cell_figures(c, s, format))
                .collect::<Vec<_>>()
        },
    );
    let mut out = run_level?;
    for figures in per_cell {
        out.extend(figures?);
    }
    Ok(out)
}

#[cfg(test)]
mod tests;
