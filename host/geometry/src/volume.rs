//! The measurement volume: the depths (camera `z`, mm) where the scanner measures. Candidates
//! that triangulate outside it are dropped; inside it, each camera pixel can only see a
//! limited range of projector columns (see [`crate::Calibration::column_range`]).

use nalgebra::Point3;

use crate::error::ModelError;

/// Depth limits along the camera's optical axis, mm.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MeasurementVolume {
    near_mm: f64,
    far_mm: f64,
}

impl MeasurementVolume {
    /// Requires `0 < near_mm < far_mm`, finite.
    pub fn new(near_mm: f64, far_mm: f64) -> Result<Self, ModelError> {
        if !(near_mm.is_finite() && near_mm > 0.0) {
            return Err(ModelError::Field {
                device: "volume",
                field: "near_mm",
                value: near_mm,
                rule: "must be a finite number above 0",
            });
        }
        if !(far_mm.is_finite() && far_mm > near_mm) {
            return Err(ModelError::Field {
                device: "volume",
                field: "far_mm",
                value: far_mm,
                rule: "must be finite and above near_mm",
            });
        }
        Ok(MeasurementVolume { near_mm, far_mm })
    }

    /// Nearest depth, mm.
    pub fn near_mm(&self) -> f64 {
        self.near_mm
    }

    /// Farthest depth, mm.
    pub fn far_mm(&self) -> f64 {
        self.far_mm
    }

    /// Whether a camera-frame point's depth lies within the limits.
    pub fn contains(&self, camera_point: &Point3<f64>) -> bool {
        self.contains_depth(camera_point.z)
    }

    /// Whether a depth lies within the limits.
    pub fn contains_depth(&self, depth_mm: f64) -> bool {
        depth_mm >= self.near_mm && depth_mm <= self.far_mm
    }
}
