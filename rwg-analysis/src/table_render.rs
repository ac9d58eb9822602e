//! How any table is written, whatever it holds: a small table model
//! ([`Table`] of [`Cell`]s) rendered as aligned text, Markdown, LaTeX
//! (booktabs), CSV or HTML ([`TableFormat`]), and the fixed-width columns
//! ([`TextColumns`]) every terminal table of rwg is laid out with.
//!
//! What goes in the tables of a run is [`crate::run_tables`]'s job.

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
            '−' => out.push_str("$-$"),
            '·' => out.push_str("$\\cdot$"),
            '–' => out.push_str("--"),
            _ => out.push(c),
        }
    }
    out
}

/// How a text column is aligned.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Align {
    /// Padded on the right.
    Left,
    /// Padded on the left (numbers).
    Right,
}

/// Fixed-width text columns: the one way rwg lays out a terminal table.
/// Each cell is padded to its column's width (in characters) and aligned,
/// cells are joined by a separator, and trailing spaces are trimmed.
#[derive(Debug, Clone, PartialEq)]
pub struct TextColumns {
    columns: Vec<(usize, Align)>,
    sep: &'static str,
    /// Separators that differ from `sep`: `(i, gap)` joins columns `i` and `i + 1`.
    gaps: Vec<(usize, &'static str)>,
}

impl TextColumns {
    /// Columns of the given widths and alignments, joined by `sep`.
    pub fn new(columns: &[(usize, Align)], sep: &'static str) -> Self {
        TextColumns {
            columns: columns.to_vec(),
            sep,
            gaps: vec![],
        }
    }

    /// The same columns with `gap` instead of the separator between column
    /// `i` and column `i + 1` (e.g. more space before a free-text column).
    pub fn gap(mut self, i: usize, gap: &'static str) -> Self {
        self.gaps.retain(|g| g.0 != i);
        self.gaps.push((i, gap));
        self
    }

    /// Columns as wide as the widest of `header` and `rows` in each column,
    /// aligned by `align(column index)`, joined by `sep`.
    pub fn fit<S: AsRef<str>>(
        header: &[S],
        rows: &[Vec<S>],
        align: impl Fn(usize) -> Align,
        sep: &'static str,
    ) -> Self {
        let mut widths: Vec<usize> = header.iter().map(|c| c.as_ref().chars().count()).collect();
        for row in rows {
            for (w, c) in widths.iter_mut().zip(row) {
                *w = (*w).max(c.as_ref().chars().count());
            }
        }
        TextColumns {
            columns: widths
                .iter()
                .enumerate()
                .map(|(i, &w)| (w, align(i)))
                .collect(),
            sep,
            gaps: vec![],
        }
    }

    /// The column widths.
    pub fn widths(&self) -> impl Iterator<Item = usize> + '_ {
        self.columns.iter().map(|c| c.0)
    }

    /// One line (no newline): each cell padded and aligned to its column.
    /// Cells beyond the last column are ignored.
    pub fn line<S: AsRef<str>>(&self, cells: &[S]) -> String {
        let mut out = String::new();
        for (i, (c, &(w, align))) in cells.iter().zip(&self.columns).enumerate() {
            if i > 0 {
                let gap = self.gaps.iter().find(|g| g.0 == i - 1);
                out.push_str(gap.map_or(self.sep, |g| g.1));
            }
            match align {
                Align::Left => out.push_str(&format!("{:<w$}", c.as_ref())),
                Align::Right => out.push_str(&format!("{:>w$}", c.as_ref())),
            }
        }
        out.truncate(out.trim_end().len());
        out
    }
}

/// The plain texts of a row of cells.
fn texts(cells: &[Cell]) -> Vec<&str> {
    cells.iter().map(|c| c.text.as_str()).collect()
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

    fn text(&self) -> String {
        let rows: Vec<Vec<&str>> = self.rows.iter().map(|r| texts(r)).collect();
        let align = |i: usize| if i == 0 { Align::Left } else { Align::Right };
        let columns = TextColumns::fit(&texts(&self.header), &rows, align, "  ");
        let w: Vec<usize> = columns.widths().collect();
        let line = |cells: &[Cell]| -> String { columns.line(&texts(cells)) };
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
        let mut out = format!("# {}\n", self.title).into_bytes();
        let mut w = rwg_study::rundir::export::csv_writer(&mut out);
        for r in std::iter::once(&self.header).chain(&self.rows) {
            w.write_record(texts(r)).expect("writing to memory");
        }
        drop(w);
        String::from_utf8(out).expect("UTF-8 cells")
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
    fn text_columns_pad_align_and_trim() {
        let c = TextColumns::new(
            &[(4, Align::Left), (6, Align::Right), (5, Align::Left)],
            " ",
        );
        assert_eq!(c.line(&["ab", "1.5", "x"]), "ab      1.5 x");
        assert_eq!(c.line(&["abcdef", "1", ""]), "abcdef      1");
        let rows = vec![vec!["é–x", "2"], vec!["a", "100"]];
        let fit = TextColumns::fit(&["id", "n"], &rows, |_| Align::Left, "  ");
        assert_eq!(fit.widths().collect::<Vec<_>>(), [3, 3]);
        assert_eq!(fit.line(&rows[0]), "é–x  2");
        let gapped = c.gap(1, "  ");
        assert_eq!(gapped.line(&["ab", "1.5", "x"]), "ab      1.5  x");
        assert_eq!(
            gapped.gap(0, "|").line(&["ab", "1.5", "x"]),
            "ab  |   1.5  x"
        );
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
        assert_eq!(latex_escape("k·N − 1"), "k$\\cdot$N $-$ 1");
    }
}
