//! Errors of the geometric models.

use core::fmt;

/// A parameter of a model breaks a rule; the message names the device, the field and the rule.
#[derive(Clone, Debug, PartialEq)]
pub enum ModelError {
    /// One field has a value it may not have.
    Field {
        /// `"camera"`, `"projector"`, `"pose"` or `"volume"`.
        device: &'static str,
        /// The field.
        field: &'static str,
        /// Its value.
        value: f64,
        /// The rule it breaks.
        rule: &'static str,
    },
    /// The distortion cannot be inverted somewhere on the image.
    NotInvertible {
        /// `"camera"` or `"projector"`.
        device: &'static str,
        /// Image point where it fails, pixels.
        pixel: (f64, f64),
        /// Why.
        reason: String,
    },
}

impl fmt::Display for ModelError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ModelError::Field {
                device,
                field,
                value,
                rule,
            } => write!(f, "{device}.{field} = {value}: {rule}"),
            ModelError::NotInvertible {
                device,
                pixel,
                reason,
            } => write!(
                f,
                "{device}: distortion is not invertible at image point ({:.1}, {:.1}): {reason}",
                pixel.0, pixel.1
            ),
        }
    }
}

impl std::error::Error for ModelError {}

/// The host's commands report a calibration file's error as it is (it names the file and the
/// key).
impl From<crate::file::CalibrationFileError> for fsm_io::Error {
    fn from(e: crate::file::CalibrationFileError) -> Self {
        fsm_io::Error::Usage(e.to_string())
    }
}

/// … and another tool's file's (it names the file and the key).
impl From<crate::opencv::OpenCvError> for fsm_io::Error {
    fn from(e: crate::opencv::OpenCvError) -> Self {
        fsm_io::Error::Usage(e.to_string())
    }
}
