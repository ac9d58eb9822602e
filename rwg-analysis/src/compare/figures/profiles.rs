//! The performance profiles of `rwg compare --figure`: one panel per
//! architecture × bias setting, a curve per (run, env) with its Wilson band.

use super::{boxed_label, text_width, Look, Looks, BACKDROP, BACKDROP_TEXT, PALETTE, SOLVED};
use crate::compare::data::CompareRun;
use crate::plot::panels::{chart, PanelText};
use crate::plot::{distinct, draw_err, render, Figure, ImageFormat, Layers, Paint, PlotError};
use crate::run_tables::bias_label;
use plotters::coord::types::RangedCoordf64;
use plotters::coord::Shift;
use plotters::prelude::*;
use rwg_study::stats::{wilson_interval, CellSummary, Z_95};

/// At most this many points per curve.
const CURVE_POINTS: usize = 600;

/// One curve of a profile panel: the fraction of samples at or above each
/// of its normalised means, with the Wilson band.
struct Curve {
    label: String,
    look: Look,
    /// `(x, fraction, lo, hi)`, x ascending.
    points: Vec<(f64, f64, f64, f64)>,
}

fn curve(values: &[f64], label: String, look: Look, xmax: f64) -> Option<Curve> {
    let mut v: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
    if v.is_empty() {
        return None;
    }
    v.sort_by(|a, b| b.total_cmp(a));
    let n = v.len() as u64;
    let step = (v.len() / CURVE_POINTS).max(1);
    // (x_k, (k+1)/n): the fraction of samples at or above the k-th largest
    let mut points: Vec<(f64, f64, f64, f64)> = v
        .iter()
        .enumerate()
        .filter(|&(i, &x)| x >= 0.0 && (i % step == 0 || i + 1 == v.len()))
        .map(|(i, &x)| {
            let k = i as u64 + 1;
            let (lo, hi) = wilson_interval(k, n, Z_95);
            (x.min(xmax), k as f64 / n as f64, lo, hi)
        })
        .collect();
    points.reverse();
    (!points.is_empty()).then_some(Curve {
        label,
        look,
        points,
    })
}

/// One panel: an architecture × bias setting.
struct Panel {
    title: String,
    curves: Vec<Curve>,
}

/// The whole profiles figure, ready to paint: the panels in a grid `cols`
/// wide, their shared axes (x up to `xmax`, y from `y0`), the key.
struct ProfilesPaint {
    panels: Vec<Panel>,
    cols: usize,
    xmax: f64,
    y0: f64,
    panel_w: u32,
    header: Vec<(String, RGBColor)>,
}

/// Panel size `(width, height)` for a grid `cols` panels wide: the figure
/// stays about 1200 px wide.
fn panel_size(cols: usize) -> (u32, u32) {
    match cols {
        1 => (900, 520),
        2 => (610, 470),
        _ => (420, 400),
    }
}
/// Height of the title and key above the panels.
const HEADER_H: u32 = 70;
/// Room right of the data for the curves' labels.
const LABEL_ROOM: u32 = 150;

/// A profile panel's chart: the normalised mean on x, the fraction of
/// networks on a log y axis.
type ProfileChart<'a, DB> = ChartContext<'a, DB, Cartesian2d<RangedCoordf64, LogCoord<f64>>>;

impl Paint for ProfilesPaint {
    fn paint<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, Shift>,
        _layers: &mut Layers,
    ) -> Result<(), PlotError> {
        let (head, body) = root.split_vertically(HEADER_H);
        self.paint_header(&head)?;
        let rows = self.panels.len().div_ceil(self.cols);
        let grid = body.split_evenly((rows, self.cols));
        let t = if self.cols <= 2 {
            PanelText::LARGE
        } else {
            PanelText::SMALL
        };
        for (p, area) in self.panels.iter().zip(&grid) {
            self.paint_panel(root, area, p, t)?;
        }
        Ok(())
    }
}

impl ProfilesPaint {
    /// The figure's title and its key: one entry per run.
    fn paint_header<DB: DrawingBackend>(
        &self,
        head: &DrawingArea<DB, Shift>,
    ) -> Result<(), PlotError> {
        head.draw(&Text::new(
            "Fraction of random networks whose normalised mean score reaches x",
            (14, 8),
            ("sans-serif", 20).into_font().color(&BLACK),
        ))
        .map_err(draw_err)?;
        let mut x = 14;
        for (s, c) in &self.header {
            head.draw(&Rectangle::new([(x, 46), (x + 22, 54)], c.filled()))
                .map_err(draw_err)?;
            boxed_label(head, s, (x + 28, 50), 16, BLACK)?;
            x += 28 + text_width(s, 16) + 30;
        }
        Ok(())
    }

    /// One panel in `area`: its chart, its curves (the backdrop first, so
    /// the compared envs are drawn over it), the solved line, and the
    /// curves' labels (on `root`, free to run past the panel).
    fn paint_panel<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, Shift>,
        area: &DrawingArea<DB, Shift>,
        p: &Panel,
        t: PanelText,
    ) -> Result<(), PlotError> {
        let (plot_area, _) = area.split_horizontally(self.panel_w - LABEL_ROOM + 40);
        let mut ch = chart(
            &plot_area,
            &p.title,
            t,
            0.0..self.xmax,
            (self.y0..1.0).log_scale(),
            (
                "normalised mean (0: median random net, 1: solved)",
                "fraction of networks ≥ x",
            ),
        )?;
        let mut order: Vec<&Curve> = p.curves.iter().collect();
        order.sort_by_key(|c| !c.look.backdrop);
        for c in &order {
            self.draw_curve(&mut ch, c)?;
        }
        self.draw_solved_line(root, &mut ch)?;
        label_curve_ends(root, &ch, &order)
    }

    /// A curve's band, then the curve itself (dashed once the palette is
    /// used up); the backdrop's fainter and thinner.
    fn draw_curve<DB: DrawingBackend>(
        &self,
        ch: &mut ProfileChart<'_, DB>,
        c: &Curve,
    ) -> Result<(), PlotError> {
        let color = c.look.color;
        let (band, width) = if c.look.backdrop {
            (0.10, 1)
        } else {
            (0.16, 2)
        };
        let mut poly = self.stairs(c, |p| p.3);
        poly.extend(self.stairs(c, |p| p.2).into_iter().rev());
        ch.draw_series(std::iter::once(Polygon::new(
            poly,
            color.mix(band).filled(),
        )))
        .map_err(draw_err)?;
        let line = self.stairs(c, |p| p.1);
        if c.look.dashed {
            ch.draw_series(DashedLineSeries::new(line, 7, 4, color.stroke_width(width)))
                .map_err(draw_err)?;
        } else {
            ch.draw_series(LineSeries::new(line, color.stroke_width(width)))
                .map_err(draw_err)?;
        }
        Ok(())
    }

    /// The step line through `y` of each of a curve's points (the curve, or
    /// its band's lower or upper edge), floored at the axis: S(x) is
    /// constant on (x_i, x_i+1], a vertical drop at each x_i.
    fn stairs(&self, c: &Curve, y: impl Fn(&(f64, f64, f64, f64)) -> f64) -> Vec<(f64, f64)> {
        let mut out = Vec::with_capacity(2 * c.points.len());
        for (i, p) in c.points.iter().enumerate() {
            out.push((p.0, y(p).max(self.y0)));
            if let Some(q) = c.points.get(i + 1) {
                out.push((p.0, y(q).max(self.y0)));
            }
        }
        out
    }

    /// The dashed red line at the solved score (x = 1), labelled.
    fn draw_solved_line<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, Shift>,
        ch: &mut ProfileChart<'_, DB>,
    ) -> Result<(), PlotError> {
        ch.draw_series(DashedLineSeries::new(
            [(1.0, self.y0), (1.0, 1.0)],
            8,
            5,
            SOLVED.stroke_width(2),
        ))
        .map_err(draw_err)?;
        let (sx, sy) = ch.backend_coord(&(1.0, 1.0));
        root.draw(&Text::new(
            "solved",
            (sx + 4, sy + 4),
            ("sans-serif", 12).into_font().color(&SOLVED),
        ))
        .map_err(draw_err)
    }
}

/// Labels beside the curves' ends, from the lowest end up, each moved up a
/// line while it would overlap one already placed (then joined to its end by
/// a thin line); a dot marks each end.
fn label_curve_ends<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    ch: &ProfileChart<'_, DB>,
    curves: &[&Curve],
) -> Result<(), PlotError> {
    let mut ends: Vec<(i32, i32, &Curve)> = curves
        .iter()
        .map(|c| {
            let last = c.points.last().expect("non-empty curve");
            let (x, y) = ch.backend_coord(&(last.0, last.1));
            (x, y, *c)
        })
        .collect();
    ends.sort_by_key(|&(x, y, c)| (-y, x, c.look.backdrop));
    let mut placed: Vec<(i32, i32, i32)> = Vec::new();
    let size = 13u32;
    let line_h = size as i32 + 3;
    for (x, y, c) in ends {
        let w = text_width(&c.label, size) + 8;
        let (lx, mut ly) = (x + 5, y - line_h / 2);
        while placed
            .iter()
            .any(|&(px, py, pw)| lx < px + pw && px < lx + w && (ly - py).abs() < line_h)
        {
            ly -= line_h;
        }
        placed.push((lx, ly, w));
        root.draw(&Circle::new((x, y), 3, c.look.color.filled()))
            .map_err(draw_err)?;
        if ly != y - line_h / 2 {
            root.draw(&PathElement::new(
                [(x, y), (lx, ly)],
                c.look.color.mix(0.6).stroke_width(1),
            ))
            .map_err(draw_err)?;
        }
        let text_color = if c.look.backdrop {
            BACKDROP_TEXT
        } else {
            c.look.color
        };
        boxed_label(root, &c.label, (lx + 2, ly), size, text_color)?;
    }
    Ok(())
}

/// The panels' key: `arch · bias`, in order of first appearance, settings
/// without bias first.
fn panel_keys(runs: &[CompareRun]) -> Vec<(String, bool)> {
    let archs = distinct(
        runs.iter()
            .flat_map(|r| r.cells.iter().map(|(s, _)| s.id.arch.clone())),
    );
    let mut keys = Vec::new();
    for bias in [false, true] {
        for a in &archs {
            if runs.iter().any(|r| {
                r.cells
                    .iter()
                    .any(|(s, _)| &s.id.arch == a && s.id.bias == bias)
            }) {
                keys.push((a.clone(), bias));
            }
        }
    }
    keys
}

/// A cell's sample means, normalised (none without a solved score).
fn normalised(s: &CellSummary, means: &[f64]) -> Vec<f64> {
    means.iter().filter_map(|&x| s.normalise(x)).collect()
}

/// The panels, in [`panel_keys`] order, each with a curve per (run, env)
/// that has the panel's setting; the envs of the compared runs are labelled
/// with their run when more than one run is compared.
fn profile_panels(runs: &[CompareRun], looks: &Looks, xmax: f64) -> Vec<Panel> {
    let multi = runs.len() > 2;
    panel_keys(runs)
        .into_iter()
        .map(|(arch, bias)| {
            let mut curves = Vec::new();
            for (i, r) in runs.iter().enumerate() {
                for (s, m) in r
                    .cells
                    .iter()
                    .filter(|(s, _)| s.id.arch == arch && s.id.bias == bias)
                {
                    let look = looks.get(i, &s.id.env);
                    let label = if multi && !look.backdrop {
                        format!("{} ({})", s.id.env, r.label)
                    } else {
                        s.id.env.clone()
                    };
                    curves.extend(curve(&normalised(s, m), label, look, xmax));
                }
            }
            Panel {
                title: format!("{arch} · {}", bias_label(bias)),
                curves,
            }
        })
        .collect()
}

/// The key above the panels: the reference set's grey (when there is
/// one), the compared runs' colours, the band's shade.
fn key_entries(runs: &[CompareRun], looks: &Looks) -> Vec<(String, RGBColor)> {
    let mut header = Vec::new();
    let compared: Vec<&str> = match &looks.reference {
        Some(r) => {
            header.push((format!("grey: the reference set ({r})"), BACKDROP));
            runs[1..].iter().map(|r| r.label.as_str()).collect()
        }
        None => runs.iter().map(|r| r.label.as_str()).collect(),
    };
    header.push((
        format!("a colour per env of {}", compared.join(", ")),
        PALETTE[0],
    ));
    header.push(("shade: 95% Wilson interval".into(), RGBColor(190, 218, 236)));
    header
}

/// The grid's columns: as many as the architectures of the bias setting
/// with the most, 1 to 3.
fn grid_cols(runs: &[CompareRun]) -> usize {
    let keys = panel_keys(runs);
    let without = keys.iter().filter(|k| !k.1).count();
    let with = keys.iter().filter(|k| k.1).count();
    without.max(with).clamp(1, 3)
}

/// The comparison's performance profiles: one panel per architecture × bias
/// setting (see the module doc). Cells without a solved score have no
/// normalised score and are left out.
pub fn profiles_figure(runs: &[CompareRun], format: ImageFormat) -> Result<Figure, PlotError> {
    let looks = Looks::new(runs);
    let xmax_data = runs
        .iter()
        .flat_map(|r| r.cells.iter().flat_map(|(s, m)| normalised(s, m)))
        .filter(|v| v.is_finite())
        .fold(1.1f64, f64::max);
    let xmax = xmax_data.min(3.0) * 1.03;
    let nmax = runs
        .iter()
        .flat_map(|r| r.cells.iter().map(|(_, m)| m.len()))
        .max()
        .unwrap_or(1)
        .max(1);
    let panels = profile_panels(runs, &looks, xmax);
    let cols = grid_cols(runs);
    let rows = panels.len().div_ceil(cols).max(1);
    let (pw, ph) = panel_size(cols);
    let size = (cols as u32 * pw, HEADER_H + rows as u32 * ph);
    Ok(Figure {
        name: "profiles".into(),
        caption: "Per architecture, the fraction of random networks whose mean score, normalised \
                  so the median random network is 0 and the solved score 1, reaches x (log scale), \
                  with 95% Wilson bands; the reference run in grey"
            .into(),
        format,
        bytes: render(
            &ProfilesPaint {
                panels,
                cols,
                xmax,
                y0: 0.6 / nmax as f64,
                panel_w: pw,
                header: key_entries(runs, &looks),
            },
            size,
            format,
        )?,
    })
}
