//! The projector as an inverse camera observed through its column coordinate only
//! (Moreno & Taubin 2012 calibrate the projector as a camera from local homographies of both
//! projector coordinates; an FSM scan decodes columns only, so each corner gives one equation).
//!
//! Once the camera is calibrated, every corner of every pose has a known camera-frame position
//! `X`; its decoded column `c` (from [`crate::homography::local_column`]) must equal the
//! projector's column of `X`:
//!
//! ```text
//! X_p = R·X + t,   (x, y) = (X_p.x/X_p.z, X_p.y/X_p.z),   c = fx·x_d(x, y) + cx
//! ```
//!
//! with `x_d` the Brown–Conrady distorted `x`. What one column per point can and cannot fix:
//!
//! * `fy`, `cy` and the projector's row count never enter `c`: they are **not identifiable**.
//!   The calibration file gets `fy = fx` (square pixels) and `cy` and the rows as given
//!   ([`ProjectorSettings`]); triangulation uses columns only, so they do not change a point.
//! * Without distortion the columns are a pencil of planes through the projector's vertical
//!   axis (the line through its centre along its `y`). Moving the centre along that axis
//!   changes no column: `t.y` is not identifiable, and is set so that the centre is the point
//!   of the axis nearest the camera centre (`t.y = 0`). With distortion `x_d` depends on `y`
//!   (the `k1·x·y²`, `p1·x·y` terms), so `t.y` becomes weakly observable; it is refined only
//!   when [`ProjectorSettings::refine_vertical_offset`] is set.
//! * `fx`, `cx`, `k1`, `k2` are identifiable from columns; `p2` (through `p2·(3x² + y²)`) and
//!   `p1` (through `2·p1·x·y`) are weakly so; `k3` trades off against `k1`, `k2` over a
//!   projector's narrow field and is fixed at 0 by default.
//!
//! Initialisation (no distortion): the first and third rows of the 3×4 projection matrix,
//! `c·(P3·X̃) = P1·X̃`, are linear in 8 unknowns up to scale: one equation per point, so ≥ 7
//! points not on one plane (corners of ≥ 2 non-parallel poses), solved by SVD after
//! normalising the points and columns (Hartley). `P3 = (r3, t_z)` and
//! `P1 = fx·(r1, t_x) + cx·(r3, t_z)` then give `cx = P1·r3`, `fx`, `r1`, and `r2 = r3 × r1`.

use core::fmt;

use nalgebra::{DMatrix, DVector, Matrix3, Point3, Rotation3, Vector2, Vector3};

use fsm_geometry::{BrownConrady, Pose};

use crate::homography::null_vector;
use crate::refine::{levenberg_marquardt, LmError, LmSettings, Stop};

/// What the projector fit assumes and estimates (default: `fx, cx, k1, k2`, `R`, `t.x`, `t.z`).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ProjectorSettings {
    /// Estimate `p1`, `p2` (weakly identifiable from columns).
    pub refine_tangential: bool,
    /// Estimate `k3`.
    pub refine_k3: bool,
    /// Estimate `t.y` (only observable through the distortion; see the module docs).
    pub refine_vertical_offset: bool,
    /// Solver stopping rules.
    pub lm: LmSettings,
}

/// The projector's column model: the part of a pinhole a column depends on.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ColumnModel {
    /// `fx`, columns per normalised unit.
    pub fx: f64,
    /// `cx`, columns.
    pub cx: f64,
    /// Distortion.
    pub distortion: BrownConrady,
    /// Camera → projector: `X_p = R·X_c + t`.
    pub rotation: Rotation3<f64>,
    /// `t`, mm.
    pub translation_mm: Vector3<f64>,
}

impl ColumnModel {
    /// Column of a camera-frame point, `None` behind the projector.
    pub fn column(&self, x: &Point3<f64>) -> Option<f64> {
        let p = self.rotation * x.coords + self.translation_mm;
        if p.z.is_nan() || p.z <= 0.0 {
            return None;
        }
        let d = self.distortion.distort(Vector2::new(p.x / p.z, p.y / p.z));
        Some(self.fx * d.x + self.cx)
    }

    /// The pose as [`fsm_geometry::Pose`].
    pub fn pose(&self) -> Pose {
        Pose::from_rotation(self.rotation, self.translation_mm)
    }

    fn to_params(self) -> [f64; PROJECTOR_PARAMS] {
        let w = self.rotation.scaled_axis();
        let t = self.translation_mm;
        let d = self.distortion;
        [
            self.fx, self.cx, d.k1, d.k2, d.p1, d.p2, d.k3, w.x, w.y, w.z, t.x, t.y, t.z,
        ]
    }

    fn from_params(p: &[f64]) -> ColumnModel {
        ColumnModel {
            fx: p[0],
            cx: p[1],
            distortion: BrownConrady {
                k1: p[2],
                k2: p[3],
                p1: p[4],
                p2: p[5],
                k3: p[6],
            },
            rotation: Rotation3::new(Vector3::new(p[7], p[8], p[9])),
            translation_mm: Vector3::new(p[10], p[11], p[12]),
        }
    }
}

/// Projector parameters: `fx, cx, k1, k2, p1, p2, k3, rx, ry, rz, tx, ty, tz`.
pub const PROJECTOR_PARAMS: usize = 13;
/// Index of `t.y` in the projector parameters.
pub const TY_INDEX: usize = 11;

/// The free projector parameters for `settings`.
pub fn projector_free_mask(settings: &ProjectorSettings) -> [bool; PROJECTOR_PARAMS] {
    let mut free = [true; PROJECTOR_PARAMS];
    free[4] = settings.refine_tangential;
    free[5] = settings.refine_tangential;
    free[6] = settings.refine_k3;
    free[TY_INDEX] = settings.refine_vertical_offset;
    free
}

/// Why the projector could not be calibrated.
#[derive(Clone, Debug, PartialEq)]
pub enum ProjectorError {
    /// Too few corners with a column.
    TooFewPoints {
        /// Corners with a column.
        given: usize,
        /// Needed.
        needed: usize,
    },
    /// The points do not determine the column planes (all on one plane, or on a line).
    Degenerate {
        /// What was seen.
        reason: String,
    },
    /// The refinement failed.
    Solver(LmError),
}

impl fmt::Display for ProjectorError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ProjectorError::TooFewPoints { given, needed } => write!(
                f,
                "{given} corners have a decoded projector column; at least {needed} (over 2 or more non-parallel poses) are needed"
            ),
            ProjectorError::Degenerate { reason } => write!(
                f,
                "the corners do not determine the projector's column planes ({reason}); use poses tilted differently"
            ),
            ProjectorError::Solver(e) => write!(f, "projector refinement: {e}"),
        }
    }
}

impl std::error::Error for ProjectorError {}

/// Fewest corners with a column for the linear initialisation (8 unknowns up to scale).
pub const MIN_POINTS: usize = 7;

/// Linear initial estimate (no distortion, `t.y = 0`) from camera-frame points and columns.
pub fn initial_column_model(
    points: &[Point3<f64>],
    columns: &[f64],
) -> Result<ColumnModel, ProjectorError> {
    let n = points.len().min(columns.len());
    if n < MIN_POINTS {
        return Err(ProjectorError::TooFewPoints {
            given: n,
            needed: MIN_POINTS,
        });
    }
    // Hartley normalisation in 3-D (mean distance √3) and of the columns.
    let centroid = points.iter().map(|p| p.coords).sum::<Vector3<f64>>() / n as f64;
    let mean = points
        .iter()
        .map(|p| (p.coords - centroid).norm())
        .sum::<f64>()
        / n as f64;
    if !(mean.is_finite() && mean > 0.0) {
        return Err(ProjectorError::Degenerate {
            reason: "the points coincide".into(),
        });
    }
    let s = 3f64.sqrt() / mean;
    let c0 = columns.iter().sum::<f64>() / n as f64;
    let sc = (columns.iter().map(|c| (c - c0).abs()).sum::<f64>() / n as f64).max(1e-9);
    let mut a = DMatrix::zeros(n, 8);
    for i in 0..n {
        let x = (points[i].coords - centroid) * s;
        let c = (columns[i] - c0) / sc;
        let xt = [x.x, x.y, x.z, 1.0];
        for j in 0..4 {
            a[(i, j)] = xt[j];
            a[(i, 4 + j)] = -c * xt[j];
        }
    }
    let (p, gap) = null_vector(&a).ok_or_else(|| ProjectorError::Degenerate {
        reason: "SVD failed".into(),
    })?;
    if gap < 1e-8 {
        return Err(ProjectorError::Degenerate {
            reason: format!(
                "the linear system has more than one solution (singular value ratio {gap:.1e}): the corners lie on one plane"
            ),
        });
    }
    // Undo the normalisation: X_n = s·(X − centroid) = T·X̃, T = [s·I | −s·centroid].
    let t_mat = |q: [f64; 4]| -> [f64; 4] {
        let v = Vector3::new(q[0], q[1], q[2]) * s;
        [v.x, v.y, v.z, q[3] - v.dot(&centroid)]
    };
    let p1n = [p[0], p[1], p[2], p[3]];
    let p3n = [p[4], p[5], p[6], p[7]];
    let mut p1 = t_mat([
        sc * p1n[0] + c0 * p3n[0],
        sc * p1n[1] + c0 * p3n[1],
        sc * p1n[2] + c0 * p3n[2],
        sc * p1n[3] + c0 * p3n[3],
    ]);
    let mut p3 = t_mat(p3n);
    // Scale so that ‖P3[0..3]‖ = 1 with the points in front (P3·X̃ > 0).
    let norm3 = Vector3::new(p3[0], p3[1], p3[2]).norm();
    if norm3.is_nan() || norm3 <= 0.0 {
        return Err(ProjectorError::Degenerate {
            reason: "the depth row vanished".into(),
        });
    }
    let depth0 = p3[0] * centroid.x + p3[1] * centroid.y + p3[2] * centroid.z + p3[3];
    let sign = if depth0 < 0.0 { -1.0 } else { 1.0 };
    for v in p1.iter_mut().chain(p3.iter_mut()) {
        *v *= sign / norm3;
    }
    let r3 = Vector3::new(p3[0], p3[1], p3[2]);
    let q1 = Vector3::new(p1[0], p1[1], p1[2]);
    let cx = q1.dot(&r3);
    let fx_r1 = q1 - cx * r3;
    let fx = fx_r1.norm();
    if !(fx.is_finite() && fx > 0.0) {
        return Err(ProjectorError::Degenerate {
            reason: "the focal length came out zero".into(),
        });
    }
    let r1 = fx_r1 / fx;
    let tx = (p1[3] - cx * p3[3]) / fx;
    let tz = p3[3];
    let r2 = r3.cross(&r1);
    let r = Matrix3::from_rows(&[r1.transpose(), r2.transpose(), r3.transpose()]);
    Ok(ColumnModel {
        fx,
        cx,
        distortion: BrownConrady::NONE,
        rotation: Rotation3::from_matrix_unchecked(r),
        translation_mm: Vector3::new(tx, 0.0, tz),
    })
}

/// The refined projector.
#[derive(Clone, Debug)]
pub struct ProjectorFit {
    /// The column model.
    pub model: ColumnModel,
    /// Column residuals (observed − predicted) per pose and corner; `None` where the corner
    /// had no column.
    pub residuals: Vec<Vec<Option<f64>>>,
    /// RMS per pose, columns.
    pub rms_columns: Vec<f64>,
    /// Over all poses.
    pub rms_total_columns: f64,
    /// Standard deviations of `fx, cx, k1, k2, p1, p2, k3, rx, ry, rz, tx, ty, tz`.
    pub std_dev: [f64; PROJECTOR_PARAMS],
    /// Solver iterations.
    pub iterations: usize,
    /// Why LM stopped.
    pub stop: Stop,
}

/// Column residuals of all poses, flattened over the corners that have a column.
pub(crate) fn column_residuals(
    model: &ColumnModel,
    points: &[Vec<Point3<f64>>],
    columns: &[Vec<Option<f64>>],
    out: &mut Vec<f64>,
) -> Option<()> {
    for (pts, cols) in points.iter().zip(columns) {
        for (x, c) in pts.iter().zip(cols) {
            if let Some(c) = c {
                out.push(c - model.column(x)?);
            }
        }
    }
    Some(())
}

/// Splits flattened residuals back into poses and corners.
pub(crate) fn unflatten(
    flat: &[f64],
    columns: &[Vec<Option<f64>>],
) -> (Vec<Vec<Option<f64>>>, Vec<f64>, f64) {
    let mut k = 0;
    let mut per_pose = Vec::new();
    let mut rms = Vec::new();
    let (mut sum, mut count) = (0.0, 0usize);
    for cols in columns {
        let mut pose = Vec::with_capacity(cols.len());
        let (mut s, mut n) = (0.0, 0usize);
        for c in cols {
            if c.is_some() {
                let r = flat[k];
                k += 1;
                s += r * r;
                n += 1;
                pose.push(Some(r));
            } else {
                pose.push(None);
            }
        }
        sum += s;
        count += n;
        rms.push(if n > 0 {
            (s / n as f64).sqrt()
        } else {
            f64::NAN
        });
        per_pose.push(pose);
    }
    let total = if count > 0 {
        (sum / count as f64).sqrt()
    } else {
        f64::NAN
    };
    (per_pose, rms, total)
}

/// Initialises and refines the projector from the corners' camera-frame positions
/// (`points[pose][corner]`) and their decoded columns (`None` where there is none).
pub fn calibrate_projector(
    points: &[Vec<Point3<f64>>],
    columns: &[Vec<Option<f64>>],
    settings: &ProjectorSettings,
) -> Result<ProjectorFit, ProjectorError> {
    let mut xs = Vec::new();
    let mut cs = Vec::new();
    for (pts, cols) in points.iter().zip(columns) {
        for (x, c) in pts.iter().zip(cols) {
            if let Some(c) = c {
                if c.is_finite() {
                    xs.push(*x);
                    cs.push(*c);
                }
            }
        }
    }
    let start = initial_column_model(&xs, &cs)?;
    refine_projector(points, columns, &start, settings)
}

/// Levenberg–Marquardt on the projector's column model with the corners' positions fixed.
pub fn refine_projector(
    points: &[Vec<Point3<f64>>],
    columns: &[Vec<Option<f64>>],
    start: &ColumnModel,
    settings: &ProjectorSettings,
) -> Result<ProjectorFit, ProjectorError> {
    let free = projector_free_mask(settings);
    let f = |p: &DVector<f64>| -> Option<DVector<f64>> {
        let model = ColumnModel::from_params(p.as_slice());
        let mut out = Vec::new();
        column_residuals(&model, points, columns, &mut out)?;
        Some(DVector::from_vec(out))
    };
    let res = levenberg_marquardt(
        f,
        DVector::from_row_slice(&start.to_params()),
        &free,
        &settings.lm,
    )
    .map_err(ProjectorError::Solver)?;
    let model = ColumnModel::from_params(res.params.as_slice());
    let (residuals, rms_columns, rms_total_columns) = unflatten(res.residuals.as_slice(), columns);
    let mut std_dev = [0.0; PROJECTOR_PARAMS];
    std_dev.copy_from_slice(res.std_dev.as_slice());
    Ok(ProjectorFit {
        model,
        residuals,
        rms_columns,
        rms_total_columns,
        std_dev,
        iterations: res.iterations,
        stop: res.stop,
    })
}

pub(crate) fn model_params(model: &ColumnModel) -> [f64; PROJECTOR_PARAMS] {
    model.to_params()
}

pub(crate) fn model_from_params(p: &[f64]) -> ColumnModel {
    ColumnModel::from_params(p)
}
