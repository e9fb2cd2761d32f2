//! Triangulation of candidates (SPEC §5): the point on a camera pixel's ray whose projection
//! into the projector has the candidate's column coordinate.
//!
//! Without projector distortion the column is a plane through the projector centre and the
//! point is a closed-form ray–plane intersection. With distortion the column's preimage is a
//! curved surface; the point is found by a bracketed 1-D solve (Brent) of
//! `column(z) = c` over the depths `z ∈ [near, far]` of the measurement volume. Along a ray the
//! column changes monotonically there (the ray's image is a segment of the epipolar line, and
//! [`Pinhole::new`](crate::Pinhole::new) rejects distortions that fold the image), so the
//! column is reachable exactly when it lies between the columns at the two depth limits, and
//! [`PixelRay::column_range`] is that interval — the decoder's per-pixel column limits.

use core::fmt;

use nalgebra::{Point2, Point3, Vector3};

use crate::calibration::Calibration;
use crate::distortion::UndistortError;

/// Columns a pixel can see inside the measurement volume (inclusive, `first ≤ last`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ColumnInterval {
    /// Smallest column.
    pub first: f64,
    /// Largest column.
    pub last: f64,
}

impl ColumnInterval {
    /// Whether `column` lies in the interval.
    pub fn contains(&self, column: f64) -> bool {
        column >= self.first && column <= self.last
    }

    /// The interval grown by `margin` columns on each side (decoder tolerance, blur).
    pub fn widened(&self, margin: f64) -> Self {
        ColumnInterval {
            first: self.first - margin,
            last: self.last + margin,
        }
    }

    /// As the decoder's per-pixel limit.
    pub fn to_column_range(&self) -> fsm_core::ColumnRange {
        fsm_core::ColumnRange {
            first: self.first as f32,
            last: self.last as f32,
        }
    }
}

/// Why a candidate has no point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum TriangulationError {
    /// The camera pixel has no ray (outside the invertible part of the camera's distortion).
    Pixel {
        /// The pixel.
        pixel: (f64, f64),
        /// Why.
        reason: UndistortError,
    },
    /// The projector does not see the pixel's ray at a depth limit (behind it, or beyond its
    /// distortion model's valid field).
    ProjectorCannotSee {
        /// The pixel.
        pixel: (f64, f64),
        /// The depth, mm.
        depth_mm: f64,
    },
    /// The column's plane contains the ray or is parallel to it.
    Degenerate {
        /// The pixel.
        pixel: (f64, f64),
        /// The column.
        column: f64,
    },
    /// The column is not seen by this pixel inside the measurement volume.
    NotInVolume {
        /// The pixel.
        pixel: (f64, f64),
        /// The column.
        column: f64,
        /// The columns the pixel sees between the depth limits.
        reachable: ColumnInterval,
    },
}

impl fmt::Display for TriangulationError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            TriangulationError::Pixel { pixel, reason } => {
                write!(f, "pixel ({:.2}, {:.2}): {reason}", pixel.0, pixel.1)
            }
            TriangulationError::ProjectorCannotSee { pixel, depth_mm } => write!(
                f,
                "pixel ({:.2}, {:.2}): the projector does not see its ray at depth {depth_mm} mm",
                pixel.0, pixel.1
            ),
            TriangulationError::Degenerate { pixel, column } => write!(
                f,
                "pixel ({:.2}, {:.2}), column {column}: the ray is parallel to the column's plane",
                pixel.0, pixel.1
            ),
            TriangulationError::NotInVolume {
                pixel,
                column,
                reachable,
            } => write!(
                f,
                "pixel ({:.2}, {:.2}): column {column} is outside the columns {:.3}..{:.3} it sees inside the measurement volume",
                pixel.0, pixel.1, reachable.first, reachable.last
            ),
        }
    }
}

impl std::error::Error for TriangulationError {}

/// The ray of one camera pixel, undistorted once and reused for all its candidates.
#[derive(Clone, Copy, Debug)]
pub struct PixelRay<'c> {
    calibration: &'c Calibration,
    pixel: Point2<f64>,
    /// `(x, y, 1)` in the camera frame: the point at depth `z` is `z·direction`.
    direction: Vector3<f64>,
}

/// Columns this close to a limit of the reachable range (relative) count as inside it.
const COLUMN_SLACK: f64 = 1e-9;

/// Depth tolerance of the 1-D solve, as a fraction of the far limit.
const DEPTH_TOLERANCE: f64 = 1e-12;

impl Calibration {
    /// The ray of a camera pixel (SPEC §1 coordinates).
    pub fn pixel_ray(&self, pixel: Point2<f64>) -> Result<PixelRay<'_>, TriangulationError> {
        let direction = self
            .camera
            .ray(pixel)
            .map_err(|reason| TriangulationError::Pixel {
                pixel: (pixel.x, pixel.y),
                reason,
            })?;
        Ok(PixelRay {
            calibration: self,
            pixel,
            direction,
        })
    }

    /// The 3D point (camera frame, mm) of the candidate `(pixel, column)`, inside the volume.
    pub fn triangulate(
        &self,
        pixel: Point2<f64>,
        column: f64,
    ) -> Result<Point3<f64>, TriangulationError> {
        self.pixel_ray(pixel)?.triangulate(column)
    }

    /// The columns a pixel sees between the volume's depth limits.
    pub fn column_range(&self, pixel: Point2<f64>) -> Result<ColumnInterval, TriangulationError> {
        self.pixel_ray(pixel)?.column_range()
    }
}

impl PixelRay<'_> {
    /// The pixel.
    pub fn pixel(&self) -> Point2<f64> {
        self.pixel
    }

    /// `(x, y, 1)`, camera frame.
    pub fn direction(&self) -> Vector3<f64> {
        self.direction
    }

    /// The point of the ray at camera depth `depth_mm`.
    pub fn point_at_depth(&self, depth_mm: f64) -> Point3<f64> {
        Point3::from(self.direction * depth_mm)
    }

    /// Projector column of the ray's point at `depth_mm`.
    pub fn column_at_depth(&self, depth_mm: f64) -> Option<f64> {
        self.calibration
            .projector_column_of(&self.point_at_depth(depth_mm))
    }

    fn pixel_tuple(&self) -> (f64, f64) {
        (self.pixel.x, self.pixel.y)
    }

    fn column_at_limit(&self, depth_mm: f64) -> Result<f64, TriangulationError> {
        self.column_at_depth(depth_mm)
            .ok_or(TriangulationError::ProjectorCannotSee {
                pixel: self.pixel_tuple(),
                depth_mm,
            })
    }

    /// The columns the ray shows the projector between the depth limits.
    pub fn column_range(&self) -> Result<ColumnInterval, TriangulationError> {
        let v = &self.calibration.volume;
        let a = self.column_at_limit(v.near_mm())?;
        let b = self.column_at_limit(v.far_mm())?;
        Ok(ColumnInterval {
            first: a.min(b),
            last: a.max(b),
        })
    }

    /// Depth where the ray meets the plane of `column`, ignoring projector distortion and the
    /// volume (closed form; `None` when parallel or behind the projector).
    pub fn depth_of_column_plane(&self, column: f64) -> Option<f64> {
        let cal = self.calibration;
        let k = cal.projector.intrinsics();
        let xn = (column - k.cx_px) / k.fx_px;
        // The column's plane in the projector frame: x − xn·z = 0, normal (1, 0, −xn).
        let normal = Vector3::new(1.0, 0.0, -xn);
        let d = cal.pose.direction_to_projector(&self.direction);
        let denom = normal.dot(&d);
        let scale = normal.norm() * d.norm();
        if denom.abs() <= 1e-12 * scale {
            return None;
        }
        let depth = -normal.dot(cal.pose.translation_mm()) / denom;
        let p = cal.pose.to_projector(&self.point_at_depth(depth));
        (depth.is_finite() && p.z > 0.0).then_some(depth)
    }

    /// The point of `column` on this ray, inside the measurement volume.
    pub fn triangulate(&self, column: f64) -> Result<Point3<f64>, TriangulationError> {
        let cal = self.calibration;
        let range = self.column_range()?;
        let not_in_volume = TriangulationError::NotInVolume {
            pixel: self.pixel_tuple(),
            column,
            reachable: range,
        };
        // Columns computed at a depth limit may round a hair outside the range.
        let slack = COLUMN_SLACK * (1.0 + column.abs());
        if !column.is_finite() || !range.widened(slack).contains(column) {
            return Err(not_in_volume);
        }
        let column = column.clamp(range.first, range.last);
        let depth = if cal.projector.distortion().is_none() {
            let depth =
                self.depth_of_column_plane(column)
                    .ok_or(TriangulationError::Degenerate {
                        pixel: self.pixel_tuple(),
                        column,
                    })?;
            // Columns at the limits were checked; clamp the rounding of the closed form.
            depth.clamp(cal.volume.near_mm(), cal.volume.far_mm())
        } else {
            self.solve_depth(column).ok_or(not_in_volume)?
        };
        Ok(self.point_at_depth(depth))
    }

    /// Brent's method on `column(z) − c` over the volume's depths (bracketed by the caller's
    /// range check).
    fn solve_depth(&self, column: f64) -> Option<f64> {
        let v = &self.calibration.volume;
        let f = |z: f64| self.column_at_depth(z).map(|c| c - column);
        brent(f, v.near_mm(), v.far_mm(), DEPTH_TOLERANCE * v.far_mm())
    }
}

/// Brent's root finder on `[a, b]` with `f(a)·f(b) ≤ 0`; `None` if `f` is undefined somewhere it
/// looks or the bracket is not a bracket.
fn brent(f: impl Fn(f64) -> Option<f64>, mut a: f64, mut b: f64, tol: f64) -> Option<f64> {
    let mut fa = f(a)?;
    let mut fb = f(b)?;
    if fa == 0.0 {
        return Some(a);
    }
    if fb == 0.0 {
        return Some(b);
    }
    if fa.signum() == fb.signum() {
        return None;
    }
    let (mut c, mut fc) = (a, fa);
    let mut d = b - a;
    let mut e = d;
    for _ in 0..200 {
        if fb.signum() == fc.signum() {
            c = a;
            fc = fa;
            d = b - a;
            e = d;
        }
        if fc.abs() < fb.abs() {
            a = b;
            b = c;
            c = a;
            fa = fb;
            fb = fc;
            fc = fa;
        }
        let tol1 = 2.0 * f64::EPSILON * b.abs() + 0.5 * tol;
        let xm = 0.5 * (c - b);
        if xm.abs() <= tol1 || fb == 0.0 {
            return Some(b);
        }
        if e.abs() >= tol1 && fa.abs() > fb.abs() {
            let s = fb / fa;
            let (mut p, mut q);
            if a == c {
                p = 2.0 * xm * s;
                q = 1.0 - s;
            } else {
                let qq = fa / fc;
                let r = fb / fc;
                p = s * (2.0 * xm * qq * (qq - r) - (b - a) * (r - 1.0));
                q = (qq - 1.0) * (r - 1.0) * (s - 1.0);
            }
            if p > 0.0 {
                q = -q;
            }
            p = p.abs();
            let min1 = 3.0 * xm * q - (tol1 * q).abs();
            let min2 = (e * q).abs();
            if 2.0 * p < min1.min(min2) {
                e = d;
                d = p / q;
            } else {
                d = xm;
                e = d;
            }
        } else {
            d = xm;
            e = d;
        }
        a = b;
        fa = fb;
        b += if d.abs() > tol1 { d } else { tol1.copysign(xm) };
        fb = f(b)?;
    }
    Some(b)
}
