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
//! ```
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
use std::io::Write;
use std::path::{Path, PathBuf};

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
        };
        file.checksum_crc32 = Some(format_crc(file.checksum()));
        file
    }

    /// The numbers in checksum order: camera, projector (width, height, fx, fy, cx, cy, k1, k2,
    /// p1, p2, k3), rotation row-major, translation, near, far.
    fn checksum(&self) -> u32 {
        let mut numbers = Vec::with_capacity(36);
        self.camera.numbers(&mut numbers);
        self.projector.numbers(&mut numbers);
        numbers.extend(self.pose.rotation.iter().flatten());
        numbers.extend(self.pose.translation_mm);
        numbers.extend([self.volume.near_mm, self.volume.far_mm]);
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
# Volume: depth limits along the camera's z axis. checksum_crc32 covers the numbers, not the
# text: delete it after editing a number by hand.
";

impl Calibration {
    /// The CRC-32 stored in the file as `checksum_crc32` (see [`crate::file`]).
    pub fn checksum(&self) -> u32 {
        FileV1::of(self).checksum()
    }

    /// The calibration as the text of a version-1 file.
    pub fn to_toml(&self) -> String {
        let body = toml::to_string(&FileV1::of(self))
            .expect("a calibration of finite numbers always serialises");
        format!("{HEADER}\n{body}")
    }

    /// Parses and validates the text of a calibration file; `source` names it in errors.
    pub fn from_toml(text: &str, source: &str) -> Result<Calibration, CalibrationFileError> {
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
        if let Some(stored) = &file.checksum_crc32 {
            let computed = format_crc(file.checksum());
            if !stored.trim().eq_ignore_ascii_case(&computed) {
                return Err(err(CalibrationFileErrorKind::Checksum {
                    stored: stored.clone(),
                    computed,
                }));
            }
        }
        Ok(calibration)
    }

    /// Reads a calibration file.
    pub fn read(path: &Path) -> Result<Calibration, CalibrationFileError> {
        let source = path.display().to_string();
        let bytes = std::fs::read(path).map_err(|e| CalibrationFileError {
            source: source.clone(),
            kind: CalibrationFileErrorKind::Io(e),
        })?;
        let text = std::str::from_utf8(&bytes).map_err(|e| CalibrationFileError {
            source: source.clone(),
            kind: CalibrationFileErrorKind::Syntax(format!(
                "not UTF-8 text (invalid byte at offset {})",
                e.valid_up_to()
            )),
        })?;
        Calibration::from_toml(text, &source)
    }

    /// Writes a calibration file whole or not at all: a temporary file in the same folder,
    /// flushed to disk, then renamed over `path`.
    pub fn write(&self, path: &Path) -> Result<(), CalibrationFileError> {
        let io = |e| CalibrationFileError {
            source: path.display().to_string(),
            kind: CalibrationFileErrorKind::Io(e),
        };
        let tmp = temporary_path(path);
        let result = (|| {
            let mut f = std::fs::File::create(&tmp)?;
            f.write_all(self.to_toml().as_bytes())?;
            f.sync_all()?;
            std::fs::rename(&tmp, path)
        })();
        if result.is_err() {
            let _ = std::fs::remove_file(&tmp);
        }
        result.map_err(io)
    }
}

/// `dir/.name.tmp-<pid>`: same folder (so rename is atomic), hidden, unique per process.
fn temporary_path(path: &Path) -> PathBuf {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "calibration".into());
    path.with_file_name(format!(".{name}.tmp-{}", std::process::id()))
}
