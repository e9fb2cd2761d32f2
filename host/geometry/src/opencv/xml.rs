//! The XML subset OpenCV writes (`<opencv_storage>`): elements, `type_id="opencv-matrix"`,
//! whitespace-separated sequences, comments, CDATA, the five entities and character references.
//!
//! quick-xml tokenizes; the tree, the nesting bound ([`MAX_DEPTH`], kept on our own stack so no
//! input recurses) and the refusals of what OpenCV never writes (DOCTYPE, processing
//! instructions inside elements) are ours, as are the messages, which name the line.

use quick_xml::errors::{Error, IllFormedError, SyntaxError as XmlSyntax};
use quick_xml::escape::{resolve_xml_entity, unescape, EscapeError};
use quick_xml::events::attributes::AttrError;
use quick_xml::events::{BytesRef, BytesStart, Event};
use quick_xml::Reader;

use super::{syntax, Document, Node, Syntax, SyntaxError, MAX_DEPTH};

const ROOT: &str = "opencv_storage";

const DOCTYPE: &str = "a DOCTYPE (not written by OpenCV) is not read";

/// The document of `<opencv_storage>` text; an error names its line in `text`.
pub fn parse(text: &str) -> Result<Document, SyntaxError> {
    let text = text.trim_start_matches('\u{feff}');
    let mut reader = Reader::from_str(text);
    // End tags are matched against our stack instead, so the message can name both elements.
    reader.config_mut().check_end_names = false;
    let mut p = Parser {
        lines: Lines {
            text,
            offset: 0,
            line: 1,
        },
        open: Vec::new(),
        root: None,
        declared: false,
    };
    loop {
        let at = reader.buffer_position();
        let event = match reader.read_event() {
            Ok(event) => event,
            Err(e) => {
                // A position the reader did not set is 0: the event's start is better.
                let line = p.lines.at(reader.error_position().max(at));
                return Err(syntax(line, message(&e)));
            }
        };
        if !p.event(event, at)? {
            break;
        }
    }
    let entries = match p.root {
        Some(Node::Map { entries, .. }) => entries,
        Some(Node::Scalar { text, .. }) if text.is_empty() => Vec::new(),
        Some(other) => {
            return Err(syntax(
                1,
                format!("<{ROOT}> must hold elements, found {}", other.describe()),
            ))
        }
        None => {
            let line = p.lines.at(text.len() as u64);
            return Err(syntax(
                line,
                format!("expected the root element <{ROOT}>, found the end of the text"),
            ));
        }
    };
    Ok(Document {
        syntax: Syntax::Xml,
        entries,
    })
}

/// An element whose end tag is still to come.
struct Open {
    name: String,
    /// The line of its start tag.
    line: usize,
    type_id: Option<String>,
    text: String,
    children: Vec<(String, Node)>,
}

struct Parser<'a> {
    lines: Lines<'a>,
    /// The open elements, the root first; never longer than `MAX_DEPTH + 1`.
    open: Vec<Open>,
    /// The root's node, once `</opencv_storage>` is read.
    root: Option<Node>,
    /// Whether `<?xml …?>` was read.
    declared: bool,
}

impl Parser<'_> {
    /// Takes one event that starts at byte `at`; `false` at the end of the text.
    fn event(&mut self, event: Event<'_>, at: u64) -> Result<bool, SyntaxError> {
        let line = self.lines.at(at);
        match event {
            Event::Start(tag) => self.start(&tag, at, false)?,
            Event::Empty(tag) => self.start(&tag, at, true)?,
            Event::End(tag) => {
                let name: &str = &tag;
                if !is_name(name) {
                    return Err(syntax(
                        line,
                        format!(
                            "expected an element name after `</`, found {:?}",
                            shown(name)
                        ),
                    ));
                }
                let Some(mut open) = self.open.pop() else {
                    return Err(syntax(line, format!("</{name}> after </{ROOT}>")));
                };
                if name != open.name {
                    return Err(syntax(
                        line,
                        format!(
                            "</{name}> closes <{}> (opened on line {})",
                            open.name, open.line
                        ),
                    ));
                }
                let node = open.node()?;
                self.close(open.name, node);
            }
            Event::Text(t) => self.text(&t, at, "text")?,
            Event::CData(t) => self.text(&t, at, "a CDATA section")?,
            Event::GeneralRef(r) => {
                let c = resolve(&r).map_err(|m| syntax(line, m))?;
                self.text(&c, at, "a reference")?;
            }
            Event::Comment(_) => {}
            Event::Decl(_) | Event::PI(_) => {
                let decl = matches!(event, Event::Decl(_));
                if let Some(open) = self.open.last() {
                    return Err(syntax(
                        line,
                        format!(
                            "a processing instruction inside <{}> (OpenCV writes none)",
                            open.name
                        ),
                    ));
                }
                if decl && self.root.is_some() {
                    return Err(syntax(line, format!("`<?xml` after </{ROOT}>")));
                }
                if decl && self.declared {
                    return Err(syntax(line, "a second `<?xml` declaration"));
                }
                self.declared |= decl;
            }
            Event::DocType(_) => return Err(syntax(line, DOCTYPE)),
            Event::Eof => {
                if let Some(open) = self.open.last() {
                    return Err(syntax(
                        open.line,
                        format!("<{}> is never closed", open.name),
                    ));
                }
                return Ok(false);
            }
        }
        Ok(true)
    }

    /// A start tag (`empty`: `<name …/>`) at byte `at`.
    fn start(&mut self, tag: &BytesStart<'_>, at: u64, empty: bool) -> Result<(), SyntaxError> {
        let line = self.lines.at(at);
        let name = tag.name().as_ref().to_string();
        if !is_name(&name) {
            return Err(syntax(
                line,
                format!(
                    "expected an element name after `<`, found {:?}",
                    shown(&name)
                ),
            ));
        }
        if self.root.is_some() {
            return Err(syntax(
                line,
                format!("<{name}> after </{ROOT}> (a file has one root element)"),
            ));
        }
        if self.open.len() > MAX_DEPTH {
            return Err(syntax(
                line,
                format!("nested deeper than {MAX_DEPTH} levels"),
            ));
        }
        match self.open.last() {
            None if name != ROOT => {
                return Err(syntax(
                    1,
                    format!("the root element is <{name}>, expected <{ROOT}>"),
                ))
            }
            Some(parent) if name != "_" && parent.children.iter().any(|(k, _)| *k == name) => {
                return Err(syntax(
                    line,
                    format!("key `{name}` appears twice in <{}>", parent.name),
                ))
            }
            _ => {}
        }
        let mut open = Open {
            type_id: self.type_id(tag, &name, at)?,
            name,
            line,
            text: String::new(),
            children: Vec::new(),
        };
        if empty {
            let node = open.node()?;
            self.close(open.name, node);
        } else {
            self.open.push(open);
        }
        Ok(())
    }

    /// The `type_id` of a start tag at byte `at`; every attribute must be well-formed.
    fn type_id(
        &mut self,
        tag: &BytesStart<'_>,
        name: &str,
        at: u64,
    ) -> Result<Option<String>, SyntaxError> {
        let content: &str = tag;
        let mut type_id = None;
        for attr in tag.attributes() {
            let attr = attr.map_err(|e| {
                let (pos, m) = attr_message(content, name, &e);
                // `pos` counts from the byte after `<`.
                syntax(self.lines.at(at + 1 + pos as u64), m)
            })?;
            let key = attr.key.as_ref();
            // The key is a slice of the tag, so its distance from the tag's start is its place.
            let pos = (key.as_ptr() as usize).saturating_sub(content.as_ptr() as usize);
            let line = self.lines.at(at + 1 + pos as u64);
            if !is_name(key) {
                return Err(syntax(
                    line,
                    format!("<{name}>: `{}` is not an attribute name", shown(key)),
                ));
            }
            let value = unescape(&attr.value).map_err(|e| syntax(line, escape_message(&e)))?;
            if key == "type_id" {
                type_id = Some(value.into_owned());
            }
        }
        Ok(type_id)
    }

    /// Text (or CDATA, or a resolved reference) at byte `at`: content inside an element,
    /// white space only outside.
    fn text(&mut self, t: &str, at: u64, what: &str) -> Result<(), SyntaxError> {
        if let Some(open) = self.open.last_mut() {
            open.text.push_str(t);
            return Ok(());
        }
        let trimmed = t.trim_start();
        if trimmed.is_empty() && what == "text" {
            return Ok(());
        }
        let line = self.lines.at(at + (t.len() - trimmed.len()) as u64);
        Err(syntax(
            line,
            match self.root {
                Some(_) => format!("{what} after </{ROOT}>"),
                None => format!("expected the root element <{ROOT}>, found {what}"),
            },
        ))
    }

    /// Gives a finished element to its parent, or makes it the root.
    fn close(&mut self, name: String, node: Node) {
        match self.open.last_mut() {
            Some(parent) => parent.children.push((name, node)),
            None => self.root = Some(node),
        }
    }
}

impl Open {
    /// Child elements make a map (a sequence when all are `<_>`); text makes a scalar, or a
    /// sequence when it has several tokens.
    fn node(&mut self) -> Result<Node, SyntaxError> {
        let (name, line, text) = (&self.name, self.line, self.text.trim());
        let children = std::mem::take(&mut self.children);
        if !children.is_empty() && !text.is_empty() {
            return Err(syntax(line, format!("<{name}> mixes text and elements")));
        }
        if self.type_id.is_some() && !text.is_empty() {
            let m = format!("<{name} type_id=…> holds text instead of elements");
            return Err(syntax(line, m));
        }
        if !children.is_empty() && children.iter().all(|(k, _)| k == "_") {
            return Ok(Node::Seq(children.into_iter().map(|(_, n)| n).collect()));
        }
        if !children.is_empty() || self.type_id.is_some() {
            let tag = self.type_id.take();
            return Ok(Node::Map {
                tag,
                entries: children,
            });
        }
        let tokens = tokens(text).map_err(|m| syntax(line, m))?;
        let mut items: Vec<Node> = tokens
            .into_iter()
            .map(|(text, quoted)| Node::Scalar { text, quoted })
            .collect();
        Ok(match items.len() {
            0 => Node::plain(""),
            1 => items.remove(0),
            _ => Node::Seq(items),
        })
    }
}

/// Line numbers of byte offsets, counted on from the last offset asked for, so that a whole
/// file costs one pass.
struct Lines<'a> {
    text: &'a str,
    offset: usize,
    line: usize,
}

impl Lines<'_> {
    fn at(&mut self, offset: u64) -> usize {
        let offset = usize::try_from(offset)
            .unwrap_or(usize::MAX)
            .min(self.text.len());
        if offset < self.offset {
            self.offset = 0;
            self.line = 1;
        }
        let bytes = &self.text.as_bytes()[self.offset..offset];
        self.line += bytes.iter().filter(|&&b| b == b'\n').count();
        self.offset = offset;
        self.line
    }
}

/// Letters, digits and `_ - . :`, as before quick-xml (which takes anything up to white space).
fn is_name(name: &str) -> bool {
    !name.is_empty()
        && name
            .chars()
            .all(|c| c.is_alphanumeric() || "_-.:".contains(c))
}

/// `&lt; &gt; &amp; &quot; &apos;` and `&#…;`; other entities need a DTD, which is not read.
fn resolve(r: &BytesRef<'_>) -> Result<String, String> {
    let name: &str = r;
    if !plausible_entity(name) {
        return Err(NOT_AN_ENTITY.into());
    }
    if r.is_char_ref() {
        return match r.resolve_char_ref() {
            Ok(Some(c)) => Ok(c.to_string()),
            _ => Err(format!("`&{name};` is not a valid character reference")),
        };
    }
    resolve_xml_entity(name)
        .map(str::to_string)
        .ok_or_else(|| format!("unknown entity `&{name};`"))
}

const NOT_AN_ENTITY: &str = "an `&` that does not start an entity";

/// Whether `&name;` looks meant as a reference: quick-xml's runs to the next `;`, however far.
fn plausible_entity(name: &str) -> bool {
    !name.is_empty() && name.len() <= 32 && !name.contains(char::is_whitespace)
}

fn escape_message(e: &EscapeError) -> String {
    match e {
        EscapeError::UnrecognizedEntity(_, name) if plausible_entity(name) => {
            format!("unknown entity `&{name};`")
        }
        EscapeError::InvalidCharRef(e) => format!("an invalid character reference ({e})"),
        _ => NOT_AN_ENTITY.into(),
    }
}

/// The message of a malformed attribute of `<name …>`, and where it is (the start of the
/// attribute's name, counted from the byte after `<` as quick-xml counts).
fn attr_message(content: &str, name: &str, e: &AttrError) -> (usize, String) {
    let (end, what) = match *e {
        AttrError::ExpectedEq(p) => (p, "without a value"),
        AttrError::ExpectedValue(p) => (p, "without a value after `=`"),
        AttrError::UnquotedValue(p) => (p, "without quotes (`\"` or `'`) around its value"),
        AttrError::ExpectedQuote(p, _) => (p, "without its closing quote"),
        AttrError::Duplicated(p, _) => {
            let rest = content.get(p..).unwrap_or("");
            (
                p + rest.find(separator).unwrap_or(rest.len()),
                "given twice",
            )
        }
    };
    // The attribute's name is the last word before `end`, white space and `=` skipped.
    let head = content.get(..end).unwrap_or(content);
    let head = head.trim_end_matches(separator);
    let start = head
        .rfind(|c: char| c.is_ascii_whitespace())
        .map_or(0, |i| i + 1);
    let key = shown(&head[start..]);
    (start, format!("<{name}>: attribute `{key}` {what}"))
}

/// What ends an attribute's name for quick-xml: ASCII white space (one byte, so the byte after
/// it starts a character) or `=`.
fn separator(c: char) -> bool {
    c.is_ascii_whitespace() || c == '='
}

/// At most 40 characters of `s`, for messages about text that is not a name.
fn shown(s: &str) -> String {
    match s.char_indices().nth(40) {
        Some((i, _)) => format!("{}…", &s[..i]),
        None => s.to_string(),
    }
}

/// The message of an error of quick-xml's tokenizer, in the words of the other messages.
fn message(e: &Error) -> String {
    use IllFormedError as Ill;
    match e {
        Error::Syntax(XmlSyntax::UnclosedDoctype) | Error::IllFormed(Ill::MissingDoctypeName) => {
            DOCTYPE.into()
        }
        Error::Syntax(XmlSyntax::InvalidBangMarkup) => {
            "unexpected markup after `<!` (OpenCV writes only comments there)".into()
        }
        Error::Syntax(XmlSyntax::UnclosedPI) => "an unclosed processing instruction".into(),
        Error::Syntax(XmlSyntax::UnclosedXmlDecl) => "an unclosed `<?xml` declaration".into(),
        Error::Syntax(XmlSyntax::UnclosedComment) => "an unclosed comment".into(),
        Error::Syntax(XmlSyntax::UnclosedCData) => "an unclosed CDATA section".into(),
        Error::Syntax(XmlSyntax::UnclosedTag) => "a tag without its closing `>`".into(),
        Error::Syntax(
            XmlSyntax::UnclosedSingleQuotedAttributeValue
            | XmlSyntax::UnclosedDoubleQuotedAttributeValue,
        ) => "an attribute value without its closing quote".into(),
        Error::IllFormed(Ill::UnclosedReference) => NOT_AN_ENTITY.into(),
        Error::IllFormed(Ill::UnmatchedEndTag(name)) => format!("</{name}> after </{ROOT}>"),
        other => other.to_string(),
    }
}

/// Whitespace-separated tokens, `"quoted strings"` kept whole.
fn tokens(text: &str) -> Result<Vec<(String, bool)>, String> {
    let mut out = Vec::new();
    let mut chars = text.chars().peekable();
    while let Some(&c) = chars.peek() {
        if c.is_whitespace() {
            chars.next();
            continue;
        }
        if c == '"' {
            chars.next();
            let mut s = String::new();
            loop {
                match chars.next() {
                    Some('"') => break,
                    Some(ch) => s.push(ch),
                    None => return Err("an unclosed quote in element text".into()),
                }
            }
            out.push((s, true));
        } else {
            let mut s = String::new();
            while let Some(&ch) = chars.peek() {
                if ch.is_whitespace() {
                    break;
                }
                s.push(ch);
                chars.next();
            }
            out.push((s, false));
        }
    }
    Ok(out)
}
