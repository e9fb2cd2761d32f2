//! Brown–Conrady lens distortion `(k1, k2, p1, p2, k3)`, OpenCV's model and parameter order.
//!
//! A point `(x, y)` on the normalised image plane (`z = 1`, undistorted) moves to
//!
//! ```text
//! r² = x² + y²,   radial = 1 + k1 r² + k2 r⁴ + k3 r⁶
//! x_d = x·radial + 2 p1 x y + p2 (r² + 2x²)
//! y_d = y·radial + p1 (r² + 2y²) + 2 p2 x y
//! ```
//!
//! exactly as OpenCV's `projectPoints` with 5 coefficients, so an OpenCV calibration imports
//! without conversion. The model is a polynomial: far enough from the axis it folds back on
//! itself (the radial map `r·radial(r)` stops increasing). [`BrownConrady::max_radius`] is where
//! that happens; points beyond it have no meaningful image, and undistortion refuses them.

use nalgebra::{Matrix2, Vector2};

/// Brown–Conrady coefficients in OpenCV's order `(k1, k2, p1, p2, k3)`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct BrownConrady {
    /// Radial, `r²`.
    pub k1: f64,
    /// Radial, `r⁴`.
    pub k2: f64,
    /// Tangential (decentring), first.
    pub p1: f64,
    /// Tangential (decentring), second.
    pub p2: f64,
    /// Radial, `r⁶`.
    pub k3: f64,
}

/// Why a distorted point could not be undistorted.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum UndistortError {
    /// Newton's iteration did not reach the tolerance (the point is outside the region where
    /// the model is invertible).
    NoConvergence {
        /// Residual left, normalised units.
        residual: f64,
    },
    /// The solution lies beyond [`BrownConrady::max_radius`], where the model folds.
    BeyondValidRadius {
        /// Undistorted radius found.
        radius: f64,
        /// Largest radius where the model is monotone.
        max_radius: f64,
    },
}

impl core::fmt::Display for UndistortError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match *self {
            UndistortError::NoConvergence { residual } => write!(
                f,
                "undistortion did not converge (residual {residual:.3e} in normalised units)"
            ),
            UndistortError::BeyondValidRadius { radius, max_radius } => write!(
                f,
                "undistorted radius {radius:.4} is beyond {max_radius:.4}, where the distortion model folds back"
            ),
        }
    }
}

impl std::error::Error for UndistortError {}

/// Undistortion stops when the distorted point is reproduced within this (normalised units;
/// about 1e-9 px for focal lengths of a few thousand pixels).
const UNDISTORT_TOLERANCE: f64 = 1e-12;
const UNDISTORT_MAX_ITERATIONS: usize = 50;
/// Radii searched for the fold of the radial map (r = 10 is 84° off axis).
const RADIUS_SEARCH_LIMIT: f64 = 10.0;

impl BrownConrady {
    /// No distortion.
    pub const NONE: BrownConrady = BrownConrady {
        k1: 0.0,
        k2: 0.0,
        p1: 0.0,
        p2: 0.0,
        k3: 0.0,
    };

    /// From OpenCV's coefficient vector `(k1, k2, p1, p2, k3)`.
    pub fn from_opencv(c: [f64; 5]) -> Self {
        BrownConrady {
            k1: c[0],
            k2: c[1],
            p1: c[2],
            p2: c[3],
            k3: c[4],
        }
    }

    /// OpenCV's coefficient vector `(k1, k2, p1, p2, k3)`.
    pub fn to_opencv(&self) -> [f64; 5] {
        [self.k1, self.k2, self.p1, self.p2, self.k3]
    }

    /// Whether every coefficient is zero (the closed-form triangulation applies).
    pub fn is_none(&self) -> bool {
        self.to_opencv().iter().all(|&c| c == 0.0)
    }

    /// Distorts a normalised point.
    pub fn distort(&self, p: Vector2<f64>) -> Vector2<f64> {
        let (x, y) = (p.x, p.y);
        let r2 = x * x + y * y;
        let radial = 1.0 + r2 * (self.k1 + r2 * (self.k2 + r2 * self.k3));
        Vector2::new(
            x * radial + 2.0 * self.p1 * x * y + self.p2 * (r2 + 2.0 * x * x),
            y * radial + self.p1 * (r2 + 2.0 * y * y) + 2.0 * self.p2 * x * y,
        )
    }

    /// Jacobian `∂(x_d, y_d)/∂(x, y)` at a normalised point.
    pub fn jacobian(&self, p: Vector2<f64>) -> Matrix2<f64> {
        let (x, y) = (p.x, p.y);
        let r2 = x * x + y * y;
        let radial = 1.0 + r2 * (self.k1 + r2 * (self.k2 + r2 * self.k3));
        // d(radial)/d(r²)
        let dradial = self.k1 + r2 * (2.0 * self.k2 + 3.0 * r2 * self.k3);
        let dxdx = radial + 2.0 * x * x * dradial + 2.0 * self.p1 * y + 6.0 * self.p2 * x;
        let dxdy = 2.0 * x * y * dradial + 2.0 * self.p1 * x + 2.0 * self.p2 * y;
        let dydx = 2.0 * x * y * dradial + 2.0 * self.p1 * x + 2.0 * self.p2 * y;
        let dydy = radial + 2.0 * y * y * dradial + 6.0 * self.p1 * y + 2.0 * self.p2 * x;
        Matrix2::new(dxdx, dxdy, dydx, dydy)
    }

    /// The largest undistorted radius up to which the radial map `r·radial(r)` increases
    /// (`+∞` when it never stops within 84° of the axis). Beyond it the model folds back.
    pub fn max_radius(&self) -> f64 {
        // d(r·radial)/dr = 1 + 3k1 s + 5k2 s² + 7k3 s³ with s = r²: find its first root.
        let slope = |s: f64| 1.0 + s * (3.0 * self.k1 + s * (5.0 * self.k2 + s * 7.0 * self.k3));
        let s_limit = RADIUS_SEARCH_LIMIT * RADIUS_SEARCH_LIMIT;
        let steps = 4096;
        let mut lo = 0.0;
        for i in 1..=steps {
            // Quadratic spacing: fine steps near the axis where the image is.
            let t = i as f64 / steps as f64;
            let hi = s_limit * t * t;
            if slope(hi) <= 0.0 {
                let (mut a, mut b) = (lo, hi);
                for _ in 0..80 {
                    let m = 0.5 * (a + b);
                    if slope(m) > 0.0 {
                        a = m;
                    } else {
                        b = m;
                    }
                }
                return a.sqrt();
            }
            lo = hi;
        }
        f64::INFINITY
    }

    /// Inverts [`BrownConrady::distort`] by Newton's method started at the distorted point,
    /// checking convergence and that the solution lies on the monotone part of the model.
    pub fn undistort(&self, q: Vector2<f64>) -> Result<Vector2<f64>, UndistortError> {
        self.undistort_within(q, self.max_radius())
    }

    /// [`BrownConrady::undistort`] with the valid radius already known.
    pub fn undistort_within(
        &self,
        q: Vector2<f64>,
        max_radius: f64,
    ) -> Result<Vector2<f64>, UndistortError> {
        if self.is_none() {
            return Ok(q);
        }
        if !(q.x.is_finite() && q.y.is_finite()) {
            return Err(UndistortError::NoConvergence { residual: f64::NAN });
        }
        let mut p = q;
        let mut residual = f64::INFINITY;
        for _ in 0..UNDISTORT_MAX_ITERATIONS {
            let e = self.distort(p) - q;
            residual = e.norm();
            if residual <= UNDISTORT_TOLERANCE * (1.0 + q.norm()) {
                let radius = p.norm();
                if radius > max_radius {
                    return Err(UndistortError::BeyondValidRadius { radius, max_radius });
                }
                return Ok(p);
            }
            let Some(inv) = self.jacobian(p).try_inverse() else {
                break;
            };
            let mut step = inv * e;
            // Damping: never jump further than the point's own scale (keeps the iteration on
            // the branch that starts at the distorted point).
            let limit = 0.5 * (1.0 + p.norm());
            let len = step.norm();
            if len > limit {
                step *= limit / len;
            }
            p -= step;
            if !(p.x.is_finite() && p.y.is_finite()) {
                break;
            }
        }
        Err(UndistortError::NoConvergence { residual })
    }
}
