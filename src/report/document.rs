//! A report as a list of blocks, rendered twice: a self-contained HTML page
//! (SVG inlined, styles embedded, no external assets) and a Markdown twin
//! that links the same figures as files.

use super::svg::esc;
use std::fmt::Write;

/// One piece of a report.
#[derive(Clone, Debug)]
pub enum Block {
    Heading(usize, String),
    Paragraph(String),
    Table {
        header: Vec<String>,
        rows: Vec<Vec<String>>,
    },
    /// An SVG figure; `file` is its name in the figures directory.
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
svg{max-width:100%;height:auto}";

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
        let mut s = format!("<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>{}</title><style>{STYLE}</style></head><body>\n<h1>{}</h1>\n", esc(&self.title), esc(&self.title));
        for b in &self.blocks {
            match b {
                Block::Heading(l, t) => {
                    let l = (*l).clamp(2, 6);
                    let _ = writeln!(s, "<h{l}>{}</h{l}>", esc(t));
                }
                Block::Paragraph(t) => {
                    let _ = writeln!(s, "<p>{}</p>", esc(t));
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
                            let _ = write!(s, "<td>{}</td>", esc(c));
                        }
                        s.push_str("</tr>\n");
                    }
                    s.push_str("</tbody></table>\n");
                }
                Block::Figure { caption, svg, .. } => {
                    let _ = writeln!(
                        s,
                        "<figure>{}<figcaption>{}</figcaption></figure>",
                        strip_prolog(svg),
                        esc(caption)
                    );
                }
            }
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
                    let _ = writeln!(s, "{t}\n");
                }
                Block::Table { header, rows } => {
                    let cell = |c: &str| c.replace('|', "\\|");
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
                    let _ = writeln!(s, "![{caption}]({figure_dir}/{file})\n");
                }
            }
        }
        s
    }
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
            !html.contains("src=") && !html.contains("href="),
            "no external assets"
        );
        let md = d.to_markdown("figures");
        assert!(md.contains("| pso\\|seed=1 | 0.98 |"));
        assert!(md.contains("![MAC matrix](figures/mac.svg)"));
        assert_eq!(d.figures().count(), 1);
    }
}
