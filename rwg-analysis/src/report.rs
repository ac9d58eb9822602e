//! `report.html`: one self-contained page per run — run metadata, the
//! tables, every figure inline as SVG, the manifest. No external resource:
//! it opens in a browser with no network.
//!
//! A small inline script checks, once the page has loaded, that every figure
//! laid out with a non-zero size and text, and that every embedded raster
//! decodes to non-blank pixels (drawn on a canvas); it
//! marks each `<figure>` with `data-rendered="ok"` (or `"failed"`) and shows
//! the count at the top of the page.

use crate::jax_cells::{device_text, jax_settings, jax_table, versions_text};
use crate::plot::{cell_label, Figure, ImageFormat};
use crate::run_tables::run_tables;
use crate::table_render::{html_escape, TableFormat};
use rwg_env::float::fmt_f64;
use rwg_study::rundir::data::{Run, RunStats};
use rwg_study::stats::CellSummary;

/// File name of the report in the run directory (named with the run
/// directory's other files in `rwg_study::rundir`).
pub use rwg_study::rundir::REPORT_HTML;

/// The stylesheet of the report and the comparison page: fits a 1280 px
/// window; wide tables scroll inside their own box.
pub(crate) const STYLE: &str = r#"
body { font-family: system-ui, -apple-system, "Segoe UI", sans-serif; margin: 2em auto; max-width: 1500px; padding: 0 1em; color: #222; }
h1 { margin-bottom: 0.2em; }
h2 { border-bottom: 1px solid #ccc; padding-bottom: 0.2em; margin-top: 2em; }
table { border-collapse: collapse; margin: 1em 0; font-variant-numeric: tabular-nums; }
caption { text-align: left; font-weight: 600; padding: 0.3em 0; }
th, td { white-space: nowrap; padding: 0.25em 0.8em; border-bottom: 1px solid #e4e4e4; text-align: right; }
th:first-child, thead th { text-align: left; }
thead th { border-bottom: 2px solid #999; }
table.meta th { text-align: left; font-weight: 600; }
table.meta td { text-align: left; }
.note { font-size: 0.9em; color: #555; }
figure.rwg-figure { margin: 1em 0; }
figure.rwg-figure svg { max-width: 100%; height: auto; border: 1px solid #eee; }
figure.zoomable svg { cursor: zoom-in; }
figure.zoomable.zoomed { overflow-x: auto; }
figure.zoomable.zoomed svg { max-width: none; cursor: zoom-out; }
table.meta td { white-space: normal; overflow-wrap: anywhere; }
body { box-sizing: border-box; }
figcaption { font-size: 0.9em; color: #444; margin-top: 0.3em; }
.row { display: flex; flex-wrap: wrap; gap: 1em; }
.row figure.rwg-figure { flex: 1 1 480px; }
pre { background: #f6f6f6; padding: 1em; overflow-x: auto; }
.table-scroll { overflow-x: auto; max-width: 100%; }
.ranking-table td:nth-child(-n+5) { text-align: left; }
#render-status { color: #555; font-size: 0.9em; }
nav a { margin-right: 1em; }
"#;

/// The page's self-check (see the module doc).
pub(crate) const SCRIPT: &str = r#"
function rasterOk(im) {
  const w = Number(im.getAttribute('width')), h = Number(im.getAttribute('height'));
  const c = document.createElement('canvas');
  c.width = w; c.height = h;
  const ctx = c.getContext('2d');
  try { ctx.drawImage(im, 0, 0, w, h); } catch (e) { return false; }
  const d = ctx.getImageData(0, 0, w, h).data;
  for (let i = 3; i < d.length; i += 4) if (d[i] > 0) return true;
  return false;
}
window.addEventListener('load', () => {
  for (const f of document.querySelectorAll('figure.zoomable'))
    f.querySelector('svg').addEventListener('click', () => f.classList.toggle('zoomed'));
  const figs = Array.from(document.querySelectorAll('figure.rwg-figure'));
  let ok = 0;
  for (const f of figs) {
    const svg = f.querySelector('svg');
    const box = svg ? svg.getBoundingClientRect() : null;
    let good = !!box && box.width > 0 && box.height > 0 && svg.querySelectorAll('text').length > 0;
    for (const im of f.querySelectorAll('image')) good = good && rasterOk(im);
    f.dataset.rendered = good ? 'ok' : 'failed';
    if (good) ok++;
  }
  document.body.dataset.figures = String(figs.length);
  document.body.dataset.rendered = String(ok);
  document.getElementById('render-status').textContent =
    ok + ' of ' + figs.length + ' figures rendered';
  document.body.dataset.errors = String((window.rwgErrors || []).length);
  document.body.dataset.scrollWidth = String(document.documentElement.scrollWidth);
  document.body.dataset.viewportWidth = String(window.innerWidth);
});
"#;

/// Collects script errors, failed resource loads and `console.error` calls
/// into `window.rwgErrors`; [`SCRIPT`] reports their count as
/// `data-errors` on `<body>`. Goes first in `<head>`.
pub(crate) const ERROR_PROBE: &str = r#"<script>
window.rwgErrors = [];
window.addEventListener('error', e => window.rwgErrors.push(String(e.message || (e.target && (e.target.src || e.target.href)) || 'error')), true);
(() => { const ce = console.error.bind(console); console.error = (...a) => { window.rwgErrors.push(a.join(' ')); ce(...a); }; })();
</script>
"#;

/// A figure inline, with its caption.
pub(crate) fn figure_html(f: &Figure) -> String {
    figure_html_class(f, "rwg-figure", "")
}

/// A figure wider than the page: shown to fit, full size on a click (it
/// then scrolls inside its own box).
fn zoomable_figure_html(f: &Figure) -> String {
    figure_html_class(
        f,
        "rwg-figure zoomable",
        " (click the figure to see it at full size)",
    )
}

fn figure_html_class(f: &Figure, class: &str, hint: &str) -> String {
    assert_eq!(f.format, ImageFormat::Svg, "the report inlines SVG figures");
    let svg = String::from_utf8_lossy(&f.bytes);
    // drop an XML declaration if any: not allowed inside HTML
    let svg = match svg.find("<svg") {
        Some(i) => &svg[i..],
        None => &svg[..],
    };
    format!(
        "<figure class=\"{class}\" id=\"fig-{}\" data-name=\"{}\">\n{}\n<figcaption>{}{hint}</figcaption>\n</figure>\n",
        html_escape(&f.name),
        html_escape(&f.name),
        svg.trim_end(),
        html_escape(&f.caption)
    )
}

/// A table in its own horizontally scrolling box, so a wide table never
/// widens the page.
pub(crate) fn table_html(t: &crate::table_render::Table) -> String {
    format!(
        "<div class=\"table-scroll\">\n{}</div>\n",
        t.render(TableFormat::Html)
    )
}

fn meta_table(run: &Run) -> String {
    let m = &run.meta;
    let rows: Vec<(&str, String)> = vec![
        ("run directory", run.dir.display().to_string()),
        ("rwg version", m.rwg_version.clone()),
        ("seed", m.seed.to_string()),
        ("samples per cell", m.samples.to_string()),
        ("episodes per sample", m.episodes.to_string()),
        (
            "weights",
            format!(
                "{} (scale {})",
                m.weights.distribution,
                fmt_f64(m.weights.scale)
            ),
        ),
        ("threads", m.threads.to_string()),
        ("start", m.start_time.clone()),
        (
            "end",
            m.end_time.clone().unwrap_or_else(|| "(incomplete)".into()),
        ),
        ("wall time", format!("{:.1} s", m.wall_s)),
        ("environment steps", m.env_steps.to_string()),
        ("steps per second", format!("{:.0}", m.steps_per_s)),
        ("cells", m.cells.len().to_string()),
    ];
    let mut out = String::from("<table class=\"meta\">\n");
    for (k, v) in rows {
        out.push_str(&format!(
            "<tr><th>{}</th><td>{}</td></tr>\n",
            html_escape(k),
            html_escape(&v)
        ));
    }
    out.push_str("</table>\n");
    out
}

fn cell_numbers(s: &CellSummary) -> String {
    let mut parts = vec![
        format!("best mean {}", crate::fmt::score(s.best_mean)),
        format!("99.9th percentile of M {}", crate::fmt::score(s.p99_9_mean)),
        format!("median M {}", crate::fmt::score(s.median_mean)),
    ];
    if let Some(a) = &s.at_n {
        parts.push(format!(
            "at N = {} networks, median [min, max] over {} disjoint blocks: best mean {}, \
             99.9th percentile of M {}",
            a.n,
            a.blocks,
            crate::run_tables::spread_text(&a.best_mean),
            crate::run_tables::spread_text(&a.p99_9_mean)
        ));
    }
    if let Some(p) = s.solved_fraction {
        parts.push(format!(
            "p(solved) {} [{}, {}] ({} of {})",
            crate::fmt::sig(p.p, 3),
            crate::fmt::sig(p.lo, 3),
            crate::fmt::sig(p.hi, 3),
            p.successes,
            p.trials
        ));
        parts.push(format!(
            "expected guesses {}",
            crate::run_tables::guesses_cell(s.expected_guesses).text
        ));
    }
    parts.push(format!("mean episode length {:.1}", s.mean_episode_length));
    if let Some(n) = s.non_finite_episodes {
        parts.push(format!(
            "{n} of {} episodes ended at a non-finite value",
            s.samples * u64::from(s.episodes)
        ));
    }
    format!("<p>{}</p>\n", html_escape(&parts.join(" · ")))
}

/// The report page. `figures` are SVG figures as [`crate::plot::run_figures`]
/// returns them: run-level figures (overviews, bias comparison) first, then
/// each cell's, named `<cell dir>.<kind>`.
pub fn report_html(run: &Run, stats: &RunStats, figures: &[Figure]) -> String {
    let name = run
        .dir
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| run.dir.display().to_string());
    let mut h = String::new();
    h.push_str("<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n");
    h.push_str(ERROR_PROBE);
    h.push_str(&format!(
        "<title>RWG report: {}</title>\n",
        html_escape(&name)
    ));
    h.push_str(&format!("<style>{STYLE}</style>\n</head>\n<body>\n"));
    h.push_str(&format!("<h1>RWG report: {}</h1>\n", html_escape(&name)));
    h.push_str("<p id=\"render-status\">figures not checked (scripts disabled)</p>\n");
    h.push_str(
        "<nav><a href=\"#run\">Run</a><a href=\"#tables\">Tables</a>\
         <a href=\"#overview\">Overview</a><a href=\"#cells\">Cells</a>\
         <a href=\"#manifest\">Manifest</a></nav>\n",
    );

    h.push_str("<section id=\"run\">\n<h2>Run</h2>\n");
    h.push_str(&meta_table(run));
    let jax = jax_settings(&run.dir, stats.cells.iter().map(|c| c.id.dir.as_str()));
    if !jax.is_empty() {
        h.push_str(&table_html(&jax_table(&jax)));
    }
    h.push_str("</section>\n");

    h.push_str("<section id=\"tables\">\n<h2>Tables</h2>\n");
    h.push_str(
        "<p class=\"note\">M is a sample's mean episode score; V the population variance \
         (1/E, as numpy's var) of its episode scores. Intervals are 95% Wilson score intervals.</p>\n",
    );
    for t in run_tables(stats) {
        h.push_str(&table_html(&t));
    }
    h.push_str("</section>\n");

    let is_cell_fig = |f: &Figure| {
        stats
            .cells
            .iter()
            .any(|c| f.name.starts_with(&format!("{}.", c.id.dir)))
    };
    h.push_str("<section id=\"overview\">\n<h2>Overview</h2>\n");
    for f in figures.iter().filter(|f| !is_cell_fig(f)) {
        h.push_str(&zoomable_figure_html(f));
    }
    h.push_str("</section>\n");

    h.push_str("<section id=\"cells\">\n<h2>Cells</h2>\n");
    for c in &stats.cells {
        h.push_str(&format!(
            "<h3 id=\"cell-{}\">{}</h3>\n",
            html_escape(&c.id.dir),
            html_escape(&cell_label(c))
        ));
        h.push_str(&cell_numbers(c));
        if let Some(s) = jax.iter().find(|s| s.cells.contains(&c.id.dir)) {
            h.push_str(&format!(
                "<p class=\"note\">JAX: {}, {}, {} networks per call; {}</p>\n",
                html_escape(&device_text(&s.record)),
                html_escape(&s.record.precision),
                s.record.networks_per_call,
                html_escape(&versions_text(&s.record))
            ));
        }
        h.push_str("<div class=\"row\">\n");
        let prefix = format!("{}.", c.id.dir);
        for f in figures.iter().filter(|f| f.name.starts_with(&prefix)) {
            h.push_str(&figure_html(f));
        }
        h.push_str("</div>\n");
    }
    h.push_str("</section>\n");

    h.push_str("<section id=\"manifest\">\n<h2>Manifest</h2>\n");
    match &run.manifest {
        Some(m) => h.push_str(&format!("<pre>{}</pre>\n", html_escape(m))),
        None => h.push_str("<p class=\"note\">No manifest.toml in the run directory.</p>\n"),
    }
    h.push_str("</section>\n");
    h.push_str(&format!(
        "<footer class=\"note\"><p>Written by rwg {}. <code>rwg stats</code> writes every statistic to stats.json and stats.csv.</p></footer>\n",
        env!("CARGO_PKG_VERSION")
    ));
    h.push_str(&format!("<script>{SCRIPT}</script>\n</body>\n</html>\n"));
    h
}
