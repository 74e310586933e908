//! A report as a list of blocks, rendered twice: a self-contained HTML page
//! (SVG inlined, styles embedded, no external assets) and a Markdown twin
//! that links the same figures as files.
//!
//! Failures must not be overlooked in either rendering: a [`Block::Callout`]
//! of [`Tone::Failure`] is a red box in HTML and a bold blockquote in
//! Markdown, and a table cell that starts with [`FAIL`] (✗) is red and bold
//! in HTML and bold in Markdown (one that starts with [`PASS`], ✓, green).

use super::format::tidy;
use super::svg::esc;
use std::fmt::Write;

/// The mark that starts a failed cell or callout title.
pub const FAIL: char = '✗';
/// The mark that starts a passed cell or callout title.
pub const PASS: char = '✓';

/// How a [`Block::Callout`] is shown.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Tone {
    /// Everything as it should be (green, ✓).
    Pass,
    /// Worth a look (amber, ⚠).
    Warning,
    /// Something failed (red, ✗).
    Failure,
}

impl Tone {
    fn mark(self) -> char {
        match self {
            Tone::Pass => PASS,
            Tone::Warning => '⚠',
            Tone::Failure => FAIL,
        }
    }

    fn class(self) -> &'static str {
        match self {
            Tone::Pass => "pass",
            Tone::Warning => "warning",
            Tone::Failure => "failure",
        }
    }
}

/// One piece of a report.
#[derive(Clone, Debug)]
pub enum Block {
    Heading(usize, String),
    Paragraph(String),
    /// A bulleted list.
    List(Vec<String>),
    /// A boxed message: a title (prefixed with the tone's mark) and lines.
    Callout {
        tone: Tone,
        title: String,
        lines: Vec<String>,
    },
    Table {
        header: Vec<String>,
        rows: Vec<Vec<String>>,
    },
    /// An SVG figure; `file` is its name in the figures directory (where
    /// a PNG of the same stem sits beside it).
    Figure {
        caption: String,
        file: String,
        svg: String,
    },
}

#[derive(Clone, Debug, Default)]
pub struct Document {
    pub title: String,
    pub blocks: Vec<Block>,
}

const STYLE: &str = "body{font-family:Helvetica,Arial,sans-serif;max-width:1100px;margin:2em auto;padding:0 1em;color:#222}\
table{border-collapse:collapse;margin:1em 0;font-size:0.9em}th,td{border:1px solid #ccc;padding:4px 8px;text-align:right}\
th{background:#f0f4f8}td:first-child,th:first-child{text-align:left}figure{margin:1.5em 0}figcaption{color:#555;font-size:0.9em}\
svg{max-width:100%;height:auto}\
figcaption a{color:#555}td.fail{background:#fdecea;color:#b71c1c;font-weight:bold}td.pass{color:#1b5e20}td.text{text-align:left}\
.callout{margin:1em 0;padding:0.6em 1em;border-left:6px solid}.callout p{margin:0;font-weight:bold}.callout ul{margin:0.4em 0 0}\
.callout.failure{border-color:#c62828;background:#fdecea;color:#b71c1c}.callout.failure p{font-size:1.15em}\
.callout.warning{border-color:#f9a825;background:#fff8e1}.callout.pass{border-color:#2e7d32;background:#edf7ed}";

impl Document {
    pub fn new(title: impl Into<String>) -> Document {
        Document {
            title: title.into(),
            blocks: Vec::new(),
        }
    }

    pub fn heading(&mut self, level: usize, text: impl Into<String>) {
        self.blocks.push(Block::Heading(level, text.into()));
    }

    pub fn paragraph(&mut self, text: impl Into<String>) {
        self.blocks.push(Block::Paragraph(text.into()));
    }

    pub fn list(&mut self, items: Vec<String>) {
        if !items.is_empty() {
            self.blocks.push(Block::List(items));
        }
    }

    pub fn callout(&mut self, tone: Tone, title: impl Into<String>, lines: Vec<String>) {
        self.blocks.push(Block::Callout {
            tone,
            title: title.into(),
            lines,
        });
    }

    pub fn table(&mut self, header: Vec<String>, rows: Vec<Vec<String>>) {
        self.blocks.push(Block::Table { header, rows });
    }

    pub fn figure(&mut self, caption: impl Into<String>, file: impl Into<String>, svg: String) {
        self.blocks.push(Block::Figure {
            caption: caption.into(),
            file: file.into(),
            svg,
        });
    }

    /// The figures as `(file name, svg)`.
    pub fn figures(&self) -> impl Iterator<Item = (&str, &str)> {
        self.blocks.iter().filter_map(|b| match b {
            Block::Figure { file, svg, .. } => Some((file.as_str(), svg.as_str())),
            _ => None,
        })
    }

    pub fn to_html(&self) -> String {
        let mut s = format!("<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>{}</title><style>{STYLE}{}</style></head><body>\n<h1>{}</h1>\n", esc(&self.title), super::zoom::STYLE, esc(&self.title));
        for b in &self.blocks {
            match b {
                Block::Heading(l, t) => {
                    let l = (*l).clamp(2, 6);
                    let _ = writeln!(s, "<h{l} id=\"{}\">{}</h{l}>", anchor(t), esc(t));
                }
                Block::Paragraph(t) => {
                    let _ = writeln!(s, "<p>{}</p>", text(t));
                }
                Block::List(items) => html_list(&mut s, items),
                Block::Callout { tone, title, lines } => {
                    let _ = writeln!(
                        s,
                        "<div class=\"callout {}\"><p>{} {}</p>",
                        tone.class(),
                        tone.mark(),
                        text(title)
                    );
                    html_list(&mut s, lines);
                    s.push_str("</div>\n");
                }
                Block::Table { header, rows } => {
                    s.push_str("<table><thead><tr>");
                    for h in header {
                        let _ = write!(s, "<th>{}</th>", esc(h));
                    }
                    s.push_str("</tr></thead><tbody>\n");
                    for r in rows {
                        s.push_str("<tr>");
                        for c in r {
                            let class = if c.starts_with(FAIL) {
                                " class=\"fail\""
                            } else if c.starts_with(PASS) {
                                " class=\"pass\""
                            } else if is_prose(c) {
                                " class=\"text\""
                            } else {
                                ""
                            };
                            let _ = write!(s, "<td{class}>{}</td>", text(c));
                        }
                        s.push_str("</tr>\n");
                    }
                    s.push_str("</tbody></table>\n");
                }
                Block::Figure { caption, svg, file } => {
                    let stem = file.strip_suffix(".svg").unwrap_or(file);
                    let _ = writeln!(
                        s,
                        "<figure{}>{}<figcaption>{} (<a href=\"figures/{}\">SVG</a>, <a href=\"figures/{}.png\">PNG</a>)</figcaption></figure>",
                        if zoomable(file) { " class=\"zoomable\"" } else { "" },
                        strip_prolog(svg),
                        text(caption),
                        esc(file),
                        esc(stem)
                    );
                }
            }
        }
        if self.figures().any(|(f, _)| zoomable(f)) {
            let _ = writeln!(s, "<script>{}</script>", super::zoom::SCRIPT);
        }
        s.push_str("</body></html>\n");
        s
    }

    /// Markdown with figures linked as `figure_dir/<file>`.
    pub fn to_markdown(&self, figure_dir: &str) -> String {
        let mut s = format!("# {}\n\n", self.title);
        for b in &self.blocks {
            match b {
                Block::Heading(l, t) => {
                    let _ = writeln!(s, "{} {t}\n", "#".repeat((*l).clamp(2, 6)));
                }
                Block::Paragraph(t) => {
                    let _ = writeln!(s, "{}\n", tidy(t));
                }
                Block::List(items) => {
                    for i in items {
                        let _ = writeln!(s, "- {}", tidy(i));
                    }
                    s.push('\n');
                }
                Block::Callout { tone, title, lines } => {
                    let _ = writeln!(s, "> **{} {}**", tone.mark(), tidy(title));
                    if !lines.is_empty() {
                        s.push_str(">\n");
                    }
                    for l in lines {
                        let _ = writeln!(s, "> - {}", tidy(l));
                    }
                    s.push('\n');
                }
                Block::Table { header, rows } => {
                    let cell = |c: &str| {
                        let c = tidy(c).replace('|', "\\|");
                        if c.starts_with(FAIL) {
                            format!("**{c}**")
                        } else {
                            c
                        }
                    };
                    let _ = writeln!(
                        s,
                        "| {} |",
                        header
                            .iter()
                            .map(|h| cell(h))
                            .collect::<Vec<_>>()
                            .join(" | ")
                    );
                    let _ = writeln!(s, "|{}", "---|".repeat(header.len()));
                    for r in rows {
                        let _ = writeln!(
                            s,
                            "| {} |",
                            r.iter().map(|c| cell(c)).collect::<Vec<_>>().join(" | ")
                        );
                    }
                    s.push('\n');
                }
                Block::Figure { caption, file, .. } => {
                    let _ = writeln!(s, "![{}]({figure_dir}/{file})\n", tidy(caption));
                }
            }
        }
        s
    }
}

fn html_list(s: &mut String, items: &[String]) {
    if items.is_empty() {
        return;
    }
    s.push_str("<ul>");
    for i in items {
        let _ = write!(s, "<li>{}</li>", text(i));
    }
    s.push_str("</ul>\n");
}

/// A cell of running text (a message, a warning), set flush left: longer
/// than a number or a short label and mostly letters.
fn is_prose(c: &str) -> bool {
    let letters = c.chars().filter(|ch| ch.is_alphabetic()).count();
    c.chars().count() > 30 && 2 * letters > c.chars().count()
}

/// A heading's anchor: lower-case ASCII letters and digits, the rest as
/// `-` (`Initial vs updated model` → `initial-vs-updated-model`), so a
/// section can be linked (`index.html#warnings`).
pub fn anchor(t: &str) -> String {
    let mut out = String::new();
    for c in t.chars() {
        if c.is_ascii_alphanumeric() {
            out.push(c.to_ascii_lowercase());
        } else if !out.ends_with('-') && !out.is_empty() {
            out.push('-');
        }
    }
    out.trim_end_matches('-').to_string()
}

/// Text for HTML: numbers tidied ([`tidy`]), then escaped.
fn text(t: &str) -> String {
    esc(&tidy(t))
}

/// Dense figures the HTML page lets the reader zoom: FRF overlays and
/// stabilization diagrams.
fn zoomable(file: &str) -> bool {
    file.contains("frf_") || file.contains("stabilization")
}

/// Drop an XML prolog so the SVG can sit inside HTML.
fn strip_prolog(svg: &str) -> &str {
    match svg.find("<svg") {
        Some(i) => &svg[i..],
        None => svg,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn html_is_self_contained_and_markdown_links_figures() {
        let mut d = Document::new("Study <1>");
        d.heading(2, "Summary");
        d.table(
            vec!["method".into(), "MAC".into()],
            vec![vec!["pso|seed=1".into(), "0.98".into()]],
        );
        d.figure(
            "MAC matrix",
            "mac.svg",
            "<?xml version=\"1.0\"?><svg xmlns=\"http://www.w3.org/2000/svg\"></svg>".into(),
        );
        let html = d.to_html();
        assert!(html.contains("<title>Study &lt;1&gt;</title>"));
        assert!(
            html.contains("<figure><svg"),
            "prolog stripped, SVG inlined"
        );
        assert!(
            !html.contains("src=") && !html.contains("href=\"http"),
            "no external assets"
        );
        assert!(html.contains("<a href=\"figures/mac.png\">PNG</a>"));
        assert!(
            !html.contains("<script>"),
            "no zoom script without dense figures"
        );
        let md = d.to_markdown("figures");
        assert!(md.contains("| pso\\|seed=1 | 0.98 |"));
        assert!(md.contains("![MAC matrix](figures/mac.svg)"));
        assert_eq!(d.figures().count(), 1);
        assert!(html.contains("<h2 id=\"summary\">Summary</h2>"), "{html}");
        assert_eq!(
            anchor("Initial vs updated model"),
            "initial-vs-updated-model"
        );
        assert_eq!(anchor("score[run=pso] (1)"), "score-run-pso-1");
    }

    #[test]
    fn failures_stand_out_in_html_and_markdown() {
        let mut d = Document::new("Verdicts");
        d.callout(
            Tone::Failure,
            "1 of 2 identifications failed",
            vec!["fit: stalled <early>".into()],
        );
        d.table(
            vec!["stage".into(), "verdict".into()],
            vec![
                vec!["a".into(), "✗ failed".into()],
                vec!["b".into(), "✓ ok".into()],
            ],
        );
        d.list(vec!["a: 2 modes ambiguous".into()]);
        d.list(Vec::new());
        let html = d.to_html();
        assert!(
            html.contains("<div class=\"callout failure\"><p>✗ 1 of 2 identifications failed</p>"),
            "{html}"
        );
        assert!(
            html.contains("<li>fit: stalled &lt;early&gt;</li>"),
            "{html}"
        );
        assert!(html.contains("<td class=\"fail\">✗ failed</td>"), "{html}");
        assert!(html.contains("<td class=\"pass\">✓ ok</td>"), "{html}");
        assert!(html.contains("<td>a</td>"), "plain cells stay plain");
        assert!(is_prose(
            "position 2: reference mode without a model partner"
        ));
        assert!(!is_prose("[1.064e8, 1.066e8]") && !is_prose("guided"));
        assert_eq!(html.matches("<ul>").count(), 2, "an empty list is dropped");
        let md = d.to_markdown("figures");
        assert!(
            md.contains("> **✗ 1 of 2 identifications failed**\n>\n> - fit: stalled <early>\n"),
            "{md}"
        );
        assert!(md.contains("| a | **✗ failed** |"), "{md}");
        assert!(md.contains("| b | ✓ ok |"), "{md}");
        assert!(md.contains("- a: 2 modes ambiguous\n"), "{md}");
    }
}
