//! The tree both syntaxes parse into: maps, sequences and scalars, and the
//! `opencv-matrix` nodes read as matrices.

use super::{syntax, xml, yaml, OpenCvErrorKind, Syntax, SyntaxError};

/// One node of a FileStorage document.
#[derive(Clone, Debug, PartialEq)]
pub enum Node {
    /// A number or a string, as written (quotes removed).
    Scalar {
        /// The text.
        text: String,
        /// Whether it was quoted (then it is a string, never a number).
        quoted: bool,
    },
    /// A sequence.
    Seq(Vec<Node>),
    /// A map, with its type tag (`opencv-matrix` from `!!opencv-matrix` or `type_id`).
    Map {
        /// The tag, without `!!`.
        tag: Option<String>,
        /// The entries in file order.
        entries: Vec<(String, Node)>,
    },
}

impl Node {
    pub(super) fn plain(text: &str) -> Node {
        Node::Scalar {
            text: text.to_string(),
            quoted: false,
        }
    }

    /// The entry `key` of a map.
    pub fn get(&self, key: &str) -> Option<&Node> {
        match self {
            Node::Map { entries, .. } => entries.iter().find(|(k, _)| k == key).map(|(_, v)| v),
            _ => None,
        }
    }

    /// The number of an unquoted scalar (`.nan`, `.inf`, `-.inf` included).
    pub fn number(&self) -> Option<f64> {
        match self {
            Node::Scalar {
                text,
                quoted: false,
            } => parse_number(text),
            _ => None,
        }
    }

    /// A short description for messages.
    pub(super) fn describe(&self) -> String {
        match self {
            Node::Scalar { text, quoted: true } => format!("the string {text:?}"),
            Node::Scalar { text, .. } if parse_number(text).is_some() => {
                format!("the number {text}")
            }
            Node::Scalar { text, .. } if text.is_empty() => "an empty value".into(),
            Node::Scalar { text, .. } => format!("the string {text:?}"),
            Node::Seq(items) => format!("a sequence of {} items", items.len()),
            Node::Map { tag: Some(t), .. } => format!("a map tagged {t}"),
            Node::Map { tag: None, .. } => "a map".into(),
        }
    }
}

pub(super) fn parse_number(text: &str) -> Option<f64> {
    let t = text.trim();
    match t.to_ascii_lowercase().as_str() {
        ".nan" => return Some(f64::NAN),
        ".inf" | "+.inf" => return Some(f64::INFINITY),
        "-.inf" => return Some(f64::NEG_INFINITY),
        _ => {}
    }
    // Rust also reads "inf", "nan" and "infinity"; FileStorage writes only the forms above.
    if !t
        .bytes()
        .all(|b| b.is_ascii_digit() || b"+-.eE".contains(&b))
    {
        return None;
    }
    t.parse::<f64>().ok()
}

/// A dense single-channel matrix, row-major.
#[derive(Clone, Debug, PartialEq)]
pub struct Matrix {
    /// Rows.
    pub rows: usize,
    /// Columns.
    pub cols: usize,
    /// OpenCV's element type letter: `u c w s i f d`.
    pub dt: char,
    /// `rows · cols` values, row by row.
    pub data: Vec<f64>,
}

impl Matrix {
    /// `rows×cols`.
    pub fn shape(&self) -> String {
        format!("{}x{}", self.rows, self.cols)
    }

    /// Entry `(r, c)`.
    pub fn at(&self, r: usize, c: usize) -> f64 {
        self.data[r * self.cols + c]
    }
}

/// A parsed FileStorage file: its top-level map.
#[derive(Clone, Debug, PartialEq)]
pub struct Document {
    /// The syntax it was written in.
    pub syntax: Syntax,
    /// Top-level entries in file order.
    pub entries: Vec<(String, Node)>,
}

pub(super) fn key_error(key: &str, message: impl Into<String>) -> OpenCvErrorKind {
    OpenCvErrorKind::Key {
        key: key.to_string(),
        message: message.into(),
    }
}

impl Document {
    /// Parses FileStorage text, YAML or XML (recognised from the first characters).
    pub fn parse(text: &str) -> Result<Document, SyntaxError> {
        match Syntax::of_text(text) {
            Some(Syntax::Yaml) => yaml::parse(text),
            Some(Syntax::Xml) => xml::parse(text),
            None => Err(syntax(
                1,
                "not an OpenCV FileStorage file: expected `%YAML:1.0` or `<?xml` at the start",
            )),
        }
    }

    /// The top-level entry `key`.
    pub fn get(&self, key: &str) -> Option<&Node> {
        self.entries.iter().find(|(k, _)| k == key).map(|(_, v)| v)
    }

    /// The top-level keys in file order.
    pub fn keys(&self) -> Vec<String> {
        self.entries.iter().map(|(k, _)| k.clone()).collect()
    }

    /// The `opencv-matrix` at `key` (`None` when the key is absent).
    pub fn matrix(&self, key: &str) -> Result<Option<Matrix>, OpenCvErrorKind> {
        let Some(node) = self.get(key) else {
            return Ok(None);
        };
        matrix_of(key, node).map(Some)
    }
}

pub(super) fn matrix_of(key: &str, node: &Node) -> Result<Matrix, OpenCvErrorKind> {
    let is_matrix = matches!(node, Node::Map { tag: Some(t), .. } if t == "opencv-matrix");
    if !is_matrix {
        return Err(key_error(
            key,
            format!("expected an opencv-matrix, found {}", node.describe()),
        ));
    }
    let count = |field: &str| -> Result<usize, OpenCvErrorKind> {
        let v = node
            .get(field)
            .ok_or_else(|| key_error(key, format!("opencv-matrix without `{field}`")))?;
        match v.number() {
            Some(n) if n >= 0.0 && n.fract() == 0.0 && n <= u32::MAX as f64 => Ok(n as usize),
            _ => Err(key_error(
                key,
                format!(
                    "`{field}` must be a non-negative integer, found {}",
                    v.describe()
                ),
            )),
        }
    };
    let rows = count("rows")?;
    let cols = count("cols")?;
    let dt = match node.get("dt") {
        Some(Node::Scalar { text, .. }) => text.trim().to_string(),
        Some(other) => {
            return Err(key_error(
                key,
                format!("`dt` must be a type letter, found {}", other.describe()),
            ))
        }
        None => return Err(key_error(key, "opencv-matrix without `dt`")),
    };
    let letter = dt.chars().last().unwrap_or(' ');
    let channels = &dt[..dt.len() - letter.len_utf8().min(dt.len())];
    if !"ucwsifd".contains(letter) || !(channels.is_empty() || channels == "1") {
        return Err(key_error(
            key,
            format!("dt = {dt:?}: expected a single-channel type (u, c, w, s, i, f or d)"),
        ));
    }
    let items: Vec<&Node> = match node.get("data") {
        Some(Node::Seq(items)) => items.iter().collect(),
        Some(Node::Scalar { text, .. }) if text.is_empty() => Vec::new(),
        // One value (a 1×1 matrix in XML, or written by hand).
        Some(n @ Node::Scalar { quoted: false, .. }) => vec![n],
        Some(other) => {
            return Err(key_error(
                key,
                format!("`data` must be a sequence, found {}", other.describe()),
            ))
        }
        None => return Err(key_error(key, "opencv-matrix without `data`")),
    };
    let expected = rows.checked_mul(cols);
    if expected != Some(items.len()) {
        return Err(key_error(
            key,
            format!(
                "a {rows}x{cols} opencv-matrix with {} values in `data`",
                items.len()
            ),
        ));
    }
    let mut data = Vec::with_capacity(items.len());
    for (i, item) in items.iter().enumerate() {
        let v = item.number().ok_or_else(|| {
            key_error(
                key,
                format!("entry {i} of `data` is not a number ({})", item.describe()),
            )
        })?;
        data.push(v);
    }
    Ok(Matrix {
        rows,
        cols,
        dt: letter,
        data,
    })
}
