//! Surfaces the simulator traces: rectangles, spheres and the two colours of a printed
//! checkerboard, with their materials (the glossy one's BRDF: [`super::brdf`]).

use nalgebra::{Point3, Unit, Vector3};

use super::brdf::CookTorrance;

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
    /// One colour of a checkerboard printed on a plane: its dark squares (`dark`), or its light
    /// squares together with the margin around the squares (`!dark`). The two colours of one
    /// board tile it exactly (every point of the board is in one of them, by the same
    /// floor-division test), so a board is two coplanar surfaces of different albedo and the
    /// camera's footprint integration anti-aliases its edges like any other surface border.
    ///
    /// Board coordinates of a point `p` of the plane: `bx = (p − origin)·axis_x`,
    /// `by = (p − origin)·axis_y`. Inner corner `(c, r)` is at `(c, r)·square_mm`; the squares
    /// cover `bx ∈ [−s, inner[0]·s]`, `by ∈ [−s, inner[1]·s]` (`s = square_mm`), the square
    /// `[a·s, (a+1)·s) × [b·s, (b+1)·s)` is dark when `a + b` is even (the square diagonally
    /// outside corner (0, 0) is dark), and the margin extends `margin_mm` beyond the squares.
    /// Front normal `axis_x × axis_y` (into the board when it faces the camera).
    Checker {
        /// Inner corner (0, 0), mm.
        origin: Point3<f64>,
        /// Unit vector along the board's rows (board `+x`).
        axis_x: Vector3<f64>,
        /// Unit vector down the board's columns (board `+y`), perpendicular to `axis_x`.
        axis_y: Vector3<f64>,
        /// Side of a square, mm.
        square_mm: f64,
        /// Inner corners along `+x` and along `+y`.
        inner: [u32; 2],
        /// Width of the margin around the squares, mm (light).
        margin_mm: f64,
        /// The dark squares (`true`) or the light squares and the margin (`false`).
        dark: bool,
    },
}

/// Which colour of a checkerboard the board point `(bx, by)` (mm) has: `Some(true)` dark,
/// `Some(false)` light (a light square or the margin), `None` off the board. See
/// [`Shape::Checker`].
pub fn checker_colour(
    bx: f64,
    by: f64,
    square_mm: f64,
    inner: [u32; 2],
    margin_mm: f64,
) -> Option<bool> {
    let s = square_mm;
    let (wx, wy) = (inner[0] as f64 * s, inner[1] as f64 * s);
    if !(bx >= -s - margin_mm
        && bx <= wx + margin_mm
        && by >= -s - margin_mm
        && by <= wy + margin_mm)
    {
        return None;
    }
    if bx < -s || bx >= wx || by < -s || by >= wy {
        return Some(false);
    }
    let a = (bx / s).floor() as i64;
    let b = (by / s).floor() as i64;
    Some((a + b).rem_euclid(2) == 0)
}

/// How a surface reflects light.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Material {
    /// Lambertian on both sides, reflectance `albedo ∈ [0, 1]`.
    Diffuse {
        /// Hemispherical reflectance.
        albedo: f64,
    },
    /// Rough metal on both sides: the Cook–Torrance GGX BRDF of [`CookTorrance`] with
    /// Schlick reflectance `f0` at normal incidence and GGX roughness `roughness` (`α`).
    Glossy {
        /// Reflectance at normal incidence, `F₀ ∈ [0, 1]`.
        f0: f64,
        /// GGX `α` (0.2: a rough, brushed metal).
        roughness: f64,
    },
    /// A perfect mirror on the front side with reflectance `reflectance`; black behind.
    Mirror {
        /// Fraction of light reflected.
        reflectance: f64,
    },
    /// Absorbs everything (a covered mirror, a light trap); still occludes.
    Black,
}

impl Material {
    /// `π·f_r`, the BRDF relative to a white Lambertian surface (the albedo of a diffuse
    /// surface), for unit directions to the light and to the viewer on the side of the unit
    /// normal `n`: a point lit with `E` reference whites of irradiance sends the camera
    /// `relative_brdf · E` reference whites. 0 for mirrors (a delta) and black surfaces.
    pub fn relative_brdf(
        &self,
        n: &Vector3<f64>,
        to_light: &Vector3<f64>,
        to_viewer: &Vector3<f64>,
    ) -> f64 {
        if let Some(brdf) = self.cook_torrance() {
            return std::f64::consts::PI * brdf.value(n, to_light, to_viewer);
        }
        match *self {
            Material::Diffuse { albedo } => albedo,
            _ => 0.0,
        }
    }

    /// The BRDF of a glossy material; `None` for the others.
    pub fn cook_torrance(&self) -> Option<CookTorrance> {
        match *self {
            Material::Glossy { f0, roughness } => Some(CookTorrance {
                f0,
                alpha: roughness,
            }),
            _ => None,
        }
    }

    /// Whether the camera measures the surface: it scatters light (diffuse or glossy), so a
    /// camera ray ends there.
    pub fn scatters(&self) -> bool {
        matches!(self, Material::Diffuse { .. } | Material::Glossy { .. })
    }
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
            Shape::Checker {
                origin: o,
                axis_x,
                axis_y,
                square_mm,
                inner,
                margin_mm,
                dark,
            } => {
                let n = axis_x.cross(&axis_y);
                let denom = n.dot(dir);
                if denom == 0.0 {
                    return None;
                }
                let t = n.dot(&(o - origin)) / denom;
                if !(t > t_min && t < t_max) {
                    return None;
                }
                let p = origin + dir * t;
                let d = p - o;
                let colour =
                    checker_colour(d.dot(&axis_x), d.dot(&axis_y), square_mm, inner, margin_mm)?;
                (colour == dark).then(|| (t, p, Unit::new_normalize(n)))
            }
        }
    }

    /// The plane of a rectangle or a checker colour: `(a point of it, unit front normal)`.
    pub fn plane(&self) -> Option<(Point3<f64>, Unit<Vector3<f64>>)> {
        match *self {
            Shape::Rectangle {
                centre,
                half_u,
                half_v,
            } => Some((centre, Unit::new_normalize(half_u.cross(&half_v)))),
            Shape::Checker {
                origin,
                axis_x,
                axis_y,
                ..
            } => Some((origin, Unit::new_normalize(axis_x.cross(&axis_y)))),
            Shape::Sphere { .. } => None,
        }
    }

    /// Whether a point of the rectangle's (or the checker colour's) plane lies inside it.
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
            Shape::Checker {
                origin,
                axis_x,
                axis_y,
                square_mm,
                inner,
                margin_mm,
                dark,
            } => {
                let d = p - origin;
                checker_colour(d.dot(&axis_x), d.dot(&axis_y), square_mm, inner, margin_mm)
                    == Some(dark)
            }
            Shape::Sphere { .. } => false,
        }
    }
}
