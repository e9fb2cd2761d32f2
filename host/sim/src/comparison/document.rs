//! The demo's report as one document that two renderers format: [`Document::markdown`]
//! (`report.md`) and [`Document::html`] (`report.html`). The figures, table rows and pictures
//! are put in the document once ([`super::document`]), so the two files cannot disagree.

use std::fmt::Write;

/// A titled sequence of blocks.
pub(super) struct Document {
    /// The page's title and top heading.
    pub title: String,
    /// What follows the title, in order.
    pub blocks: Vec<Block>,
}

/// One block of the report.
pub(super) enum Block {
    /// A section heading below the title, prose.
    Heading(String),
    /// A paragraph of prose.
    Paragraph(String),
    /// A table.
    Table(Table),
    /// A picture on its own.
    Figure(Picture),
}

/// A table whose rows all have as many cells as its header.
pub(super) struct Table {
    header: Vec<String>,
    rows: Vec<Vec<Cell>>,
}

/// A table cell: plain text (figures, names) or a picture.
pub(super) enum Cell {
    /// Plain text, shown as it is (no markup).
    Text(String),
    /// A picture.
    Picture(Picture),
}

/// A picture the report links: its path relative to the report's folder, and a description
/// for readers who cannot see it.
pub(super) struct Picture {
    /// Relative to the output folder, `/`-separated.
    pub path: String,
    /// What it shows.
    pub alt: String,
}

impl Table {
    /// A table with these column headings (units included) and no rows yet.
    pub fn new(header: &[&str]) -> Table {
        Table {
            header: header.iter().map(|h| h.to_string()).collect(),
            rows: Vec::new(),
        }
    }

    /// Appends a row; one cell per column, or the table would be malformed in both formats.
    pub fn push(&mut self, cells: Vec<Cell>) {
        assert_eq!(
            cells.len(),
            self.header.len(),
            "a row of the table headed {:?}",
            self.header
        );
        self.rows.push(cells);
    }
}

impl Document {
    /// Markdown (GitHub's tables). Prose is markdown already (`code` in backticks); a table
    /// cell's `|` and `\` are escaped so a cell cannot split.
    pub fn markdown(&self) -> String {
        let mut md = format!("# {}\n", self.title);
        for block in &self.blocks {
            md.push('\n');
            match block {
                Block::Heading(text) => md.push_str(&format!("## {text}\n")),
                Block::Paragraph(text) => md.push_str(&format!("{text}\n")),
                Block::Figure(picture) => md.push_str(&format!("{}\n", markdown_picture(picture))),
                Block::Table(table) => {
                    let row = |cells: Vec<String>| format!("| {} |\n", cells.join(" | "));
                    let cell = |text: &str| text.replace('\\', "\\\\").replace('|', "\\|");
                    md.push_str(&row(table.header.iter().map(|h| cell(h)).collect()));
                    md.push_str(&format!("|{}\n", "---|".repeat(table.header.len())));
                    for cells in &table.rows {
                        md.push_str(&row(cells
                            .iter()
                            .map(|c| match c {
                                Cell::Text(text) => cell(text),
                                Cell::Picture(picture) => markdown_picture(picture),
                            })
                            .collect()));
                    }
                }
            }
        }
        md
    }

    /// A self-contained HTML5 page (no scripts, no external resources besides the pictures,
    /// which are relative links) in the XML syntax as well (polyglot markup: closed tags,
    /// quoted attributes, `<img … />`), so that an XML parser can check it strictly.
    pub fn html(&self) -> String {
        let mut html = String::new();
        let title = escape(&self.title);
        // `write!` into a String cannot fail.
        let _ = write!(
            html,
            "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\" />\n\
             <title>{title}</title>\n<style>{STYLE}</style>\n</head>\n<body>\n<h1>{title}</h1>\n"
        );
        for block in &self.blocks {
            match block {
                Block::Heading(text) => {
                    let _ = writeln!(html, "<h2>{}</h2>", prose(text));
                }
                Block::Paragraph(text) => {
                    let _ = writeln!(html, "<p>{}</p>", prose(text));
                }
                Block::Figure(picture) => {
                    let _ = writeln!(html, "{}", html_figure(picture));
                }
                Block::Table(table) => {
                    html.push_str("<table>\n<thead>\n<tr>");
                    for h in &table.header {
                        let _ = write!(html, "<th>{}</th>", escape(h));
                    }
                    html.push_str("</tr>\n</thead>\n<tbody>\n");
                    for cells in &table.rows {
                        html.push_str("<tr>");
                        for c in cells {
                            match c {
                                Cell::Text(text) => {
                                    let _ = write!(html, "<td>{}</td>", escape(text));
                                }
                                Cell::Picture(picture) => {
                                    let _ = write!(html, "<td>{}</td>", html_figure(picture));
                                }
                            }
                        }
                        html.push_str("</tr>\n");
                    }
                    html.push_str("</tbody>\n</table>\n");
                }
            }
        }
        html.push_str("</body>\n</html>\n");
        html
    }
}

/// The page's style: readable prose width, ruled tables, pictures that fit their cell.
const STYLE: &str = "body{font-family:sans-serif;margin:2em auto;max-width:80em;padding:0 1em;\
line-height:1.4}p{max-width:50em}table{border-collapse:collapse;margin:1em 0}\
th,td{border:1px solid #bbb;padding:.25em .5em;text-align:right}th{background:#eee}\
th:first-child,td:first-child{text-align:left}figure{margin:0;text-align:center}img{max-width:100%}\
figcaption{font-size:.8em}code{background:#f4f4f4}";

/// `![alt](path)`, the path as a URL.
fn markdown_picture(picture: &Picture) -> String {
    format!("![{}]({})", picture.alt, url_path(&picture.path))
}

/// The picture, a link to itself at full size, captioned with its path.
fn html_figure(picture: &Picture) -> String {
    let url = escape(&url_path(&picture.path));
    format!(
        "<figure><a href=\"{url}\"><img src=\"{url}\" alt=\"{}\" /></a>\
         <figcaption><code>{}</code></figcaption></figure>",
        escape(&picture.alt),
        escape(&picture.path)
    )
}

/// A relative `/`-separated file path as a URL path: every byte but RFC 3986's unreserved
/// characters and `/` percent-encoded (UTF-8), so that a method or folder name with a space,
/// `#`, `%`, `(` or markup still links to its file, in markdown and HTML alike.
fn url_path(path: &str) -> String {
    let mut out = String::with_capacity(path.len());
    for b in path.bytes() {
        match b {
            b'A'..=b'Z' | b'a'..=b'z' | b'0'..=b'9' | b'-' | b'.' | b'_' | b'~' | b'/' => {
                out.push(b as char)
            }
            _ => out.push_str(&format!("%{b:02X}")),
        }
    }
    out
}

/// Prose with its markdown code spans (between backticks) as `<code>`, the rest escaped.
fn prose(text: &str) -> String {
    text.split('`')
        .enumerate()
        .map(|(i, part)| match i % 2 {
            0 => escape(part),
            _ => format!("<code>{}</code>", escape(part)),
        })
        .collect()
}

/// Text and attribute values: `&`, `<`, `>` and `"` as character references, the same in
/// HTML and XML.
pub(super) fn escape(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            c => out.push(c),
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn escapes_the_four_markup_characters() {
        assert_eq!(escape(r#"a<&>"b'"#), "a&lt;&amp;&gt;&quot;b'");
        assert_eq!(prose("x & `<y>` z"), "x &amp; <code>&lt;y&gt;</code> z");
    }

    #[test]
    fn picture_paths_become_urls() {
        assert_eq!(url_path("bfsm/depth.png"), "bfsm/depth.png");
        assert_eq!(
            url_path("efsm x2/a#b%(c)é.png"),
            "efsm%20x2/a%23b%25%28c%29%C3%A9.png"
        );
        let p = Picture {
            path: "my scan/depth.png".into(),
            alt: "a & b".into(),
        };
        assert_eq!(markdown_picture(&p), "![a & b](my%20scan/depth.png)");
        assert!(html_figure(&p).contains("href=\"my%20scan/depth.png\""));
        assert!(html_figure(&p).contains("<code>my scan/depth.png</code>"));
    }

    #[test]
    #[should_panic(expected = "a row of the table")]
    fn a_row_must_fill_the_header() {
        let mut table = Table::new(&["a", "b"]);
        table.push(vec![Cell::Text("1".into())]);
    }

    #[test]
    fn a_markdown_cell_cannot_split() {
        let mut table = Table::new(&["a|b"]);
        table.push(vec![Cell::Text(r"1\|2".into())]);
        let doc = Document {
            title: "t".into(),
            blocks: vec![Block::Table(table)],
        };
        assert_eq!(doc.markdown(), "# t\n\n| a\\|b |\n|---|\n| 1\\\\\\|2 |\n");
    }
}
