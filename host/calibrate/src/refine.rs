//! Levenberg–Marquardt, and the camera's refinement (Zhang 2000, §3.2–3.3: maximum-likelihood
//! estimate of `K`, distortion and the board poses by minimising the reprojection error).
//!
//! The solver is a small dense one written here rather than a crate: the problems have at
//! most a few hundred parameters and a few thousand residuals, a dense `JᵀJ` solve is
//! milliseconds, and we need parameter masks (fix `k3`, fix a projector offset) and the
//! covariance `σ²(JᵀJ)⁻¹` for the report — simpler to own than to adapt (the `levenberg-
//! marquardt` crate ties its API to a nalgebra version and has no parameter fixing).
//!
//! Method: Marquardt's scaled damping `(JᵀJ + μ·diag(JᵀJ))·δ = −Jᵀr` with Nielsen's update of
//! `μ` from the gain ratio (Madsen, Nielsen & Tingleff, *Methods for non-linear least squares
//! problems*, 2004, §3.2); the Jacobian is numeric (central differences, step
//! `ε^(1/3)·(1 + |p|)`), evaluated only for free parameters. It stops when the relative step,
//! the relative decrease of the cost or the gradient is below tolerance, or after
//! [`LmSettings::max_iterations`].

use nalgebra::{DMatrix, DVector, Point2, Rotation3, Vector2, Vector3};

use fsm_geometry::BrownConrady;

use crate::zhang::{BoardPose, CameraMatrix};

/// Stopping rules.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LmSettings {
    /// Iteration cap.
    pub max_iterations: usize,
    /// Stop when `‖δ‖ ≤ tol·(‖p‖ + tol)`.
    pub step_tolerance: f64,
    /// Stop when the cost decreases by less than this fraction.
    pub cost_tolerance: f64,
    /// Stop when `‖Jᵀr‖∞` is below this.
    pub gradient_tolerance: f64,
}

impl Default for LmSettings {
    fn default() -> Self {
        LmSettings {
            max_iterations: 200,
            step_tolerance: 1e-12,
            cost_tolerance: 1e-14,
            gradient_tolerance: 1e-12,
        }
    }
}

/// Why the solver stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Stop {
    /// The step became negligible.
    SmallStep,
    /// The cost stopped decreasing.
    SmallDecrease,
    /// The gradient vanished.
    SmallGradient,
    /// [`LmSettings::max_iterations`] reached.
    IterationCap,
    /// No step decreased the cost (damping ran away).
    NoProgress,
}

/// What the solver found.
#[derive(Clone, Debug)]
pub struct LmResult {
    /// Parameters at the end (fixed ones unchanged).
    pub params: DVector<f64>,
    /// Residuals at the end.
    pub residuals: DVector<f64>,
    /// `½‖r‖²` at the start and at the end.
    pub initial_cost: f64,
    /// `½‖r‖²` at the end.
    pub cost: f64,
    /// Iterations done.
    pub iterations: usize,
    /// Why it stopped.
    pub stop: Stop,
    /// Standard deviation of every parameter, `sqrt(diag(σ²(JᵀJ)⁻¹))` with
    /// `σ² = ‖r‖²/(m − n_free)` (0 for fixed parameters; NaN when `JᵀJ` is singular).
    pub std_dev: DVector<f64>,
}

/// Why the solver could not start.
#[derive(Clone, Debug, PartialEq)]
pub enum LmError {
    /// The residuals are not defined at the start (a point behind a camera, NaN).
    InvalidStart,
    /// Fewer residuals than free parameters.
    Underdetermined {
        /// Residuals.
        residuals: usize,
        /// Free parameters.
        parameters: usize,
    },
}

impl core::fmt::Display for LmError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            LmError::InvalidStart => write!(
                f,
                "the model cannot be evaluated at the initial estimate (a point is behind a device or beyond its distortion's valid field)"
            ),
            LmError::Underdetermined {
                residuals,
                parameters,
            } => write!(
                f,
                "{residuals} residuals for {parameters} free parameters: underdetermined"
            ),
        }
    }
}

impl std::error::Error for LmError {}

fn numeric_jacobian<F>(f: &F, p: &DVector<f64>, free: &[usize], m: usize) -> Option<DMatrix<f64>>
where
    F: Fn(&DVector<f64>) -> Option<DVector<f64>>,
{
    let mut j = DMatrix::zeros(m, free.len());
    let mut q = p.clone();
    for (col, &i) in free.iter().enumerate() {
        let h = 6e-6 * (1.0 + p[i].abs());
        q[i] = p[i] + h;
        let plus = f(&q)?;
        q[i] = p[i] - h;
        let minus = f(&q)?;
        q[i] = p[i];
        j.set_column(col, &((plus - minus) / (2.0 * h)));
    }
    Some(j)
}

/// Minimises `½‖f(p)‖²` over the parameters where `free[i]` is true. `f` returns `None` where
/// the model is undefined; such a trial step is rejected as if it increased the cost.
pub fn levenberg_marquardt<F>(
    f: F,
    start: DVector<f64>,
    free: &[bool],
    settings: &LmSettings,
) -> Result<LmResult, LmError>
where
    F: Fn(&DVector<f64>) -> Option<DVector<f64>>,
{
    let free_idx: Vec<usize> = (0..start.len()).filter(|&i| free[i]).collect();
    let n = free_idx.len();
    let mut p = start;
    let mut r = f(&p)
        .filter(|r| r.iter().all(|x| x.is_finite()))
        .ok_or(LmError::InvalidStart)?;
    let m = r.len();
    if m < n {
        return Err(LmError::Underdetermined {
            residuals: m,
            parameters: n,
        });
    }
    let mut cost = 0.5 * r.norm_squared();
    let initial_cost = cost;
    let mut mu = -1.0;
    let mut nu = 2.0;
    let mut iterations = 0;
    let mut stop = Stop::IterationCap;
    let mut j = numeric_jacobian(&f, &p, &free_idx, m).ok_or(LmError::InvalidStart)?;
    'outer: while iterations < settings.max_iterations {
        iterations += 1;
        let jtj = j.transpose() * &j;
        let g = j.transpose() * &r;
        if g.amax() <= settings.gradient_tolerance {
            stop = Stop::SmallGradient;
            break;
        }
        if mu < 0.0 {
            // Dimensionless: the damping is μ·diag(JᵀJ).
            mu = 1e-3;
        }
        // Inner loop: increase the damping until a step decreases the cost.
        loop {
            let mut a = jtj.clone();
            for k in 0..n {
                // Marquardt's scaling, with a floor so a parameter without influence still
                // gets a finite step.
                a[(k, k)] += mu * jtj[(k, k)].max(1e-12);
            }
            let Some(chol) = a.clone().cholesky() else {
                mu *= nu;
                nu *= 2.0;
                if !mu.is_finite() || mu > 1e30 {
                    stop = Stop::NoProgress;
                    break 'outer;
                }
                continue;
            };
            let delta = chol.solve(&(-&g));
            let p_norm = free_idx.iter().map(|&i| p[i] * p[i]).sum::<f64>().sqrt();
            if delta.norm() <= settings.step_tolerance * (p_norm + settings.step_tolerance) {
                stop = Stop::SmallStep;
                break 'outer;
            }
            let mut trial = p.clone();
            for (k, &i) in free_idx.iter().enumerate() {
                trial[i] += delta[k];
            }
            let trial_r = f(&trial).filter(|r| r.iter().all(|x| x.is_finite()));
            let trial_cost = trial_r.as_ref().map(|r| 0.5 * r.norm_squared());
            // Predicted decrease of the linear model: ½δᵀ(μ·D·δ − g).
            let mut predicted = 0.0;
            for k in 0..n {
                predicted += 0.5 * delta[k] * (mu * jtj[(k, k)].max(1e-12) * delta[k] - g[k]);
            }
            match (trial_r, trial_cost) {
                (Some(tr), Some(tc)) if tc < cost && predicted > 0.0 => {
                    let rho = (cost - tc) / predicted;
                    let decrease = (cost - tc) / cost.max(f64::MIN_POSITIVE);
                    p = trial;
                    r = tr;
                    cost = tc;
                    mu *= (1.0_f64 / 3.0).max(1.0 - (2.0 * rho - 1.0).powi(3));
                    nu = 2.0;
                    if decrease < settings.cost_tolerance {
                        stop = Stop::SmallDecrease;
                        break 'outer;
                    }
                    match numeric_jacobian(&f, &p, &free_idx, m) {
                        Some(new_j) => j = new_j,
                        None => {
                            stop = Stop::NoProgress;
                            break 'outer;
                        }
                    }
                    break;
                }
                _ => {
                    mu *= nu;
                    nu *= 2.0;
                    if !mu.is_finite() || mu > 1e30 {
                        stop = Stop::NoProgress;
                        break 'outer;
                    }
                }
            }
        }
    }
    // Covariance at the solution.
    let jtj = j.transpose() * &j;
    let dof = (m - n).max(1) as f64;
    let sigma2 = r.norm_squared() / dof;
    let mut std_dev = DVector::zeros(p.len());
    match jtj.try_inverse() {
        Some(inv) => {
            for (k, &i) in free_idx.iter().enumerate() {
                std_dev[i] = (sigma2 * inv[(k, k)]).max(0.0).sqrt();
            }
        }
        None => {
            for &i in &free_idx {
                std_dev[i] = f64::NAN;
            }
        }
    }
    Ok(LmResult {
        params: p,
        residuals: r,
        initial_cost,
        cost,
        iterations,
        stop,
        std_dev,
    })
}

/// Pose as 6 parameters: Rodrigues vector (axis·angle, rad) and translation (mm).
pub fn pose_to_params(pose: &BoardPose) -> [f64; 6] {
    let w = pose.rotation.scaled_axis();
    let t = pose.translation_mm;
    [w.x, w.y, w.z, t.x, t.y, t.z]
}

/// Inverse of [`pose_to_params`].
pub fn pose_from_params(p: &[f64]) -> BoardPose {
    BoardPose {
        rotation: Rotation3::new(Vector3::new(p[0], p[1], p[2])),
        translation_mm: Vector3::new(p[3], p[4], p[5]),
    }
}

/// Pixel of a device-frame point through `K` (no skew) and Brown–Conrady; `None` behind the
/// device. Used inside the solvers instead of [`fsm_geometry::Pinhole`], whose constructor
/// checks invertibility over the whole image (too slow per evaluation, and the trial
/// parameters of a step need not be valid).
pub fn project(k: &CameraMatrix, d: &BrownConrady, p: &Vector3<f64>) -> Option<Point2<f64>> {
    if p.z.is_nan() || p.z <= 0.0 {
        return None;
    }
    let n = d.distort(Vector2::new(p.x / p.z, p.y / p.z));
    Some(Point2::new(k.fx * n.x + k.cx, k.fy * n.y + k.cy))
}

/// Camera parameter vector layout: `fx, fy, cx, cy, k1, k2, p1, p2, k3`, then 6 per pose.
pub const CAMERA_INTRINSIC_PARAMS: usize = 9;

/// What to estimate in [`refine_camera`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraRefineSettings {
    /// Keep `k3 = 0` (recommended for narrow fields: it trades off against `k1`, `k2`).
    pub fix_k3: bool,
    /// Keep `p1 = p2 = 0`.
    pub fix_tangential: bool,
    /// Solver stopping rules.
    pub lm: LmSettings,
}

impl Default for CameraRefineSettings {
    fn default() -> Self {
        CameraRefineSettings {
            fix_k3: true,
            fix_tangential: false,
            lm: LmSettings::default(),
        }
    }
}

/// The refined camera.
#[derive(Clone, Debug)]
pub struct CameraFit {
    /// `K`.
    pub camera: CameraMatrix,
    /// Distortion.
    pub distortion: BrownConrady,
    /// Board poses.
    pub poses: Vec<BoardPose>,
    /// Reprojection RMS per pose, pixels (over both coordinates: `sqrt(Σ(du² + dv²)/N)`).
    pub rms_px: Vec<f64>,
    /// Over all poses.
    pub rms_total_px: f64,
    /// Residual `(du, dv)` per pose and corner, pixels (observed − predicted).
    pub residuals_px: Vec<Vec<Vector2<f64>>>,
    /// Standard deviations of `fx, fy, cx, cy, k1, k2, p1, p2, k3`.
    pub std_dev: [f64; CAMERA_INTRINSIC_PARAMS],
    /// Solver iterations and stop reason.
    pub iterations: usize,
    /// Why LM stopped.
    pub stop: Stop,
}

/// Unpacks the camera parameter vector.
pub fn camera_from_params(p: &[f64]) -> (CameraMatrix, BrownConrady) {
    (
        CameraMatrix {
            fx: p[0],
            fy: p[1],
            cx: p[2],
            cy: p[3],
        },
        BrownConrady {
            k1: p[4],
            k2: p[5],
            p1: p[6],
            p2: p[7],
            k3: p[8],
        },
    )
}

/// Packs the camera parameter vector.
pub fn camera_to_params(k: &CameraMatrix, d: &BrownConrady) -> [f64; CAMERA_INTRINSIC_PARAMS] {
    [k.fx, k.fy, k.cx, k.cy, d.k1, d.k2, d.p1, d.p2, d.k3]
}

/// Camera residuals (observed − predicted, pixels; `du, dv` per corner) appended to `out`.
pub(crate) fn camera_residuals(
    k: &CameraMatrix,
    d: &BrownConrady,
    poses: &[BoardPose],
    board_mm: &[Point2<f64>],
    images: &[Vec<Point2<f64>>],
    out: &mut Vec<f64>,
) -> Option<()> {
    for (pose, img) in poses.iter().zip(images) {
        for (b, obs) in board_mm.iter().zip(img) {
            let x = pose.to_camera(b);
            let q = project(k, d, &x.coords)?;
            out.push(obs.x - q.x);
            out.push(obs.y - q.y);
        }
    }
    Some(())
}

/// Refines `K`, the distortion and every board pose from Zhang's start by minimising the
/// reprojection error of the corners (Zhang 2000 §3.2–3.3; distortion starts at `start_d`).
pub fn refine_camera(
    board_mm: &[Point2<f64>],
    images: &[Vec<Point2<f64>>],
    start_k: &CameraMatrix,
    start_d: &BrownConrady,
    start_poses: &[BoardPose],
    settings: &CameraRefineSettings,
) -> Result<CameraFit, LmError> {
    let np = start_poses.len();
    let mut p0 = Vec::with_capacity(CAMERA_INTRINSIC_PARAMS + 6 * np);
    p0.extend(camera_to_params(start_k, start_d));
    for pose in start_poses {
        p0.extend(pose_to_params(pose));
    }
    let mut free = vec![true; p0.len()];
    if settings.fix_k3 {
        free[8] = false;
    }
    if settings.fix_tangential {
        free[6] = false;
        free[7] = false;
    }
    let f = |p: &DVector<f64>| -> Option<DVector<f64>> {
        let (k, d) = camera_from_params(&p.as_slice()[..CAMERA_INTRINSIC_PARAMS]);
        let poses: Vec<BoardPose> = (0..np)
            .map(|i| pose_from_params(&p.as_slice()[CAMERA_INTRINSIC_PARAMS + 6 * i..]))
            .collect();
        let mut out = Vec::with_capacity(2 * board_mm.len() * np);
        camera_residuals(&k, &d, &poses, board_mm, images, &mut out)?;
        Some(DVector::from_vec(out))
    };
    let res = levenberg_marquardt(f, DVector::from_vec(p0), &free, &settings.lm)?;
    let (camera, distortion) =
        camera_from_params(&res.params.as_slice()[..CAMERA_INTRINSIC_PARAMS]);
    let poses: Vec<BoardPose> = (0..np)
        .map(|i| pose_from_params(&res.params.as_slice()[CAMERA_INTRINSIC_PARAMS + 6 * i..]))
        .collect();
    let n = board_mm.len();
    let mut residuals_px = Vec::with_capacity(np);
    let mut rms_px = Vec::with_capacity(np);
    for i in 0..np {
        let rs: Vec<Vector2<f64>> = (0..n)
            .map(|j| {
                let o = 2 * (i * n + j);
                Vector2::new(res.residuals[o], res.residuals[o + 1])
            })
            .collect();
        rms_px.push((rs.iter().map(|r| r.norm_squared()).sum::<f64>() / n as f64).sqrt());
        residuals_px.push(rs);
    }
    let rms_total_px = (res.residuals.norm_squared() / (n * np) as f64).sqrt();
    let mut std_dev = [0.0; CAMERA_INTRINSIC_PARAMS];
    std_dev.copy_from_slice(&res.std_dev.as_slice()[..CAMERA_INTRINSIC_PARAMS]);
    Ok(CameraFit {
        camera,
        distortion,
        poses,
        rms_px,
        rms_total_px,
        residuals_px,
        std_dev,
        iterations: res.iterations,
        stop: res.stop,
    })
}
