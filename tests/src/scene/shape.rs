//! Surfaces the simulator traces: rectangles and spheres, with their materials.

use nalgebra::{Point3, Unit, Vector3};

/// Rays shorter than this (mm) do not hit: keeps a ray leaving a surface off that surface.
pub const RAY_EPSILON_MM: f64 = 1e-6;

/// A surface's geometry, camera frame, mm.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Shape {
    /// The parallelogram `centre + a·half_u + b·half_v`, `a, b ∈ [−1, 1]` (`half_u ⊥ half_v`
    /// for a rectangle). Its front normal is `half_u × half_v`.
    Rectangle {
        /// Centre.
        centre: Point3<f64>,
        /// Half the first edge.
        half_u: Vector3<f64>,
        /// Half the second edge.
        half_v: Vector3<f64>,
    },
    /// A sphere; its front is the outside.
    Sphere {
        /// Centre.
        centre: Point3<f64>,
        /// Radius, mm.
        radius_mm: f64,
    },
}

/// How a surface reflects light.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Material {
    /// Lambertian on both sides, reflectance `albedo ∈ [0, 1]`.
    Diffuse {
        /// Hemispherical reflectance.
        albedo: f64,
    },
    /// A perfect mirror on the front side with reflectance `reflectance`; black behind.
    Mirror {
        /// Fraction of light reflected.
        reflectance: f64,
    },
    /// Absorbs everything (a covered mirror, a light trap); still occludes.
    Black,
}

/// A named surface of a scene.
#[derive(Clone, Debug, PartialEq)]
pub struct Surface {
    /// Name, for reports.
    pub name: String,
    /// Geometry.
    pub shape: Shape,
    /// Material.
    pub material: Material,
}

/// Where a ray meets a surface.
#[derive(Clone, Copy, Debug)]
pub struct Hit {
    /// Ray parameter (the ray direction's units).
    pub t: f64,
    /// The point, mm.
    pub point: Point3<f64>,
    /// Front normal of the surface at the point (unit).
    pub normal: Unit<Vector3<f64>>,
    /// Index of the surface in its scene.
    pub surface: usize,
}

impl Shape {
    /// First intersection with `t ∈ (RAY_EPSILON_MM/|dir|, t_max)`: `(t, point, front normal)`.
    pub fn intersect(
        &self,
        origin: &Point3<f64>,
        dir: &Vector3<f64>,
        t_max: f64,
    ) -> Option<(f64, Point3<f64>, Unit<Vector3<f64>>)> {
        let t_min = RAY_EPSILON_MM / dir.norm();
        match *self {
            Shape::Rectangle {
                centre,
                half_u,
                half_v,
            } => {
                let n = half_u.cross(&half_v);
                let denom = n.dot(dir);
                if denom == 0.0 {
                    return None;
                }
                let t = n.dot(&(centre - origin)) / denom;
                if !(t > t_min && t < t_max) {
                    return None;
                }
                let p = origin + dir * t;
                let d = p - centre;
                let a = d.dot(&half_u) / half_u.norm_squared();
                let b = d.dot(&half_v) / half_v.norm_squared();
                if a.abs() > 1.0 || b.abs() > 1.0 {
                    return None;
                }
                Some((t, p, Unit::new_normalize(n)))
            }
            Shape::Sphere { centre, radius_mm } => {
                let oc = origin - centre;
                let a = dir.norm_squared();
                let half_b = oc.dot(dir);
                let c = oc.norm_squared() - radius_mm * radius_mm;
                let disc = half_b * half_b - a * c;
                if disc < 0.0 {
                    return None;
                }
                let sq = disc.sqrt();
                let t = [(-half_b - sq) / a, (-half_b + sq) / a]
                    .into_iter()
                    .find(|&t| t > t_min && t < t_max)?;
                let p = origin + dir * t;
                Some((t, p, Unit::new_normalize(p - centre)))
            }
        }
    }

    /// The plane of a rectangle: `(centre, unit front normal)`.
    pub fn plane(&self) -> Option<(Point3<f64>, Unit<Vector3<f64>>)> {
        match *self {
            Shape::Rectangle {
                centre,
                half_u,
                half_v,
            } => Some((centre, Unit::new_normalize(half_u.cross(&half_v)))),
            Shape::Sphere { .. } => None,
        }
    }

    /// Whether a point of the rectangle's plane lies inside it.
    pub fn rectangle_contains(&self, p: &Point3<f64>) -> bool {
        match *self {
            Shape::Rectangle {
                centre,
                half_u,
                half_v,
            } => {
                let d = p - centre;
                (d.dot(&half_u) / half_u.norm_squared()).abs() <= 1.0
                    && (d.dot(&half_v) / half_v.norm_squared()).abs() <= 1.0
            }
            Shape::Sphere { .. } => false,
        }
    }
}
