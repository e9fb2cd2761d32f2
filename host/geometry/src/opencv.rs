//! OpenCV FileStorage calibrations of other structured-light tools: import into a
//! [`Calibration`] and export from one.
//!
//! Three key sets, one per tool. Every one of them comes out of OpenCV's `stereoCalibrate`
//! called with the camera as the first device, so its `R`, `T` map camera coordinates to
//! projector coordinates, `X_p = R·X_c + T` — our [`Pose`] convention — and no inversion is
//! needed. Intrinsics are OpenCV's `K` (pixel `(0, 0)` centred at `(0, 0)`, our convention too)
//! and distortion is OpenCV's `(k1, k2, p1, p2[, k3])`.
//!
//! | tool | camera `K`, dist | projector `K`, dist | `R`, `T` | sizes in the file | written by the tool as |
//! |---|---|---|---|---|---|
//! | SLStudio | `Kc`, `kc` | `Kp`, `kp` | `Rp`, `Tp` | `frameWidth`, `frameHeight`, `screenResX`, `screenResY` (newer versions; not trusted when 0) | XML, `float` (`dt: f`), `kc`/`kp` 5×1, `Tp` 3×1 |
//! | scan3d-capture (Moreno–Taubin) | `cam_K`, `cam_kc` | `proj_K`, `proj_kc` | `R`, `T` | none | YAML, `double`, `*_kc` 1×5, `T` 3×1, plus `E`, `F` |
//! | procam-calibration (kamino410) | `cam_int`, `cam_dist` | `proj_int`, `proj_dist` | `roration` (sic), `translation` | `img_shape` = camera `(height, width)` | XML, `double`, `*_dist` 1×5, `translation` 3×1 |
//!
//! Units: each tool's `T` is in the unit of the checkerboard square size its user typed.
//! SLStudio builds its target in millimetres; scan3d-capture's corner size is in millimetres
//! (its JSON export divides `T` by 1000 to get metres); procam-calibration takes "mm or cm or m".
//! Import and export therefore take a [`LengthUnit`], millimetres by default.
//!
//! None of the tools stores a measurement volume and not all store image sizes, so
//! [`ImportOptions`] supplies them; a missing one is an error that names what to give.
//!
//! The reader handles the subset of FileStorage that OpenCV writes: YAML (`%YAML:1.0`, which
//! is not valid YAML 1.2 — block and flow maps and sequences, plain and quoted scalars,
//! comments, `!!opencv-matrix` nodes) and XML (`<opencv_storage>`, `type_id="opencv-matrix"`
//! elements, whitespace-separated sequences, comments and the five entities). The syntax is
//! recognised from the content, not the file name. Nothing in a file can make the reader panic
//! or recurse without bound (nesting is limited to [`MAX_DEPTH`]).

use std::fmt;
use std::path::Path;

use nalgebra::{Matrix3, Vector3};

use crate::calibration::Calibration;
use crate::distortion::BrownConrady;
use crate::error::ModelError;
use crate::pinhole::{Intrinsics, Pinhole};
use crate::pose::Pose;
use crate::volume::MeasurementVolume;

/// Deepest nesting of maps and sequences a file may have.
pub const MAX_DEPTH: usize = 64;

/// Largest image side (pixels) accepted from a file's size keys.
const MAX_SIDE_PX: f64 = 1_000_000.0;

// ---------------------------------------------------------------------------------------------
// The tools
// ---------------------------------------------------------------------------------------------

/// The tools whose calibration files are read and written.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Tool {
    /// SLStudio (Wilm et al.): `Kc kc Kp kp Rp Tp`.
    SlStudio,
    /// scan3d-capture (Moreno & Taubin, Brown University): `cam_K cam_kc proj_K proj_kc R T`.
    Scan3dCapture,
    /// procam-calibration (kamino410): `cam_int cam_dist proj_int proj_dist roration
    /// translation`.
    Procam,
}

/// Whether a distortion vector is written as a row (1×5) or a column (5×1).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum VectorLayout {
    Row,
    Column,
}

/// The keys one tool uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct KeySet {
    /// Camera matrix `K`, 3×3.
    pub camera_matrix: &'static str,
    /// Camera distortion, 4 or 5 entries.
    pub camera_distortion: &'static str,
    /// Projector matrix `K`, 3×3.
    pub projector_matrix: &'static str,
    /// Projector distortion, 4 or 5 entries.
    pub projector_distortion: &'static str,
    /// `R`, 3×3, camera to projector.
    pub rotation: &'static str,
    /// `T`, 3 entries, camera to projector.
    pub translation: &'static str,
}

impl Tool {
    /// Every tool, in the order of the CLI's `--format` values.
    pub const ALL: [Tool; 3] = [Tool::SlStudio, Tool::Scan3dCapture, Tool::Procam];

    /// The name used by `--format`: `slstudio`, `scan3d-capture`, `procam`.
    pub fn name(self) -> &'static str {
        match self {
            Tool::SlStudio => "slstudio",
            Tool::Scan3dCapture => "scan3d-capture",
            Tool::Procam => "procam",
        }
    }

    /// The tool of a `--format` name.
    pub fn from_name(name: &str) -> Option<Tool> {
        Tool::ALL.into_iter().find(|t| t.name() == name)
    }

    /// The tool's own name, for messages.
    pub fn display_name(self) -> &'static str {
        match self {
            Tool::SlStudio => "SLStudio",
            Tool::Scan3dCapture => "scan3d-capture",
            Tool::Procam => "procam-calibration",
        }
    }

    /// The six keys of the calibration.
    pub fn keys(self) -> KeySet {
        match self {
            Tool::SlStudio => KeySet {
                camera_matrix: "Kc",
                camera_distortion: "kc",
                projector_matrix: "Kp",
                projector_distortion: "kp",
                rotation: "Rp",
                translation: "Tp",
            },
            Tool::Scan3dCapture => KeySet {
                camera_matrix: "cam_K",
                camera_distortion: "cam_kc",
                projector_matrix: "proj_K",
                projector_distortion: "proj_kc",
                rotation: "R",
                translation: "T",
            },
            Tool::Procam => KeySet {
                camera_matrix: "cam_int",
                camera_distortion: "cam_dist",
                projector_matrix: "proj_int",
                projector_distortion: "proj_dist",
                // The tool's own spelling.
                rotation: "roration",
                translation: "translation",
            },
        }
    }

    /// The syntax the tool itself writes.
    pub fn native_syntax(self) -> Syntax {
        match self {
            Tool::SlStudio | Tool::Procam => Syntax::Xml,
            Tool::Scan3dCapture => Syntax::Yaml,
        }
    }

    fn distortion_layout(self) -> VectorLayout {
        match self {
            // cv::Vec<float, 5> is a 5×1 Matx; SLStudio's loader asserts that shape.
            Tool::SlStudio => VectorLayout::Column,
            // calibrateCamera's distCoeffs, 1×5.
            Tool::Scan3dCapture | Tool::Procam => VectorLayout::Row,
        }
    }
}

impl fmt::Display for Tool {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.display_name())
    }
}

/// The unit of a file's translation (the unit its user gave the checkerboard squares in).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum LengthUnit {
    /// Millimetres (SLStudio, scan3d-capture, and our files).
    #[default]
    Mm,
    /// Centimetres.
    Cm,
    /// Metres.
    M,
}

impl LengthUnit {
    /// Millimetres per unit.
    pub fn mm(self) -> f64 {
        match self {
            LengthUnit::Mm => 1.0,
            LengthUnit::Cm => 10.0,
            LengthUnit::M => 1000.0,
        }
    }

    /// `mm`, `cm` or `m`.
    pub fn name(self) -> &'static str {
        match self {
            LengthUnit::Mm => "mm",
            LengthUnit::Cm => "cm",
            LengthUnit::M => "m",
        }
    }

    /// The unit of a name.
    pub fn from_name(name: &str) -> Option<LengthUnit> {
        [LengthUnit::Mm, LengthUnit::Cm, LengthUnit::M]
            .into_iter()
            .find(|u| u.name() == name)
    }
}

/// FileStorage's two text syntaxes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Syntax {
    /// `%YAML:1.0`.
    Yaml,
    /// `<opencv_storage>`.
    Xml,
}

impl Syntax {
    /// The syntax of an output file name: `.yml`/`.yaml` or `.xml` (OpenCV chooses the same
    /// way).
    pub fn of_path(path: &Path) -> Option<Syntax> {
        let ext = path.extension()?.to_str()?.to_ascii_lowercase();
        match ext.as_str() {
            "yml" | "yaml" => Some(Syntax::Yaml),
            "xml" => Some(Syntax::Xml),
            _ => None,
        }
    }

    /// The syntax of a file's text, from its first characters.
    pub fn of_text(text: &str) -> Option<Syntax> {
        let t = text.trim_start_matches('\u{feff}').trim_start();
        if t.starts_with("%YAML") {
            Some(Syntax::Yaml)
        } else if t.starts_with('<') {
            Some(Syntax::Xml)
        } else {
            None
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Errors
// ---------------------------------------------------------------------------------------------

/// What is wrong with an OpenCV calibration file; the message names the file and the key.
#[derive(Debug)]
pub struct OpenCvError {
    /// The file (or a name given by the caller for text).
    pub source: String,
    /// What is wrong.
    pub kind: OpenCvErrorKind,
}

/// The kinds of [`OpenCvError`].
#[derive(Debug)]
pub enum OpenCvErrorKind {
    /// Reading or writing failed.
    Io(std::io::Error),
    /// Not FileStorage text, or malformed at a line.
    Syntax {
        /// 1-based line (0 when the text has no lines at all).
        line: usize,
        /// What is wrong.
        message: String,
    },
    /// A key of the tool's key set is absent.
    MissingKey {
        /// The key.
        key: &'static str,
        /// The tool whose key set was asked for.
        tool: Tool,
        /// The top-level keys the file has (to spot a wrong `--format`).
        present: Vec<String>,
    },
    /// A key has the wrong type, shape or values.
    Key {
        /// The key.
        key: String,
        /// What is wrong (shape found and expected, which entry).
        message: String,
    },
    /// A value the file does not carry and the options did not give.
    MissingOption {
        /// What is missing and how to give it.
        message: String,
    },
    /// The values break a rule of the model.
    Model {
        /// The keys the values came from.
        keys: String,
        /// The rule.
        error: ModelError,
    },
    /// The output file name does not say YAML or XML.
    OutputName,
}

impl fmt::Display for OpenCvError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: ", self.source)?;
        match &self.kind {
            OpenCvErrorKind::Io(e) => write!(f, "{e}"),
            OpenCvErrorKind::Syntax { line: 0, message } => write!(f, "{message}"),
            OpenCvErrorKind::Syntax { line, message } => write!(f, "line {line}: {message}"),
            OpenCvErrorKind::MissingKey { key, tool, present } => {
                let k = tool.keys();
                write!(
                    f,
                    "key `{key}` is missing (a {tool} calibration has {} {} {} {} {} {}); ",
                    k.camera_matrix,
                    k.camera_distortion,
                    k.projector_matrix,
                    k.projector_distortion,
                    k.rotation,
                    k.translation
                )?;
                if present.is_empty() {
                    write!(f, "the file has no keys")
                } else {
                    const SHOWN: usize = 20;
                    let list: Vec<String> = present
                        .iter()
                        .take(SHOWN)
                        .map(|k| format!("`{k}`"))
                        .collect();
                    let more = if present.len() > SHOWN { ", …" } else { "" };
                    write!(f, "the file has {}{more}", list.join(", "))
                }
            }
            OpenCvErrorKind::Key { key, message } => write!(f, "key `{key}`: {message}"),
            OpenCvErrorKind::MissingOption { message } => write!(f, "{message}"),
            OpenCvErrorKind::Model { keys, error } => write!(f, "keys {keys}: {error}"),
            OpenCvErrorKind::OutputName => write!(
                f,
                "the file name must end in .yml, .yaml or .xml (OpenCV picks the syntax by it)"
            ),
        }
    }
}

impl std::error::Error for OpenCvError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match &self.kind {
            OpenCvErrorKind::Io(e) => Some(e),
            OpenCvErrorKind::Model { error, .. } => Some(error),
            _ => None,
        }
    }
}

/// A syntax error before it is given a file name.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SyntaxError {
    /// 1-based line.
    pub line: usize,
    /// What is wrong.
    pub message: String,
}

impl fmt::Display for SyntaxError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "line {}: {}", self.line, self.message)
    }
}

impl std::error::Error for SyntaxError {}

fn syntax(line: usize, message: impl Into<String>) -> SyntaxError {
    SyntaxError {
        line,
        message: message.into(),
    }
}

// ---------------------------------------------------------------------------------------------
// The document
// ---------------------------------------------------------------------------------------------

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
    fn plain(text: &str) -> Node {
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
    fn describe(&self) -> String {
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

fn parse_number(text: &str) -> Option<f64> {
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

fn key_error(key: &str, message: impl Into<String>) -> OpenCvErrorKind {
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

fn matrix_of(key: &str, node: &Node) -> Result<Matrix, OpenCvErrorKind> {
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

// ---------------------------------------------------------------------------------------------
// YAML subset
// ---------------------------------------------------------------------------------------------

mod yaml {
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
                    Some(next)
                        if next.indent == indent && is_seq_item(&next.text) && tag.is_none() =>
                    {
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
}

// ---------------------------------------------------------------------------------------------
// XML subset
// ---------------------------------------------------------------------------------------------

mod xml {
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
}

// ---------------------------------------------------------------------------------------------
// Writing
// ---------------------------------------------------------------------------------------------

/// A number as OpenCV writes a double: integers as `640.`, others as `%.16e` (exact for f64).
pub fn format_double(v: f64) -> String {
    if v.is_nan() {
        return ".Nan".into();
    }
    if v.is_infinite() {
        return if v > 0.0 {
            ".Inf".into()
        } else {
            "-.Inf".into()
        };
    }
    if v.fract() == 0.0 && v.abs() < 2_147_483_648.0 {
        let sign = if v.is_sign_negative() && v == 0.0 {
            "-"
        } else {
            ""
        };
        return format!("{sign}{}.", v as i64);
    }
    let s = format!("{v:.16e}");
    let (mantissa, exponent) = s.split_once('e').unwrap_or((&s, "0"));
    let e: i32 = exponent.parse().unwrap_or(0);
    let sign = if e < 0 { '-' } else { '+' };
    format!("{mantissa}e{sign}{:02}", e.abs())
}

enum Value {
    Int(i64),
    Matrix {
        rows: usize,
        cols: usize,
        data: Vec<f64>,
    },
}

struct Writer {
    syntax: Syntax,
    out: String,
}

impl Writer {
    fn new(syntax: Syntax, comment: &[String]) -> Writer {
        let mut out = String::new();
        match syntax {
            Syntax::Yaml => {
                out.push_str("%YAML:1.0\n---\n");
                for line in comment {
                    out.push_str(&format!("# {line}\n"));
                }
            }
            Syntax::Xml => {
                out.push_str("<?xml version=\"1.0\"?>\n");
                if !comment.is_empty() {
                    out.push_str("<!--\n");
                    for line in comment {
                        // `--` may not appear inside an XML comment.
                        out.push_str(&format!("  {}\n", line.replace("--", "-")));
                    }
                    out.push_str("-->\n");
                }
                out.push_str("<opencv_storage>\n");
            }
        }
        Writer { syntax, out }
    }

    fn entry(&mut self, key: &str, value: &Value) {
        match (self.syntax, value) {
            (Syntax::Yaml, Value::Int(v)) => self.out.push_str(&format!("{key}: {v}\n")),
            (Syntax::Xml, Value::Int(v)) => self.out.push_str(&format!("<{key}>{v}</{key}>\n")),
            (Syntax::Yaml, Value::Matrix { rows, cols, data }) => {
                self.out.push_str(&format!(
                    "{key}: !!opencv-matrix\n   rows: {rows}\n   cols: {cols}\n   dt: d\n   data: [ "
                ));
                let items: Vec<String> = data.iter().map(|v| format_double(*v)).collect();
                for (i, chunk) in items.chunks(3).enumerate() {
                    if i > 0 {
                        self.out.push_str(",\n       ");
                    }
                    self.out.push_str(&chunk.join(", "));
                }
                self.out.push_str(" ]\n");
            }
            (Syntax::Xml, Value::Matrix { rows, cols, data }) => {
                self.out.push_str(&format!(
                    "<{key} type_id=\"opencv-matrix\">\n  <rows>{rows}</rows>\n  <cols>{cols}</cols>\n  <dt>d</dt>\n  <data>"
                ));
                let items: Vec<String> = data.iter().map(|v| format_double(*v)).collect();
                for chunk in items.chunks(3) {
                    self.out.push_str("\n    ");
                    self.out.push_str(&chunk.join(" "));
                }
                self.out.push_str(&format!("</data></{key}>\n"));
            }
        }
    }

    fn finish(mut self) -> String {
        if self.syntax == Syntax::Xml {
            self.out.push_str("</opencv_storage>\n");
        }
        self.out
    }
}

fn k_matrix(p: &Pinhole) -> Value {
    let k = p.intrinsics();
    Value::Matrix {
        rows: 3,
        cols: 3,
        data: vec![k.fx_px, 0.0, k.cx_px, 0.0, k.fy_px, k.cy_px, 0.0, 0.0, 1.0],
    }
}

fn vector(data: Vec<f64>, layout: VectorLayout) -> Value {
    let n = data.len();
    let (rows, cols) = match layout {
        VectorLayout::Row => (1, n),
        VectorLayout::Column => (n, 1),
    };
    Value::Matrix { rows, cols, data }
}

fn cross_matrix(t: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, -t.z, t.y, t.z, 0.0, -t.x, -t.y, t.x, 0.0)
}

fn k_of(p: &Pinhole) -> Matrix3<f64> {
    let k = p.intrinsics();
    Matrix3::new(k.fx_px, 0.0, k.cx_px, 0.0, k.fy_px, k.cy_px, 0.0, 0.0, 1.0)
}

fn row_major(m: &Matrix3<f64>) -> Vec<f64> {
    (0..3)
        .flat_map(|i| (0..3).map(move |j| (i, j)))
        .map(|(i, j)| m[(i, j)])
        .collect()
}

/// The calibration as the text of `tool`'s file in `syntax`, the translation in `unit`.
///
/// Beside the six keys, each file gets what its tool reads or writes besides: SLStudio's
/// `frameWidth frameHeight screenResX screenResY`; scan3d-capture's `E` and `F` (its loader
/// counts a file without them as invalid), computed from the pose and intrinsics; procam's
/// `img_shape` (camera height, width). Numbers are written as doubles (`dt: d`) with 17
/// significant digits, so reading the file back gives the same numbers; SLStudio converts
/// them to its `float` matrices on loading. A comment at the top gives the sizes and the
/// measurement volume that the file cannot carry.
pub fn to_text(calibration: &Calibration, tool: Tool, syntax: Syntax, unit: LengthUnit) -> String {
    let keys = tool.keys();
    let c = calibration;
    let layout = tool.distortion_layout();
    let r = *c.pose.rotation().matrix();
    let t_mm = *c.pose.translation_mm();
    let t = t_mm / unit.mm();
    let mut comment = vec![
        format!(
            "{} calibration written by fsm calibrate export.",
            tool.display_name()
        ),
        format!(
            "Pose: X_p = {} X_c + {} (camera to projector), {} in {}.",
            keys.rotation,
            keys.translation,
            keys.translation,
            unit.name()
        ),
    ];
    // What the tool's file cannot carry, and the import options that restore it.
    let camera = format!("{}x{}", c.camera.width_px(), c.camera.height_px());
    let projector = format!("{}x{}", c.projector.width_px(), c.projector.height_px());
    let mut missing = Vec::new();
    let mut options = Vec::new();
    if tool == Tool::Scan3dCapture {
        missing.push(format!("camera {camera} px"));
        options.push(format!("--camera-size {camera}"));
    }
    if tool != Tool::SlStudio {
        missing.push(format!("projector {projector} (columns x rows)"));
        options.push(format!("--projector-size {projector}"));
    }
    missing.push(format!(
        "measurement volume {}..{} mm",
        c.volume.near_mm(),
        c.volume.far_mm()
    ));
    options.push(format!(
        "--near-mm {} --far-mm {} --unit {}",
        c.volume.near_mm(),
        c.volume.far_mm(),
        unit.name()
    ));
    comment.push(format!("Not in this file: {}.", missing.join(", ")));
    // (An XML comment may not contain `--`.)
    if syntax == Syntax::Yaml {
        comment.push(format!(
            "Import: fsm calibrate import --format {} {}",
            tool.name(),
            options.join(" ")
        ));
    }
    let mut w = Writer::new(syntax, &comment);
    if tool == Tool::Procam {
        w.entry(
            "img_shape",
            &Value::Matrix {
                rows: 2,
                cols: 1,
                data: vec![c.camera.height_px() as f64, c.camera.width_px() as f64],
            },
        );
    }
    w.entry(keys.camera_matrix, &k_matrix(&c.camera));
    w.entry(
        keys.camera_distortion,
        &vector(c.camera.distortion().to_opencv().to_vec(), layout),
    );
    w.entry(keys.projector_matrix, &k_matrix(&c.projector));
    w.entry(
        keys.projector_distortion,
        &vector(c.projector.distortion().to_opencv().to_vec(), layout),
    );
    w.entry(
        keys.rotation,
        &Value::Matrix {
            rows: 3,
            cols: 3,
            data: row_major(&r),
        },
    );
    w.entry(
        keys.translation,
        &vector(vec![t.x, t.y, t.z], VectorLayout::Column),
    );
    match tool {
        Tool::SlStudio => {
            w.entry("frameWidth", &Value::Int(c.camera.width_px() as i64));
            w.entry("frameHeight", &Value::Int(c.camera.height_px() as i64));
            w.entry("screenResX", &Value::Int(c.projector.width_px() as i64));
            w.entry("screenResY", &Value::Int(c.projector.height_px() as i64));
        }
        Tool::Scan3dCapture => {
            let e = cross_matrix(&t) * r;
            let kp_inv = k_of(&c.projector)
                .try_inverse()
                .unwrap_or_else(Matrix3::zeros);
            let kc_inv = k_of(&c.camera).try_inverse().unwrap_or_else(Matrix3::zeros);
            let f = kp_inv.transpose() * e * kc_inv;
            for (key, m) in [("E", e), ("F", f)] {
                w.entry(
                    key,
                    &Value::Matrix {
                        rows: 3,
                        cols: 3,
                        data: row_major(&m),
                    },
                );
            }
        }
        Tool::Procam => {}
    }
    w.finish()
}

/// Writes `tool`'s file whole or not at all (the workspace's one atomic writer,
/// [`fsm_io::outputs::write_file`]); the syntax follows the extension (`.yml`, `.yaml`, `.xml`).
pub fn write(
    calibration: &Calibration,
    tool: Tool,
    path: &Path,
    unit: LengthUnit,
) -> Result<(), OpenCvError> {
    let err = |kind| OpenCvError {
        source: path.display().to_string(),
        kind,
    };
    let syntax = Syntax::of_path(path).ok_or_else(|| err(OpenCvErrorKind::OutputName))?;
    let text = to_text(calibration, tool, syntax, unit);
    fsm_io::outputs::write_file(path, text.as_bytes())
        .map_err(|e| err(OpenCvErrorKind::Io(e.into_io_error())))
}

// ---------------------------------------------------------------------------------------------
// Reading
// ---------------------------------------------------------------------------------------------

/// What an import needs beyond the file.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ImportOptions {
    /// Camera image `(width, height)`, pixels. Required unless the file has it (SLStudio's
    /// `frameWidth`/`frameHeight`, procam's `img_shape`); when both are there, this wins and
    /// a note says they disagree.
    pub camera_size: Option<(u32, u32)>,
    /// Projector `(columns, rows)`. Required unless the file has it (SLStudio's
    /// `screenResX`/`screenResY`); when both are there, this wins (with a note).
    pub projector_size: Option<(u32, u32)>,
    /// Nearest depth of the measurement volume, mm (camera `z`). Required.
    pub near_mm: Option<f64>,
    /// Farthest depth, mm. Required.
    pub far_mm: Option<f64>,
    /// The unit of the file's translation.
    pub unit: LengthUnit,
}

/// An imported calibration and what was taken from where.
#[derive(Clone, Debug, PartialEq)]
pub struct Imported {
    /// The calibration.
    pub calibration: Calibration,
    /// One line per value that did not come from the six keys (sizes, volume, unit).
    pub notes: Vec<String>,
}

/// A 3×3 camera matrix without skew: `[fx 0 cx; 0 fy cy; 0 0 1]`.
fn intrinsics_of(key: &str, m: &Matrix) -> Result<Intrinsics, OpenCvErrorKind> {
    if (m.rows, m.cols) != (3, 3) {
        return Err(key_error(
            key,
            format!("expected a 3x3 camera matrix, found {}", m.shape()),
        ));
    }
    let fx = m.at(0, 0);
    let skew = m.at(0, 1);
    // OpenCV never estimates skew; a tool-written K has an exact 0 there.
    if skew.abs() > 1e-9 * fx.abs().max(1.0) || !skew.is_finite() {
        return Err(key_error(
            key,
            format!("skew K[0][1] = {skew}: the model has no skew (must be 0)"),
        ));
    }
    for (r, c, want) in [(1, 0, 0.0), (2, 0, 0.0), (2, 1, 0.0), (2, 2, 1.0)] {
        let v = m.at(r, c);
        if (v - want).abs() > 1e-12 || !v.is_finite() {
            return Err(key_error(
                key,
                format!("K[{r}][{c}] = {v}: a camera matrix has {want} there"),
            ));
        }
    }
    Ok(Intrinsics {
        fx_px: fx,
        fy_px: m.at(1, 1),
        cx_px: m.at(0, 2),
        cy_px: m.at(1, 2),
    })
}

/// The entries of a 1×n or n×1 matrix.
fn vector_of<'m>(key: &str, m: &'m Matrix, what: &str) -> Result<&'m [f64], OpenCvErrorKind> {
    if m.rows != 1 && m.cols != 1 {
        return Err(key_error(
            key,
            format!("expected {what} (1xN or Nx1), found a {} matrix", m.shape()),
        ));
    }
    Ok(&m.data)
}

/// OpenCV's distortion vector `(k1, k2, p1, p2[, k3[, k4, k5, k6[, s1..s4[, τx, τy]]]])`: 4 or 5
/// entries, or 8/12/14 with the terms beyond k3 all zero.
fn distortion_of(key: &str, m: &Matrix) -> Result<BrownConrady, OpenCvErrorKind> {
    let v = vector_of(key, m, "a distortion vector")?;
    let names = [
        "k1", "k2", "p1", "p2", "k3", "k4", "k5", "k6", "s1", "s2", "s3", "s4", "tau_x", "tau_y",
    ];
    match v.len() {
        4 | 5 => {}
        8 | 12 | 14 => {
            let extra: Vec<String> = v[5..]
                .iter()
                .zip(&names[5..])
                .filter(|(x, _)| **x != 0.0)
                .map(|(x, n)| format!("{n} = {x}"))
                .collect();
            if !extra.is_empty() {
                return Err(key_error(
                    key,
                    format!(
                        "a {} distortion vector with non-zero terms beyond (k1, k2, p1, p2, k3): {}; the model is Brown-Conrady with 5 coefficients",
                        m.shape(),
                        extra.join(", ")
                    ),
                ));
            }
        }
        n => {
            return Err(key_error(
                key,
                format!(
                    "a {} distortion vector ({n} entries): expected 4 or 5 (k1, k2, p1, p2[, k3])",
                    m.shape()
                ),
            ))
        }
    }
    let mut c = [0.0; 5];
    for (dst, src) in c.iter_mut().zip(v) {
        *dst = *src;
    }
    Ok(BrownConrady::from_opencv(c))
}

fn required_matrix(
    doc: &Document,
    tool: Tool,
    key: &'static str,
) -> Result<Matrix, OpenCvErrorKind> {
    doc.matrix(key)?.ok_or_else(|| OpenCvErrorKind::MissingKey {
        key,
        tool,
        present: doc.keys(),
    })
}

/// A positive integer size key, `None` when absent or 0 (SLStudio's "unknown").
fn size_key(doc: &Document, key: &str) -> Result<Option<u32>, OpenCvErrorKind> {
    let Some(node) = doc.get(key) else {
        return Ok(None);
    };
    match node.number() {
        // 0 is SLStudio's "not known"; some versions leave the fields uninitialised, so a
        // negative or absurd number is not trusted either.
        Some(v) if v <= 0.0 || v > MAX_SIDE_PX => Ok(None),
        Some(v) if v.fract() == 0.0 => Ok(Some(v as u32)),
        _ => Err(key_error(
            key,
            format!(
                "expected an image size in pixels, found {}",
                node.describe()
            ),
        )),
    }
}

/// The sizes a tool's file states: camera `(width, height)` and projector `(columns, rows)`,
/// with the keys they came from.
type FileSize = Option<((u32, u32), &'static str)>;

fn file_sizes(doc: &Document, tool: Tool) -> Result<(FileSize, FileSize), OpenCvErrorKind> {
    match tool {
        Tool::SlStudio => {
            let pair = |a: &'static str, b: &'static str, keys: &'static str| {
                Ok::<_, OpenCvErrorKind>(match (size_key(doc, a)?, size_key(doc, b)?) {
                    (Some(w), Some(h)) => Some(((w, h), keys)),
                    _ => None,
                })
            };
            Ok((
                pair("frameWidth", "frameHeight", "`frameWidth`, `frameHeight`")?,
                pair("screenResX", "screenResY", "`screenResX`, `screenResY`")?,
            ))
        }
        Tool::Procam => {
            let camera = match doc.get("img_shape") {
                None => None,
                Some(node) => {
                    // A numpy shape written by cv2.FileStorage: a 2x1 (or 1x2, or 3 entries
                    // for a colour image) matrix, or a plain sequence.
                    let values: Vec<f64> = match node {
                        Node::Seq(items) => items.iter().filter_map(Node::number).collect(),
                        _ => {
                            let m = matrix_of("img_shape", node)?;
                            vector_of("img_shape", &m, "the image shape (height, width)")?.to_vec()
                        }
                    };
                    let ok = |v: f64| v.fract() == 0.0 && (1.0..=MAX_SIDE_PX).contains(&v);
                    if !(values.len() == 2 || values.len() == 3) || !ok(values[0]) || !ok(values[1])
                    {
                        return Err(key_error(
                            "img_shape",
                            format!(
                                "expected the camera image shape (height, width), found {:?}",
                                values
                            ),
                        ));
                    }
                    Some(((values[1] as u32, values[0] as u32), "`img_shape`"))
                }
            };
            Ok((camera, None))
        }
        Tool::Scan3dCapture => Ok((None, None)),
    }
}

fn choose_size(
    what: &str,
    option: &str,
    given: Option<(u32, u32)>,
    in_file: FileSize,
    tool: Tool,
    notes: &mut Vec<String>,
) -> Result<(u32, u32), OpenCvErrorKind> {
    match (given, in_file) {
        (Some(g), _) if g.0 == 0 || g.1 == 0 => Err(OpenCvErrorKind::MissingOption {
            message: format!("{option} {}x{}: sizes must be at least 1", g.0, g.1),
        }),
        (Some(g), Some((f, keys))) if g != f => {
            notes.push(format!(
                "warning: {what} {}x{} from {option} overrides {keys} = {}x{} in the file",
                g.0, g.1, f.0, f.1
            ));
            Ok(g)
        }
        (Some(g), _) => {
            notes.push(format!("{what} {}x{} from {option}", g.0, g.1));
            Ok(g)
        }
        (None, Some((f, keys))) => {
            notes.push(format!("{what} {}x{} from {keys}", f.0, f.1));
            Ok(f)
        }
        (None, None) => Err(OpenCvErrorKind::MissingOption {
            message: format!(
                "{tool} files do not give the {what}: give {option} (e.g. {option} 1280x1024)"
            ),
        }),
    }
}

/// Builds our calibration from a parsed file of `tool`.
pub fn import_document(
    doc: &Document,
    tool: Tool,
    options: &ImportOptions,
) -> Result<Imported, OpenCvErrorKind> {
    let keys = tool.keys();
    let kc = required_matrix(doc, tool, keys.camera_matrix)?;
    let dc = required_matrix(doc, tool, keys.camera_distortion)?;
    let kp = required_matrix(doc, tool, keys.projector_matrix)?;
    let dp = required_matrix(doc, tool, keys.projector_distortion)?;
    let r = required_matrix(doc, tool, keys.rotation)?;
    let t = required_matrix(doc, tool, keys.translation)?;

    let camera_k = intrinsics_of(keys.camera_matrix, &kc)?;
    let camera_d = distortion_of(keys.camera_distortion, &dc)?;
    let projector_k = intrinsics_of(keys.projector_matrix, &kp)?;
    let projector_d = distortion_of(keys.projector_distortion, &dp)?;
    if (r.rows, r.cols) != (3, 3) {
        return Err(key_error(
            keys.rotation,
            format!("expected a 3x3 rotation matrix, found {}", r.shape()),
        ));
    }
    let tv = vector_of(keys.translation, &t, "a translation vector")?;
    if tv.len() != 3 {
        return Err(key_error(
            keys.translation,
            format!(
                "expected a translation of 3 entries (3x1), found {}",
                t.shape()
            ),
        ));
    }

    let mut notes = Vec::new();
    let (camera_in_file, projector_in_file) = file_sizes(doc, tool)?;
    let (cw, ch) = choose_size(
        "camera image size (width x height)",
        "--camera-size",
        options.camera_size,
        camera_in_file,
        tool,
        &mut notes,
    )?;
    let (pw, ph) = choose_size(
        "projector size (columns x rows)",
        "--projector-size",
        options.projector_size,
        projector_in_file,
        tool,
        &mut notes,
    )?;
    let (near, far) = match (options.near_mm, options.far_mm) {
        (Some(n), Some(f)) => (n, f),
        _ => {
            return Err(OpenCvErrorKind::MissingOption {
                message: format!(
                    "{tool} files have no measurement volume: give --near-mm and --far-mm (depth limits along the camera's z axis)"
                ),
            })
        }
    };
    notes.push(format!(
        "measurement volume {near}..{far} mm from --near-mm, --far-mm"
    ));
    notes.push(format!(
        "`{}` read in {} (--unit {})",
        keys.translation,
        options.unit.name(),
        options.unit.name()
    ));

    let model = |keys: String| move |error| OpenCvErrorKind::Model { keys, error };
    let camera = Pinhole::new("camera", cw, ch, camera_k, camera_d).map_err(model(format!(
        "`{}`, `{}`",
        keys.camera_matrix, keys.camera_distortion
    )))?;
    let projector =
        Pinhole::new("projector", pw, ph, projector_k, projector_d).map_err(model(format!(
            "`{}`, `{}`",
            keys.projector_matrix, keys.projector_distortion
        )))?;
    let scale = options.unit.mm();
    let pose = Pose::new(
        Matrix3::from_fn(|i, j| r.at(i, j)),
        Vector3::new(tv[0] * scale, tv[1] * scale, tv[2] * scale),
    )
    .map_err(model(format!(
        "`{}`, `{}`",
        keys.rotation, keys.translation
    )))?;
    let volume =
        MeasurementVolume::new(near, far).map_err(model("--near-mm, --far-mm".to_string()))?;
    Ok(Imported {
        calibration: Calibration {
            camera,
            projector,
            pose,
            volume,
        },
        notes,
    })
}

/// Parses and imports the text of `tool`'s file; `source` names it in errors.
pub fn from_text(
    text: &str,
    source: &str,
    tool: Tool,
    options: &ImportOptions,
) -> Result<Imported, OpenCvError> {
    let err = |kind| OpenCvError {
        source: source.to_string(),
        kind,
    };
    let doc = Document::parse(text).map_err(|e| {
        err(OpenCvErrorKind::Syntax {
            line: e.line,
            message: e.message,
        })
    })?;
    import_document(&doc, tool, options).map_err(err)
}

/// Reads `tool`'s file (YAML or XML, whatever its name).
pub fn read(path: &Path, tool: Tool, options: &ImportOptions) -> Result<Imported, OpenCvError> {
    let source = path.display().to_string();
    let bytes = std::fs::read(path).map_err(|e| OpenCvError {
        source: source.clone(),
        kind: OpenCvErrorKind::Io(e),
    })?;
    from_bytes(&bytes, &source, tool, options)
}

/// Parses and imports the bytes of `tool`'s file (UTF-8 text, YAML or XML), as [`read`] does
/// a file's; `source` names it in errors.
pub fn from_bytes(
    bytes: &[u8],
    source: &str,
    tool: Tool,
    options: &ImportOptions,
) -> Result<Imported, OpenCvError> {
    let text = std::str::from_utf8(bytes).map_err(|e| OpenCvError {
        source: source.to_string(),
        kind: OpenCvErrorKind::Syntax {
            line: bytes[..e.valid_up_to()]
                .iter()
                .filter(|b| **b == b'\n')
                .count()
                + 1,
            message: format!(
                "not UTF-8 text (invalid byte at offset {})",
                e.valid_up_to()
            ),
        },
    })?;
    from_text(text, source, tool, options)
}
