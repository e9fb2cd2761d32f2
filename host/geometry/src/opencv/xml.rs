//! The XML subset OpenCV writes (`<opencv_storage>`): elements, `type_id="opencv-matrix"`,
//! whitespace-separated sequences, comments and the five entities.

use super::{syntax, Document, Node, Syntax, SyntaxError, MAX_DEPTH};

struct Parser<'a> {
    text: &'a str,
    pos: usize,
}

pub fn parse(text: &str) -> Result<Document, SyntaxError> {
    let text = text.trim_start_matches('\u{feff}');
    let mut p = Parser { text, pos: 0 };
    p.misc()?;
    if p.rest().starts_with("<?xml") {
        p.skip_past("?>", "an unclosed `<?xml` declaration")?;
    }
    p.misc()?;
    if p.rest().starts_with("<!DOCTYPE") {
        return Err(p.error("a DOCTYPE (not written by OpenCV) is not read"));
    }
    let (name, _, node) = p.element(0)?;
    if name != "opencv_storage" {
        return Err(syntax(
            1,
            format!("the root element is <{name}>, expected <opencv_storage>"),
        ));
    }
    p.misc()?;
    if p.pos < p.text.len() {
        return Err(p.error("text after </opencv_storage>"));
    }
    let entries = match node {
        Node::Map { entries, .. } => entries,
        Node::Scalar { text, .. } if text.is_empty() => Vec::new(),
        other => {
            return Err(syntax(
                1,
                format!(
                    "<opencv_storage> must hold elements, found {}",
                    other.describe()
                ),
            ))
        }
    };
    Ok(Document {
        syntax: Syntax::Xml,
        entries,
    })
}

fn is_name_char(c: char) -> bool {
    c.is_alphanumeric() || "_-.:".contains(c)
}

impl Parser<'_> {
    fn rest(&self) -> &str {
        &self.text[self.pos..]
    }

    fn line(&self) -> usize {
        self.text[..self.pos].matches('\n').count() + 1
    }

    fn error(&self, message: impl Into<String>) -> SyntaxError {
        syntax(self.line(), message)
    }

    fn skip_past(&mut self, end: &str, what: &str) -> Result<(), SyntaxError> {
        match self.rest().find(end) {
            Some(i) => {
                self.pos += i + end.len();
                Ok(())
            }
            None => Err(self.error(what)),
        }
    }

    fn skip_ws(&mut self) {
        let rest = self.rest();
        self.pos += rest.len() - rest.trim_start().len();
    }

    /// White space, comments and processing instructions.
    fn misc(&mut self) -> Result<(), SyntaxError> {
        loop {
            self.skip_ws();
            if self.rest().starts_with("<!--") {
                self.skip_past("-->", "an unclosed comment")?;
            } else if self.rest().starts_with("<?") && !self.rest().starts_with("<?xml") {
                self.skip_past("?>", "an unclosed processing instruction")?;
            } else {
                return Ok(());
            }
        }
    }

    fn name(&mut self) -> Result<String, SyntaxError> {
        let rest = self.rest();
        let len = rest
            .char_indices()
            .find(|(_, c)| !is_name_char(*c))
            .map_or(rest.len(), |(i, _)| i);
        if len == 0 {
            return Err(self.error("expected an element or attribute name"));
        }
        let name = rest[..len].to_string();
        self.pos += len;
        Ok(name)
    }

    /// `<name attrs>content</name>` or `<name attrs/>`: the name, its `type_id` and its
    /// node.
    fn element(&mut self, depth: usize) -> Result<(String, Option<String>, Node), SyntaxError> {
        if depth > MAX_DEPTH {
            return Err(self.error(format!("nested deeper than {MAX_DEPTH} levels")));
        }
        if !self.rest().starts_with('<') {
            return Err(self.error("expected an element"));
        }
        let start_line = self.line();
        self.pos += 1;
        let name = self.name()?;
        let mut type_id = None;
        loop {
            self.skip_ws();
            if self.rest().starts_with("/>") {
                self.pos += 2;
                let node = match type_id {
                    Some(t) => Node::Map {
                        tag: Some(t),
                        entries: Vec::new(),
                    },
                    None => Node::plain(""),
                };
                return Ok((name, None, node));
            }
            if self.rest().starts_with('>') {
                self.pos += 1;
                break;
            }
            let attr = self.name()?;
            self.skip_ws();
            if !self.rest().starts_with('=') {
                return Err(self.error(format!("attribute `{attr}` without a value")));
            }
            self.pos += 1;
            self.skip_ws();
            let q = match self.rest().chars().next() {
                Some(q @ ('"' | '\'')) => q,
                _ => return Err(self.error(format!("attribute `{attr}`: expected a quote"))),
            };
            self.pos += 1;
            let Some(end) = self.rest().find(q) else {
                return Err(self.error(format!("attribute `{attr}`: unclosed quote")));
            };
            let value = decode(&self.rest()[..end]).map_err(|m| self.error(m))?;
            self.pos += end + 1;
            if attr == "type_id" {
                type_id = Some(value);
            }
        }
        // Content: text and child elements.
        let mut text = String::new();
        let mut children: Vec<(String, Node)> = Vec::new();
        loop {
            let rest = self.rest();
            let Some(lt) = rest.find('<') else {
                return Err(syntax(start_line, format!("<{name}> is never closed")));
            };
            text.push_str(&decode(&rest[..lt]).map_err(|m| self.error(m))?);
            self.pos += lt;
            let rest = self.rest();
            if rest.starts_with("<!--") {
                self.skip_past("-->", "an unclosed comment")?;
            } else if rest.starts_with("<![CDATA[") {
                self.pos += 9;
                let Some(end) = self.rest().find("]]>") else {
                    return Err(self.error("an unclosed CDATA section"));
                };
                text.push_str(&self.rest()[..end]);
                self.pos += end + 3;
            } else if rest.starts_with("</") {
                self.pos += 2;
                let close = self.name()?;
                self.skip_ws();
                if !self.rest().starts_with('>') {
                    return Err(self.error(format!("</{close} is not closed by `>`")));
                }
                self.pos += 1;
                if close != name {
                    return Err(self.error(format!(
                        "</{close}> closes <{name}> (opened on line {start_line})"
                    )));
                }
                break;
            } else if rest.starts_with("<?") || rest.starts_with("<!") {
                return Err(self.error("unexpected markup"));
            } else {
                let child_line = self.line();
                let (child, _, node) = self.element(depth + 1)?;
                if child != "_" && children.iter().any(|(k, _)| *k == child) {
                    return Err(syntax(
                        child_line,
                        format!("key `{child}` appears twice in <{name}>"),
                    ));
                }
                children.push((child, node));
            }
        }
        let node = if !children.is_empty() {
            if !text.trim().is_empty() {
                return Err(syntax(
                    start_line,
                    format!("<{name}> mixes text and elements"),
                ));
            }
            if children.iter().all(|(k, _)| k == "_") {
                Node::Seq(children.into_iter().map(|(_, n)| n).collect())
            } else {
                Node::Map {
                    tag: type_id.clone(),
                    entries: children,
                }
            }
        } else if type_id.is_some() {
            if !text.trim().is_empty() {
                return Err(syntax(
                    start_line,
                    format!("<{name} type_id=…> holds text instead of elements"),
                ));
            }
            Node::Map {
                tag: type_id.clone(),
                entries: Vec::new(),
            }
        } else {
            let tokens = tokens(&text).map_err(|m| syntax(start_line, m))?;
            match tokens.len() {
                0 => Node::plain(""),
                1 => {
                    let (t, quoted) = tokens.into_iter().next().unwrap_or_default();
                    Node::Scalar { text: t, quoted }
                }
                _ => Node::Seq(
                    tokens
                        .into_iter()
                        .map(|(text, quoted)| Node::Scalar { text, quoted })
                        .collect(),
                ),
            }
        };
        Ok((name, type_id, node))
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

/// Decodes `&lt; &gt; &amp; &quot; &apos;` and numeric references.
fn decode(s: &str) -> Result<String, String> {
    if !s.contains('&') {
        return Ok(s.to_string());
    }
    let mut out = String::with_capacity(s.len());
    let mut rest = s;
    while let Some(i) = rest.find('&') {
        out.push_str(&rest[..i]);
        rest = &rest[i + 1..];
        let Some(end) = rest.find(';').filter(|&e| e <= 12) else {
            return Err("an `&` that does not start an entity".into());
        };
        let entity = &rest[..end];
        let c = match entity {
            "lt" => '<',
            "gt" => '>',
            "amp" => '&',
            "quot" => '"',
            "apos" => '\'',
            _ => {
                let code = if let Some(h) = entity.strip_prefix("#x") {
                    u32::from_str_radix(h, 16).ok()
                } else if let Some(d) = entity.strip_prefix('#') {
                    d.parse::<u32>().ok()
                } else {
                    None
                };
                code.and_then(char::from_u32)
                    .ok_or_else(|| format!("unknown entity `&{entity};`"))?
            }
        };
        out.push(c);
        rest = &rest[end + 1..];
    }
    out.push_str(rest);
    Ok(out)
}
