//! Zhang's closed form: the camera matrix and the board poses from plane homographies
//! (Z. Zhang, "A flexible new technique for camera calibration", IEEE TPAMI 22(11), 2000, §3.1).
//!
//! Each homography `H = λ·K·[r1 r2 t]` from the board plane (mm) to the image (pixels) gives
//! two constraints on the image of the absolute conic `B = K⁻ᵀK⁻¹` (`r1`, `r2` orthonormal):
//! `h1ᵀBh2 = 0` and `h1ᵀBh1 = h2ᵀBh2`, linear in `b = (B11, B12, B22, B13, B23, B33)`
//! (`V·b = 0`). Our [`fsm_geometry::Intrinsics`] has no skew, so `B12 = 0` is imposed by
//! dropping that unknown: 5 unknowns up to scale. Zhang needs ≥ 3 planes for the general
//! camera; with zero skew 2 suffice in theory, but we ask for 3, and planes that are all
//! parallel leave `V` rank-deficient (Zhang §3.3) — detected and reported, never a panic.
//! Distortion starts at zero; the Levenberg–Marquardt refinement ([`crate::refine`]) fits it.

use core::fmt;

use nalgebra::{DMatrix, Matrix3, Point2, Rotation3, Vector3};

use crate::homography::{homography, null_vector, HomographyError};

/// Board pose in the camera frame: `X_c = R·X_board + t`, mm.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BoardPose {
    /// Rotation board → camera.
    pub rotation: Rotation3<f64>,
    /// Translation, mm (the board origin in the camera frame).
    pub translation_mm: Vector3<f64>,
}

impl BoardPose {
    /// The camera-frame position of a board point (board plane `z = 0`).
    pub fn to_camera(&self, board_mm: &Point2<f64>) -> nalgebra::Point3<f64> {
        nalgebra::Point3::from(
            self.rotation * Vector3::new(board_mm.x, board_mm.y, 0.0) + self.translation_mm,
        )
    }

    /// The board's normal in the camera frame.
    pub fn normal(&self) -> Vector3<f64> {
        self.rotation * Vector3::z()
    }
}

/// Camera matrix without skew: `(fx, fy, cx, cy)`, pixels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraMatrix {
    /// `fx`.
    pub fx: f64,
    /// `fy`.
    pub fy: f64,
    /// `cx`.
    pub cx: f64,
    /// `cy`.
    pub cy: f64,
}

impl CameraMatrix {
    /// `K`.
    pub fn matrix(&self) -> Matrix3<f64> {
        Matrix3::new(self.fx, 0.0, self.cx, 0.0, self.fy, self.cy, 0.0, 0.0, 1.0)
    }
}

/// Why Zhang's closed form failed.
#[derive(Clone, Debug, PartialEq)]
pub enum ZhangError {
    /// Fewer than 3 poses.
    TooFewPoses {
        /// Poses given.
        given: usize,
    },
    /// A pose's homography could not be fitted.
    Homography {
        /// Pose index.
        pose: usize,
        /// Why.
        error: HomographyError,
    },
    /// The poses do not determine `K` (the board planes are parallel, or nearly).
    Degenerate {
        /// What was seen.
        reason: String,
    },
}

impl fmt::Display for ZhangError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ZhangError::TooFewPoses { given } => write!(
                f,
                "{given} board poses given; Zhang's method needs at least 3 (tilted differently)"
            ),
            ZhangError::Homography { pose, error } => {
                write!(f, "pose {pose}: board-to-image homography: {error}")
            }
            ZhangError::Degenerate { reason } => write!(
                f,
                "the board poses do not determine the camera ({reason}); tilt the board by 10-45 degrees in different directions"
            ),
        }
    }
}

impl std::error::Error for ZhangError {}

/// Fewest poses accepted.
pub const MIN_POSES: usize = 3;
/// Below this angle (degrees) between every pair of board normals the poses count as parallel.
pub const MIN_TILT_SPREAD_DEG: f64 = 2.0;

/// `v_ij` of Zhang's eq. (8) without the `B12` entry.
fn v(h: &Matrix3<f64>, i: usize, j: usize) -> [f64; 5] {
    let (hi, hj) = (h.column(i), h.column(j));
    [
        hi[0] * hj[0],
        hi[1] * hj[1],
        hi[2] * hj[0] + hi[0] * hj[2],
        hi[2] * hj[1] + hi[1] * hj[2],
        hi[2] * hj[2],
    ]
}

/// `K` from homographies board (mm) → image (px), zero skew.
pub fn camera_matrix(homographies: &[Matrix3<f64>]) -> Result<CameraMatrix, ZhangError> {
    if homographies.len() < MIN_POSES {
        return Err(ZhangError::TooFewPoses {
            given: homographies.len(),
        });
    }
    // Precondition: image coordinates are scaled by a nominal focal-like factor so the entries
    // of V are of similar magnitude (the result is unscaled afterwards). Using the mean of
    // |H[0..2, 2]| (the image of the board origin) as the scale keeps everything O(1).
    let s = homographies
        .iter()
        .map(|h| {
            (h[(0, 2)] / h[(2, 2)])
                .abs()
                .max((h[(1, 2)] / h[(2, 2)]).abs())
        })
        .sum::<f64>()
        / homographies.len() as f64;
    let s = if s.is_finite() && s > 1.0 { s } else { 1.0 };
    let n = Matrix3::new(1.0 / s, 0.0, 0.0, 0.0, 1.0 / s, 0.0, 0.0, 0.0, 1.0);
    let mut a = DMatrix::zeros(2 * homographies.len(), 5);
    for (k, h) in homographies.iter().enumerate() {
        let h = n * h;
        let h = h / h.norm();
        let v12 = v(&h, 0, 1);
        let v11 = v(&h, 0, 0);
        let v22 = v(&h, 1, 1);
        for j in 0..5 {
            a[(2 * k, j)] = v12[j];
            a[(2 * k + 1, j)] = v11[j] - v22[j];
        }
    }
    let (b, gap) = null_vector(&a).ok_or_else(|| ZhangError::Degenerate {
        reason: "the SVD of V failed".into(),
    })?;
    if gap < 1e-7 {
        return Err(ZhangError::Degenerate {
            reason: format!("V·b = 0 has more than one solution (singular value ratio {gap:.1e})"),
        });
    }
    let (mut b11, mut b22, mut b13, mut b23, mut b33) = (b[0], b[1], b[2], b[3], b[4]);
    if b11 < 0.0 {
        b11 = -b11;
        b22 = -b22;
        b13 = -b13;
        b23 = -b23;
        b33 = -b33;
    }
    // Zhang's Appendix B with B12 = 0.
    let degenerate = |what: &str| ZhangError::Degenerate {
        reason: format!("{what} (the image of the absolute conic is not positive definite)"),
    };
    if !(b11 > 0.0 && b22 > 0.0) {
        return Err(degenerate("B11 or B22 is not positive"));
    }
    let v0 = -b23 / b22;
    let lambda = b33 - (b13 * b13 + v0 * (-b11 * b23)) / b11;
    if lambda.is_nan() || lambda <= 0.0 {
        return Err(degenerate("lambda is not positive"));
    }
    let alpha = (lambda / b11).sqrt();
    let beta = (lambda / b22).sqrt();
    let u0 = -b13 * alpha * alpha / lambda;
    let k = CameraMatrix {
        fx: alpha * s,
        fy: beta * s,
        cx: u0 * s,
        cy: v0 * s,
    };
    if ![k.fx, k.fy, k.cx, k.cy].iter().all(|x| x.is_finite()) {
        return Err(degenerate("K is not finite"));
    }
    Ok(k)
}

/// Board pose from its homography and `K` (Zhang §3.1), with `R` re-orthonormalised (the
/// nearest rotation in Frobenius norm, Zhang's Appendix C, via SVD) and the board in front of
/// the camera.
pub fn board_pose(h: &Matrix3<f64>, k: &CameraMatrix) -> Option<BoardPose> {
    let k_inv = k.matrix().try_inverse()?;
    let m = k_inv * h;
    let (m1, m2, m3) = (m.column(0), m.column(1), m.column(2));
    let mut lambda = 1.0 / m1.norm();
    if m3[2] * lambda < 0.0 {
        lambda = -lambda;
    }
    let r1 = m1 * lambda;
    let r2 = m2 * lambda;
    let r3 = r1.cross(&r2);
    let t = m3 * lambda;
    let q = Matrix3::from_columns(&[r1, r2, r3]);
    let svd = q.svd(true, true);
    let (u, v_t) = (svd.u?, svd.v_t?);
    let mut r = u * v_t;
    if r.determinant() < 0.0 {
        let mut u = u;
        u.column_mut(2).neg_mut();
        r = u * v_t;
    }
    if !t.iter().all(|x| x.is_finite()) {
        return None;
    }
    Some(BoardPose {
        rotation: Rotation3::from_matrix_unchecked(r),
        translation_mm: t,
    })
}

/// Zhang's initial estimate: `K` and every board pose.
#[derive(Clone, Debug, PartialEq)]
pub struct ZhangEstimate {
    /// Camera matrix.
    pub camera: CameraMatrix,
    /// Board → camera per pose.
    pub poses: Vec<BoardPose>,
    /// Board-to-image homographies per pose.
    pub homographies: Vec<Matrix3<f64>>,
}

/// Homographies, `K`, then the poses. `board_mm` are the board's corners (plane `z = 0`),
/// `images[i]` their pixels in pose `i` (same order).
pub fn initial_estimate(
    board_mm: &[Point2<f64>],
    images: &[Vec<Point2<f64>>],
) -> Result<ZhangEstimate, ZhangError> {
    if images.len() < MIN_POSES {
        return Err(ZhangError::TooFewPoses {
            given: images.len(),
        });
    }
    let homographies = images
        .iter()
        .enumerate()
        .map(|(pose, img)| {
            homography(board_mm, img).map_err(|error| ZhangError::Homography { pose, error })
        })
        .collect::<Result<Vec<_>, _>>()?;
    let camera = camera_matrix(&homographies)?;
    let poses = homographies
        .iter()
        .map(|h| {
            board_pose(h, &camera).ok_or_else(|| ZhangError::Degenerate {
                reason: "a board pose could not be recovered from K".into(),
            })
        })
        .collect::<Result<Vec<_>, _>>()?;
    let mut spread: f64 = 0.0;
    for (i, a) in poses.iter().enumerate() {
        for b in &poses[i + 1..] {
            let c = a.normal().dot(&b.normal()).clamp(-1.0, 1.0);
            spread = spread.max(c.acos().to_degrees());
        }
    }
    if spread < MIN_TILT_SPREAD_DEG {
        return Err(ZhangError::Degenerate {
            reason: format!("the board planes are parallel within {spread:.2} degrees"),
        });
    }
    Ok(ZhangEstimate {
        camera,
        poses,
        homographies,
    })
}
