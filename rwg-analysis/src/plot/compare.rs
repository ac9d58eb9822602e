//! The figures of `rwg compare`, drawn the way performance profiles are
//! drawn in rliable (Agarwal et al., NeurIPS 2021): one curve per
//! environment with its confidence band, small multiples instead of one
//! crowded panel.
//!
//! - [`profiles_figure`]: one panel per architecture × bias setting; in each,
//!   per env of every run, the fraction of random networks whose normalised
//!   mean reaches x (log scale), with its 95% Wilson band. The first run is
//!   the reference set, drawn as a muted grey backdrop; the envs of the other
//!   runs get distinct colours. Every curve is labelled beside its end.
//! - [`ranking_figure`]: the difficulty ranking, one row per cell, easiest at
//!   the top: the expected random guesses `1/p` with their interval (log
//!   scale) and the normalised 99.9th percentile of `M`.
//!
//! With a single run there is no reference: every env is coloured.

use super::panels::{chart, tick, PanelText};
use super::{distinct, draw_err, render, Figure, ImageFormat, Layers, Paint, PlotError};
use crate::compare::{CompareRow, CompareRun};
use crate::ranking::{difficulty_order, guesses_short};
use crate::tables::bias_label;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use rwg_study::stats::{wilson_interval, ExpectedGuesses, Z_95};

/// Colours of the compared (non-reference) envs: colour-blind-safe
/// (Okabe–Ito first, then darker tab10 hues), no grey.
const PALETTE: [RGBColor; 10] = [
    RGBColor(0, 114, 178),
    RGBColor(213, 94, 0),
    RGBColor(0, 158, 115),
    RGBColor(204, 121, 167),
    RGBColor(230, 159, 0),
    RGBColor(86, 180, 233),
    RGBColor(140, 86, 75),
    RGBColor(148, 103, 189),
    RGBColor(188, 189, 34),
    RGBColor(23, 190, 207),
];
/// The reference set's curves.
const BACKDROP: RGBColor = RGBColor(175, 175, 175);
/// The reference set's labels (darker than its curves, to stay legible).
const BACKDROP_TEXT: RGBColor = RGBColor(120, 120, 120);
/// The solved line.
const SOLVED: RGBColor = RGBColor(214, 39, 40);
/// At most this many points per curve.
const CURVE_POINTS: usize = 600;

/// How a (run, env) pair is drawn, the same in every panel and both figures.
#[derive(Debug, Clone, Copy)]
struct Look {
    color: RGBColor,
    backdrop: bool,
    dashed: bool,
}

/// The look of every (run index, env) pair: grey for the reference run
/// (the first, when there are several), palette colours in order of first
/// appearance for the others (dashed once the palette is used up).
struct Looks {
    keys: Vec<(usize, String)>,
    looks: Vec<Look>,
    reference: Option<String>,
}

impl Looks {
    fn new(runs: &[CompareRun]) -> Self {
        let has_reference = runs.len() > 1;
        let (mut keys, mut looks) = (Vec::new(), Vec::new());
        let mut k = 0;
        for (i, r) in runs.iter().enumerate() {
            for env in distinct(r.cells.iter().map(|(s, _)| s.id.env.clone())) {
                let backdrop = has_reference && i == 0;
                looks.push(if backdrop {
                    Look {
                        color: BACKDROP,
                        backdrop,
                        dashed: false,
                    }
                } else {
                    k += 1;
                    Look {
                        color: PALETTE[(k - 1) % PALETTE.len()],
                        backdrop,
                        dashed: k > PALETTE.len(),
                    }
                });
                keys.push((i, env));
            }
        }
        Looks {
            keys,
            looks,
            reference: has_reference.then(|| runs[0].label.clone()),
        }
    }

    fn get(&self, run: usize, env: &str) -> Look {
        let i = self
            .keys
            .iter()
            .position(|(r, e)| *r == run && e == env)
            .expect("every (run, env) has a look");
        self.looks[i]
    }
}

/// Rough width in pixels of `s` at `size` px in DejaVu Sans.
fn text_width(s: &str, size: u32) -> i32 {
    (s.chars().count() as f64 * f64::from(size) * 0.58).ceil() as i32
}

/// Draws `s` left-anchored and vertically centred at `(x, y)` over a
/// translucent white box, so it stays legible over curves.
fn boxed_label<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    s: &str,
    (x, y): (i32, i32),
    size: u32,
    color: RGBColor,
) -> Result<(), PlotError> {
    let w = text_width(s, size);
    let h = size as i32 / 2 + 2;
    root.draw(&Rectangle::new(
        [(x - 2, y - h), (x + w + 2, y + h)],
        WHITE.mix(0.8).filled(),
    ))
    .map_err(draw_err)?;
    root.draw(&Text::new(
        s.to_string(),
        (x, y),
        ("sans-serif", size)
            .into_font()
            .color(&color)
            .pos(Pos::new(HPos::Left, VPos::Center)),
    ))
    .map_err(draw_err)
}

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
const HEADER_H: u32 = 70;
/// Room right of the data for the curves' labels.
const LABEL_ROOM: u32 = 150;

impl Paint for ProfilesPaint {
    fn paint<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, Shift>,
        _layers: &mut Layers,
    ) -> Result<(), PlotError> {
        let (head, body) = root.split_vertically(HEADER_H);
        head.draw(&Text::new(
            "Fraction of random networks whose normalised mean score reaches x",
            (14, 8),
            ("sans-serif", 20).into_font().color(&BLACK),
        ))
        .map_err(draw_err)?;
        // the key: one entry per run
        let mut x = 14;
        for (s, c) in &self.header {
            head.draw(&Rectangle::new([(x, 46), (x + 22, 54)], c.filled()))
                .map_err(draw_err)?;
            boxed_label(&head, s, (x + 28, 50), 16, BLACK)?;
            x += 28 + text_width(s, 16) + 30;
        }
        let rows = self.panels.len().div_ceil(self.cols);
        let grid = body.split_evenly((rows, self.cols));
        let t = if self.cols <= 2 {
            PanelText::LARGE
        } else {
            PanelText::SMALL
        };
        for (p, area) in self.panels.iter().zip(&grid) {
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
            // backdrop first, so the compared envs are drawn over it
            let mut order: Vec<&Curve> = p.curves.iter().collect();
            order.sort_by_key(|c| !c.look.backdrop);
            for c in &order {
                let (color, band, width) = if c.look.backdrop {
                    (c.look.color, 0.10, 1)
                } else {
                    (c.look.color, 0.16, 2)
                };
                // the curve (k = 1), its band's lower (2) or upper (3) edge
                let y = |p: &(f64, f64, f64, f64), k: usize| match k {
                    1 => p.1,
                    2 => p.2,
                    _ => p.3,
                };
                let stairs = |k: usize| -> Vec<(f64, f64)> {
                    // S(x) is constant on (x_i, x_i+1]: a vertical drop at each x_i
                    let mut out = Vec::with_capacity(2 * c.points.len());
                    for (i, p) in c.points.iter().enumerate() {
                        out.push((p.0, y(p, k).max(self.y0)));
                        if let Some(q) = c.points.get(i + 1) {
                            out.push((p.0, y(q, k).max(self.y0)));
                        }
                    }
                    out
                };
                let mut poly = stairs(3);
                poly.extend(stairs(2).into_iter().rev());
                ch.draw_series(std::iter::once(Polygon::new(
                    poly,
                    color.mix(band).filled(),
                )))
                .map_err(draw_err)?;
                let line = stairs(1);
                if c.look.dashed {
                    ch.draw_series(DashedLineSeries::new(line, 7, 4, color.stroke_width(width)))
                        .map_err(draw_err)?;
                } else {
                    ch.draw_series(LineSeries::new(line, color.stroke_width(width)))
                        .map_err(draw_err)?;
                }
            }
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
            .map_err(draw_err)?;
            // labels beside the curves' ends, stacked upwards where they meet
            let mut ends: Vec<(i32, i32, &Curve)> = order
                .iter()
                .map(|c| {
                    let last = c.points.last().expect("non-empty curve");
                    let (x, y) = ch.backend_coord(&(last.0, last.1));
                    (x, y, *c)
                })
                .collect();
            ends.sort_by_key(|&(x, y, c)| (-y, x, c.look.backdrop));
            let mut placed: Vec<(i32, i32, i32, i32)> = Vec::new();
            let size = 13u32;
            let line_h = size as i32 + 3;
            for (x, y, c) in ends {
                let w = text_width(&c.label, size) + 8;
                let (lx, mut ly) = (x + 5, y - line_h / 2);
                while placed
                    .iter()
                    .any(|&(px, py, pw, _)| lx < px + pw && px < lx + w && (ly - py).abs() < line_h)
                {
                    ly -= line_h;
                }
                placed.push((lx, ly, w, line_h));
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
        }
        Ok(())
    }
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

/// The comparison's performance profiles: one panel per architecture × bias
/// setting (see the module doc). Cells without a solved score have no
/// normalised score and are left out.
pub fn profiles_figure(runs: &[CompareRun], format: ImageFormat) -> Result<Figure, PlotError> {
    let looks = Looks::new(runs);
    let norm = |s: &rwg_study::stats::CellSummary, m: &[f64]| -> Vec<f64> {
        m.iter().filter_map(|&x| s.normalise(x)).collect()
    };
    let xmax_data = runs
        .iter()
        .flat_map(|r| r.cells.iter().flat_map(|(s, m)| norm(s, m)))
        .filter(|v| v.is_finite())
        .fold(1.1f64, f64::max);
    let xmax = xmax_data.min(3.0) * 1.03;
    let nmax = runs
        .iter()
        .flat_map(|r| r.cells.iter().map(|(_, m)| m.len()))
        .max()
        .unwrap_or(1)
        .max(1);
    let multi = runs.len() > 2;
    let panels: Vec<Panel> = panel_keys(runs)
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
                    curves.extend(curve(&norm(s, m), label, look, xmax));
                }
            }
            Panel {
                title: format!("{arch} · {}", bias_label(bias)),
                curves,
            }
        })
        .collect();
    let cols = panel_keys(runs)
        .iter()
        .filter(|k| !k.1)
        .count()
        .max(panel_keys(runs).iter().filter(|k| k.1).count())
        .clamp(1, 3);
    let rows = panels.len().div_ceil(cols).max(1);
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
                header,
            },
            size,
            format,
        )?,
    })
}

struct RankingPaint<'a> {
    rows: Vec<(usize, &'a CompareRow, Look)>,
    gmax: f64,
    nmin: f64,
    nmax: f64,
}

const ROW_H: u32 = 24;
const LABEL_W: u32 = 440;
const TOP_H: u32 = 74;
const BOTTOM_H: u32 = 56;

/// A ranking panel's chart builder: room for the title above, the x axis
/// below, no y axis (the rows are labelled at the left of the figure).
fn ranking_builder<'a, 'b, DB: DrawingBackend>(
    area: &'a DrawingArea<DB, Shift>,
    title: &'b str,
) -> ChartBuilder<'a, 'b, DB> {
    let mut b = ChartBuilder::on(area);
    b.margin_top(TOP_H - 24)
        .margin_right(14)
        .x_label_area_size(BOTTOM_H)
        .caption(title, ("sans-serif", 15));
    b
}

impl Paint for RankingPaint<'_> {
    fn paint<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, Shift>,
        _layers: &mut Layers,
    ) -> Result<(), PlotError> {
        root.draw(&Text::new(
            "Difficulty ranking, easiest first",
            (14, 8),
            ("sans-serif", 20).into_font().color(&BLACK),
        ))
        .map_err(draw_err)?;
        let n = self.rows.len() as f64;
        let (labels, rest) = root.split_horizontally(LABEL_W);
        let (w, _) = rest.dim_in_pixel();
        let (left, right) = rest.split_horizontally(w * 3 / 5);
        let mut gl = ranking_builder(
            &left,
            "expected random guesses to the first solving network (1/p)",
        )
        .build_cartesian_2d((1.0..self.gmax).log_scale(), 0.0..n)
        .map_err(draw_err)?;
        gl.configure_mesh()
            .disable_y_mesh()
            .y_labels(0)
            .x_desc("1/p, 95% interval (log scale); ▷ none seen: at least")
            .label_style(("sans-serif", 12))
            .axis_desc_style(("sans-serif", 13))
            .x_label_formatter(&tick)
            .light_line_style(TRANSPARENT)
            .bold_line_style(BLACK.mix(0.14))
            .draw()
            .map_err(draw_err)?;
        let mut gr = ranking_builder(&right, "normalised 99.9th percentile of M")
            .build_cartesian_2d(self.nmin..self.nmax, 0.0..n)
            .map_err(draw_err)?;
        gr.configure_mesh()
            .disable_y_mesh()
            .y_labels(0)
            .x_desc("0: median random net, 1: solved")
            .label_style(("sans-serif", 12))
            .axis_desc_style(("sans-serif", 13))
            .x_label_formatter(&tick)
            .light_line_style(TRANSPARENT)
            .bold_line_style(BLACK.mix(0.14))
            .draw()
            .map_err(draw_err)?;
        gr.draw_series(DashedLineSeries::new(
            [(1.0, 0.0), (1.0, n)],
            6,
            4,
            SOLVED.stroke_width(1),
        ))
        .map_err(draw_err)?;
        for (k, &(rank, row, look)) in self.rows.iter().enumerate() {
            let y = n - k as f64 - 0.5;
            let s = &row.summary;
            if k % 2 == 0 {
                let (_, ya) = gl.backend_coord(&(1.0, y + 0.5));
                let (_, yb) = gl.backend_coord(&(1.0, y - 0.5));
                let (wfull, _) = root.dim_in_pixel();
                root.draw(&Rectangle::new(
                    [(0, ya), (wfull as i32, yb)],
                    BLACK.mix(0.035).filled(),
                ))
                .map_err(draw_err)?;
            }
            let color = look.color;
            let text_color = if look.backdrop {
                BLACK.mix(0.55).to_rgba()
            } else {
                color.to_rgba()
            };
            let (_, py) = gl.backend_coord(&(1.0, y));
            let label = format!(
                "{rank:>2}. {} · {} · {} — {}",
                s.id.env,
                s.id.arch,
                bias_label(s.id.bias),
                row.run
            );
            labels
                .draw(&Text::new(
                    label,
                    (10, py),
                    ("sans-serif", 14)
                        .into_font()
                        .color(&text_color)
                        .pos(Pos::new(HPos::Left, VPos::Center)),
                ))
                .map_err(draw_err)?;
            let stroke = color.stroke_width(if look.backdrop { 3 } else { 4 });
            match s.expected_guesses {
                Some(ExpectedGuesses::Estimate {
                    value,
                    lo_bound,
                    hi_bound,
                }) => {
                    let hi = hi_bound.unwrap_or(self.gmax).min(self.gmax);
                    gl.draw_series(std::iter::once(PathElement::new(
                        [(lo_bound.max(1.0), y), (hi, y)],
                        color.mix(0.55).stroke_width(7),
                    )))
                    .map_err(draw_err)?;
                    gl.draw_series(std::iter::once(Circle::new(
                        (value.max(1.0), y),
                        4,
                        BLACK.filled(),
                    )))
                    .map_err(draw_err)?;
                }
                Some(ExpectedGuesses::NoneSeen { at_least }) => {
                    let a = at_least.max(1.0).min(self.gmax);
                    gl.draw_series(DashedLineSeries::new(
                        [(a, y), (self.gmax, y)],
                        5,
                        4,
                        stroke,
                    ))
                    .map_err(draw_err)?;
                    let (px, py) = gl.backend_coord(&(a, y));
                    root.draw(&Polygon::new(
                        vec![(px, py - 6), (px + 9, py), (px, py + 6)],
                        color.filled(),
                    ))
                    .map_err(draw_err)?;
                    boxed_label(root, &guesses_short(row), (px + 14, py), 12, BLACK)?;
                }
                None => {
                    let (px, py) = gl.backend_coord(&(1.0, y));
                    boxed_label(root, "no solved score", (px + 6, py), 12, BLACK)?;
                }
            }
            if let Some(v) = row.normalised_p99_9.filter(|v| v.is_finite()) {
                let v = v.clamp(self.nmin, self.nmax);
                gr.draw_series(std::iter::once(PathElement::new(
                    [(self.nmin.max(0.0).min(v), y), (v, y)],
                    color.mix(0.35).stroke_width(2),
                )))
                .map_err(draw_err)?;
                gr.draw_series(std::iter::once(Circle::new((v, y), 5, color.filled())))
                    .map_err(draw_err)?;
            }
        }
        Ok(())
    }
}

/// The difficulty ranking as one figure (see the module doc): a row per
/// comparison row, in [`difficulty_order`].
pub fn ranking_figure(
    runs: &[CompareRun],
    rows: &[CompareRow],
    format: ImageFormat,
) -> Result<Figure, PlotError> {
    let looks = Looks::new(runs);
    let run_index = |label: &str| runs.iter().position(|r| r.label == label).unwrap_or(0);
    let ordered: Vec<(usize, &CompareRow, Look)> = difficulty_order(rows)
        .into_iter()
        .enumerate()
        .map(|(k, i)| {
            let r = &rows[i];
            (k + 1, r, looks.get(run_index(&r.run), &r.summary.id.env))
        })
        .collect();
    let gmax = rows
        .iter()
        .filter_map(|r| match r.summary.expected_guesses {
            Some(ExpectedGuesses::Estimate {
                lo_bound, hi_bound, ..
            }) => Some(hi_bound.unwrap_or(lo_bound * 10.0)),
            Some(ExpectedGuesses::NoneSeen { at_least }) => Some(at_least),
            None => None,
        })
        .fold(10.0f64, f64::max)
        * 3.0;
    let norms = rows
        .iter()
        .filter_map(|r| r.normalised_p99_9)
        .filter(|v| v.is_finite());
    let (lo, hi) = norms.fold((0.0f64, 1.1f64), |(a, b), v| (a.min(v), b.max(v)));
    let (nmin, nmax) = (lo.max(-1.0) - 0.05, hi.min(3.0) + 0.05);
    let height = TOP_H + BOTTOM_H + ROW_H * ordered.len().max(3) as u32;
    Ok(Figure {
        name: "ranking".into(),
        caption: "Every cell of every run from the easiest to the hardest for random search: \
                  expected random guesses to the first solving network (1/p, 95% interval), \
                  then the normalised 99.9th percentile of M"
            .into(),
        format,
        bytes: render(
            &RankingPaint {
                rows: ordered,
                gmax,
                nmin,
                nmax,
            },
            (1240, height),
            format,
        )?,
    })
}
