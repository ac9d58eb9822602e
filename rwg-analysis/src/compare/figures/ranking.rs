//! The difficulty-ranking figure of `rwg compare --ranking-figure`: a row
//! per cell, easiest at the top, with `1/p` and the normalised 99.9th
//! percentile of `M` side by side.

use super::{boxed_label, Look, Looks, SOLVED};
use crate::compare::data::{CompareRow, CompareRun};
use crate::compare::ranking::{difficulty_order, guesses_short};
use crate::plot::panels::tick;
use crate::plot::{draw_err, render, Figure, ImageFormat, Layers, Paint, PlotError};
use crate::run_tables::bias_label;
use plotters::coord::ranged1d::ValueFormatter;
use plotters::coord::types::RangedCoordf64;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use rwg_study::stats::ExpectedGuesses;

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

/// The left chart: `1/p` on a log x axis, a row per cell on y.
type GuessChart<'a, DB> = ChartContext<'a, DB, Cartesian2d<LogCoord<f64>, RangedCoordf64>>;
/// The right chart: the normalised 99.9th percentile of `M` on x.
type NormChart<'a, DB> = ChartContext<'a, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

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
        let (labels, rest) = root.split_horizontally(LABEL_W);
        let (w, _) = rest.dim_in_pixel();
        let (left, right) = rest.split_horizontally(w * 3 / 5);
        let mut gl = self.guesses_chart(&left)?;
        let mut gr = self.norm_chart(&right)?;
        let n = self.rows.len() as f64;
        for (k, &(rank, row, look)) in self.rows.iter().enumerate() {
            let y = n - k as f64 - 0.5;
            if k % 2 == 0 {
                stripe(root, &gl, y)?;
            }
            row_label(&labels, &gl, (rank, row, look), y)?;
            self.draw_guesses(root, &mut gl, (row, look), y)?;
            self.draw_norm(&mut gr, (row, look), y)?;
        }
        Ok(())
    }
}

impl RankingPaint<'_> {
    /// The left chart with its axis.
    fn guesses_chart<'a, DB: DrawingBackend>(
        &self,
        left: &'a DrawingArea<DB, Shift>,
    ) -> Result<GuessChart<'a, DB>, PlotError> {
        let n = self.rows.len() as f64;
        let mut gl = ranking_builder(
            left,
            "expected random guesses to the first solving network (1/p)",
        )
        .build_cartesian_2d((1.0..self.gmax).log_scale(), 0.0..n)
        .map_err(draw_err)?;
        draw_x_axis(
            &mut gl,
            "1/p, 95% interval (log scale); ▷ none seen: at least",
        )?;
        Ok(gl)
    }

    /// The right chart with its axis and the dashed solved line at 1.
    fn norm_chart<'a, DB: DrawingBackend>(
        &self,
        right: &'a DrawingArea<DB, Shift>,
    ) -> Result<NormChart<'a, DB>, PlotError> {
        let n = self.rows.len() as f64;
        let mut gr = ranking_builder(right, "normalised 99.9th percentile of M")
            .build_cartesian_2d(self.nmin..self.nmax, 0.0..n)
            .map_err(draw_err)?;
        draw_x_axis(&mut gr, "0: median random net, 1: solved")?;
        gr.draw_series(DashedLineSeries::new(
            [(1.0, 0.0), (1.0, n)],
            6,
            4,
            SOLVED.stroke_width(1),
        ))
        .map_err(draw_err)?;
        Ok(gr)
    }

    /// A row's `1/p`: its interval and estimate; or, none seen, a dashed
    /// line from the lower bound on with an arrowhead and the bound's text;
    /// or "no solved score".
    fn draw_guesses<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, Shift>,
        gl: &mut GuessChart<'_, DB>,
        (row, look): (&CompareRow, Look),
        y: f64,
    ) -> Result<(), PlotError> {
        let color = look.color;
        match row.summary.expected_guesses {
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
                let stroke = color.stroke_width(if look.backdrop { 3 } else { 4 });
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
        Ok(())
    }

    /// A row's normalised 99.9th percentile of `M` (clamped to the axis):
    /// a bar from 0 and a dot; nothing when it has none.
    fn draw_norm<DB: DrawingBackend>(
        &self,
        gr: &mut NormChart<'_, DB>,
        (row, look): (&CompareRow, Look),
        y: f64,
    ) -> Result<(), PlotError> {
        let Some(v) = row.normalised_p99_9.filter(|v| v.is_finite()) else {
            return Ok(());
        };
        let v = v.clamp(self.nmin, self.nmax);
        gr.draw_series(std::iter::once(PathElement::new(
            [(self.nmin.max(0.0).min(v), y), (v, y)],
            look.color.mix(0.35).stroke_width(2),
        )))
        .map_err(draw_err)?;
        gr.draw_series(std::iter::once(Circle::new((v, y), 5, look.color.filled())))
            .map_err(draw_err)?;
        Ok(())
    }
}

/// A ranking chart's mesh: vertical grid lines and the x axis described by
/// `x_desc`, no y labels (the rows are labelled at the left of the figure).
fn draw_x_axis<DB: DrawingBackend, X, Y>(
    ch: &mut ChartContext<'_, DB, Cartesian2d<X, Y>>,
    x_desc: &str,
) -> Result<(), PlotError>
where
    X: Ranged<ValueType = f64> + ValueFormatter<f64>,
    Y: Ranged<ValueType = f64> + ValueFormatter<f64>,
{
    ch.configure_mesh()
        .disable_y_mesh()
        .y_labels(0)
        .x_desc(x_desc)
        .label_style(("sans-serif", 12))
        .axis_desc_style(("sans-serif", 13))
        .x_label_formatter(&tick)
        .light_line_style(TRANSPARENT)
        .bold_line_style(BLACK.mix(0.14))
        .draw()
        .map_err(draw_err)
}

/// The light stripe behind the row at `y`, across the whole figure.
fn stripe<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    gl: &GuessChart<'_, DB>,
    y: f64,
) -> Result<(), PlotError> {
    let (_, ya) = gl.backend_coord(&(1.0, y + 0.5));
    let (_, yb) = gl.backend_coord(&(1.0, y - 0.5));
    let (wfull, _) = root.dim_in_pixel();
    root.draw(&Rectangle::new(
        [(0, ya), (wfull as i32, yb)],
        BLACK.mix(0.035).filled(),
    ))
    .map_err(draw_err)
}

/// The row's label at the left: `rank. env · arch · bias — run`, in the
/// run's colour (dark grey for the reference set).
fn row_label<DB: DrawingBackend>(
    labels: &DrawingArea<DB, Shift>,
    gl: &GuessChart<'_, DB>,
    (rank, row, look): (usize, &CompareRow, Look),
    y: f64,
) -> Result<(), PlotError> {
    let s = &row.summary;
    let text_color = if look.backdrop {
        BLACK.mix(0.55).to_rgba()
    } else {
        look.color.to_rgba()
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
        .map_err(draw_err)
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
