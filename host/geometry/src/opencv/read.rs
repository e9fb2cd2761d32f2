//! Import: a tool's keys in a parsed document to a [`Calibration`], with the sizes and
//! the measurement volume the file does not hold.

use std::path::Path;

use nalgebra::{Matrix3, Vector3};

use super::document::{key_error, matrix_of, Document, Matrix, Node};
use super::{LengthUnit, OpenCvError, OpenCvErrorKind, Tool, MAX_SIDE_PX};
use crate::calibration::Calibration;
use crate::distortion::BrownConrady;
use crate::pinhole::{Intrinsics, Pinhole};
use crate::pose::Pose;
use crate::volume::MeasurementVolume;

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

impl Imported {
    /// What `fsm calibrate import` says once the calibration read from `tool`'s file `input`
    /// is written to `out`: each note, then `wrote OUT: TOOL calibration from INPUT; SUMMARY`
    /// ([`Calibration::summary`]). Made here, with the notes it follows.
    pub fn report(&self, tool: Tool, input: &Path, out: &Path) -> String {
        let mut lines = self.notes.clone();
        lines.push(format!(
            "wrote {}: {tool} calibration from {}; {}",
            out.display(),
            input.display(),
            self.calibration.summary()
        ));
        lines.join("\n")
    }
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
