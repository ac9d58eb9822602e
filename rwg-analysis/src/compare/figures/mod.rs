//! The figures of `rwg compare` (`--figure`, `--ranking-figure`, and those
//! of its page), drawn the way performance profiles are drawn in rliable
//! (Agarwal et al., NeurIPS 2021): one curve per environment with its
//! confidence band, small multiples instead of one crowded panel.
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
//!
//! This file holds what both share: the look of each (run, env) pair and the
//! boxed labels.

mod profiles;
mod ranking;

pub use profiles::profiles_figure;
pub use ranking::ranking_figure;

use super::data::CompareRun;
use crate::plot::{distinct, draw_err, PlotError};
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

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
