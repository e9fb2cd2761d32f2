//! Export: a [`Calibration`] as a tool's FileStorage file, numbers as OpenCV writes them.

use std::path::Path;

use nalgebra::{Matrix3, Vector3};

use super::{LengthUnit, OpenCvError, OpenCvErrorKind, Syntax, Tool, VectorLayout};
use crate::calibration::Calibration;
use crate::pinhole::Pinhole;

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

/// What `fsm calibrate export` says once `tool`'s file `out` is written from our calibration
/// file `source`: a note when the tool cannot load the syntax chosen (SLStudio loads only
/// XML), then `wrote OUT: TOOL calibration (translation in UNIT) from SOURCE`. Made here, where
/// the tools' syntaxes are known.
pub fn export_report(tool: Tool, unit: LengthUnit, out: &Path, source: &Path) -> String {
    let note = match Syntax::of_path(out) {
        Some(Syntax::Yaml) if tool == Tool::SlStudio => {
            "note: SLStudio loads only .xml calibration files\n"
        }
        _ => "",
    };
    format!(
        "{note}wrote {}: {tool} calibration (translation in {}) from {}",
        out.display(),
        unit.name(),
        source.display()
    )
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
