//! The projector's pose: `X_p = R·X_c + t`, camera frame to projector frame, millimetres
//! (SPEC §5; OpenCV's `stereoCalibrate` `R`, `T` with the camera as the first device).

use nalgebra::{Matrix3, Point3, Rotation3, Unit, Vector3};

use crate::error::ModelError;

/// How far `RᵀR` may be from the identity (and `det R` from 1) in a calibration file.
pub const ROTATION_TOLERANCE: f64 = 1e-6;

/// Rigid transform from the camera frame to the projector frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pose {
    rotation: Rotation3<f64>,
    translation_mm: Vector3<f64>,
}

impl Pose {
    /// Checks that `rotation` is a proper rotation (orthonormal, determinant +1, within
    /// [`ROTATION_TOLERANCE`]) and every number is finite.
    pub fn new(rotation: Matrix3<f64>, translation_mm: Vector3<f64>) -> Result<Self, ModelError> {
        let field = |field, value, rule| ModelError::Field {
            device: "pose",
            field,
            value,
            rule,
        };
        if let Some(v) = rotation.iter().find(|v| !v.is_finite()) {
            return Err(field("rotation", *v, "must hold finite numbers"));
        }
        if let Some(v) = translation_mm.iter().find(|v| !v.is_finite()) {
            return Err(field("translation_mm", *v, "must hold finite numbers"));
        }
        let off = (rotation.transpose() * rotation - Matrix3::identity())
            .abs()
            .max();
        if off > ROTATION_TOLERANCE {
            return Err(field(
                "rotation",
                off,
                "is not orthonormal (largest entry of R^T R - I shown)",
            ));
        }
        let det = rotation.determinant();
        if (det - 1.0).abs() > ROTATION_TOLERANCE {
            return Err(field(
                "rotation",
                det,
                "must have determinant +1 (a reflection was given)",
            ));
        }
        Ok(Pose {
            rotation: Rotation3::from_matrix_unchecked(rotation),
            translation_mm,
        })
    }

    /// From an exact rotation.
    pub fn from_rotation(rotation: Rotation3<f64>, translation_mm: Vector3<f64>) -> Self {
        Pose {
            rotation,
            translation_mm,
        }
    }

    /// The pose of a projector whose centre is at `centre_mm` (camera frame) and whose optical
    /// axis points at `target_mm`, with its image `y` axis as close as possible to `down`
    /// (camera frame). `None` when the axis is degenerate or parallel to `down`.
    pub fn looking_at(
        centre_mm: Point3<f64>,
        target_mm: Point3<f64>,
        down: Vector3<f64>,
    ) -> Option<Self> {
        let z = Unit::try_new(target_mm - centre_mm, 1e-12)?;
        let x = Unit::try_new(down.cross(&z), 1e-12)?;
        let y = z.cross(&x);
        // Rows of R are the projector axes expressed in the camera frame.
        let r = Matrix3::from_rows(&[x.transpose(), y.transpose(), z.transpose()]);
        let rotation = Rotation3::from_matrix_unchecked(r);
        let translation_mm = -(rotation * centre_mm.coords);
        Some(Pose {
            rotation,
            translation_mm,
        })
    }

    /// `R`.
    pub fn rotation(&self) -> &Rotation3<f64> {
        &self.rotation
    }

    /// `t`, mm.
    pub fn translation_mm(&self) -> &Vector3<f64> {
        &self.translation_mm
    }

    /// `X_p = R·X_c + t`.
    pub fn to_projector(&self, camera_point: &Point3<f64>) -> Point3<f64> {
        self.rotation * camera_point + self.translation_mm
    }

    /// `X_c = Rᵀ(X_p − t)`.
    pub fn to_camera(&self, projector_point: &Point3<f64>) -> Point3<f64> {
        self.rotation
            .inverse_transform_point(&(projector_point - self.translation_mm))
    }

    /// A direction of the camera frame in the projector frame.
    pub fn direction_to_projector(&self, camera_direction: &Vector3<f64>) -> Vector3<f64> {
        self.rotation * camera_direction
    }

    /// The projector's centre in the camera frame, `−Rᵀt`, mm.
    pub fn projector_centre_mm(&self) -> Point3<f64> {
        self.to_camera(&Point3::origin())
    }

    /// Distance between the two centres, mm.
    pub fn baseline_mm(&self) -> f64 {
        self.translation_mm.norm()
    }
}
