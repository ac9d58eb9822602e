//! The self-contained comparison page of `rwg compare --html FILE`: the
//! difficulty ranking (figure and table), the performance profiles per
//! architecture, every cell side by side, and each run's metadata. Figures
//! are inlined as SVG; the page loads nothing from the network and checks
//! its own figures like the report does ([`crate::report`]).

use super::data::{CompareRow, CompareRun};
use super::ranking::ranking_table;
use super::table_csv::compare_table;
use crate::plot::Figure;
use crate::report::{figure_html, table_html, ERROR_PROBE, SCRIPT, STYLE};
use crate::table_render::html_escape;
use rwg_env::float::fmt_f64;

/// One row of the metadata table: a field and its value per run.
fn meta_rows(runs: &[CompareRun]) -> Vec<(&'static str, Vec<String>)> {
    let f = |get: &dyn Fn(&CompareRun) -> String| runs.iter().map(get).collect::<Vec<_>>();
    vec![
        ("run directory", f(&|r| r.dir.clone())),
        ("rwg version", f(&|r| r.meta.rwg_version.clone())),
        ("seed", f(&|r| r.meta.seed.to_string())),
        ("samples per cell", f(&|r| r.meta.samples.to_string())),
        ("episodes per sample", f(&|r| r.meta.episodes.to_string())),
        (
            "weights",
            f(&|r| {
                format!(
                    "{} (scale {})",
                    r.meta.weights.distribution,
                    fmt_f64(r.meta.weights.scale)
                )
            }),
        ),
        (
            "envs",
            f(&|r| {
                let mut envs: Vec<&str> = Vec::new();
                for c in &r.meta.cells {
                    if !envs.contains(&c.id.env.as_str()) {
                        envs.push(&c.id.env);
                    }
                }
                envs.join(", ")
            }),
        ),
        ("cells", f(&|r| r.meta.cells.len().to_string())),
        ("start", f(&|r| r.meta.start_time.clone())),
        (
            "end",
            f(&|r| {
                r.meta
                    .end_time
                    .clone()
                    .unwrap_or_else(|| "(incomplete)".into())
            }),
        ),
        ("wall time", f(&|r| format!("{:.1} s", r.meta.wall_s))),
        ("environment steps", f(&|r| r.meta.env_steps.to_string())),
    ]
}

fn meta_table(runs: &[CompareRun]) -> String {
    let mut out =
        String::from("<div class=\"table-scroll\">\n<table class=\"meta\">\n<thead><tr><th></th>");
    for r in runs {
        out.push_str(&format!("<th>{}</th>", html_escape(&r.label)));
    }
    out.push_str("</tr></thead>\n<tbody>\n");
    for (k, vs) in meta_rows(runs) {
        out.push_str(&format!("<tr><th>{}</th>", html_escape(k)));
        for v in vs {
            out.push_str(&format!("<td>{}</td>", html_escape(&v)));
        }
        out.push_str("</tr>\n");
    }
    out.push_str("</tbody>\n</table>\n</div>\n");
    out
}

/// The page. `figures` are the SVG figures to show: the ranking figure
/// (named `ranking`) goes to the ranking section, the others (the profiles)
/// to the profiles section.
pub fn compare_html(runs: &[CompareRun], rows: &[CompareRow], figures: &[Figure]) -> String {
    let names: Vec<&str> = runs.iter().map(|r| r.label.as_str()).collect();
    let title = format!("RWG comparison: {}", names.join(", "));
    let mut h = String::new();
    h.push_str("<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n");
    h.push_str(ERROR_PROBE);
    h.push_str("<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n");
    h.push_str(&format!("<title>{}</title>\n", html_escape(&title)));
    h.push_str(&format!("<style>{STYLE}</style>\n</head>\n<body>\n"));
    h.push_str(&format!("<h1>{}</h1>\n", html_escape(&title)));
    h.push_str("<p id=\"render-status\">figures not checked (scripts disabled)</p>\n");
    h.push_str(
        "<nav><a href=\"#ranking\">Ranking</a><a href=\"#profiles\">Profiles</a>\
         <a href=\"#cells\">All cells</a><a href=\"#runs\">Runs</a></nav>\n",
    );
    let reference = (runs.len() > 1).then(|| runs[0].label.as_str());
    h.push_str(&format!(
        "<p>{} cells from {} run{}. {}</p>\n",
        rows.len(),
        runs.len(),
        if runs.len() == 1 { "" } else { "s" },
        match reference {
            Some(r) => format!(
                "The first run, <strong>{}</strong>, is the reference set: grey in the figures; \
                 the envs of the other runs are in colour.",
                html_escape(r)
            ),
            None => "Each env has its own colour.".into(),
        }
    ));

    h.push_str("<section id=\"ranking\">\n<h2>Difficulty ranking</h2>\n");
    h.push_str(
        "<p class=\"note\">Easiest first: cells where some random network reached the solved \
         score, by the expected number of random networks to the first one (1/p, with its 95% \
         Wilson interval); then cells where none did, by how close the best 1 in 1000 networks \
         came (the 99.9th percentile of M, normalised so the median random network is 0 and the \
         solved score 1); cells without a solved score last.</p>\n",
    );
    for f in figures.iter().filter(|f| f.name == "ranking") {
        h.push_str(&figure_html(f));
    }
    h.push_str(&table_html(&ranking_table(rows)).replacen(
        "table-scroll",
        "table-scroll ranking-table",
        1,
    ));
    h.push_str("</section>\n");

    h.push_str("<section id=\"profiles\">\n<h2>Profiles per architecture</h2>\n");
    h.push_str(
        "<p class=\"note\">For each env, the fraction of random networks (log scale) whose mean \
         score reaches x, with x normalised so the median random network is 0 and the solved \
         score 1 (the dashed red line). A curve further right and higher: an easier env. \
         The shaded band is the 95% Wilson interval of each fraction.</p>\n",
    );
    for f in figures.iter().filter(|f| f.name != "ranking") {
        h.push_str(&figure_html(f));
    }
    h.push_str("</section>\n");

    h.push_str("<section id=\"cells\">\n<h2>All cells</h2>\n");
    h.push_str(&table_html(&compare_table(rows)));
    h.push_str("</section>\n");

    h.push_str("<section id=\"runs\">\n<h2>Runs</h2>\n");
    h.push_str(&meta_table(runs));
    h.push_str("</section>\n");
    h.push_str(&format!(
        "<footer class=\"note\"><p>Written by rwg {} (<code>rwg compare --html</code>).</p></footer>\n",
        env!("CARGO_PKG_VERSION")
    ));
    h.push_str(&format!("<script>{SCRIPT}</script>\n</body>\n</html>\n"));
    h
}
