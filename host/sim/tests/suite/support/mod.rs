//! Test support shared by fsm-sim's tests (`host/sim/tests`) and the CLI tests
//! (`host/cli/tests`, included by path): the demo's two reports read back into one outline, so a
//! test can check `report.html` and compare it with `report.md`.
//!
//! No browser runs in CI, so [`read_html`] checks the page strictly instead. The report is
//! polyglot markup (HTML5 in the XML syntax), so it must parse as XML with `quick-xml` —
//! well-formed, quoted attributes, no duplicate attribute, no entity but the five both languages
//! share — and, where the XML and the HTML parsers would build different trees, the checker
//! refuses what would differ: a void element not written `<img … />` (or a closed element
//! written `<td />`, which HTML reads as an open tag), an element where HTML's parser would move
//! or close it (a block in a `<p>`, text or a row straight in a `<table>`), a table row with
//! more or fewer cells than its header. It also refuses what makes a page not self-contained:
//! scripts, event attributes, styles that load something, links that are not relative.
#![allow(dead_code)] // each test binary uses part of it

use quick_xml::escape::resolve_predefined_entity;
use quick_xml::events::Event;
use quick_xml::Reader;
use quick_xml::XmlVersion;

/// A report's outline: what both formats must agree on.
#[derive(Clone, Debug, PartialEq)]
pub struct Outline {
    /// The top heading (and, in HTML, the `<title>`).
    pub title: String,
    /// The blocks after it, in order.
    pub blocks: Vec<Block>,
}

/// One block of a report, its text as a reader sees it (code spans without their backticks,
/// white space collapsed).
#[derive(Clone, Debug, PartialEq)]
pub enum Block {
    /// A section heading.
    Heading(String),
    /// A paragraph.
    Paragraph(String),
    /// A picture on its own.
    Figure(Picture),
    /// The header's cells and each row's: text, or a picture as `![alt](src)`.
    Table {
        header: Vec<String>,
        rows: Vec<Vec<String>>,
    },
}

/// A picture a report links.
#[derive(Clone, Debug, PartialEq)]
pub struct Picture {
    /// Relative to the report.
    pub src: String,
    /// Its text alternative.
    pub alt: String,
}

impl Picture {
    /// The file `src` names, relative to the report: its percent-encoded bytes decoded.
    pub fn file(&self) -> String {
        let bytes = self.src.as_bytes();
        let mut out = Vec::with_capacity(bytes.len());
        let mut i = 0;
        while i < bytes.len() {
            let hex = bytes
                .get(i + 1..i + 3)
                .and_then(|h| std::str::from_utf8(h).ok())
                .and_then(|h| u8::from_str_radix(h, 16).ok());
            match (bytes[i], hex) {
                (b'%', Some(byte)) => {
                    out.push(byte);
                    i += 3;
                }
                (b, _) => {
                    out.push(b);
                    i += 1;
                }
            }
        }
        String::from_utf8(out).expect("a UTF-8 path")
    }
}

impl Outline {
    /// Every picture, on its own or in a table, in order.
    pub fn pictures(&self) -> Vec<Picture> {
        let mut pictures = Vec::new();
        for block in &self.blocks {
            match block {
                Block::Figure(p) => pictures.push(p.clone()),
                Block::Table { rows, .. } => {
                    pictures.extend(rows.iter().flatten().filter_map(|c| picture_cell(c)))
                }
                _ => {}
            }
        }
        pictures
    }

    /// The tables, in order.
    pub fn tables(&self) -> Vec<(&[String], &[Vec<String>])> {
        self.blocks
            .iter()
            .filter_map(|b| match b {
                Block::Table { header, rows } => Some((header.as_slice(), rows.as_slice())),
                _ => None,
            })
            .collect()
    }
}

/// A table cell `![alt](src)`'s picture.
fn picture_cell(cell: &str) -> Option<Picture> {
    let (alt, src) = cell
        .strip_prefix("![")?
        .strip_suffix(')')?
        .split_once("](")?;
    Some(Picture {
        src: src.to_string(),
        alt: alt.to_string(),
    })
}

/// Runs of white space as one space, none at the ends.
fn collapse(text: &str) -> String {
    text.split_whitespace().collect::<Vec<_>>().join(" ")
}

/// Reads `report.md` as the demo writes it: `#` title, `##` headings, paragraphs, pipe
/// tables (a cell's `\|` and `\\` unescaped) and pictures on their own line.
pub fn read_markdown(md: &str) -> Outline {
    let mut title = None;
    let mut blocks = Vec::new();
    let mut lines = md.lines().peekable();
    while let Some(line) = lines.next() {
        if line.trim().is_empty() {
            continue;
        }
        if let Some(t) = line.strip_prefix("# ") {
            assert!(title.is_none(), "a second title: {line}");
            title = Some(collapse(&t.replace('`', "")));
        } else if let Some(h) = line.strip_prefix("## ") {
            blocks.push(Block::Heading(collapse(&h.replace('`', ""))));
        } else if line.starts_with('|') {
            let mut table = vec![markdown_cells(line)];
            while let Some(next) = lines.next_if(|l| l.starts_with('|')) {
                table.push(markdown_cells(next));
            }
            assert!(
                table.len() >= 2 && table[1].iter().all(|c| c == "---"),
                "a table without its separator row: {line}"
            );
            let header = table.remove(0);
            table.remove(0);
            blocks.push(Block::Table {
                header,
                rows: table,
            });
        } else if let Some(p) = picture_cell(line.trim()) {
            blocks.push(Block::Figure(p));
        } else {
            let mut text = line.to_string();
            while let Some(next) = lines.next_if(|l| !l.trim().is_empty()) {
                text.push(' ');
                text.push_str(next);
            }
            blocks.push(Block::Paragraph(collapse(&text.replace('`', ""))));
        }
    }
    Outline {
        title: title.expect("report.md has no `# ` title"),
        blocks,
    }
}

/// The cells of a markdown table row `| a | b\|c |`.
fn markdown_cells(line: &str) -> Vec<String> {
    let inner = line.trim().strip_prefix('|').unwrap_or(line);
    let inner = inner.strip_suffix('|').unwrap_or(inner);
    let (mut cells, mut cell, mut chars) = (Vec::new(), String::new(), inner.chars());
    while let Some(c) = chars.next() {
        match c {
            '\\' => cell.extend(chars.next()),
            '|' => cells.push(collapse(&std::mem::take(&mut cell))),
            c => cell.push(c),
        }
    }
    cells.push(collapse(&cell));
    cells
}

/// An element of the parsed page.
#[derive(Debug)]
struct Element {
    name: String,
    attributes: Vec<(String, String)>,
    children: Vec<Node>,
}

#[derive(Debug)]
enum Node {
    Element(Element),
    Text(String),
}

/// HTML's void elements the report may use: written `<name … />`, never with content.
const VOID: &[&str] = &["meta", "img"];

/// Each element the report may use, the elements it may contain, whether it may contain text,
/// and its attributes (a `!` before a name: required).
const ELEMENTS: &[(&str, &[&str], bool, &[&str])] = &[
    ("html", &["head", "body"], false, &["!lang"]),
    ("head", &["meta", "title", "style"], false, &[]),
    ("meta", &[], false, &["!charset"]),
    ("title", &[], true, &[]),
    ("style", &[], true, &[]),
    ("body", &["h1", "h2", "p", "table", "figure"], false, &[]),
    ("h1", &["code"], true, &[]),
    ("h2", &["code"], true, &[]),
    ("p", &["code", "a"], true, &[]),
    ("code", &[], true, &[]),
    ("a", &["img", "code"], true, &["!href"]),
    ("table", &["thead", "tbody"], false, &[]),
    ("thead", &["tr"], false, &[]),
    ("tbody", &["tr"], false, &[]),
    ("tr", &["th", "td"], false, &[]),
    ("th", &["code"], true, &[]),
    ("td", &["code", "figure"], true, &[]),
    ("figure", &["a", "img", "figcaption"], false, &[]),
    ("figcaption", &["code"], true, &[]),
    ("img", &[], false, &["!src", "!alt"]),
];

/// Parses and checks `report.html` (see the module's doc), and reads its outline.
pub fn read_html(html: &str) -> Result<Outline, String> {
    let root = parse(html)?;
    check(&root)?;
    outline(&root)
}

/// The page as a tree, refusing what is not well-formed XML or would parse otherwise as HTML.
fn parse(html: &str) -> Result<Element, String> {
    let mut reader = Reader::from_str(html);
    reader.config_mut().check_comments = true;
    let at = |reader: &Reader<&[u8]>| {
        let offset = reader.buffer_position() as usize;
        let line = html[..offset.min(html.len())].lines().count();
        format!("line {line}")
    };
    let mut doctype = false;
    let mut stack: Vec<Element> = Vec::new();
    let mut root = None;
    loop {
        let event = reader
            .read_event()
            .map_err(|e| format!("not well-formed at {}: {e}", at(&reader)))?;
        match event {
            Event::DocType(d) => {
                let d = d.xml10_content();
                if doctype || root.is_some() || !stack.is_empty() {
                    return Err(format!("a DOCTYPE that is not the first thing: {d}"));
                }
                if !d.trim().eq_ignore_ascii_case("html") {
                    return Err(format!("<!DOCTYPE {d}> is not HTML5's <!DOCTYPE html>"));
                }
                doctype = true;
            }
            Event::Start(e) | Event::Empty(e) if !doctype => {
                return Err(format!(
                    "<{}> before <!DOCTYPE html> (a browser would render in quirks mode)",
                    e.name().as_ref()
                ));
            }
            Event::Start(e) | Event::Empty(e) if root.is_some() => {
                return Err(format!("<{}> after the root element", e.name().as_ref()));
            }
            Event::Start(ref e) | Event::Empty(ref e) => {
                let name = e.name().as_ref().to_string();
                let closed = matches!(event, Event::Empty(_));
                let void = VOID.contains(&name.as_str());
                if closed && !void {
                    return Err(format!(
                        "<{name} /> at {}: HTML reads it as an open tag, write <{name}></{name}>",
                        at(&reader)
                    ));
                }
                if !closed && void {
                    return Err(format!(
                        "<{name}> at {} is void in HTML, write <{name} />",
                        at(&reader)
                    ));
                }
                let mut attributes = Vec::new();
                for a in e.attributes().with_checks(true) {
                    let a = a.map_err(|e| format!("<{name}> at {}: {e}", at(&reader)))?;
                    let value = a
                        .normalized_value(XmlVersion::Implicit1_0)
                        .map_err(|e| format!("<{name}> at {}: {e}", at(&reader)))?;
                    attributes.push((a.key.as_ref().to_string(), value.into_owned()));
                }
                let element = Element {
                    name,
                    attributes,
                    children: Vec::new(),
                };
                if closed {
                    match stack.last_mut() {
                        Some(parent) => parent.children.push(Node::Element(element)),
                        None => return Err(format!("the root is <{} />", element.name)),
                    }
                } else {
                    stack.push(element);
                }
            }
            Event::End(_) => {
                // quick-xml has checked the name against the open element.
                let element = stack.pop().ok_or("an end tag without a start")?;
                match stack.last_mut() {
                    Some(parent) => parent.children.push(Node::Element(element)),
                    None => root = Some(element),
                }
            }
            Event::Text(t) => text(&mut stack, &t.xml10_content(), &root)?,
            Event::GeneralRef(r) => {
                let resolved = match r.resolve_char_ref() {
                    Ok(Some(c)) => c.to_string(),
                    Ok(None) => {
                        let name = r.xml10_content();
                        resolve_predefined_entity(&name)
                            .ok_or(format!(
                                "&{name}; at {}: not one of XML's five entities",
                                at(&reader)
                            ))?
                            .to_string()
                    }
                    Err(e) => return Err(format!("{e} at {}", at(&reader))),
                };
                text(&mut stack, &resolved, &root)?;
            }
            Event::Comment(_) => {}
            Event::CData(_) => return Err("CDATA: a comment in HTML, text in XML".into()),
            Event::Decl(_) | Event::PI(_) => {
                return Err("an XML declaration or processing instruction".into())
            }
            Event::Eof => break,
        }
    }
    if !stack.is_empty() {
        return Err(format!("<{}> is not closed", stack[stack.len() - 1].name));
    }
    root.ok_or_else(|| "no root element".to_string())
}

/// Appends text to the open element; outside the root only white space.
fn text(stack: &mut [Element], text: &str, root: &Option<Element>) -> Result<(), String> {
    match stack.last_mut() {
        Some(parent) => {
            match parent.children.last_mut() {
                Some(Node::Text(t)) => t.push_str(text),
                _ => parent.children.push(Node::Text(text.to_string())),
            }
            Ok(())
        }
        None if text.trim().is_empty() => Ok(()),
        None => Err(format!(
            "text {} the root element: {text:?}",
            if root.is_some() { "after" } else { "before" }
        )),
    }
}

/// The element rules of [`ELEMENTS`], the page's head and the tables' shape.
fn check(root: &Element) -> Result<(), String> {
    if root.name != "html" {
        return Err(format!("the root is <{}>, not <html>", root.name));
    }
    check_element(root)?;
    let children = elements(root);
    match children.as_slice() {
        [head, body] if head.name == "head" && body.name == "body" => {
            let head = elements(head);
            let charset = head
                .first()
                .map(|m| (m.name.as_str(), attribute(m, "charset")));
            if charset != Some(("meta", Some("utf-8"))) {
                return Err("<head> does not start with <meta charset=\"utf-8\" />".into());
            }
            let titles: Vec<_> = head.iter().filter(|e| e.name == "title").collect();
            if titles.len() != 1 || text_of(titles[0]).is_empty() {
                return Err("<head> needs one non-empty <title>".into());
            }
            Ok(())
        }
        _ => Err("<html> must hold <head> and then <body>".into()),
    }
}

/// One element and everything in it.
fn check_element(element: &Element) -> Result<(), String> {
    let name = element.name.as_str();
    let Some(&(_, children, text, attributes)) = ELEMENTS.iter().find(|(n, ..)| *n == name) else {
        return Err(format!("<{name}> is not an element the report uses"));
    };
    for (key, value) in &element.attributes {
        if !attributes.iter().any(|a| a.trim_start_matches('!') == key) {
            return Err(format!("<{name}> has the attribute {key}"));
        }
        if (key == "src" || key == "href") && !is_relative(value) {
            return Err(format!("<{name} {key}=\"{value}\">: not a relative link"));
        }
    }
    for required in attributes.iter().filter_map(|a| a.strip_prefix('!')) {
        match attribute(element, required) {
            Some(value) if !value.trim().is_empty() => {}
            _ => return Err(format!("<{name}> without a non-empty {required}")),
        }
    }
    if name == "style" {
        let css = text_of(element).to_lowercase();
        if css.contains("url(") || css.contains("@import") {
            return Err("<style> loads something".into());
        }
    }
    for child in &element.children {
        match child {
            Node::Text(t) if !text && !t.trim().is_empty() => {
                return Err(format!("<{name}> holds the text {:?}", t.trim()))
            }
            Node::Element(e) if !children.contains(&e.name.as_str()) => {
                return Err(format!("<{name}> holds a <{}>", e.name))
            }
            Node::Element(e) => check_element(e)?,
            Node::Text(_) => {}
        }
    }
    match name {
        "table" => check_table(element),
        "thead" | "tbody" if elements(element).is_empty() => Err(format!("an empty <{name}>")),
        "tr" => {
            let cells: Vec<_> = elements(element).iter().map(|c| c.name.as_str()).collect();
            if cells.is_empty()
                || !(cells.iter().all(|c| *c == "th") || cells.iter().all(|c| *c == "td"))
            {
                return Err(format!("a row of <{}>", cells.join("> <")));
            }
            Ok(())
        }
        "figure" => {
            let inside: Vec<_> = elements(element).iter().map(|c| c.name.as_str()).collect();
            if inside.len() != 2
                || inside[1] != "figcaption"
                || text_of(elements(element)[1]).is_empty()
            {
                return Err("a <figure> is one picture and then its non-empty <figcaption>".into());
            }
            if figure_picture(element).is_none() {
                return Err("a <figure> without its <img>".into());
            }
            Ok(())
        }
        "a" => {
            // A picture's link opens the picture itself.
            let href = attribute(element, "href");
            for img in elements(element).iter().filter(|e| e.name == "img") {
                if attribute(img, "src") != href {
                    return Err(format!(
                        "<a href=\"{}\"> around another picture",
                        href.unwrap_or("")
                    ));
                }
            }
            Ok(())
        }
        _ => Ok(()),
    }
}

/// `<thead>` with one row of `<th>`, then `<tbody>` whose rows have as many `<td>` each.
fn check_table(table: &Element) -> Result<(), String> {
    let parts = elements(table);
    let [thead, tbody] = parts.as_slice() else {
        return Err("a <table> is <thead> and then <tbody>".into());
    };
    if thead.name != "thead" || tbody.name != "tbody" {
        return Err("a <table> is <thead> and then <tbody>".into());
    }
    let header_rows = elements(thead);
    let [header] = header_rows.as_slice() else {
        return Err("a <thead> has one row".into());
    };
    let header = elements(header);
    if header.iter().any(|c| c.name != "th") {
        return Err("the header row is not <th> cells".into());
    }
    for (i, row) in elements(tbody).iter().enumerate() {
        let cells = elements(row);
        if cells.iter().any(|c| c.name != "td") {
            return Err(format!("row {} of a table body has a <th>", i + 1));
        }
        if cells.len() != header.len() {
            return Err(format!(
                "row {} of the table headed {:?} has {} cells, its header {}",
                i + 1,
                text_of(header[0]),
                cells.len(),
                header.len()
            ));
        }
    }
    Ok(())
}

/// The checked page's outline.
fn outline(root: &Element) -> Result<Outline, String> {
    let body = elements(root)[1];
    let title = text_of(
        elements(elements(root)[0])
            .iter()
            .find(|e| e.name == "title")
            .unwrap(),
    );
    let mut parts = elements(body).into_iter();
    match parts.next() {
        Some(h1) if h1.name == "h1" && text_of(h1) == title => {}
        _ => return Err(format!("<body> does not start with <h1>{title}</h1>")),
    }
    let blocks = parts
        .map(|e| match e.name.as_str() {
            "h1" => Err("a second <h1>".to_string()),
            "h2" => Ok(Block::Heading(text_of(e))),
            "p" => Ok(Block::Paragraph(text_of(e))),
            "figure" => Ok(Block::Figure(figure_picture(e).unwrap())),
            _ => {
                let [thead, tbody] = elements(e)[..] else {
                    unreachable!("checked")
                };
                let row = |tr: &Element| -> Vec<String> {
                    elements(tr)
                        .iter()
                        .map(
                            |cell| match elements(cell).iter().find(|f| f.name == "figure") {
                                Some(f) => {
                                    let p = figure_picture(f).unwrap();
                                    format!("![{}]({})", p.alt, p.src)
                                }
                                None => text_of(cell),
                            },
                        )
                        .collect()
                };
                Ok(Block::Table {
                    header: row(elements(thead)[0]),
                    rows: elements(tbody).into_iter().map(row).collect(),
                })
            }
        })
        .collect::<Result<_, _>>()?;
    Ok(Outline { title, blocks })
}

/// A figure's one `<img>`, straight in it or in its link.
fn figure_picture(figure: &Element) -> Option<Picture> {
    let first = *elements(figure).first()?;
    let img = match first.name.as_str() {
        "img" => first,
        "a" => match elements(first).as_slice() {
            [img] if img.name == "img" => img,
            _ => return None,
        },
        _ => return None,
    };
    Some(Picture {
        src: attribute(img, "src")?.to_string(),
        alt: attribute(img, "alt")?.to_string(),
    })
}

/// A link that stays in the report's folder: no scheme, not absolute, not up.
fn is_relative(link: &str) -> bool {
    !link.is_empty()
        && !link.contains(':')
        && !link.starts_with('/')
        && !link.starts_with('\\')
        && !link.split('/').any(|part| part == "..")
}

fn elements(element: &Element) -> Vec<&Element> {
    element
        .children
        .iter()
        .filter_map(|c| match c {
            Node::Element(e) => Some(e),
            Node::Text(_) => None,
        })
        .collect()
}

fn attribute<'a>(element: &'a Element, name: &str) -> Option<&'a str> {
    element
        .attributes
        .iter()
        .find(|(k, _)| k == name)
        .map(|(_, v)| v.as_str())
}

/// All the text in an element, white space collapsed.
fn text_of(element: &Element) -> String {
    fn gather(element: &Element, out: &mut String) {
        for c in &element.children {
            match c {
                Node::Text(t) => out.push_str(t),
                Node::Element(e) => gather(e, out),
            }
        }
    }
    let mut out = String::new();
    gather(element, &mut out);
    collapse(&out)
}
