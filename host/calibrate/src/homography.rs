//! Plane-to-image homographies and the local camera-pixel → projector-column map.
//!
//! * [`homography`]: the normalised direct linear transform (Hartley & Zisserman, *Multiple View
//!   Geometry*, alg. 4.2): both point sets are shifted to their centroid and scaled to a mean
//!   distance of √2 before the SVD, which makes the solve well conditioned whatever the units
//!   (board millimetres, image pixels). Zhang's method starts from these.
//! * [`local_column`]: the projector column of a checkerboard corner, after Moreno & Taubin,
//!   "Simple, accurate, and robust projector-camera calibration" (3DIMPVT 2012). They fit a
//!   local homography from the decoded projector coordinates around each corner and evaluate
//!   it at the corner's sub-pixel position, because the decoded coordinates are smooth on the
//!   plane while the corner itself (dark squares meet) decodes badly. An FSM scan decodes
//!   columns only, so here the fit is the *column row* of that homography, the 1-D projective
//!   map `c = (a·x + b·y + e)/(g·x + h·y + 1)`, fitted over the window's valid pixels with a
//!   robust re-weighting that drops outliers (dark pixels, interreflections).

use core::fmt;

use nalgebra::{DMatrix, Matrix3, Point2, Vector3};

/// Why a homography or a local column could not be fitted.
#[derive(Clone, Debug, PartialEq)]
pub enum HomographyError {
    /// Fewer point pairs than the model needs.
    TooFewPoints {
        /// Pairs given (or valid pixels in the window).
        given: usize,
        /// Pairs needed.
        needed: usize,
    },
    /// The points are (nearly) collinear or coincident: the model is not determined.
    Degenerate,
    /// A coordinate is NaN or infinite.
    NotFinite,
    /// The two point lists have different lengths.
    LengthMismatch {
        /// Source points.
        source: usize,
        /// Destination points.
        destination: usize,
    },
}

impl fmt::Display for HomographyError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            HomographyError::TooFewPoints { given, needed } => {
                write!(f, "{given} point pairs given, at least {needed} needed")
            }
            HomographyError::Degenerate => {
                write!(f, "the points are collinear or coincident: no unique fit")
            }
            HomographyError::NotFinite => write!(f, "a coordinate is not a finite number"),
            HomographyError::LengthMismatch {
                source,
                destination,
            } => write!(
                f,
                "{source} source points but {destination} destination points"
            ),
        }
    }
}

impl std::error::Error for HomographyError {}

/// Similarity `T` (shift to the centroid, isotropic scale to mean distance √2) of Hartley's
/// normalisation; `None` when the points coincide.
pub fn normalising_transform(points: &[Point2<f64>]) -> Option<Matrix3<f64>> {
    let n = points.len() as f64;
    if points.is_empty() {
        return None;
    }
    let cx = points.iter().map(|p| p.x).sum::<f64>() / n;
    let cy = points.iter().map(|p| p.y).sum::<f64>() / n;
    let mean = points
        .iter()
        .map(|p| ((p.x - cx).powi(2) + (p.y - cy).powi(2)).sqrt())
        .sum::<f64>()
        / n;
    if !(mean.is_finite() && mean > 0.0) {
        return None;
    }
    let s = std::f64::consts::SQRT_2 / mean;
    Some(Matrix3::new(
        s,
        0.0,
        -s * cx,
        0.0,
        s,
        -s * cy,
        0.0,
        0.0,
        1.0,
    ))
}

fn apply(t: &Matrix3<f64>, p: &Point2<f64>) -> Point2<f64> {
    let v = t * Vector3::new(p.x, p.y, 1.0);
    Point2::new(v.x / v.z, v.y / v.z)
}

/// Maps a point through a homography (`None` at the line at infinity).
pub fn transform(h: &Matrix3<f64>, p: &Point2<f64>) -> Option<Point2<f64>> {
    let v = h * Vector3::new(p.x, p.y, 1.0);
    if v.z.abs() < 1e-300 {
        return None;
    }
    Some(Point2::new(v.x / v.z, v.y / v.z))
}

/// Unit null vector of `a` (right singular vector of the smallest singular value) and the ratio
/// of the two smallest singular values' gap: `σ_{n−2}/σ_0` (how far from a 2-D null space).
/// Pads `a` with zero rows so the SVD is full whatever its shape.
pub(crate) fn null_vector(a: &DMatrix<f64>) -> Option<(nalgebra::DVector<f64>, f64)> {
    let n = a.ncols();
    let a = if a.nrows() < n {
        let mut padded = DMatrix::zeros(n, n);
        padded.rows_mut(0, a.nrows()).copy_from(a);
        padded
    } else {
        a.clone()
    };
    let svd = a.svd(false, true);
    let v_t = svd.v_t?;
    let s = &svd.singular_values;
    // nalgebra sorts singular values in descending order.
    let (imin, _) = s
        .iter()
        .enumerate()
        .min_by(|x, y| x.1.total_cmp(y.1))
        .expect("n > 0");
    let mut sorted: Vec<f64> = s.iter().copied().collect();
    sorted.sort_by(|x, y| y.total_cmp(x));
    let gap = if sorted[0] > 0.0 {
        sorted[n - 2] / sorted[0]
    } else {
        0.0
    };
    Some((v_t.row(imin).transpose(), gap))
}

/// Below this `σ_{n−2}/σ_0` the homogeneous system has (numerically) more than one solution.
const RANK_TOLERANCE: f64 = 1e-9;

/// The homography `H` with `dst ~ H·src` from ≥ 4 point pairs (normalised DLT), scaled so that
/// `H[(2, 2)] = 1` when possible (else unit Frobenius norm).
pub fn homography(
    src: &[Point2<f64>],
    dst: &[Point2<f64>],
) -> Result<Matrix3<f64>, HomographyError> {
    if src.len() != dst.len() {
        return Err(HomographyError::LengthMismatch {
            source: src.len(),
            destination: dst.len(),
        });
    }
    if src.len() < 4 {
        return Err(HomographyError::TooFewPoints {
            given: src.len(),
            needed: 4,
        });
    }
    if src
        .iter()
        .chain(dst)
        .any(|p| !(p.x.is_finite() && p.y.is_finite()))
    {
        return Err(HomographyError::NotFinite);
    }
    let ts = normalising_transform(src).ok_or(HomographyError::Degenerate)?;
    let td = normalising_transform(dst).ok_or(HomographyError::Degenerate)?;
    let mut a = DMatrix::zeros(2 * src.len(), 9);
    for (i, (s, d)) in src.iter().zip(dst).enumerate() {
        let s = apply(&ts, s);
        let d = apply(&td, d);
        let (x, y, u, v) = (s.x, s.y, d.x, d.y);
        let r0 = [-x, -y, -1.0, 0.0, 0.0, 0.0, u * x, u * y, u];
        let r1 = [0.0, 0.0, 0.0, -x, -y, -1.0, v * x, v * y, v];
        for j in 0..9 {
            a[(2 * i, j)] = r0[j];
            a[(2 * i + 1, j)] = r1[j];
        }
    }
    let (h, gap) = null_vector(&a).ok_or(HomographyError::Degenerate)?;
    if gap < RANK_TOLERANCE {
        return Err(HomographyError::Degenerate);
    }
    let hn = Matrix3::new(h[0], h[1], h[2], h[3], h[4], h[5], h[6], h[7], h[8]);
    let td_inv = td.try_inverse().ok_or(HomographyError::Degenerate)?;
    let mut hm = td_inv * hn * ts;
    if hm.determinant().abs() < 1e-300 {
        return Err(HomographyError::Degenerate);
    }
    if hm[(2, 2)].abs() > 1e-12 * hm.norm() {
        hm /= hm[(2, 2)];
    } else {
        hm /= hm.norm();
    }
    Ok(hm)
}

/// Settings of [`local_column`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LocalColumnSettings {
    /// Half-width of the square window around the corner, pixels (window `2·h + 1` wide).
    pub half_window_px: usize,
    /// Valid pixels needed in the window (at least 5, the map's parameters).
    pub min_pixels: usize,
    /// Pixels farther than this many robust standard deviations from the fit are dropped.
    pub outlier_sigmas: f64,
    /// Pixels nearer the corner than this are left out: the dark and bright squares meet
    /// there and the decoded columns blur across the edges (Moreno & Taubin use the whole
    /// window; 0 keeps every pixel).
    pub exclude_radius_px: f64,
}

impl Default for LocalColumnSettings {
    fn default() -> Self {
        LocalColumnSettings {
            half_window_px: 12,
            min_pixels: 20,
            outlier_sigmas: 3.5,
            exclude_radius_px: 0.0,
        }
    }
}

/// A fitted local map and how well it fits.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LocalColumn {
    /// Projector column at the corner.
    pub column: f64,
    /// The map `(a, b, e, g, h, i)` in coordinates centred on the corner and scaled by
    /// `scale`, columns shifted by `c0`.
    map: [f64; 6],
    corner: Point2<f64>,
    scale: f64,
    c0: f64,
    /// Pixels used in the final fit.
    pub pixels: usize,
    /// RMS residual of those pixels, columns.
    pub rms_columns: f64,
}

impl LocalColumn {
    /// The fitted map at another point near the corner, e.g. where the calibrated camera
    /// model puts the corner: a detected corner off by `δ` px reads a column off by
    /// `δ·∂c/∂x` (≈ 2 columns per pixel on the bench), while the model's position averages
    /// the detection noise of every corner of the pose.
    pub fn at(&self, p: Point2<f64>) -> f64 {
        let (x, y) = (
            (p.x - self.corner.x) * self.scale,
            (p.y - self.corner.y) * self.scale,
        );
        let m = &self.map;
        (m[0] * x + m[1] * y + m[2]) / (m[3] * x + m[4] * y + m[5]) + self.c0
    }
}

/// Fits the 1-D projective map `c = (a·x + b·y + e)/(g·x + h·y + 1)` from camera pixels to
/// decoded projector columns over a window around `corner`, then evaluates it at the corner.
/// `columns[y·width + x]` is the decoded column of pixel `(x, y)`; NaN (or infinite) marks a
/// pixel without a column. Robust: the fit is repeated without the pixels whose residual
/// exceeds [`LocalColumnSettings::outlier_sigmas`] robust standard deviations (MAD).
///
/// Pixel coordinates are normalised around the corner before the homogeneous solve, so the
/// projective terms `g, h` (small over a window) do not spoil the conditioning.
pub fn local_column(
    columns: &[f32],
    width: usize,
    height: usize,
    corner: Point2<f64>,
    settings: &LocalColumnSettings,
) -> Result<LocalColumn, HomographyError> {
    if !(corner.x.is_finite() && corner.y.is_finite()) {
        return Err(HomographyError::NotFinite);
    }
    let needed = settings.min_pixels.max(5);
    if columns.len() < width * height {
        return Err(HomographyError::TooFewPoints { given: 0, needed });
    }
    let h = settings.half_window_px as i64;
    let (cx, cy) = (corner.x.round() as i64, corner.y.round() as i64);
    let mut samples: Vec<(f64, f64, f64)> = Vec::new();
    for y in (cy - h)..=(cy + h) {
        if y < 0 || y >= height as i64 {
            continue;
        }
        for x in (cx - h)..=(cx + h) {
            if x < 0 || x >= width as i64 {
                continue;
            }
            let c = columns[y as usize * width + x as usize];
            if !c.is_finite() {
                continue;
            }
            let (dx, dy) = (x as f64 - corner.x, y as f64 - corner.y);
            if (dx * dx + dy * dy).sqrt() < settings.exclude_radius_px {
                continue;
            }
            samples.push((dx, dy, c as f64));
        }
    }
    let scale = 1.0 / (h.max(1) as f64);
    let mut keep = vec![true; samples.len()];
    let mut last = None;
    for _round in 0..4 {
        let used: Vec<&(f64, f64, f64)> = samples
            .iter()
            .zip(&keep)
            .filter(|(_, k)| **k)
            .map(|(s, _)| s)
            .collect();
        if used.len() < needed {
            return Err(HomographyError::TooFewPoints {
                given: used.len(),
                needed,
            });
        }
        // Columns are shifted by their median so the homogeneous system is balanced.
        let mut cs: Vec<f64> = used.iter().map(|s| s.2).collect();
        let c0 = median(&mut cs);
        let mut a = DMatrix::zeros(used.len(), 6);
        for (i, &&(dx, dy, c)) in used.iter().enumerate() {
            let (x, y, c) = (dx * scale, dy * scale, c - c0);
            // a x + b y + e − c (g x + h y + i) = 0
            let row = [x, y, 1.0, -c * x, -c * y, -c];
            for (j, v) in row.into_iter().enumerate() {
                a[(i, j)] = v;
            }
        }
        let (p, gap) = null_vector(&a).ok_or(HomographyError::Degenerate)?;
        if gap < RANK_TOLERANCE || p[5].abs() < 1e-12 {
            return Err(HomographyError::Degenerate);
        }
        let eval = |x: f64, y: f64| {
            let num = p[0] * x + p[1] * y + p[2];
            let den = p[3] * x + p[4] * y + p[5];
            num / den + c0
        };
        let residuals: Vec<f64> = samples
            .iter()
            .map(|&(dx, dy, c)| c - eval(dx * scale, dy * scale))
            .collect();
        let mut abs_used: Vec<f64> = residuals
            .iter()
            .zip(&keep)
            .filter(|(_, k)| **k)
            .map(|(r, _)| r.abs())
            .collect();
        // 1.4826·MAD estimates σ for Gaussian noise; a floor keeps exact data from rejecting
        // everything on rounding.
        let sigma = (1.4826 * median(&mut abs_used)).max(1e-9);
        let rms = (residuals
            .iter()
            .zip(&keep)
            .filter(|(_, k)| **k)
            .map(|(r, _)| r * r)
            .sum::<f64>()
            / used.len() as f64)
            .sqrt();
        let column = eval(0.0, 0.0);
        last = Some(LocalColumn {
            column,
            map: [p[0], p[1], p[2], p[3], p[4], p[5]],
            corner,
            scale,
            c0,
            pixels: used.len(),
            rms_columns: rms,
        });
        let new_keep: Vec<bool> = residuals
            .iter()
            .map(|r| r.abs() <= settings.outlier_sigmas * sigma)
            .collect();
        if new_keep == keep {
            break;
        }
        keep = new_keep;
    }
    let fit = last.ok_or(HomographyError::Degenerate)?;
    if !fit.column.is_finite() {
        return Err(HomographyError::Degenerate);
    }
    Ok(fit)
}

/// Median of `v` (reordered), the mean of the middle two for an even count; NaN when empty.
pub(crate) fn median(v: &mut [f64]) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(|a, b| a.total_cmp(b));
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}
