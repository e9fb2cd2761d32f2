//! OpenCV FileStorage calibrations of other structured-light tools: import into a
//! [`Calibration`](crate::Calibration) and export from one.
//!
//! Three key sets, one per tool. Every one of them comes out of OpenCV's `stereoCalibrate`
//! called with the camera as the first device, so its `R`, `T` map camera coordinates to
//! projector coordinates, `X_p = R·X_c + T` — our [`Pose`](crate::pose::Pose) convention — and no inversion is
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
//! elements, whitespace-separated sequences, comments, CDATA, the five entities and character
//! references). The syntax is recognised from the content, not the file name. Nothing in a file
//! can make the reader panic or recurse without bound (nesting is limited to [`MAX_DEPTH`]).
//!
//! | concern | file |
//! |---|---|
//! | the tools' key sets, units, syntaxes, errors | `mod.rs` |
//! | the document tree both syntaxes parse into, its matrices | `document.rs` |
//! | the YAML subset | `yaml.rs` |
//! | the XML subset (through quick-xml) | `xml.rs` |
//! | a document's keys to a [`Calibration`](crate::Calibration) (import) | `read.rs` |
//! | a [`Calibration`](crate::Calibration) to a tool's file (export) | `write.rs` |
//!
//! The XML is tokenized by `quick-xml`, a maintained streaming reader; the tree, the nesting
//! bound and the messages stay ours. The YAML parser is our own: OpenCV's `%YAML:1.0` header is
//! not valid YAML (the maintained YAML crates refuse it, and `serde_yaml` is no longer
//! maintained), and the subset it needs is small enough to bound every input's cost. The fuzz
//! targets check both.

mod document;
mod read;
mod write;
mod xml;
mod yaml;

use std::fmt;
use std::path::Path;

use crate::error::ModelError;

pub use document::{Document, Matrix, Node};
pub use read::{from_bytes, from_text, import_document, read, ImportOptions, Imported};
pub use write::{export_report, format_double, to_text, write};

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
    /// Every unit, in the order of the CLI's `--unit` values.
    pub const ALL: [LengthUnit; 3] = [LengthUnit::Mm, LengthUnit::Cm, LengthUnit::M];

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
        LengthUnit::ALL.into_iter().find(|u| u.name() == name)
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
