//! The YAML subset OpenCV writes (`%YAML:1.0`): block and flow maps and sequences, plain and
//! quoted scalars, comments, `!!opencv-matrix` tags.

use super::{syntax, Document, Node, Syntax, SyntaxError, MAX_DEPTH};

struct Line {
    number: usize,
    indent: usize,
    text: String,
}

/// Removes a comment (`#` at the start or after white space, outside quotes).
fn strip_comment(s: &str) -> &str {
    let mut quote: Option<char> = None;
    let mut prev_space = true;
    for (i, c) in s.char_indices() {
        match quote {
            Some(q) => {
                if c == q {
                    quote = None;
                }
            }
            None => {
                if c == '#' && prev_space {
                    return &s[..i];
                }
                if c == '"' || c == '\'' {
                    quote = Some(c);
                }
            }
        }
        prev_space = c == ' ' || c == '\t';
    }
    s
}

pub fn parse(text: &str) -> Result<Document, SyntaxError> {
    let text = text.trim_start_matches('\u{feff}');
    let mut lines = Vec::new();
    let mut header_seen = false;
    for (i, raw) in text.lines().enumerate() {
        let number = i + 1;
        let raw = raw.trim_end_matches('\r');
        if !header_seen {
            if raw.trim().is_empty() {
                continue;
            }
            let t = raw.trim_start();
            if !(t.starts_with("%YAML:1.") || t.starts_with("%YAML 1.")) {
                return Err(syntax(number, "expected the header `%YAML:1.0`"));
            }
            header_seen = true;
            continue;
        }
        let body = strip_comment(raw);
        if body.trim().is_empty() {
            continue;
        }
        let indent = body.len() - body.trim_start_matches(' ').len();
        if body[indent..].starts_with('\t') {
            return Err(syntax(number, "a tab in the indentation"));
        }
        let content = body.trim();
        if indent == 0 && (content == "---" || content.starts_with("--- ")) {
            if !lines.is_empty() {
                return Err(syntax(
                    number,
                    "a second document (`---`): one calibration per file",
                ));
            }
            continue;
        }
        if indent == 0 && content == "..." {
            break;
        }
        if content.starts_with('%') {
            return Err(syntax(number, "a directive after the header"));
        }
        lines.push(Line {
            number,
            indent,
            text: content.to_string(),
        });
    }
    if !header_seen {
        return Err(syntax(1, "expected the header `%YAML:1.0`"));
    }
    let mut p = Parser { lines, pos: 0 };
    if p.lines.is_empty() {
        return Ok(Document {
            syntax: Syntax::Yaml,
            entries: Vec::new(),
        });
    }
    let first = &p.lines[0];
    if first.indent != 0 {
        return Err(syntax(
            first.number,
            "the top-level keys must not be indented",
        ));
    }
    if first.text.starts_with('{') {
        // A top-level flow map.
        let node = p.flow_value(0)?;
        if p.pos < p.lines.len() {
            return Err(syntax(
                p.lines[p.pos].number,
                "text after the top-level map",
            ));
        }
        return match node {
            Node::Map { entries, .. } => Ok(Document {
                syntax: Syntax::Yaml,
                entries,
            }),
            _ => Err(syntax(1, "the top level must be a map")),
        };
    }
    let entries = p.block_map(0, 0)?;
    if let Some(line) = p.lines.get(p.pos) {
        return Err(syntax(
            line.number,
            "unexpected text (indentation does not match any key above)",
        ));
    }
    Ok(Document {
        syntax: Syntax::Yaml,
        entries,
    })
}

struct Parser {
    lines: Vec<Line>,
    pos: usize,
}

/// Splits `key: rest` (or `key:` at the end); `None` when the text is not a map entry.
fn split_key(text: &str) -> Option<(String, &str)> {
    if let Some(q) = text.chars().next().filter(|c| *c == '"' || *c == '\'') {
        let end = text[1..].find(q)? + 1;
        let key = &text[1..end];
        let after = text[end + 1..].trim_start();
        let rest = after.strip_prefix(':')?;
        if !(rest.is_empty() || rest.starts_with(' ')) {
            return None;
        }
        return Some((key.to_string(), rest.trim()));
    }
    let mut search = 0;
    while let Some(i) = text[search..].find(':') {
        let at = search + i;
        let rest = &text[at + 1..];
        if rest.is_empty() || rest.starts_with(' ') {
            let key = text[..at].trim_end();
            if key.is_empty() || key.starts_with(['[', '{', '-', '!']) {
                return None;
            }
            return Some((key.to_string(), rest.trim()));
        }
        search = at + 1;
    }
    None
}

fn is_seq_item(text: &str) -> bool {
    text == "-" || text.starts_with("- ")
}

impl Parser {
    fn line_number(&self) -> usize {
        self.lines
            .get(self.pos)
            .or(self.lines.last())
            .map_or(1, |l| l.number)
    }

    fn depth_check(&self, depth: usize) -> Result<(), SyntaxError> {
        if depth > MAX_DEPTH {
            Err(syntax(
                self.line_number(),
                format!("nested deeper than {MAX_DEPTH} levels"),
            ))
        } else {
            Ok(())
        }
    }

    fn block_map(
        &mut self,
        indent: usize,
        depth: usize,
    ) -> Result<Vec<(String, Node)>, SyntaxError> {
        self.depth_check(depth)?;
        let mut entries: Vec<(String, Node)> = Vec::new();
        while let Some(line) = self.lines.get(self.pos) {
            if line.indent < indent {
                break;
            }
            let number = line.number;
            if line.indent > indent {
                return Err(syntax(number, "unexpected indentation"));
            }
            if is_seq_item(&line.text) {
                return Err(syntax(number, "a sequence item where a key was expected"));
            }
            let Some((key, rest)) = split_key(&line.text) else {
                return Err(syntax(
                    number,
                    format!("expected `key: value`, found {:?}", line.text),
                ));
            };
            let rest = rest.to_string();
            if entries.iter().any(|(k, _)| *k == key) {
                return Err(syntax(number, format!("key `{key}` appears twice")));
            }
            self.pos += 1;
            let value = self.value_after(rest, indent, number, depth)?;
            entries.push((key, value));
        }
        Ok(entries)
    }

    /// The value of an entry or item whose remaining text on its line is `rest`; nested
    /// blocks must be indented deeper than `indent`.
    fn value_after(
        &mut self,
        rest: String,
        indent: usize,
        number: usize,
        depth: usize,
    ) -> Result<Node, SyntaxError> {
        self.depth_check(depth + 1)?;
        let (tag, rest) = if let Some(t) = rest.strip_prefix("!!") {
            let end = t.find(' ').unwrap_or(t.len());
            (Some(t[..end].to_string()), t[end..].trim().to_string())
        } else if rest.starts_with('!') {
            return Err(syntax(number, format!("unsupported tag in {rest:?}")));
        } else {
            (None, rest)
        };
        let node = if rest.is_empty() {
            match self.lines.get(self.pos) {
                Some(next) if next.indent > indent => {
                    let child = next.indent;
                    if is_seq_item(&next.text) {
                        Node::Seq(self.block_seq(child, depth + 1)?)
                    } else {
                        Node::Map {
                            tag: None,
                            entries: self.block_map(child, depth + 1)?,
                        }
                    }
                }
                // A sequence may sit at the same indentation as its key.
                Some(next) if next.indent == indent && is_seq_item(&next.text) && tag.is_none() => {
                    Node::Seq(self.block_seq(indent, depth + 1)?)
                }
                _ => Node::plain(""),
            }
        } else if rest.starts_with('[') || rest.starts_with('{') {
            // Re-read the entry's line from the bracket on, with the lines that follow.
            self.pos -= 1;
            self.lines[self.pos].text = rest;
            self.flow_value(depth + 1)?
        } else {
            scalar(&rest, number)?
        };
        match (tag, node) {
            (None, node) => Ok(node),
            (Some(tag), Node::Map { entries, .. }) => Ok(Node::Map {
                tag: Some(tag),
                entries,
            }),
            (Some(tag), other) if tag == "opencv-matrix" || tag == "opencv-nd-matrix" => {
                Err(syntax(
                    number,
                    format!(
                        "!!{tag} must be followed by a map, found {}",
                        other.describe()
                    ),
                ))
            }
            // Standard scalar tags (!!str, !!float …): keep the value.
            (Some(_), other) => Ok(other),
        }
    }

    fn block_seq(&mut self, indent: usize, depth: usize) -> Result<Vec<Node>, SyntaxError> {
        self.depth_check(depth)?;
        let mut items = Vec::new();
        while let Some(line) = self.lines.get(self.pos) {
            if line.indent < indent || (line.indent == indent && !is_seq_item(&line.text)) {
                break;
            }
            let number = line.number;
            if line.indent > indent {
                return Err(syntax(number, "unexpected indentation in a sequence"));
            }
            let rest = line.text[1..].trim_start().to_string();
            let offset = line.text.len() - rest.len();
            if !rest.is_empty()
                && !rest.starts_with(['[', '{', '"', '\'', '!'])
                && (split_key(&rest).is_some() || is_seq_item(&rest))
            {
                // `- key: value` (a map) or `- - item`: the rest of the line becomes a
                // line of its own, indented to where it starts.
                let l = &mut self.lines[self.pos];
                l.indent = indent + offset;
                l.text = rest;
                let child = indent + offset;
                let node = if is_seq_item(&self.lines[self.pos].text) {
                    Node::Seq(self.block_seq(child, depth + 1)?)
                } else {
                    Node::Map {
                        tag: None,
                        entries: self.block_map(child, depth + 1)?,
                    }
                };
                items.push(node);
                continue;
            }
            self.pos += 1;
            items.push(self.value_after(rest, indent, number, depth)?);
        }
        Ok(items)
    }

    /// A flow collection starting at the current line, continued over as many lines as it
    /// takes; consumes those lines (text after the collection on its last line is an
    /// error).
    fn flow_value(&mut self, depth: usize) -> Result<Node, SyntaxError> {
        let start = self.pos;
        let mut text = String::new();
        let mut line_of_char: Vec<(usize, usize)> = Vec::new();
        let mut balance: i64 = 0;
        let mut quote: Option<char> = None;
        let mut end = None;
        let mut i = start;
        while i < self.lines.len() {
            line_of_char.push((text.len(), self.lines[i].number));
            text.push_str(&self.lines[i].text);
            text.push(' ');
            for c in self.lines[i].text.chars() {
                match quote {
                    Some(q) if c == q => quote = None,
                    Some(_) => {}
                    None => match c {
                        '"' | '\'' => quote = Some(c),
                        '[' | '{' => balance += 1,
                        ']' | '}' => balance -= 1,
                        _ => {}
                    },
                }
            }
            i += 1;
            if balance <= 0 && quote.is_none() {
                end = Some(i);
                break;
            }
        }
        let number_at = |offset: usize| {
            line_of_char
                .iter()
                .rev()
                .find(|(o, _)| *o <= offset)
                .map_or(1, |(_, n)| *n)
        };
        let Some(end) = end else {
            return Err(syntax(
                self.lines[start].number,
                "a `[` or `{` that is never closed",
            ));
        };
        let chars: Vec<char> = text.chars().collect();
        let mut f = Flow {
            chars: &chars,
            pos: 0,
        };
        let node = f
            .value(depth)
            .map_err(|(at, m)| syntax(number_at(byte_offset(&chars, at)), m))?;
        f.skip_ws();
        if f.pos < chars.len() {
            return Err(syntax(
                number_at(byte_offset(&chars, f.pos)),
                "text after the closing bracket",
            ));
        }
        self.pos = end;
        Ok(node)
    }
}

fn byte_offset(chars: &[char], at: usize) -> usize {
    chars[..at.min(chars.len())]
        .iter()
        .map(|c| c.len_utf8())
        .sum()
}

fn unquote(s: &str, number: usize) -> Result<String, SyntaxError> {
    let q = s.chars().next().unwrap_or('"');
    let inner = &s[1..];
    let Some(end) = inner.find(q) else {
        return Err(syntax(number, format!("unclosed quote in {s:?}")));
    };
    if !inner[end + 1..].trim().is_empty() {
        return Err(syntax(
            number,
            format!("text after the closing quote in {s:?}"),
        ));
    }
    Ok(inner[..end].to_string())
}

fn scalar(rest: &str, number: usize) -> Result<Node, SyntaxError> {
    if rest.starts_with('"') || rest.starts_with('\'') {
        return Ok(Node::Scalar {
            text: unquote(rest, number)?,
            quoted: true,
        });
    }
    if rest.starts_with(['|', '>', '&', '*', '@', '`']) {
        return Err(syntax(
            number,
            format!("unsupported YAML construct in {rest:?}"),
        ));
    }
    Ok(Node::plain(rest))
}

/// A flow collection over characters: `[a, b]`, `{k: v}`, nested.
struct Flow<'a> {
    chars: &'a [char],
    pos: usize,
}

type FlowError = (usize, String);

impl Flow<'_> {
    fn peek(&self) -> Option<char> {
        self.chars.get(self.pos).copied()
    }

    fn skip_ws(&mut self) {
        while self.peek().is_some_and(|c| c == ' ' || c == '\t') {
            self.pos += 1;
        }
    }

    fn value(&mut self, depth: usize) -> Result<Node, FlowError> {
        if depth > MAX_DEPTH {
            return Err((self.pos, format!("nested deeper than {MAX_DEPTH} levels")));
        }
        self.skip_ws();
        let mut tag = None;
        if self.peek() == Some('!') {
            let start = self.pos;
            while self
                .peek()
                .is_some_and(|c| c != ' ' && c != '{' && c != '[')
            {
                self.pos += 1;
            }
            let t: String = self.chars[start..self.pos].iter().collect();
            match t.strip_prefix("!!") {
                Some(t) if !t.is_empty() => tag = Some(t.to_string()),
                _ => return Err((start, format!("unsupported tag {t:?}"))),
            }
            self.skip_ws();
        }
        let node = match self.peek() {
            Some('[') => {
                self.pos += 1;
                let mut items = Vec::new();
                loop {
                    self.skip_ws();
                    if self.peek() == Some(']') {
                        self.pos += 1;
                        break;
                    }
                    items.push(self.value(depth + 1)?);
                    self.skip_ws();
                    match self.peek() {
                        Some(',') => self.pos += 1,
                        Some(']') => {
                            self.pos += 1;
                            break;
                        }
                        _ => return Err((self.pos, "expected `,` or `]`".into())),
                    }
                }
                Node::Seq(items)
            }
            Some('{') => {
                self.pos += 1;
                let mut entries: Vec<(String, Node)> = Vec::new();
                loop {
                    self.skip_ws();
                    if self.peek() == Some('}') {
                        self.pos += 1;
                        break;
                    }
                    let key_at = self.pos;
                    let key = self.key()?;
                    if entries.iter().any(|(k, _)| *k == key) {
                        return Err((key_at, format!("key `{key}` appears twice")));
                    }
                    let value = self.value(depth + 1)?;
                    entries.push((key, value));
                    self.skip_ws();
                    match self.peek() {
                        Some(',') => self.pos += 1,
                        Some('}') => {
                            self.pos += 1;
                            break;
                        }
                        _ => return Err((self.pos, "expected `,` or `}`".into())),
                    }
                }
                Node::Map { tag: None, entries }
            }
            Some(q @ ('"' | '\'')) => {
                let start = self.pos;
                self.pos += 1;
                let from = self.pos;
                while self.peek().is_some_and(|c| c != q) {
                    self.pos += 1;
                }
                if self.peek().is_none() {
                    return Err((start, "unclosed quote".into()));
                }
                let text: String = self.chars[from..self.pos].iter().collect();
                self.pos += 1;
                Node::Scalar { text, quoted: true }
            }
            _ => {
                let start = self.pos;
                while self.peek().is_some_and(|c| !",]}[{".contains(c)) {
                    self.pos += 1;
                }
                let text: String = self.chars[start..self.pos].iter().collect();
                Node::plain(text.trim())
            }
        };
        match (tag, node) {
            (None, n) => Ok(n),
            (Some(t), Node::Map { entries, .. }) => Ok(Node::Map {
                tag: Some(t),
                entries,
            }),
            (Some(t), _) if t.starts_with("opencv") => {
                Err((self.pos, format!("!!{t} must be followed by a map")))
            }
            (Some(_), n) => Ok(n),
        }
    }

    fn key(&mut self) -> Result<String, FlowError> {
        self.skip_ws();
        let start = self.pos;
        let key: String = if let Some(q @ ('"' | '\'')) = self.peek() {
            self.pos += 1;
            let from = self.pos;
            while self.peek().is_some_and(|c| c != q) {
                self.pos += 1;
            }
            if self.peek().is_none() {
                return Err((start, "unclosed quote".into()));
            }
            let k = self.chars[from..self.pos].iter().collect();
            self.pos += 1;
            k
        } else {
            while self.peek().is_some_and(|c| !":,]}[{".contains(c)) {
                self.pos += 1;
            }
            let k: String = self.chars[start..self.pos].iter().collect();
            k.trim().to_string()
        };
        self.skip_ws();
        if self.peek() != Some(':') || key.is_empty() {
            return Err((start, "expected `key:` in a flow map".into()));
        }
        self.pos += 1;
        Ok(key)
    }
}
