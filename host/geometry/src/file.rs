//! The calibration file (SPEC §5–§6): TOML, versioned, millimetres and pixels, with a CRC-32 of
//! the numbers.
//!
//! ```toml
//! format = "fsm-calibration"
//! version = 1
//! checksum_crc32 = "1a2b3c4d"        # optional on input; see below
//!
//! [camera]                            # pixel (0, 0) has its centre at (0, 0) (OpenCV)
//! width_px = 320
//! height_px = 240
//! fx_px = 640.0
//! fy_px = 640.0
//! cx_px = 159.5
//! cy_px = 119.5
//! distortion = [-0.05, 0.02, 0.0, 0.0, 0.0]   # OpenCV order: k1, k2, p1, p2, k3
//!
//! [projector]                         # an inverse camera: width_px is cmax (columns)
//! width_px = 768
//! height_px = 1024
//! # … same keys as [camera]
//!
//! [pose]                              # X_p = R·X_c + t (camera frame to projector frame)
//! rotation = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]   # rows of R
//! translation_mm = [-200.0, 0.0, 0.0]
//!
//! [volume]                            # depth limits along the camera's z axis
//! near_mm = 350.0
//! far_mm = 700.0
//!
//! [projector_response]                # optional: light = code^gamma (fsm calibrate response)
//! gamma = 2.2                         # or a measured table:
//! # input = [0.0, 0.25, 0.5, 0.75, 1.0]   codes, fractions of full scale, 0 to 1, increasing
//! # output = [0.0, 0.05, 0.22, 0.53, 1.0] light, any unit, increasing
//! ```
//!
//! The `[projector_response]` section ([`ProjectorResponseSection`], read and written with
//! [`CalibrationFile`]) is optional and came after the first files: a file without it reads as
//! before and means the same, and its checksum is unchanged (the section's numbers are appended
//! to the checksummed numbers only when it is present), so it stays version 1. An older build
//! refuses a file with the section, naming the key `projector_response`. The geometry-only API
//! ([`Calibration::read`], [`Calibration::from_toml`]) checks the section and ignores it;
//! [`Calibration::write`] writes no section, so rewrite a file that has one with
//! [`CalibrationFile::write`].
//!
//! The model and parameter order are OpenCV's (`cameraMatrix`, `distCoeffs` with 5 entries,
//! `stereoCalibrate`'s `R`, `T` with the camera first), so an OpenCV calibration maps onto the
//! file field by field.
//!
//! Integrity: `checksum_crc32` is the CRC-32 (ISO-HDLC) of the numbers as little-endian `f64`
//! in the order of [`Calibration::checksum`], not of the text, so reformatting the file keeps it
//! valid while a changed digit is caught. Writers always write it; a reader rejects a file
//! whose checksum does not match, and accepts a file without one (a hand-made calibration).
//! Every number is validated on reading, and the error names the file and the field. Files are
//! written whole or not at all (temporary name, then rename).

use std::fmt;
use std::path::Path;

use fsm_io::projector_response::ProjectorResponse;
use nalgebra::{Matrix3, Vector3};
use serde::{Deserialize, Serialize};

use crate::calibration::Calibration;
use crate::distortion::BrownConrady;
use crate::error::ModelError;
use crate::pinhole::{Intrinsics, Pinhole};
use crate::pose::Pose;
use crate::volume::MeasurementVolume;

/// The `format` key of every calibration file.
pub const FORMAT: &str = "fsm-calibration";
/// The version this build writes and reads.
pub const VERSION: u32 = 1;

/// What is wrong with a calibration file; the message names the file.
#[derive(Debug)]
pub struct CalibrationFileError {
    /// The file (or `"<text>"` for a string).
    pub source: String,
    /// What is wrong.
    pub kind: CalibrationFileErrorKind,
}

/// The kinds of [`CalibrationFileError`].
#[derive(Debug)]
pub enum CalibrationFileErrorKind {
    /// Reading or writing failed.
    Io(std::io::Error),
    /// Not TOML, a missing or misspelt key, a value of the wrong type (the message has the line
    /// and the key).
    Syntax(String),
    /// `format` is missing or is not `"fsm-calibration"`.
    Format(Option<String>),
    /// A version this build does not read.
    Version(Option<i64>),
    /// A value breaks a rule of the model.
    Model(ModelError),
    /// The `[projector_response]` section breaks a rule (the message names the field).
    ProjectorResponse(String),
    /// The numbers do not match the stored checksum.
    Checksum {
        /// Stored in the file.
        stored: String,
        /// Computed from the numbers read.
        computed: String,
    },
}

impl fmt::Display for CalibrationFileError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "calibration file {}: ", self.source)?;
        match &self.kind {
            CalibrationFileErrorKind::Io(e) => write!(f, "{e}"),
            CalibrationFileErrorKind::Syntax(e) => write!(f, "{}", e.trim_end()),
            CalibrationFileErrorKind::Format(None) => {
                write!(f, "key `format` is missing: not an {FORMAT} file")
            }
            CalibrationFileErrorKind::Format(Some(found)) => {
                write!(f, "format = {found:?}: expected {FORMAT:?}")
            }
            CalibrationFileErrorKind::Version(None) => {
                write!(f, "key `version` is missing or not an integer")
            }
            CalibrationFileErrorKind::Version(Some(v)) => write!(
                f,
                "version = {v}: this build reads version {VERSION}"
            ),
            CalibrationFileErrorKind::Model(e) => write!(f, "{e}"),
            CalibrationFileErrorKind::ProjectorResponse(e) => write!(f, "{e}"),
            CalibrationFileErrorKind::Checksum { stored, computed } => write!(
                f,
                "checksum_crc32 = {stored:?} but the numbers give {computed:?}: the file was corrupted or edited (remove checksum_crc32 if the edit was deliberate)"
            ),
        }
    }
}

impl std::error::Error for CalibrationFileError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match &self.kind {
            CalibrationFileErrorKind::Io(e) => Some(e),
            CalibrationFileErrorKind::Model(e) => Some(e),
            _ => None,
        }
    }
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct FileV1 {
    format: String,
    version: u32,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    checksum_crc32: Option<String>,
    camera: DeviceV1,
    projector: DeviceV1,
    pose: PoseV1,
    volume: VolumeV1,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    projector_response: Option<ResponseV1>,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct ResponseV1 {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    gamma: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    input: Option<Vec<f64>>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    output: Option<Vec<f64>>,
}

/// The projector's intensity response (light out for code in), the optional
/// `[projector_response]` section of a calibration file: what `fsm patterns` pre-corrects the
/// fringe codes with. Codes are fractions of full scale.
#[derive(Clone, Debug, PartialEq)]
pub enum ProjectorResponseSection {
    /// `light = code^gamma`, `gamma` in `0.1..=10`.
    Gamma(f64),
    /// A measured table, interpolated linearly: `input` codes strictly increasing from exactly
    /// 0 to exactly 1, `output` light in any unit, strictly increasing, same length (≥ 2).
    Table {
        /// Codes.
        input: Vec<f64>,
        /// Light.
        output: Vec<f64>,
    },
}

impl From<&ProjectorResponse> for ProjectorResponseSection {
    fn from(response: &ProjectorResponse) -> ProjectorResponseSection {
        match response {
            ProjectorResponse::Gamma(g) => ProjectorResponseSection::Gamma(*g),
            ProjectorResponse::Table(points) => ProjectorResponseSection::Table {
                input: points.iter().map(|p| p.0).collect(),
                output: points.iter().map(|p| p.1).collect(),
            },
        }
    }
}

impl ProjectorResponseSection {
    /// The response the section describes (what `fsm patterns --calibration` pre-corrects
    /// for); the message names the field.
    pub fn response(&self) -> Result<ProjectorResponse, String> {
        match self {
            ProjectorResponseSection::Gamma(g) => ProjectorResponse::from_gamma(*g),
            ProjectorResponseSection::Table { input, output } => {
                ProjectorResponse::from_table(input, output)
            }
        }
        .map_err(|e| format!("projector_response: {e}"))
    }

    /// Checks the rules; the message names the field (`projector_response.gamma`, …).
    pub fn validate(&self) -> Result<(), String> {
        match self {
            ProjectorResponseSection::Gamma(g) => {
                if g.is_finite() && (0.1..=10.0).contains(g) {
                    Ok(())
                } else {
                    Err(format!(
                        "projector_response.gamma = {g}: must lie in 0.1..=10"
                    ))
                }
            }
            ProjectorResponseSection::Table { input, output } => {
                if input.len() != output.len() || input.len() < 2 {
                    return Err(format!(
                        "projector_response.input ({} values) and projector_response.output ({} values) must have the same length, at least 2",
                        input.len(),
                        output.len()
                    ));
                }
                if input[0] != 0.0 || input[input.len() - 1] != 1.0 {
                    return Err(format!(
                        "projector_response.input runs from {} to {}: it must run from 0 to 1 (fractions of the full code)",
                        input[0],
                        input[input.len() - 1]
                    ));
                }
                for (name, values) in [("input", input), ("output", output)] {
                    if let Some((i, v)) = values.iter().enumerate().find(|(_, v)| !v.is_finite()) {
                        return Err(format!(
                            "projector_response.{name}: entry {i} = {v} is not finite"
                        ));
                    }
                    for (i, w) in values.windows(2).enumerate() {
                        if w[1] <= w[0] {
                            return Err(format!(
                                "projector_response.{name}: values must be strictly increasing (entry {} = {} after {})",
                                i + 1,
                                w[1],
                                w[0]
                            ));
                        }
                    }
                }
                Ok(())
            }
        }
    }

    fn of(r: &ResponseV1) -> Result<Self, String> {
        let section = match (&r.gamma, &r.input, &r.output) {
            (Some(g), None, None) => ProjectorResponseSection::Gamma(*g),
            (None, Some(input), Some(output)) => ProjectorResponseSection::Table {
                input: input.clone(),
                output: output.clone(),
            },
            _ => {
                return Err(
                    "[projector_response]: give either gamma, or both input and output".into(),
                )
            }
        };
        section.validate()?;
        Ok(section)
    }

    fn to_v1(&self) -> ResponseV1 {
        match self {
            ProjectorResponseSection::Gamma(g) => ResponseV1 {
                gamma: Some(*g),
                input: None,
                output: None,
            },
            ProjectorResponseSection::Table { input, output } => ResponseV1 {
                gamma: None,
                input: Some(input.clone()),
                output: Some(output.clone()),
            },
        }
    }
}

/// Everything a calibration file holds: the geometry and the optional projector response.
#[derive(Clone, Debug, PartialEq)]
pub struct CalibrationFile {
    /// Camera, projector, pose and volume.
    pub calibration: Calibration,
    /// The `[projector_response]` section, if the file has one.
    pub projector_response: Option<ProjectorResponseSection>,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct DeviceV1 {
    width_px: u32,
    height_px: u32,
    fx_px: f64,
    fy_px: f64,
    cx_px: f64,
    cy_px: f64,
    distortion: [f64; 5],
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct PoseV1 {
    rotation: [[f64; 3]; 3],
    translation_mm: [f64; 3],
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct VolumeV1 {
    near_mm: f64,
    far_mm: f64,
}

impl DeviceV1 {
    fn of(p: &Pinhole) -> Self {
        let k = p.intrinsics();
        DeviceV1 {
            width_px: p.width_px(),
            height_px: p.height_px(),
            fx_px: k.fx_px,
            fy_px: k.fy_px,
            cx_px: k.cx_px,
            cy_px: k.cy_px,
            distortion: p.distortion().to_opencv(),
        }
    }

    fn model(&self, what: &'static str) -> Result<Pinhole, ModelError> {
        Pinhole::new(
            what,
            self.width_px,
            self.height_px,
            Intrinsics {
                fx_px: self.fx_px,
                fy_px: self.fy_px,
                cx_px: self.cx_px,
                cy_px: self.cy_px,
            },
            BrownConrady::from_opencv(self.distortion),
        )
    }

    fn numbers(&self, out: &mut Vec<f64>) {
        out.extend([
            self.width_px as f64,
            self.height_px as f64,
            self.fx_px,
            self.fy_px,
            self.cx_px,
            self.cy_px,
        ]);
        out.extend(self.distortion);
    }
}

impl FileV1 {
    fn of(c: &Calibration) -> Self {
        let r = c.pose.rotation().matrix();
        let t = c.pose.translation_mm();
        let mut file = FileV1 {
            format: FORMAT.into(),
            version: VERSION,
            checksum_crc32: None,
            camera: DeviceV1::of(&c.camera),
            projector: DeviceV1::of(&c.projector),
            pose: PoseV1 {
                rotation: [0, 1, 2].map(|i| [r[(i, 0)], r[(i, 1)], r[(i, 2)]]),
                translation_mm: [t.x, t.y, t.z],
            },
            volume: VolumeV1 {
                near_mm: c.volume.near_mm(),
                far_mm: c.volume.far_mm(),
            },
            projector_response: None,
        };
        file.checksum_crc32 = Some(format_crc(file.checksum()));
        file
    }

    fn with_response(c: &Calibration, response: Option<&ProjectorResponseSection>) -> Self {
        let mut file = FileV1::of(c);
        file.projector_response = response.map(ProjectorResponseSection::to_v1);
        file.checksum_crc32 = Some(format_crc(file.checksum()));
        file
    }

    /// The numbers in checksum order: camera, projector (width, height, fx, fy, cx, cy, k1, k2,
    /// p1, p2, k3), rotation row-major, translation, near, far; then, only if the file has a
    /// `[projector_response]`, 1 and gamma, or 2, the table's length, input and output.
    fn checksum(&self) -> u32 {
        let mut numbers = Vec::with_capacity(36);
        self.camera.numbers(&mut numbers);
        self.projector.numbers(&mut numbers);
        numbers.extend(self.pose.rotation.iter().flatten());
        numbers.extend(self.pose.translation_mm);
        numbers.extend([self.volume.near_mm, self.volume.far_mm]);
        if let Some(r) = &self.projector_response {
            if let Some(g) = r.gamma {
                numbers.extend([1.0, g]);
            }
            if let (Some(input), Some(output)) = (&r.input, &r.output) {
                numbers.extend([2.0, input.len() as f64]);
                numbers.extend(input);
                numbers.extend(output);
            }
        }
        let bytes: Vec<u8> = numbers.iter().flat_map(|v| v.to_le_bytes()).collect();
        fsm_core::wire::crc32(&bytes)
    }

    fn model(&self) -> Result<Calibration, ModelError> {
        let camera = self.camera.model("camera")?;
        let projector = self.projector.model("projector")?;
        let pose = Pose::new(
            Matrix3::from_fn(|i, j| self.pose.rotation[i][j]),
            Vector3::from(self.pose.translation_mm),
        )?;
        let volume = MeasurementVolume::new(self.volume.near_mm, self.volume.far_mm)?;
        Ok(Calibration {
            camera,
            projector,
            pose,
            volume,
        })
    }
}

fn format_crc(crc: u32) -> String {
    format!("{crc:08x}")
}

const HEADER: &str = "\
# fsm calibration (SPEC §5). Lengths in mm, image coordinates in pixels with the centre of
# pixel (0, 0) at (0, 0). Distortion: Brown-Conrady in OpenCV's order [k1, k2, p1, p2, k3].
# The projector is an inverse camera: its width_px is the number of columns cmax.
# Pose: X_p = R X_c + t (camera frame to projector frame); rotation lists the rows of R.
# Volume: depth limits along the camera's z axis. Optional [projector_response]: light =
# code^gamma, or a table of input codes (0 to 1) and output light, for fsm patterns.
# checksum_crc32 covers the numbers, not the text: delete it after editing a number by hand.
";

impl Calibration {
    /// The CRC-32 stored in the file as `checksum_crc32` (see [`crate::file`]).
    pub fn checksum(&self) -> u32 {
        FileV1::of(self).checksum()
    }

    /// The calibration in a line, as `fsm calibrate import` reports it: the devices' sizes, the
    /// baseline and the file's checksum.
    pub fn summary(&self) -> String {
        format!(
            "camera {}x{}, projector {} columns x {} rows, baseline {:.3} mm, checksum {:08x}",
            self.camera.width_px(),
            self.camera.height_px(),
            self.projector.width_px(),
            self.projector.height_px(),
            self.pose.baseline_mm(),
            self.checksum()
        )
    }

    /// The calibration as the text of a version-1 file.
    pub fn to_toml(&self) -> String {
        let body = toml::to_string(&FileV1::of(self))
            .expect("a calibration of finite numbers always serialises");
        format!("{HEADER}\n{body}")
    }

    /// Parses and validates the text of a calibration file; `source` names it in errors. A
    /// `[projector_response]` section is checked and dropped ([`CalibrationFile`] keeps it).
    pub fn from_toml(text: &str, source: &str) -> Result<Calibration, CalibrationFileError> {
        CalibrationFile::from_toml(text, source).map(|f| f.calibration)
    }

    /// Reads a calibration file (a `[projector_response]` section is checked and dropped).
    pub fn read(path: &Path) -> Result<Calibration, CalibrationFileError> {
        CalibrationFile::read(path).map(|f| f.calibration)
    }

    /// Writes a calibration file (without a projector response) whole or not at all: a
    /// temporary file in the same folder, flushed to disk, then renamed over `path`.
    pub fn write(&self, path: &Path) -> Result<(), CalibrationFileError> {
        write_text(path, &self.to_toml())
    }
}

impl CalibrationFile {
    /// A file of `calibration` without optional sections.
    pub fn new(calibration: Calibration) -> Self {
        CalibrationFile {
            calibration,
            projector_response: None,
        }
    }

    /// The CRC-32 stored as `checksum_crc32` (with the section's numbers if it has one).
    pub fn checksum(&self) -> u32 {
        FileV1::with_response(&self.calibration, self.projector_response.as_ref()).checksum()
    }

    /// The text of the file (version 1; the section only if present).
    pub fn to_toml(&self) -> String {
        let file = FileV1::with_response(&self.calibration, self.projector_response.as_ref());
        let body =
            toml::to_string(&file).expect("a calibration of finite numbers always serialises");
        format!("{HEADER}\n{body}")
    }

    /// Parses and validates the text of a calibration file; `source` names it in errors.
    pub fn from_toml(text: &str, source: &str) -> Result<CalibrationFile, CalibrationFileError> {
        let err = |kind| CalibrationFileError {
            source: source.to_string(),
            kind,
        };
        // Format and version first, so that another file or a newer version is named as such
        // rather than reported as unknown keys.
        let table: toml::Table = toml::from_str(text)
            .map_err(|e| err(CalibrationFileErrorKind::Syntax(e.to_string())))?;
        match table.get("format") {
            Some(toml::Value::String(s)) if s == FORMAT => {}
            Some(other) => {
                return Err(err(CalibrationFileErrorKind::Format(Some(
                    other.to_string(),
                ))))
            }
            None => return Err(err(CalibrationFileErrorKind::Format(None))),
        }
        match table.get("version") {
            Some(toml::Value::Integer(v)) if *v == VERSION as i64 => {}
            Some(toml::Value::Integer(v)) => {
                return Err(err(CalibrationFileErrorKind::Version(Some(*v))))
            }
            _ => return Err(err(CalibrationFileErrorKind::Version(None))),
        }
        let file: FileV1 = toml::from_str(text)
            .map_err(|e| err(CalibrationFileErrorKind::Syntax(e.to_string())))?;
        let calibration = file
            .model()
            .map_err(|e| err(CalibrationFileErrorKind::Model(e)))?;
        let projector_response = file
            .projector_response
            .as_ref()
            .map(ProjectorResponseSection::of)
            .transpose()
            .map_err(|e| err(CalibrationFileErrorKind::ProjectorResponse(e)))?;
        if let Some(stored) = &file.checksum_crc32 {
            let computed = format_crc(file.checksum());
            if !stored.trim().eq_ignore_ascii_case(&computed) {
                return Err(err(CalibrationFileErrorKind::Checksum {
                    stored: stored.clone(),
                    computed,
                }));
            }
        }
        Ok(CalibrationFile {
            calibration,
            projector_response,
        })
    }

    /// Reads a calibration file.
    pub fn read(path: &Path) -> Result<CalibrationFile, CalibrationFileError> {
        let source = path.display().to_string();
        let bytes = std::fs::read(path).map_err(|e| CalibrationFileError {
            source: source.clone(),
            kind: CalibrationFileErrorKind::Io(e),
        })?;
        CalibrationFile::from_bytes(&bytes, &source)
    }

    /// Parses and validates the bytes of a calibration file (UTF-8 TOML), as [`Self::read`]
    /// does a file's; `source` names it in errors.
    pub fn from_bytes(bytes: &[u8], source: &str) -> Result<CalibrationFile, CalibrationFileError> {
        let text = std::str::from_utf8(bytes).map_err(|e| CalibrationFileError {
            source: source.to_string(),
            kind: CalibrationFileErrorKind::Syntax(format!(
                "not UTF-8 text (invalid byte at offset {})",
                e.valid_up_to()
            )),
        })?;
        CalibrationFile::from_toml(text, source)
    }

    /// Writes the file whole or not at all, with the workspace's one atomic writer
    /// ([`fsm_io::outputs::write_file`]: staged beside `path`, synced, renamed over it).
    pub fn write(&self, path: &Path) -> Result<(), CalibrationFileError> {
        write_text(path, &self.to_toml())
    }
}

fn write_text(path: &Path, text: &str) -> Result<(), CalibrationFileError> {
    fsm_io::outputs::write_file(path, text.as_bytes()).map_err(|e| CalibrationFileError {
        source: path.display().to_string(),
        kind: CalibrationFileErrorKind::Io(e.into_io_error()),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Point3;

    fn calibration() -> Calibration {
        let k = |f: f64, cx: f64, cy: f64| Intrinsics {
            fx_px: f,
            fy_px: f,
            cx_px: cx,
            cy_px: cy,
        };
        let camera = Pinhole::new(
            "camera",
            320,
            240,
            k(640.0, 159.5, 119.5),
            BrownConrady::NONE,
        )
        .unwrap();
        let projector = Pinhole::new(
            "projector",
            768,
            1024,
            k(1400.0, 383.5, 511.5),
            BrownConrady::NONE,
        )
        .unwrap();
        let pose = Pose::looking_at(
            Point3::new(200.0, 0.0, 0.0),
            Point3::new(0.0, 0.0, 500.0),
            Vector3::y(),
        )
        .unwrap();
        Calibration {
            camera,
            projector,
            pose,
            volume: MeasurementVolume::new(350.0, 700.0).unwrap(),
        }
    }

    #[test]
    fn projector_response_section_round_trips_and_is_checksummed() {
        let cal = calibration();
        let sections = [
            ProjectorResponseSection::Gamma(2.2),
            ProjectorResponseSection::Table {
                input: vec![0.0, 0.25, 0.5, 1.0],
                output: vec![0.01, 0.05, 0.22, 1.0],
            },
        ];
        for section in sections {
            let file = CalibrationFile {
                calibration: cal,
                projector_response: Some(section.clone()),
            };
            let text = file.to_toml();
            assert!(text.lines().any(|l| l == "[projector_response]"), "{text}");
            assert!(text.contains("version = 1"), "{text}");
            assert_eq!(CalibrationFile::from_toml(&text, "x").unwrap(), file);
            // The geometry-only reader accepts it and drops the section.
            assert_eq!(Calibration::from_toml(&text, "x").unwrap(), cal);
            assert_ne!(file.checksum(), cal.checksum());
            // A changed response number is caught by the checksum.
            let edited = match &section {
                ProjectorResponseSection::Gamma(_) => {
                    text.replacen("gamma = 2.2", "gamma = 2.3", 1)
                }
                ProjectorResponseSection::Table { .. } => text.replacen("0.22", "0.23", 1),
            };
            assert_ne!(edited, text);
            let e = CalibrationFile::from_toml(&edited, "cal.toml").unwrap_err();
            assert!(
                matches!(e.kind, CalibrationFileErrorKind::Checksum { .. }),
                "{e}"
            );
            // Written whole, read back.
            let dir = tempfile::tempdir().unwrap();
            let path = dir.path().join("cal.toml");
            file.write(&path).unwrap();
            assert_eq!(CalibrationFile::read(&path).unwrap(), file);
            assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
        }
    }

    #[test]
    fn a_file_without_the_section_reads_as_before() {
        let cal = calibration();
        let text = cal.to_toml();
        assert!(!text.lines().any(|l| l.starts_with("[projector_response]")));
        let file = CalibrationFile::from_toml(&text, "x").unwrap();
        assert_eq!(file, CalibrationFile::new(cal));
        assert_eq!(file.checksum(), cal.checksum());
        assert_eq!(file.to_toml(), text);
    }

    #[test]
    fn bad_sections_name_the_field() {
        let text = calibration().to_toml();
        let body: String = text
            .lines()
            .filter(|l| !l.starts_with("checksum_crc32"))
            .map(|l| format!("{l}\n"))
            .collect();
        for (section, needle) in [
            ("gamma = 0.0", "projector_response.gamma = 0"),
            ("gamma = 2.2\ninput = [0.0, 1.0]", "give either gamma"),
            (
                "input = [0.0, 0.5, 0.9]\noutput = [0.0, 0.5, 1.0]",
                "projector_response.input runs from 0 to 0.9",
            ),
            (
                "input = [0.0, 0.5, 1.0]\noutput = [0.0, 0.6, 0.5]",
                "projector_response.output: values must be strictly increasing (entry 2",
            ),
            (
                "input = [0.0, 1.0]\noutput = [0.0, 0.5, 1.0]",
                "same length",
            ),
            ("gama = 2.2", "gama"),
        ] {
            let t = format!("{body}\n[projector_response]\n{section}\n");
            let e = CalibrationFile::from_toml(&t, "cal.toml").unwrap_err();
            let m = e.to_string();
            assert!(m.starts_with("calibration file cal.toml: "), "{m}");
            assert!(m.contains(needle), "{section}: {m}");
        }
    }
}
