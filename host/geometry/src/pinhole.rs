//! The pinhole model shared by the camera and the projector (SPEC §5).
//!
//! Image coordinates are pixels with the centre of pixel `(0, 0)` at `(0, 0)` (SPEC §1, OpenCV's
//! convention): a `W`-pixel-wide image spans `[−0.5, W − 0.5]`. The projector is the same model
//! seen as an inverse camera; its `u` coordinate is the projector column of SPEC §1 and its image
//! width is `cmax`.

use nalgebra::{Point2, Point3, Vector2, Vector3};

use crate::distortion::{BrownConrady, UndistortError};
use crate::error::ModelError;

/// Focal lengths and principal point, pixels (OpenCV's `K` without skew).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Intrinsics {
    /// `fx`, pixels.
    pub fx_px: f64,
    /// `fy`, pixels.
    pub fy_px: f64,
    /// `cx`, pixels.
    pub cx_px: f64,
    /// `cy`, pixels.
    pub cy_px: f64,
}

/// A pinhole with Brown–Conrady distortion and an image of `width × height` pixels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pinhole {
    width_px: u32,
    height_px: u32,
    intrinsics: Intrinsics,
    distortion: BrownConrady,
    /// Cached [`BrownConrady::max_radius`].
    max_radius: f64,
}

impl Pinhole {
    /// Checks the parameters; `what` names the device in errors (`"camera"`, `"projector"`).
    pub fn new(
        what: &'static str,
        width_px: u32,
        height_px: u32,
        intrinsics: Intrinsics,
        distortion: BrownConrady,
    ) -> Result<Self, ModelError> {
        let field = |field: &'static str, value: f64, rule: &'static str| ModelError::Field {
            device: what,
            field,
            value,
            rule,
        };
        if width_px == 0 {
            return Err(field("width", 0.0, "must be at least 1"));
        }
        if height_px == 0 {
            return Err(field("height", 0.0, "must be at least 1"));
        }
        let positive = "must be a finite number above 0";
        let finite = "must be a finite number";
        if !(intrinsics.fx_px.is_finite() && intrinsics.fx_px > 0.0) {
            return Err(field("fx_px", intrinsics.fx_px, positive));
        }
        if !(intrinsics.fy_px.is_finite() && intrinsics.fy_px > 0.0) {
            return Err(field("fy_px", intrinsics.fy_px, positive));
        }
        if !intrinsics.cx_px.is_finite() {
            return Err(field("cx_px", intrinsics.cx_px, finite));
        }
        if !intrinsics.cy_px.is_finite() {
            return Err(field("cy_px", intrinsics.cy_px, finite));
        }
        for (name, v) in ["k1", "k2", "p1", "p2", "k3"]
            .into_iter()
            .zip(distortion.to_opencv())
        {
            if !v.is_finite() {
                return Err(field(name, v, finite));
            }
        }
        let model = Pinhole {
            width_px,
            height_px,
            intrinsics,
            distortion,
            max_radius: distortion.max_radius(),
        };
        model.check_invertible(what)?;
        Ok(model)
    }

    /// Checks that the distortion is invertible and orientation-preserving over the whole
    /// image: every point of a grid over the image undistorts, lies inside the valid radius and
    /// has a Jacobian with positive determinant and positive diagonal (so column coordinates
    /// increase with `x` and triangulation along a ray is monotone).
    fn check_invertible(&self, what: &'static str) -> Result<(), ModelError> {
        if self.distortion.is_none() {
            return Ok(());
        }
        const GRID: u32 = 24;
        for i in 0..=GRID {
            for j in 0..=GRID {
                let u = -0.5 + self.width_px as f64 * i as f64 / GRID as f64;
                let v = -0.5 + self.height_px as f64 * j as f64 / GRID as f64;
                let p = Point2::new(u, v);
                let n = self.normalized(p).map_err(|e| ModelError::NotInvertible {
                    device: what,
                    pixel: (u, v),
                    reason: e.to_string(),
                })?;
                let jac = self.distortion.jacobian(n);
                if !(jac.determinant() > 0.0 && jac[(0, 0)] > 0.0 && jac[(1, 1)] > 0.0) {
                    return Err(ModelError::NotInvertible {
                        device: what,
                        pixel: (u, v),
                        reason: "the distortion folds the image there (Jacobian not positive)"
                            .into(),
                    });
                }
            }
        }
        Ok(())
    }

    /// Image width, pixels (projector: `cmax` columns).
    pub fn width_px(&self) -> u32 {
        self.width_px
    }

    /// Image height, pixels (projector: rows).
    pub fn height_px(&self) -> u32 {
        self.height_px
    }

    /// Focal lengths and principal point.
    pub fn intrinsics(&self) -> &Intrinsics {
        &self.intrinsics
    }

    /// Distortion coefficients.
    pub fn distortion(&self) -> &BrownConrady {
        &self.distortion
    }

    /// Largest undistorted normalised radius with a meaningful image.
    pub fn max_radius(&self) -> f64 {
        self.max_radius
    }

    /// Whether `p` lies on the image, `[−0.5, W − 0.5] × [−0.5, H − 0.5]`.
    pub fn contains(&self, p: Point2<f64>) -> bool {
        p.x >= -0.5
            && p.x <= self.width_px as f64 - 0.5
            && p.y >= -0.5
            && p.y <= self.height_px as f64 - 0.5
    }

    /// Image point of a normalised (undistorted) point, or `None` beyond the valid radius.
    pub fn image_of_normalized(&self, n: Vector2<f64>) -> Option<Point2<f64>> {
        if n.norm() > self.max_radius {
            return None;
        }
        let d = self.distortion.distort(n);
        let k = &self.intrinsics;
        Some(Point2::new(
            k.fx_px * d.x + k.cx_px,
            k.fy_px * d.y + k.cy_px,
        ))
    }

    /// Image point of a 3D point in this device's frame (mm), or `None` when it is not in
    /// front of the device or beyond the valid radius. The point need not be on the image.
    pub fn project(&self, p: &Point3<f64>) -> Option<Point2<f64>> {
        if p.z.is_nan() || p.z <= 0.0 {
            return None;
        }
        self.image_of_normalized(Vector2::new(p.x / p.z, p.y / p.z))
    }

    /// The `u` coordinate (projector: column) of a 3D point in this device's frame.
    pub fn column_of(&self, p: &Point3<f64>) -> Option<f64> {
        self.project(p).map(|q| q.x)
    }

    /// Normalised undistorted coordinates `(x/z, y/z)` of an image point.
    pub fn normalized(&self, p: Point2<f64>) -> Result<Vector2<f64>, UndistortError> {
        let k = &self.intrinsics;
        let q = Vector2::new((p.x - k.cx_px) / k.fx_px, (p.y - k.cy_px) / k.fy_px);
        self.distortion.undistort_within(q, self.max_radius)
    }

    /// Direction `(x, y, 1)` of the ray through an image point (device frame): the point at
    /// depth `z` mm is `z·ray`.
    pub fn ray(&self, p: Point2<f64>) -> Result<Vector3<f64>, UndistortError> {
        let n = self.normalized(p)?;
        Ok(Vector3::new(n.x, n.y, 1.0))
    }
}
