//! The individual panels: histogram of `M`, scores over rank, `V` over `M`.

use super::raster::Raster;
use super::{draw_err, Layers, PlotError};
use plotters::coord::ranged1d::{AsRangedCoord, ValueFormatter};
use plotters::coord::Shift;
use plotters::prelude::*;
use rwg_study::rundir::data::CellData;
use rwg_study::stats::{self, CellSummary};

/// Colour of episode scores and of the first histogram.
pub(crate) const BLUE: RGBColor = RGBColor(31, 119, 180);
/// Colour of the second histogram (with bias).
pub(crate) const ORANGE: RGBColor = RGBColor(255, 127, 14);
/// Colour of the top 0.1% of episodes.
pub(crate) const GREEN: RGBColor = RGBColor(44, 160, 44);
/// Colour of the `M` curve.
pub(crate) const DARK_RED: RGBColor = RGBColor(140, 20, 20);
/// Colour of the solved line.
pub(crate) const RED: RGBColor = RGBColor(214, 39, 40);

/// Bins of the histograms.
const BINS: usize = 40;
/// At most this many points on the `M` curve.
const CURVE_POINTS: usize = 2000;

/// Text sizes and margins of a panel.
#[derive(Debug, Clone, Copy)]
pub(crate) struct PanelText {
    title: u32,
    label: u32,
    tick: u32,
    margin: u32,
    x_area: u32,
    y_area: u32,
}

impl PanelText {
    /// A figure of its own.
    pub(crate) const LARGE: PanelText = PanelText {
        title: 19,
        label: 15,
        tick: 13,
        margin: 12,
        x_area: 48,
        y_area: 72,
    };
    /// A panel of a grid.
    pub(crate) const SMALL: PanelText = PanelText {
        title: 14,
        label: 12,
        tick: 10,
        margin: 8,
        x_area: 38,
        y_area: 58,
    };
}

/// One histogram of a histogram panel.
pub(crate) struct HistSeries<'a> {
    /// Legend entry.
    pub label: Option<&'a str>,
    /// The values (sample means).
    pub values: &'a [f64],
    /// Bar colour.
    pub color: RGBColor,
}

/// `[lo, hi]` of the finite values and `extra`, padded by `pad` of the span
/// on each side; a unit span around a single value.
pub(crate) fn padded_range(
    values: impl Iterator<Item = f64>,
    extra: Option<f64>,
    pad: f64,
) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in values.chain(extra).filter(|v| v.is_finite()) {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if lo > hi {
        return (0.0, 1.0);
    }
    if lo == hi {
        return (lo - 0.5, hi + 0.5);
    }
    let p = (hi - lo) * pad;
    (lo - p, hi + p)
}

/// Compact tick labels: `1.2e5` for large or tiny magnitudes.
pub(crate) fn tick(v: &f64) -> String {
    let a = v.abs();
    if a == 0.0 {
        "0".into()
    } else if !(1e-3..1e5).contains(&a) {
        format!("{v:.1e}")
    } else {
        let s = format!("{v:.3}");
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    }
}

fn legend_style<'a, DB: DrawingBackend + 'a, CT: plotters::coord::CoordTranslate>(
    chart: &mut ChartContext<'a, DB, CT>,
    pos: SeriesLabelPosition,
    t: PanelText,
) -> Result<(), PlotError> {
    chart
        .configure_series_labels()
        .position(pos)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK.mix(0.4))
        .label_font(("sans-serif", t.tick))
        .draw()
        .map_err(draw_err)
}

/// A panel's chart: f64 axes of the coordinate types `X` and `Y` make.
type Chart<'a, DB, X, Y> = ChartContext<
    'a,
    DB,
    Cartesian2d<<X as AsRangedCoord>::CoordDescType, <Y as AsRangedCoord>::CoordDescType>,
>;

/// A chart with what every panel shares: caption, margins, label areas, the
/// mesh's line and text styles, and [`tick`] labels on both axes.
pub(crate) fn chart<'a, DB, X, Y>(
    area: &'a DrawingArea<DB, Shift>,
    title: &str,
    t: PanelText,
    x: X,
    y: Y,
    (x_desc, y_desc): (&str, &str),
) -> Result<Chart<'a, DB, X, Y>, PlotError>
where
    DB: DrawingBackend,
    X: AsRangedCoord<Value = f64>,
    Y: AsRangedCoord<Value = f64>,
    X::CoordDescType: Ranged<ValueType = f64> + ValueFormatter<f64>,
    Y::CoordDescType: Ranged<ValueType = f64> + ValueFormatter<f64>,
{
    let mut chart = ChartBuilder::on(area)
        .caption(title, ("sans-serif", t.title))
        .margin(t.margin)
        .x_label_area_size(t.x_area)
        .y_label_area_size(t.y_area)
        .build_cartesian_2d(x, y)
        .map_err(draw_err)?;
    chart
        .configure_mesh()
        .x_desc(x_desc)
        .y_desc(y_desc)
        .label_style(("sans-serif", t.tick))
        .axis_desc_style(("sans-serif", t.label))
        .light_line_style(BLACK.mix(0.03))
        .bold_line_style(BLACK.mix(0.12))
        .x_label_formatter(&tick)
        .y_label_formatter(&tick)
        .draw()
        .map_err(draw_err)?;
    Ok(chart)
}

/// Histogram(s) of sample means over shared bins, log-scale count axis, the
/// solved score as a dashed line.
pub(crate) fn histogram_panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    title: &str,
    series: &[HistSeries<'_>],
    solved: Option<f64>,
    t: PanelText,
) -> Result<(), PlotError> {
    let (lo, hi) = padded_range(
        series.iter().flat_map(|s| s.values.iter().copied()),
        solved,
        0.0,
    );
    let width = (hi - lo) / BINS as f64;
    let counts: Vec<Vec<u64>> = series
        .iter()
        .map(|s| {
            let mut c = vec![0u64; BINS];
            for &v in s.values.iter().filter(|v| v.is_finite()) {
                let i = (((v - lo) / width).floor().max(0.0) as usize).min(BINS - 1);
                c[i] += 1;
            }
            c
        })
        .collect();
    let max_count = counts.iter().flatten().copied().max().unwrap_or(1).max(1);
    let (y0, y1) = (0.5, max_count as f64 * 2.5);
    let pad = (hi - lo) * 0.02;
    let mut chart = chart(
        area,
        title,
        t,
        lo - pad..hi + pad,
        (y0..y1).log_scale(),
        ("sample mean score M", "samples (log scale)"),
    )?;
    let alpha = if series.len() > 1 { 0.55 } else { 0.85 };
    let mut legend = false;
    for (s, c) in series.iter().zip(&counts) {
        let color = s.color;
        let anno = chart
            .draw_series(c.iter().enumerate().filter(|(_, &n)| n > 0).map(|(i, &n)| {
                let x = lo + i as f64 * width;
                Rectangle::new([(x, y0), (x + width, n as f64)], color.mix(alpha).filled())
            }))
            .map_err(draw_err)?;
        if let Some(l) = s.label {
            legend = true;
            anno.label(l).legend(move |(x, y)| {
                Rectangle::new([(x, y - 5), (x + 12, y + 5)], color.filled())
            });
        }
    }
    if let Some(s) = solved.filter(|s| s.is_finite()) {
        legend = true;
        chart
            .draw_series(DashedLineSeries::new(
                [(s, y0), (s, y1)],
                8,
                5,
                RED.stroke_width(2),
            ))
            .map_err(draw_err)?
            .label(format!("solved ({})", tick(&s)))
            .legend(|(x, y)| PathElement::new([(x, y), (x + 16, y)], RED.stroke_width(2)));
    }
    if legend {
        // the legend goes to the upper corner over the lower bars
        let side_max = |range: std::ops::Range<usize>| {
            counts
                .iter()
                .flat_map(|c| c[range.clone()].iter().copied())
                .max()
                .unwrap_or(0)
        };
        let pos = if side_max(0..BINS / 3) > side_max(BINS - BINS / 3..BINS) {
            SeriesLabelPosition::UpperRight
        } else {
            SeriesLabelPosition::UpperLeft
        };
        legend_style(&mut chart, pos, t)?;
    }
    Ok(())
}

/// Dot alpha and size for `points` dots over a plot `width` pixels wide.
pub(crate) fn dot_style(points: usize, width: u32) -> (f64, i32) {
    let per_column = points as f64 / f64::from(width.max(1));
    let alpha = (6.0 / per_column).clamp(0.15, 0.8);
    let size = if points < 20_000 { 3 } else { 2 };
    (alpha, size)
}

/// Every episode score at its sample's rank by `M`, the `M` curve, the top
/// 0.1% of episodes in green, the solved score as a dashed line.
pub(crate) fn scores_panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    layers: &mut Layers,
    title: &str,
    cell: &CellData,
    s: &CellSummary,
    t: PanelText,
) -> Result<(), PlotError> {
    let n = cell.samples();
    let (ylo, yhi) = padded_range(cell.scores.iter().copied(), s.solved, 0.04);
    let (xlo, xhi) = (-0.5, n as f64 - 0.5);
    let mut chart = chart(
        area,
        title,
        t,
        xlo..xhi,
        ylo..yhi,
        ("sample rank by mean score M", "episode score"),
    )?;

    let plot = chart.plotting_area().strip_coord_spec();
    let mut raster = Raster::over(&plot);
    let (alpha, size) = dot_style(cell.scores.len(), raster.w);
    let threshold = s.top_episode_threshold;
    let blue = BLUE.mix(alpha);
    let green = GREEN.to_rgba();
    for top in [false, true] {
        for i in 0..n {
            let x = cell.ranks[i] as f64;
            for &score in cell.sample_scores(i) {
                if (score >= threshold) == top {
                    let c = if top { green } else { blue };
                    raster.dot(chart.backend_coord(&(x, score)), size + i32::from(top), c);
                }
            }
        }
    }
    layers.add(&plot, raster)?;

    let order = stats::argsort(&cell.means());
    let step = (n / CURVE_POINTS).max(1);
    let mut curve: Vec<(f64, f64)> = (0..n)
        .step_by(step)
        .map(|r| (r as f64, cell.stats[order[r]].mean))
        .collect();
    if !(n - 1).is_multiple_of(step) {
        curve.push(((n - 1) as f64, cell.stats[order[n - 1]].mean));
    }
    chart
        .draw_series(std::iter::empty::<Circle<(f64, f64), i32>>())
        .map_err(draw_err)?
        .label("episode score")
        .legend(|(x, y)| Circle::new((x + 6, y), 3, BLUE.filled()));
    chart
        .draw_series(std::iter::empty::<Circle<(f64, f64), i32>>())
        .map_err(draw_err)?
        .label(format!(
            "top 0.1% of episodes (≥ {})",
            crate::fmt::sig(threshold, 4)
        ))
        .legend(|(x, y)| Circle::new((x + 6, y), 3, GREEN.filled()));
    chart
        .draw_series(LineSeries::new(curve, DARK_RED.stroke_width(2)))
        .map_err(draw_err)?
        .label("sample mean M")
        .legend(|(x, y)| PathElement::new([(x, y), (x + 16, y)], DARK_RED.stroke_width(2)));
    if let Some(sv) = s.solved.filter(|v| v.is_finite()) {
        chart
            .draw_series(DashedLineSeries::new(
                [(xlo, sv), (xhi, sv)],
                8,
                5,
                RED.stroke_width(2),
            ))
            .map_err(draw_err)?
            .label(format!("solved ({})", tick(&sv)))
            .legend(|(x, y)| PathElement::new([(x, y), (x + 16, y)], RED.stroke_width(2)));
    }
    legend_style(&mut chart, SeriesLabelPosition::UpperLeft, t)
}

/// Each sample's variance `V` over its mean `M`, the solved score as a
/// dashed line.
pub(crate) fn variance_panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    layers: &mut Layers,
    title: &str,
    cell: &CellData,
    s: &CellSummary,
    t: PanelText,
) -> Result<(), PlotError> {
    let (xlo, xhi) = padded_range(cell.stats.iter().map(|x| x.mean), s.solved, 0.04);
    let vmax = cell
        .stats
        .iter()
        .map(|x| x.variance)
        .filter(|v| v.is_finite())
        .fold(0.0, f64::max);
    let yhi = if vmax > 0.0 { vmax * 1.05 } else { 1.0 };
    let ylo = -yhi * 0.02;
    let mut chart = chart(
        area,
        title,
        t,
        xlo..xhi,
        ylo..yhi,
        ("sample mean score M", "variance V of episode scores"),
    )?;
    let plot = chart.plotting_area().strip_coord_spec();
    let mut raster = Raster::over(&plot);
    let (alpha, size) = dot_style(cell.samples(), raster.w);
    let color = BLUE.mix(alpha.max(0.35));
    for st in &cell.stats {
        raster.dot(chart.backend_coord(&(st.mean, st.variance)), size, color);
    }
    layers.add(&plot, raster)?;
    chart
        .draw_series(std::iter::empty::<Circle<(f64, f64), i32>>())
        .map_err(draw_err)?
        .label("sample")
        .legend(|(x, y)| Circle::new((x + 6, y), 3, BLUE.filled()));
    if let Some(sv) = s.solved.filter(|v| v.is_finite()) {
        chart
            .draw_series(DashedLineSeries::new(
                [(sv, ylo), (sv, yhi)],
                8,
                5,
                RED.stroke_width(2),
            ))
            .map_err(draw_err)?
            .label(format!("solved ({})", tick(&sv)))
            .legend(|(x, y)| PathElement::new([(x, y), (x + 16, y)], RED.stroke_width(2)));
    }
    legend_style(&mut chart, SeriesLabelPosition::UpperLeft, t)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_and_ranges() {
        assert_eq!(tick(&0.0), "0");
        assert_eq!(tick(&195.0), "195");
        assert_eq!(tick(&-1234.5), "-1234.5");
        assert_eq!(tick(&250000.0), "2.5e5");
        assert_eq!(
            padded_range([1.0, 3.0].into_iter(), Some(5.0), 0.0),
            (1.0, 5.0)
        );
        assert_eq!(padded_range([2.0].into_iter(), None, 0.1), (1.5, 2.5));
        assert_eq!(padded_range([f64::NAN].into_iter(), None, 0.1), (0.0, 1.0));
    }
}
