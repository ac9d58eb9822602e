//! The figure of `rwg compare --paired --figure`: one row per architecture
//! × bias setting, two panels each.
//!
//! - Left, with the same networks: network `n`'s mean in the first cell
//!   against its mean in the second, one dot per network, coloured by where
//!   it is solved (both, one, neither); one benchmark puts the dots along
//!   the diagonal. With different networks, the quantiles of the two cells'
//!   means against each other instead (a Q–Q plot: one distribution puts
//!   them on the diagonal).
//! - Right: the empirical CDFs of the two cells' means, the distance the
//!   KS test measures.

use super::pairing::{cell_pairs, PairSide};
use super::rows::PairedRow;
use super::table_csv::{sides, verdict_line};
use super::PairedComparison;
use crate::fmt::sig;
use crate::plot::panels::{chart, dot_style, padded_range, tick, PanelText};
use crate::plot::raster::Raster;
use crate::plot::{draw_err, render, Figure, ImageFormat, Layers, Paint, PlotError};
use crate::run_tables::bias_label;
use plotters::coord::Shift;
use plotters::prelude::*;

/// The first side's colour (Okabe–Ito blue), the second's (vermillion).
const COLOR_A: RGBColor = RGBColor(0, 114, 178);
const COLOR_B: RGBColor = RGBColor(213, 94, 0);
/// Networks solved in both cells (bluish green), in one only (orange),
/// in neither (grey).
const BOTH: RGBColor = RGBColor(0, 158, 115);
const ONE: RGBColor = RGBColor(230, 159, 0);
const NEITHER: RGBColor = RGBColor(90, 90, 90);
const SOLVED: RGBColor = RGBColor(214, 39, 40);
/// At most this many steps per CDF curve.
const CDF_POINTS: usize = 800;
const HEADER_H: u32 = 64;
const ROW_H: u32 = 440;
const WIDTH: u32 = 1200;

/// One row of the figure: the two cells' means over the compared networks.
struct RowData<'a> {
    row: &'a PairedRow,
    a: Vec<f64>,
    b: Vec<f64>,
}

struct PairedPaint<'a> {
    rows: Vec<RowData<'a>>,
    title: String,
    verdict: String,
    label_a: String,
    label_b: String,
}

/// Draws the figure of comparison `c` of `a` and `b`.
pub fn paired_figure(
    a: &PairSide,
    b: &PairSide,
    c: &PairedComparison,
    format: ImageFormat,
) -> Result<Figure, PlotError> {
    let rows = cell_pairs(a, b)
        .into_iter()
        .zip(&c.rows)
        .map(|(p, row)| {
            let n = row.networks as usize;
            RowData {
                row,
                a: p.a.means()[..n].to_vec(),
                b: p.b.means()[..n].to_vec(),
            }
        })
        .collect::<Vec<_>>();
    let paint = PairedPaint {
        title: format!("Paired comparison of {}", sides(c)),
        verdict: verdict_line(c),
        label_a: c.label_a.clone(),
        label_b: c.label_b.clone(),
        rows,
    };
    let h = HEADER_H + ROW_H * paint.rows.len() as u32;
    Ok(Figure {
        name: "paired".into(),
        caption: paint.title.clone(),
        format,
        bytes: render(&paint, (WIDTH, h), format)?,
    })
}

impl Paint for PairedPaint<'_> {
    fn paint<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, Shift>,
        layers: &mut Layers,
    ) -> Result<(), PlotError> {
        let (head, body) = root.split_vertically(HEADER_H);
        for (i, (s, size)) in [(&self.title, 19), (&self.verdict, 15)].iter().enumerate() {
            head.draw(&Text::new(
                s.to_string(),
                (14, 8 + 28 * i as i32),
                ("sans-serif", *size).into_font().color(&BLACK),
            ))
            .map_err(draw_err)?;
        }
        let grid = body.split_evenly((self.rows.len(), 2));
        for (r, cells) in self.rows.iter().zip(grid.chunks(2)) {
            self.pairs_panel(&cells[0], layers, r)?;
            self.cdf_panel(&cells[1], r)?;
        }
        Ok(())
    }
}

fn legend<'a, DB: DrawingBackend + 'a, CT: plotters::coord::CoordTranslate>(
    chart: &mut ChartContext<'a, DB, CT>,
) -> Result<(), PlotError> {
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperLeft)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK.mix(0.4))
        .label_font(("sans-serif", 13))
        .draw()
        .map_err(draw_err)
}

impl PairedPaint<'_> {
    /// Network by network (the same networks) or quantile by quantile.
    fn pairs_panel<DB: DrawingBackend>(
        &self,
        area: &DrawingArea<DB, Shift>,
        layers: &mut Layers,
        r: &RowData,
    ) -> Result<(), PlotError> {
        let row = r.row;
        let (xs, ys, title) = if row.paired {
            let rho = row
                .spearman
                .map_or_else(|| "–".into(), |x| format!("{x:.3}"));
            (
                r.a.clone(),
                r.b.clone(),
                format!(
                    "{} · {}: each network (Spearman ρ {rho})",
                    row.arch,
                    bias_label(row.bias)
                ),
            )
        } else {
            let mut xs = r.a.clone();
            let mut ys = r.b.clone();
            xs.sort_by(f64::total_cmp);
            ys.sort_by(f64::total_cmp);
            (
                xs,
                ys,
                format!(
                    "{} · {}: quantiles (not the same networks)",
                    row.arch,
                    bias_label(row.bias)
                ),
            )
        };
        let (lo, hi) = padded_range(
            xs.iter().chain(&ys).copied(),
            row.solved_a.or(row.solved_b),
            0.04,
        );
        let mut chart = chart(
            area,
            &title,
            PanelText::LARGE,
            lo..hi,
            lo..hi,
            (
                &format!("mean in {}", self.label_a),
                &format!("mean in {}", self.label_b),
            ),
        )?;
        chart
            .draw_series(LineSeries::new([(lo, lo), (hi, hi)], BLACK.mix(0.35)))
            .map_err(draw_err)?;
        let plot = chart.plotting_area().strip_coord_spec();
        let mut raster = Raster::over(&plot);
        let (alpha, size) = dot_style(xs.len(), raster.w);
        let class = |x: f64, y: f64| -> RGBColor {
            if !row.paired {
                return COLOR_A;
            }
            let sa = row.solved_a.is_some_and(|s| x >= s);
            let sb = row.solved_b.is_some_and(|s| y >= s);
            match (sa, sb) {
                (true, true) => BOTH,
                (false, false) => NEITHER,
                _ => ONE,
            }
        };
        // the rare classes last, over the crowd
        for pass in [NEITHER, COLOR_A, ONE, BOTH] {
            for (&x, &y) in xs.iter().zip(&ys) {
                let c = class(x, y);
                if c == pass {
                    let a = if c == NEITHER || c == COLOR_A {
                        alpha.max(0.3)
                    } else {
                        0.9
                    };
                    raster.dot(chart.backend_coord(&(x, y)), size + 1, c.mix(a));
                }
            }
        }
        layers.add(&plot, raster)?;
        let keyed = row.paired && row.solved_pairs.is_some();
        if keyed {
            for (c, label) in [
                (BOTH, "solved in both"),
                (ONE, "solved in one"),
                (NEITHER, "in neither"),
            ] {
                chart
                    .draw_series(std::iter::empty::<Circle<(f64, f64), i32>>())
                    .map_err(draw_err)?
                    .label(label)
                    .legend(move |(x, y)| Circle::new((x + 6, y), 4, c.filled()));
            }
        }
        for (s, vertical) in [(row.solved_a, true), (row.solved_b, false)] {
            let Some(s) = s.filter(|v| v.is_finite()) else {
                continue;
            };
            let line = if vertical {
                [(s, lo), (s, hi)]
            } else {
                [(lo, s), (hi, s)]
            };
            chart
                .draw_series(DashedLineSeries::new(line, 8, 5, SOLVED.stroke_width(2)))
                .map_err(draw_err)?;
        }
        if keyed {
            legend(&mut chart)?;
        }
        Ok(())
    }

    /// The empirical CDFs of both cells' means.
    fn cdf_panel<DB: DrawingBackend>(
        &self,
        area: &DrawingArea<DB, Shift>,
        r: &RowData,
    ) -> Result<(), PlotError> {
        let row = r.row;
        let title = match row.ks {
            Some(t) => format!(
                "CDF of the means: KS D {} (p {})",
                sig(t.statistic, 3),
                sig(t.p_value, 2)
            ),
            None => "CDF of the means (no KS test)".into(),
        };
        let (lo, hi) = padded_range(r.a.iter().chain(&r.b).copied(), row.solved_a, 0.04);
        let mut chart = chart(
            area,
            &title,
            PanelText::LARGE,
            lo..hi,
            0.0..1.02,
            ("network's mean score", "fraction of networks at or below"),
        )?;
        for (values, color, label) in [
            (&r.a, COLOR_A, &self.label_a),
            (&r.b, COLOR_B, &self.label_b),
        ] {
            chart
                .draw_series(LineSeries::new(
                    cdf_steps(values, lo, hi),
                    color.stroke_width(2),
                ))
                .map_err(draw_err)?
                .label(label.clone())
                .legend(move |(x, y)| {
                    PathElement::new([(x, y), (x + 16, y)], color.stroke_width(2))
                });
        }
        if let Some(s) = row.solved_a.filter(|v| v.is_finite()) {
            chart
                .draw_series(DashedLineSeries::new(
                    [(s, 0.0), (s, 1.02)],
                    8,
                    5,
                    SOLVED.stroke_width(2),
                ))
                .map_err(draw_err)?
                .label(format!("solved ({})", tick(&s)))
                .legend(|(x, y)| PathElement::new([(x, y), (x + 16, y)], SOLVED.stroke_width(2)));
        }
        legend(&mut chart)
    }
}

/// The step curve of the empirical CDF of `values` from `lo` to `hi`, at
/// most [`CDF_POINTS`] steps (every k-th order statistic, and the last).
fn cdf_steps(values: &[f64], lo: f64, hi: f64) -> Vec<(f64, f64)> {
    let mut v: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
    v.sort_by(f64::total_cmp);
    let n = v.len();
    let step = (n / CDF_POINTS).max(1);
    let mut out = vec![(lo, 0.0)];
    let mut last = 0.0;
    for (i, &x) in v.iter().enumerate() {
        if (i + 1) % step == 0 || i + 1 == n {
            let y = (i + 1) as f64 / n as f64;
            out.push((x, last));
            out.push((x, y));
            last = y;
        }
    }
    out.push((hi, last));
    out
}

#[cfg(test)]
mod tests {
    use super::cdf_steps;

    #[test]
    fn cdf_steps_climb_at_each_value() {
        assert_eq!(
            cdf_steps(&[2.0, 1.0], 0.0, 3.0),
            [
                (0.0, 0.0),
                (1.0, 0.0),
                (1.0, 0.5),
                (2.0, 0.5),
                (2.0, 1.0),
                (3.0, 1.0)
            ]
        );
    }
}
