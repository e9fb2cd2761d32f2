//! A calibrated camera–projector pair: the two pinholes, the pose between them and the
//! measurement volume. Everything the host needs to turn candidates into points.

use nalgebra::{Point2, Point3};

use crate::pinhole::Pinhole;
use crate::pose::Pose;
use crate::volume::MeasurementVolume;

/// Camera, projector, pose and measurement volume (SPEC §5; stored by [`crate::file`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Calibration {
    /// The camera; its frame is the world frame of every point the host outputs.
    pub camera: Pinhole,
    /// The projector as an inverse camera: image width = `cmax` columns.
    pub projector: Pinhole,
    /// `X_p = R·X_c + t`, mm.
    pub pose: Pose,
    /// Depth limits of the measurement.
    pub volume: MeasurementVolume,
}

impl Calibration {
    /// Projector columns `cmax`.
    pub fn projector_columns(&self) -> u32 {
        self.projector.width_px()
    }

    /// Camera pixel of a camera-frame point (not necessarily on the image).
    pub fn camera_pixel_of(&self, camera_point: &Point3<f64>) -> Option<Point2<f64>> {
        self.camera.project(camera_point)
    }

    /// Projector image point `(column, row)` of a camera-frame point.
    pub fn projector_point_of(&self, camera_point: &Point3<f64>) -> Option<Point2<f64>> {
        self.projector
            .project(&self.pose.to_projector(camera_point))
    }

    /// Projector column coordinate of a camera-frame point: the geometric "true column" of a
    /// pixel that sees this point (SPEC §7).
    pub fn projector_column_of(&self, camera_point: &Point3<f64>) -> Option<f64> {
        self.projector_point_of(camera_point).map(|p| p.x)
    }

    /// Projector centre in the camera frame, mm.
    pub fn projector_centre_mm(&self) -> Point3<f64> {
        self.pose.projector_centre_mm()
    }
}
