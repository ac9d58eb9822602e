//! A small table model rendered as aligned text, Markdown, LaTeX (booktabs)
//! or CSV.

/// One table cell: its plain text and its LaTeX form.
#[derive(Debug, Clone, PartialEq)]
pub struct Cell {
    /// Plain text (terminal, Markdown, CSV, HTML).
    pub text: String,
    /// LaTeX source.
    pub latex: String,
}

impl Cell {
    /// A cell whose LaTeX form is its text, escaped.
    pub fn plain(text: impl Into<String>) -> Self {
        let text = text.into();
        Cell {
            latex: latex_escape(&text),
            text,
        }
    }
}

impl From<&str> for Cell {
    fn from(s: &str) -> Self {
        Cell::plain(s)
    }
}

impl From<String> for Cell {
    fn from(s: String) -> Self {
        Cell::plain(s)
    }
}

/// Escapes LaTeX's special characters.
pub fn latex_escape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '\\' => out.push_str("\\textbackslash{}"),
            '&' | '%' | '$' | '#' | '_' | '{' | '}' => {
                out.push('\\');
                out.push(c);
            }
            '~' => out.push_str("\\textasciitilde{}"),
            '^' => out.push_str("\\textasciicircum{}"),
            '×' => out.push_str("$\\times$"),
            '≥' => out.push_str("$\\geq$"),
            '–' => out.push_str("--"),
            _ => out.push(c),
        }
    }
    out
}

/// A titled table: a header row and body rows; the first column is the row
/// label (left-aligned), the others are values (right-aligned).
#[derive(Debug, Clone, PartialEq)]
pub struct Table {
    /// Title (caption).
    pub title: String,
    /// Column headers.
    pub header: Vec<Cell>,
    /// Body rows, each as long as the header.
    pub rows: Vec<Vec<Cell>>,
    /// Notes printed under the table.
    pub notes: Vec<String>,
}

/// The output formats of tables.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TableFormat {
    /// Aligned plain text for a terminal.
    Text,
    /// GitHub-flavoured Markdown.
    Markdown,
    /// LaTeX `table` with booktabs rules.
    Latex,
    /// CSV, a title line as a `#` comment.
    Csv,
    /// An HTML `<table>` with a `<caption>`.
    Html,
}

/// Escapes `&`, `<`, `>` and `"` for HTML text and attribute values.
pub fn html_escape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            _ => out.push(c),
        }
    }
    out
}

fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

impl Table {
    /// Renders the table.
    pub fn render(&self, format: TableFormat) -> String {
        match format {
            TableFormat::Text => self.text(),
            TableFormat::Markdown => self.markdown(),
            TableFormat::Latex => self.latex(),
            TableFormat::Csv => self.csv(),
            TableFormat::Html => self.html(),
        }
    }

    fn widths(&self) -> Vec<usize> {
        let mut w: Vec<usize> = self.header.iter().map(|c| c.text.chars().count()).collect();
        for r in &self.rows {
            for (w, c) in w.iter_mut().zip(r) {
                *w = (*w).max(c.text.chars().count());
            }
        }
        w
    }

    fn text(&self) -> String {
        let w = self.widths();
        let line = |cells: &[Cell]| -> String {
            let parts: Vec<String> = cells
                .iter()
                .zip(&w)
                .enumerate()
                .map(|(i, (c, &w))| {
                    if i == 0 {
                        format!("{:<w$}", c.text)
                    } else {
                        format!("{:>w$}", c.text)
                    }
                })
                .collect();
            parts.join("  ").trim_end().to_string()
        };
        let mut out = format!("{}\n", self.title);
        out.push_str(&line(&self.header));
        out.push('\n');
        let total: usize = w.iter().sum::<usize>() + 2 * w.len().saturating_sub(1);
        out.push_str(&"-".repeat(total));
        out.push('\n');
        for r in &self.rows {
            out.push_str(&line(r));
            out.push('\n');
        }
        for n in &self.notes {
            out.push_str(n);
            out.push('\n');
        }
        out
    }

    fn markdown(&self) -> String {
        let esc = |s: &str| s.replace('|', "\\|");
        let row = |cells: &[Cell]| -> String {
            let parts: Vec<String> = cells.iter().map(|c| esc(&c.text)).collect();
            format!("| {} |\n", parts.join(" | "))
        };
        let mut out = format!("**{}**\n\n", esc(&self.title));
        out.push_str(&row(&self.header));
        let align: Vec<&str> = (0..self.header.len())
            .map(|i| if i == 0 { ":---" } else { "---:" })
            .collect();
        out.push_str(&format!("| {} |\n", align.join(" | ")));
        for r in &self.rows {
            out.push_str(&row(r));
        }
        if !self.notes.is_empty() {
            out.push('\n');
            for n in &self.notes {
                out.push_str(&format!("{}\n", esc(n)));
            }
        }
        out
    }

    fn latex(&self) -> String {
        let cols = format!("l{}", "r".repeat(self.header.len().saturating_sub(1)));
        let row = |cells: &[Cell]| -> String {
            let parts: Vec<&str> = cells.iter().map(|c| c.latex.as_str()).collect();
            format!("{} \\\\\n", parts.join(" & "))
        };
        let mut out = String::from("% requires \\usepackage{booktabs}\n");
        out.push_str("\\begin{table}[ht]\n\\centering\n");
        out.push_str(&format!("\\caption{{{}}}\n", latex_escape(&self.title)));
        out.push_str(&format!("\\begin{{tabular}}{{{cols}}}\n\\toprule\n"));
        out.push_str(&row(&self.header));
        out.push_str("\\midrule\n");
        for r in &self.rows {
            out.push_str(&row(r));
        }
        out.push_str("\\bottomrule\n\\end{tabular}\n");
        for n in &self.notes {
            out.push_str(&format!(
                "\\par\\smallskip{{\\footnotesize {}}}\n",
                latex_escape(n)
            ));
        }
        out.push_str("\\end{table}\n");
        out
    }

    fn html(&self) -> String {
        let mut out = format!(
            "<table>\n<caption>{}</caption>\n<thead><tr>",
            html_escape(&self.title)
        );
        for c in &self.header {
            out.push_str(&format!("<th>{}</th>", html_escape(&c.text)));
        }
        out.push_str("</tr></thead>\n<tbody>\n");
        for r in &self.rows {
            out.push_str("<tr>");
            for (i, c) in r.iter().enumerate() {
                let tag = if i == 0 { "th" } else { "td" };
                out.push_str(&format!("<{tag}>{}</{tag}>", html_escape(&c.text)));
            }
            out.push_str("</tr>\n");
        }
        out.push_str("</tbody>\n</table>\n");
        for n in &self.notes {
            out.push_str(&format!("<p class=\"note\">{}</p>\n", html_escape(n)));
        }
        out
    }

    fn csv(&self) -> String {
        let row = |cells: &[Cell]| -> String {
            let parts: Vec<String> = cells.iter().map(|c| csv_field(&c.text)).collect();
            format!("{}\n", parts.join(","))
        };
        let mut out = format!("# {}\n", self.title);
        out.push_str(&row(&self.header));
        for r in &self.rows {
            out.push_str(&row(r));
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn t() -> Table {
        Table {
            title: "Best mean_x".into(),
            header: vec!["env".into(), "0HL".into()],
            rows: vec![vec!["CartPole-v0".into(), "200.00 (200.00)".into()]],
            notes: vec!["N = 10".into()],
        }
    }

    #[test]
    fn renders_every_format() {
        assert_eq!(
            t().render(TableFormat::Text),
            "Best mean_x\nenv                      0HL\n\
             ----------------------------\n\
             CartPole-v0  200.00 (200.00)\nN = 10\n"
        );
        let md = t().render(TableFormat::Markdown);
        assert!(md.contains("| env | 0HL |\n| :--- | ---: |\n| CartPole-v0 | 200.00 (200.00) |\n"));
        let tex = t().render(TableFormat::Latex);
        assert!(tex.contains("\\caption{Best mean\\_x}"));
        assert!(tex.contains("\\begin{tabular}{lr}\n\\toprule\nenv & 0HL \\\\\n\\midrule\n"));
        assert!(tex.contains("\\bottomrule\n\\end{tabular}"));
        assert_eq!(
            t().render(TableFormat::Csv),
            "# Best mean_x\nenv,0HL\nCartPole-v0,200.00 (200.00)\n"
        );
    }

    #[test]
    fn html_table() {
        let h = t().render(TableFormat::Html);
        assert!(h.starts_with("<table>\n<caption>Best mean_x</caption>"));
        assert!(h.contains("<tr><th>CartPole-v0</th><td>200.00 (200.00)</td></tr>"));
        assert_eq!(html_escape("<a & \"b\">"), "&lt;a &amp; &quot;b&quot;&gt;");
    }

    #[test]
    fn latex_escapes() {
        assert_eq!(
            latex_escape("a_b & 50% #1 ≥ 2×3"),
            "a\\_b \\& 50\\% \\#1 $\\geq$ 2$\\times$3"
        );
    }
}
